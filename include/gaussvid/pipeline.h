/* `gaussvid reconstruct` (docs/RECONSTRUCT.md; issue 23): from a scene folder to a sparse
 * 3DGS model, its renders restored by the video restorer, a refined 3DGS, metrics, a video.
 *
 * Per interval n the stages run in the order of a table (gv_reconstruct_stages):
 *   train     sparse 3DGS on frames 0, n, 2n, ...            nN/sparse.ply, sparse.splat
 *   render    the evaluated frames from the sparse model     nN/frames/render/
 *   adapt     (--adapt) the restorer adapted to the scene    nN/restorer.safetensors
 *   restore   5-frame clips (clean anchors at training views, three renders) restored
 *                                                            nN/clips/, nN/frames/restored/
 *   refine    the sparse model re-optimised on the training views and, down-weighted, the
 *             restored frames                                nN/refined.ply, refined.splat,
 *                                                            nN/frames/refined/
 *   evaluate  PSNR / SSIM (LPIPS) against ground truth where it exists
 *   video     render | restored | ground truth side by side  nN/flythrough.mp4 (ffmpeg)
 * The evaluated frames are every held-out frame between the first and the last training view
 * (n >= 4: each gap between training views has n - 1 >= 3 of them); with n = 1 every view
 * trains, and the evaluated frames are a smooth path: three cameras between each pair of
 * consecutive views (slerp of rotations, linear centres), frame 4k + j for j = 1, 2, 3.
 *
 * DIR/metrics.json (documented in docs/RECONSTRUCT.md) records every number and each
 * finished stage with the inputs it was made from; it is rewritten atomically after every
 * stage, so a rerun skips the finished stages (after checking their inputs are the same and
 * their files exist) and continues with the first unfinished one. */
#ifndef GAUSSVID_PIPELINE_H
#define GAUSSVID_PIPELINE_H

#include <stddef.h>
#include <stdint.h>

#include "gaussvid/adapt.h"

#define GV_RECONSTRUCT_FORMAT "gaussvid-reconstruct-1"
#define GV_RECONSTRUCT_MAX_INTERVALS 32

typedef struct {
    const char *scene_dir;
    int intervals[GV_RECONSTRUCT_MAX_INTERVALS];
    int n_intervals;
    const char *out_dir;
    const char *ckpt;            /* the restorer: a cross-scene checkpoint (or a scene checkpoint) */
    int downscale;               /* scene images: 1, 2, 4, 8 */
    int iters;                   /* sparse 3DGS iterations */
    int densify;                 /* its density control (gv_splat_densify_mode) */
    int refine_iters;            /* refinement iterations */
    double refine_weight;        /* the restored frames' loss weight (training views: 1) */
    int adapt;                   /* run the adapt stage and restore with its scene checkpoint */
    gv_adapt_options adapt_options; /* its settings (scene, interval, base, out set per run) */
    const char *lpips;           /* AlexNet-LPIPS weights for the evaluation, or NULL */
    double fps;                  /* frames per second of the video */
    const char *ffmpeg;          /* the ffmpeg program (NULL: "ffmpeg" on the PATH) */
    const char *stop_after;      /* a stage name: stop after it (NULL: run every stage) */
    uint64_t seed;
    /* Called after each stage that ran (not the skipped ones) with its one-line summary and
     * its wall and process CPU seconds (may be NULL). */
    void (*on_stage)(void *ctx, int interval, const char *stage, const char *summary, double seconds,
                     double cpu_seconds);
    void *on_stage_ctx;
} gv_reconstruct_options;

/* The defaults (docs/RECONSTRUCT.md): 8000 sparse iterations, 1000 refinement iterations at
 * weight 0.3, 8 frames per second, gv_adapt_defaults for --adapt. */
void gv_reconstruct_defaults(gv_reconstruct_options *o);

/* The stage names in order ("train", "render", "adapt", "restore", "refine", "evaluate",
 * "video"); count in *n. */
const char *const *gv_reconstruct_stages(int *n);

/* Runs (or resumes) every interval's stages; fails with one line naming the input. */
int gv_reconstruct(const gv_reconstruct_options *o);

/* The 3D consistency (docs/METRICS.md) of every run of a reconstruct output folder: per run,
 * the sparse renders, the restored frames (both with the sparse model's depth) and the refined
 * renders (the refined model's), each frame warped into its previous and next in path order.
 * *json (free()): {"dir", "runs": [{"interval", "frames", "sparse": {"psnr", "coverage",
 * "pairs", "scored", "depth", "per_pair": [{"from", "to", "psnr", "coverage"}]}, "restored",
 * "refined"}]}; summary: one line per run. Fails with one line on a missing or foreign
 * metrics.json, a run whose frames are not its plan's, a missing or mis-sized frame or model. */
int gv_reconstruct_consistency(const char *dir, char **json, char *summary, size_t size);

#endif
