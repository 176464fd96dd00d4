/* The sparse-view split (docs/ARCHITECTURE.md section 5): for an interval n, frames 0, n, 2n, ... (in
 * image-name order) are the training views and every other frame is held out. */
#include "gaussvid/core.h"
#include "gaussvid/scene.h"

int gv_scene_is_train(int frame, int interval)
{
    return frame % interval == 0;
}

int gv_scene_split(int n_frames, int interval, int *train, int *n_train, int *held_out,
                   int *n_held_out)
{
    *n_train = *n_held_out = 0;
    if (interval < 1) return gv_fail("interval %d: must be at least 1", interval);
    if (n_frames < 2) return gv_fail("the scene has %d frame(s); a split needs at least 2", n_frames);
    int trained = (n_frames - 1) / interval + 1; /* frames 0, n, ..., below n_frames */
    if (trained < 2)
        return gv_fail("interval %d leaves %d training frame of the scene's %d frames; at least 2 "
                       "are needed (use an interval of at most %d)", interval, trained, n_frames,
                       n_frames - 1);
    for (int i = 0; i < n_frames; i++) {
        if (gv_scene_is_train(i, interval)) train[(*n_train)++] = i;
        else held_out[(*n_held_out)++] = i;
    }
    return 0;
}
