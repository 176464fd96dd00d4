/* A clip's frames from images in memory: what `dataset build` writes for its runs and
 * `reconstruct` for every held-out frame (docs/RECONSTRUCT.md), one layout for both. */
#include <string.h>

#include "gaussvid/core/core.h"
#include "gaussvid/data/dataset.h"

int gv_clip_fill(gv_clip *clip, const int frames[GV_CLIP_FRAMES], const gv_image *const inputs[GV_CLIP_FRAMES],
                 const gv_image *const targets[GV_CLIP_FRAMES], const gv_camera *const cameras[GV_CLIP_FRAMES])
{
    const gv_clip_info *info = &clip->info;
    size_t bytes = (size_t)info->width * info->height * 3;
    for (int i = 0; i < GV_CLIP_FRAMES; i++) {
        const gv_image *in = inputs[i], *target = targets[i];
        if (in->width != info->width || in->height != info->height || in->channels != 3 ||
            target->width != info->width || target->height != info->height || target->channels != 3)
            return gv_fail("frame %d is %dx%d (target %dx%d), the clip's size %dx%d: a clip needs one size, RGB",
                           frames[i], in->width, in->height, target->width, target->height, info->width,
                           info->height);
        clip->info.frames[i] = frames[i];
        snprintf(clip->info.frame_names[i], sizeof clip->info.frame_names[i], "%s", cameras[i]->name);
        memcpy(gv_clip_frame(clip->inputs, info, i), in->pixels, bytes);
        memcpy(gv_clip_frame(clip->targets, info, i), target->pixels, bytes);
        gv_clip_set_camera(clip, i, cameras[i]);
    }
    return 0;
}
