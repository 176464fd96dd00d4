/* Where a sparse 3DGS model's error is, and what the clean anchor views can give: for each
 * held-out frame, its two neighbouring training views (the restorer's anchors) are warped
 * into it by the model's rendered depth with an occlusion test (gaussvid/scene/reproject.h), and
 * the render, the warps and a per-pixel oracle over them are scored on the pixels each
 * covers (docs/SPLAT_TRAINING.md, "Coverage by the anchors"; `gaussvid splat coverage`).
 *
 * Images are scored as `splat eval` scores them: the render quantised to 8 bits, the ground
 * truth and the anchors' 8-bit images, values v / 255; the warps are quantised to 8 bits
 * too. PSNR over a set of pixels is -10 log10 of the mean squared error over their values. */
#ifndef GAUSSVID_COVERAGE_H
#define GAUSSVID_COVERAGE_H

#include <stdint.h>

#include "gaussvid/io/gaussians.h"
#include "gaussvid/splat/render.h"
#include "gaussvid/scene/scene.h"

#define GV_COVERAGE_TOLERANCE 0.05  /* relative depth agreement of the occlusion test */
#define GV_COVERAGE_MIN_OPACITY 0.5 /* rendered depth is used where 1 - T_final >= this */

typedef struct {
    double rel_tolerance;   /* occlusion test: |D_anchor - z| <= rel_tolerance z */
    double min_opacity;     /* pixels of lower accumulated opacity have no depth (never covered,
                             * and never cover) */
    float bg[3];            /* render background (the training background) */
} gv_coverage_options;

/* The defaults above, black background. */
void gv_coverage_options_default(gv_coverage_options *o);

/* One held-out frame i, anchored by training frames a = floor(i / n) n and a + n. */
typedef struct {
    int frame, anchor[2];
    int pixels;
    double covered;                 /* fraction of pixels covered by at least one anchor */
    double anchor_covered[2];       /* fraction covered by each anchor */
    double psnr_render;             /* the render, all pixels */
    double psnr_render_on[2];       /* the render on the pixels anchor k covers */
    double psnr_warp[2];            /* warped anchor k on the pixels it covers */
    double psnr_render_covered;     /* the render on the pixels some anchor covers */
    double psnr_render_uncovered;   /* ... and on the pixels none covers */
    double psnr_oracle;             /* per pixel the best of the render and the covering warps */
    double psnr_blend;              /* per pixel the mean of the render and the covering warps */
    double sse_render, sse_uncovered; /* the render's squared error: all, uncovered pixels */
} gv_coverage_frame;

/* Held-out frames with a training frame on both sides at interval n, in order: fills frames
 * (n_frames of the scene long at most) and returns their count, or -1 when n < 2 or the
 * scene has no such frame. */
int gv_coverage_frames(const gv_scene *scene, int interval, int *frames);

/* Measures the listed held-out frames (from gv_coverage_frames); results is n long. Renders
 * each anchor once. opt may be NULL for the defaults. Shows a progress bar. */
int gv_coverage_measure(const gv_gaussians *g, const gv_scene *scene, int interval,
                        const int *frames, int n, const gv_coverage_options *opt,
                        gv_coverage_frame *results);

/* Means over frames (frames where a value is undefined, e.g. an anchor covering nothing,
 * are left out of that mean and counted in `frames_with`). */
typedef struct {
    int frames;
    double covered, anchor_covered[2];
    double psnr_render, psnr_render_on[2], psnr_warp[2];
    double psnr_render_covered, psnr_render_uncovered, psnr_oracle, psnr_blend;
    int frames_with[2];             /* frames where anchor k covers some pixel */
    /* share of the render's squared error on uncovered pixels: pooled over all frames, and
     * the mean of the per-frame shares */
    double uncovered_error_share, uncovered_error_share_mean;
} gv_coverage_summary;
void gv_coverage_summarise(const gv_coverage_frame *r, int n, gv_coverage_summary *s);

/* ---- the coverage plane of a view (coverage_plane.c) ---------------------------------------
 * What the restorer is told about a corrupted frame (condition.h, variant coverage): per pixel,
 * which of the clip's two anchors sees the surface the model shows there, by the same
 * reprojection and occlusion test as above. Bit 0 (GV_COVERED_FIRST): the first anchor sees
 * it; bit 1 (GV_COVERED_LAST): the last anchor does; 0: no anchor sees it, the network must
 * complete it. */
#define GV_COVERED_FIRST 1
#define GV_COVERED_LAST 2

/* The model's depth at a camera as the coverage uses it: the expected view depth where the
 * accumulated opacity reaches opt->min_opacity, 0 elsewhere (width x height floats). r is a
 * renderer to reuse (zeroed at first); opt may be NULL for the defaults. */
int gv_coverage_depth(gv_splat_renderer *r, const gv_gaussians *g, const gv_camera *cam,
                      const gv_coverage_options *opt, float *depth);

/* The coverage plane (target width x height bytes, the bits above) of a target view with its
 * depth by the two anchors with theirs (gv_coverage_depth), occlusion test at rel_tolerance.
 * scratch holds width x height bytes. */
int gv_coverage_plane(const gv_camera *target, const float *target_depth, const gv_camera *const anchors[2],
                      const float *const anchor_depths[2], double rel_tolerance, uint8_t *scratch,
                      uint8_t *plane);

#endif
