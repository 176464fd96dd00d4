/* The restored clip in pixels (restore.h): anchors from the input, intermediates decoded from
 * the restored latent, or the render corrected by the decoded change of the latent
 * (gv_vae_decode_residual, docs/VAE.md "Residual decoding"), everywhere or only on the pixels
 * no anchor sees (the clip's coverage plane); a clip padded to the network's block is composed
 * padded and cropped back (condition.h). */
#include <stdlib.h>
#include <string.h>

#include "gaussvid/core/core.h"
#include "gaussvid/restore/restore.h"

const char *gv_compose_name(gv_compose c)
{
    return c == GV_COMPOSE_RESIDUAL ? "residual" : c == GV_COMPOSE_UNSEEN ? "unseen" : "decoded";
}

int gv_compose_from_name(const char *name, gv_compose *out)
{
    if (!strcmp(name, "decoded")) *out = GV_COMPOSE_DECODED;
    else if (!strcmp(name, "residual")) *out = GV_COMPOSE_RESIDUAL;
    else if (!strcmp(name, "unseen")) *out = GV_COMPOSE_UNSEEN;
    else return gv_fail("composition '%s': expected decoded, residual or unseen", name);
    return 0;
}

/* A value in [-1, 1] to 8 bits: (x + 1) 127.5 rounded half up, clamped. Exact for the VAE's
 * input values p / 127.5 - 1, so an unchanged render comes back as its own bytes. */
static uint8_t to_u8(float x)
{
    float p = (x + 1.0f) * 127.5f;
    if (!(p > 0)) return 0; /* NaN too */
    if (p >= 255) return 255;
    return (uint8_t)(int)(p + 0.5f);
}

static float bf16(float x)
{
    return gv_bf16_to_f32(gv_f32_to_bf16(x));
}

uint8_t gv_release_to_u8(float x)
{
    float p = bf16(bf16(bf16(x) + 1.0f) * 127.5f);
    if (!(p > 0)) return 0; /* NaN too */
    if (p >= 255) return 255;
    return (uint8_t)p; /* truncation, as torch's .to(uint8) */
}

/* The composition of a clip of the latents' size (padded, when padding was needed). */
static int compose(gv_vae *vae, const gv_clip *clip, const gv_clip_latents *l, const float *z_restored, gv_compose mode,
                   int release, uint8_t *out)
{
    const gv_clip_info *info = &clip->info;
    const int64_t plane = (int64_t)info->height * info->width, frame_bytes = plane * 3;
    const int F = l->batch == 1 ? GV_CLIP_FRAMES : 1; /* frames per decoded video */
    const int64_t per = gv_clip_latents_z_count(l) / l->batch;
    memcpy(out, clip->inputs, (size_t)(GV_CLIP_FRAMES * frame_bytes));
    float *video = malloc((size_t)(3 * F * plane) * sizeof *video);
    float *render = mode != GV_COMPOSE_DECODED ? malloc((size_t)(3 * F * plane) * sizeof *render) : NULL;
    if (!video || (mode != GV_COMPOSE_DECODED && !render)) {
        free(video), free(render);
        return gv_fail("restore: out of memory for a %dx%d clip", info->width, info->height);
    }
    int rc = 0;
    for (int b = 0; rc == 0 && b < l->batch; b++) {
        /* the video of batch entry b: the whole clip, or the one intermediate 1 + b */
        int first = l->batch == 1 ? 0 : 1 + b;
        const float *z = z_restored + b * per, *z_hat = l->z_corrupt + b * per;
        if (render) {
            gv_clip_video(clip->inputs, info, first, F, render);
            rc = gv_vae_decode_residual(vae, render, z_hat, z, l->latent_frames, l->lh, l->lw, 1, video);
        } else {
            rc = gv_vae_decode(vae, z, l->latent_frames, l->lh, l->lw, 1, 1, video);
        }
        /* the intermediates only: the anchors stay the input's */
        for (int k = 0; rc == 0 && k < F; k++) {
            int f = first + k;
            if (f == 0 || f == GV_CLIP_FRAMES - 1) continue;
            uint8_t *dst = out + f * frame_bytes;
            /* unseen: where an anchor sees the pixel, the render (already in out) stays */
            const uint8_t *seen = mode == GV_COMPOSE_UNSEEN ? clip->coverage + (f - 1) * plane : NULL;
            for (int c = 0; c < 3; c++) {
                const float *src = video + ((int64_t)c * F + k) * plane;
                for (int64_t p = 0; p < plane; p++)
                    if (!seen || !seen[p]) dst[p * 3 + c] = release ? gv_release_to_u8(src[p]) : to_u8(src[p]);
            }
        }
    }
    free(video), free(render);
    return rc;
}

int gv_restore_compose(gv_vae *vae, const gv_clip *clip, const gv_clip_latents *l, const float *z_restored,
                       gv_compose mode, int release, uint8_t *out)
{
    const gv_clip_info *info = &clip->info;
    if (l->width < info->width || l->height < info->height) /* the latents are of the clip padded, or unpadded */
        return gv_fail("restore: latents of a %dx%d clip for a %dx%d clip", l->width, l->height, info->width, info->height);
    if (mode == GV_COMPOSE_UNSEEN && !clip->coverage)
        return gv_fail("restore: the unseen composition needs the clip's coverage plane, and this clip has none "
                       "(clips built before it: build them again)");
    if (l->width == info->width && l->height == info->height) return compose(vae, clip, l, z_restored, mode, release, out);
    /* padded to the block (condition.h): composed at the latents' size and cropped */
    gv_clip padded;
    uint8_t *big = malloc((size_t)GV_CLIP_FRAMES * l->width * l->height * 3);
    int rc = big ? gv_clip_pad(clip, l->width, l->height, &padded) : gv_fail("restore: out of memory");
    if (rc == 0) {
        rc = compose(vae, &padded, l, z_restored, mode, release, big);
        if (rc == 0) rc = gv_clip_crop_frames(big, l->width, l->height, info, out);
        gv_clip_free(&padded);
    }
    free(big);
    return rc;
}
