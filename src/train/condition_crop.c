/* A spatial window of a prepared clip (train --crop): the same rows and columns of every frame
 * of the latents and the VACE context, and the matching pixels of the Plücker field. Attention
 * with RoPE depends only on the offsets between tokens, and each camera token is computed
 * from its own pixels, so the window is what the network would see of a smaller picture
 * taken by the same cameras: no position or intrinsics need to change. */
#include <stdlib.h>
#include <string.h>

#include "gaussvid/train/condition.h"
#include "gaussvid/core/core.h"

/* rows [y, y + h) and columns [x, x + w) of each of `planes` planes of rows x cols floats */
static void copy_window(const float *src, int planes, int rows, int cols, int y, int x, int h, int w, float *dst)
{
    for (int p = 0; p < planes; p++)
        for (int r = 0; r < h; r++)
            memcpy(dst + ((int64_t)p * h + r) * w, src + ((int64_t)p * rows + y + r) * cols + x, (size_t)w * sizeof(float));
}

static int same_shape(const gv_clip_latents *a, const gv_clip_latents *b)
{
    return a->batch == b->batch && a->z_dim == b->z_dim && a->latent_frames == b->latent_frames && a->lh == b->lh &&
           a->lw == b->lw && a->vace_dim == b->vace_dim && a->plucker_frames == b->plucker_frames &&
           a->height == b->height && a->width == b->width && !a->plucker == !b->plucker;
}

int gv_clip_latents_crop(const gv_clip_latents *src, int y, int x, int h, int w, gv_clip_latents *dst)
{
    if (y < 0 || x < 0 || h < 1 || w < 1 || y + h > src->lh || x + w > src->lw)
        return gv_fail("clip n%d: crop rows %d-%d, columns %d-%d outside its %dx%d latent grid", src->interval, y, y + h - 1,
                       x, x + w - 1, src->lh, src->lw);
    int sf = src->height / src->lh; /* pixels per latent cell */
    gv_clip_latents want = *src;
    want.lh = h, want.lw = w, want.height = h * sf, want.width = w * sf;
    if (!dst->z_clean || !same_shape(dst, &want)) { /* the arrays are reused while the shape stays */
        gv_clip_latents_free(dst);
        *dst = want;
        dst->z_clean = dst->z_corrupt = dst->vace = dst->plucker = NULL;
        if (gv_clip_latents_alloc(dst, src->plucker != NULL)) return -1;
    }
    dst->interval = src->interval, dst->frames = src->frames;
    memcpy(dst->no_target, src->no_target, sizeof dst->no_target);
    int z_planes = src->batch * src->z_dim * src->latent_frames;
    copy_window(src->z_clean, z_planes, src->lh, src->lw, y, x, h, w, dst->z_clean);
    copy_window(src->z_corrupt, z_planes, src->lh, src->lw, y, x, h, w, dst->z_corrupt);
    copy_window(src->vace, src->batch * src->vace_dim * src->latent_frames, src->lh, src->lw, y, x, h, w, dst->vace);
    if (src->plucker)
        copy_window(src->plucker, src->batch * 6 * src->plucker_frames, src->height, src->width, y * sf, x * sf,
                    h * sf, w * sf, dst->plucker);
    return 0;
}
