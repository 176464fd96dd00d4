/* 3D consistency of a sequence of output frames (docs/METRICS.md, "3D consistency"): each
 * frame is warped into its previous and its next frame by a 3DGS model's depth
 * (gaussvid/scene/reproject.h, with its occlusion test), and the warp is compared with the frame it
 * lands in on the pixels it covers. Frames that show one surface the same way from every
 * camera score high; a restorer that invents a different texture in each frame scores low,
 * even where each frame alone looks plausible.
 *
 * PSNR over a set of pixels is -10 log10 of the mean squared error over their values (v / 255
 * for 8-bit frames), capped at GV_CONSISTENCY_PSNR_CAP as reconstruct's evaluation caps
 * identical images. */
#ifndef GAUSSVID_CONSISTENCY_H
#define GAUSSVID_CONSISTENCY_H

#include "gaussvid/splat/coverage.h"
#include "gaussvid/io/gaussians.h"

#define GV_CONSISTENCY_PSNR_CAP 100.0

/* Frame `from` warped into frame `to`'s view. */
typedef struct {
    int from, to;           /* positions in the sequence */
    long pixels;            /* pixels of `to` the warp covers */
    double coverage;        /* pixels / (to's width x height) */
    double mse;             /* over the covered pixels' values; NaN when none is covered */
    double psnr;            /* -10 log10 mse, capped; NaN when none is covered */
} gv_consistency_pair;

/* One pair: from_rgb, to_rgb are HWC floats of their cameras' sizes; depths as reproject.h's
 * (view z, 0 where there is no surface). Pixel p of `to` is covered when its surface point
 * lands inside `from` and passes the occlusion test at rel_tolerance (gv_reproject_anchor);
 * the warped colour is compared with to_rgb there. Sets out->from, out->to to 0, 1. */
int gv_consistency_pair_measure(const gv_camera *from, const float *from_rgb, const float *from_depth,
                                const gv_camera *to, const float *to_rgb, const float *to_depth,
                                double rel_tolerance, gv_consistency_pair *out);

typedef struct {
    int n_frames, n_pairs;          /* n_pairs = 2 (n_frames - 1) */
    gv_consistency_pair *pairs;     /* k -> k + 1, then k + 1 -> k, for k = 0 .. n_frames - 2 */
    int scored;                     /* pairs that cover at least one pixel */
    double mean_psnr;               /* mean of the scored pairs' PSNRs (NaN when none) */
    double mean_coverage;           /* mean coverage over every pair */
} gv_consistency;

/* A sequence of n >= 2 frames (8-bit PNG or JPEG files, paths[i] of the size of cameras[i])
 * with the depth of model g at each camera (gv_coverage_depth with opt: depth only where the
 * accumulated opacity reaches opt->min_opacity; opt NULL for the defaults). Holds two frames
 * at a time. Fails with one line naming the file that cannot be read or has the wrong size. */
int gv_consistency_measure(const gv_gaussians *g, const gv_camera *cameras, const char *const *paths, int n,
                           const gv_coverage_options *opt, gv_consistency *out);
void gv_consistency_free(gv_consistency *c);

#endif
