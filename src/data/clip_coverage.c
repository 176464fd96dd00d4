/* The coverage plane of a clip (dataset.h, "clip_coverage.c"): for each intermediate, which of
 * the clip's anchors sees each pixel through the depth of the model that rendered it
 * (gv_coverage_plane), so the restorer can be told where to complete and where the render
 * already agrees with what the anchors show (condition.h, variant coverage). */
#include <stdlib.h>
#include <string.h>

#include "gaussvid/splat/coverage.h"
#include "gaussvid/data/dataset.h"

/* clip->coverage, allocated when missing. */
static int coverage_alloc(gv_clip *clip)
{
    if (clip->coverage) return 0;
    clip->coverage = malloc((size_t)(GV_CLIP_FRAMES - 2) * clip->info.width * clip->info.height);
    return clip->coverage ? 0 : gv_fail("out of memory for the coverage plane of a %dx%d clip", clip->info.width,
                                        clip->info.height);
}

int gv_clip_coverage_from_depths(gv_clip *clip, const gv_camera *const cams[GV_CLIP_FRAMES],
                                 const float *const depths[GV_CLIP_FRAMES], double rel_tolerance)
{
    const gv_clip_info *info = &clip->info;
    for (int f = 0; f < GV_CLIP_FRAMES; f++)
        if (cams[f]->width != info->width || cams[f]->height != info->height)
            return gv_fail("coverage: camera %s of frame %d is %dx%d, the clip %dx%d", cams[f]->name, f, cams[f]->width,
                           cams[f]->height, info->width, info->height);
    size_t plane = (size_t)info->width * info->height;
    uint8_t *scratch = malloc(plane);
    int rc = scratch ? coverage_alloc(clip) : gv_fail("out of memory for a %dx%d coverage mask", info->width, info->height);
    const gv_camera *anchors[2] = {cams[0], cams[GV_CLIP_FRAMES - 1]};
    const float *anchor_depths[2] = {depths[0], depths[GV_CLIP_FRAMES - 1]};
    for (int f = 1; rc == 0 && f < GV_CLIP_FRAMES - 1; f++)
        rc = gv_coverage_plane(cams[f], depths[f], anchors, anchor_depths, rel_tolerance, scratch,
                               clip->coverage + (size_t)(f - 1) * plane);
    free(scratch);
    return rc;
}

/* The 5 depth maps of a clip, one block. */
static float *depths_alloc(const gv_clip_info *info, const float *depths[GV_CLIP_FRAMES])
{
    size_t plane = (size_t)info->width * info->height;
    float *all = malloc(GV_CLIP_FRAMES * plane * sizeof *all);
    if (!all) {
        gv_fail("out of memory for the depth of a %dx%d clip", info->width, info->height);
        return NULL;
    }
    for (int f = 0; f < GV_CLIP_FRAMES; f++) depths[f] = all + f * plane;
    return all;
}

int gv_clip_coverage_simulated(gv_clip *clip, const gv_artifact_simulator *sim, void *model, const gv_scene *scene,
                               const int frames[GV_CLIP_FRAMES])
{
    if (!sim->depth) return gv_fail("coverage: the artifact simulator %s renders no depth", sim->name);
    const float *depths[GV_CLIP_FRAMES];
    const gv_camera *cams[GV_CLIP_FRAMES];
    float *all = depths_alloc(&clip->info, depths);
    int rc = all ? 0 : -1;
    for (int f = 0; rc == 0 && f < GV_CLIP_FRAMES; f++) {
        if (frames[f] < 0 || frames[f] >= scene->n_frames)
            rc = gv_fail("coverage: frame %d outside the scene's %d", frames[f], scene->n_frames);
        else {
            cams[f] = &scene->cameras[frames[f]];
            if (cams[f]->width != clip->info.width || cams[f]->height != clip->info.height)
                rc = gv_fail("coverage: camera %s is %dx%d, the clip %dx%d", cams[f]->name, cams[f]->width,
                             cams[f]->height, clip->info.width, clip->info.height);
            else
                rc = sim->depth(sim->ctx, model, scene, frames[f], (float *)depths[f]);
        }
    }
    if (rc == 0) rc = gv_clip_coverage_from_depths(clip, cams, depths, GV_COVERAGE_TOLERANCE);
    free(all);
    return rc;
}

int gv_clip_coverage_gaussians(gv_clip *clip, const gv_gaussians *g, const gv_camera *const cams[GV_CLIP_FRAMES],
                               double rel_tolerance, double min_opacity)
{
    gv_coverage_options opt;
    gv_coverage_options_default(&opt);
    opt.min_opacity = min_opacity;
    const float *depths[GV_CLIP_FRAMES];
    float *all = depths_alloc(&clip->info, depths);
    int rc = all ? 0 : -1;
    gv_splat_renderer r = {0};
    for (int f = 0; rc == 0 && f < GV_CLIP_FRAMES; f++)
        rc = cams[f]->width != clip->info.width || cams[f]->height != clip->info.height
                 ? gv_fail("coverage: camera %s is %dx%d, the clip %dx%d", cams[f]->name, cams[f]->width,
                           cams[f]->height, clip->info.width, clip->info.height)
                 : gv_coverage_depth(&r, g, cams[f], &opt, (float *)depths[f]);
    if (rc == 0) rc = gv_clip_coverage_from_depths(clip, cams, depths, rel_tolerance);
    gv_splat_renderer_free(&r);
    free(all);
    return rc;
}
