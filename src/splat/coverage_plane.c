/* The coverage plane of one view by a clip's two anchors (include/gaussvid/splat/coverage.h): the
 * model's depth at each camera and the reprojection with its occlusion test, kept per pixel as
 * two bits instead of being scored. */
#include <stdlib.h>
#include <string.h>

#include "gaussvid/core/core.h"
#include "gaussvid/splat/coverage.h"
#include "gaussvid/scene/reproject.h"
#include "gaussvid/splat/splat_train.h"

int gv_coverage_depth(gv_splat_renderer *r, const gv_gaussians *g, const gv_camera *cam,
                      const gv_coverage_options *opt, float *depth)
{
    gv_coverage_options defaults;
    if (!opt) gv_coverage_options_default(&defaults), opt = &defaults;
    size_t pixels = (size_t)cam->width * cam->height;
    float *image = malloc(pixels * 3 * sizeof *image), *opacity = malloc(pixels * sizeof *opacity);
    gv_splat_view view;
    int rc = image && opacity ? 0 : gv_fail("coverage: out of memory for a %dx%d view", cam->width, cam->height);
    if (rc == 0)
        rc = gv_splat_view_from_camera(&view, cam) ||
                     gv_splat_render_forward(r, g, &view, g->sh_degree, opt->bg, image) ||
                     gv_splat_render_depth(r, depth, opacity)
                 ? gv_fail_context("coverage: depth of view %s", cam->name)
                 : 0;
    for (size_t p = 0; rc == 0 && p < pixels; p++)
        if (!(opacity[p] >= opt->min_opacity)) depth[p] = 0;
    free(image), free(opacity);
    return rc;
}

int gv_coverage_plane(const gv_camera *target, const float *target_depth, const gv_camera *const anchors[2],
                      const float *const anchor_depths[2], double rel_tolerance, uint8_t *scratch,
                      uint8_t *plane)
{
    size_t pixels = (size_t)target->width * target->height;
    memset(plane, 0, pixels);
    for (int k = 0; k < 2; k++) {
        if (gv_reproject_anchor(target, target_depth, anchors[k], anchor_depths[k], NULL, rel_tolerance, NULL,
                                scratch))
            return -1;
        uint8_t bit = k ? GV_COVERED_LAST : GV_COVERED_FIRST;
        for (size_t p = 0; p < pixels; p++)
            if (scratch[p]) plane[p] |= bit;
    }
    return 0;
}
