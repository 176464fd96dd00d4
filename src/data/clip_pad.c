/* A clip padded to the restorer's block and its frames cropped back (dataset.h): every frame,
 * input and target, and the coverage plane mirrored at the right and bottom edges
 * (gv_image_pad_reflect); cameras unchanged, since a pixel keeps its coordinates. */
#include <stdlib.h>
#include <string.h>

#include "gaussvid/core/core.h"
#include "gaussvid/data/dataset.h"
#include "gaussvid/io/image.h"

/* Frame f of a [frames][height][width][channels] array as an image. */
static gv_image frame_of(uint8_t *frames, int width, int height, int channels, int f)
{
    gv_image img = {width, height, channels, frames + (size_t)f * width * height * channels};
    return img;
}

int gv_clip_pad(const gv_clip *src, int width, int height, gv_clip *dst)
{
    const gv_clip_info *info = &src->info;
    memset(dst, 0, sizeof *dst);
    if (width < info->width || height < info->height)
        return gv_fail("clip pad: a %dx%d clip does not pad to %dx%d", info->width, info->height, width, height);
    gv_clip_info padded = *info;
    padded.width = width, padded.height = height;
    if (gv_clip_alloc(dst, &padded)) return -1;
    memcpy(dst->intrinsics, src->intrinsics, sizeof dst->intrinsics);
    memcpy(dst->poses, src->poses, sizeof dst->poses);
    for (int f = 0; f < GV_CLIP_FRAMES; f++) {
        gv_image in = frame_of(src->inputs, info->width, info->height, 3, f), out = frame_of(dst->inputs, width, height, 3, f);
        gv_image tin = frame_of(src->targets, info->width, info->height, 3, f);
        gv_image tout = frame_of(dst->targets, width, height, 3, f);
        if (gv_image_pad_reflect(&in, &out) || gv_image_pad_reflect(&tin, &tout)) {
            gv_clip_free(dst);
            return -1;
        }
    }
    if (!src->coverage) return 0;
    /* the coverage mirrored with the pixels: a padded pixel copies an image pixel, and so does
     * its bit (seen by an anchor or not), so the network sees a picture and a mask that agree
     * and no mask edge at the picture's border; the padding is cropped from what it returns */
    dst->coverage = malloc((size_t)(GV_CLIP_FRAMES - 2) * width * height);
    if (!dst->coverage) {
        gv_clip_free(dst);
        return gv_fail("out of memory for a %dx%d clip", width, height);
    }
    for (int f = 0; f < GV_CLIP_FRAMES - 2; f++) {
        gv_image in = frame_of(src->coverage, info->width, info->height, 1, f);
        gv_image out = frame_of(dst->coverage, width, height, 1, f);
        if (gv_image_pad_reflect(&in, &out)) {
            gv_clip_free(dst);
            return -1;
        }
    }
    return 0;
}

int gv_clip_crop_frames(const uint8_t *padded, int width, int height, const gv_clip_info *info, uint8_t *out)
{
    for (int f = 0; f < GV_CLIP_FRAMES; f++) {
        gv_image in = frame_of((uint8_t *)padded, width, height, 3, f);
        gv_image o = frame_of(out, info->width, info->height, 3, f);
        if (gv_image_crop(&in, &o)) return -1;
    }
    return 0;
}
