/* Which frames make the scene-internal clips (internal_pairs.h): interior training view k is
 * left out of subset (k - 1) mod K and sits in the middle of a clip whose anchors are its two
 * neighbouring training views, with the uniform positions of a 2n clip (the sampling of
 * `dataset build`) around it. */
#include "gaussvid/core/core.h"
#include "gaussvid/data/internal_pairs.h"

int gv_internal_views(int n_frames, int interval)
{
    return interval >= 1 && n_frames >= 1 ? 1 + (n_frames - 1) / interval : 0;
}

int gv_internal_check(int n_frames, int interval)
{
    if (gv_interval_check(interval, 0, GV_INTERVAL_CLIPS)) return -1;
    int views = gv_internal_views(n_frames, interval);
    if (views < GV_INTERNAL_MIN_VIEWS)
        return gv_fail("%d frames give %d training views at n = %d (frames 0, %d, ...); scene-internal pairs "
                       "need at least %d (at least %d frames)",
                       n_frames, views, interval, interval, GV_INTERNAL_MIN_VIEWS,
                       (GV_INTERNAL_MIN_VIEWS - 1) * interval + 1);
    return 0;
}

int gv_internal_plan(int n_frames, int interval, int subsets, gv_internal_clip *clips, int *count)
{
    *count = 0;
    if (gv_internal_check(n_frames, interval)) return -1;
    if (subsets < 2) return gv_fail("%d subsets: scene-internal pairs need at least 2", subsets);
    int views = gv_internal_views(n_frames, interval);
    for (int k = 1; k <= views - 2; k++) {
        gv_internal_clip *c = &clips[*count];
        c->view = k;
        c->subset = (k - 1) % subsets;
        /* the window's frames counted from its first anchor's parity: anchors 2n apart, as a 2n clip */
        int first = (k - 1) % 2 * interval;
        if (gv_clip_frames(n_frames - first, 2 * interval, 1, GV_SAMPLING_UNIFORM, (k - 1) * interval - first, NULL,
                           c->frames))
            return gv_fail_context("internal clip of view %d (n = %d)", k, interval);
        for (int f = 0; f < GV_CLIP_FRAMES; f++) c->frames[f] += first;
        if (c->frames[2] != k * interval) /* the middle of a uniform 2n clip is s + n: exact */
            return gv_fail("internal clip of view %d (n = %d): middle frame %d", k, interval, c->frames[2]);
        (*count)++;
    }
    return 0;
}

int gv_internal_subset_views(int n_frames, int interval, int subsets, int subset, int *frames, int *count)
{
    *count = 0;
    int views = gv_internal_views(n_frames, interval);
    if (subsets < 2 || subset < 0 || subset >= subsets)
        return gv_fail("subset %d of %d: need 0 <= subset < subsets and subsets >= 2", subset, subsets);
    for (int v = 0; v < views; v++)
        if (v % subsets != (subset + 1) % subsets) frames[(*count)++] = v * interval;
    return 0;
}
