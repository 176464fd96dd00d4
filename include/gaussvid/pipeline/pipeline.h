/* `gaussvid reconstruct` (docs/RECONSTRUCT.md; issue 23): from a scene folder to a sparse
 * 3DGS model, its renders restored by the video restorer, a refined 3DGS, metrics, a video.
 *
 * Per interval n the stages run in the order of a table (gv_reconstruct_stages):
 *   train     sparse 3DGS on frames 0, n, 2n, ...            nN/sparse.ply, sparse.splat
 *   render    the evaluated frames from the sparse model     nN/frames/render/
 *   adapt     the restorer adapted to the scene (restore_with adapted, where the scene has
 *             the training views for it)                    nN/restorer.safetensors
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
 * The path is never worse than its own evidence allows (docs/RECONSTRUCT.md, "Decisions"):
 * by default the restorer is adapted to the scene and its gate decides; where the gate
 * closes, or adaptation cannot run (too few training views), restore keeps the renders
 * without running the network and refine keeps the sparse model, each saying so in one line
 * and in metrics.json's "decisions". GV_RESTORE_CHECKPOINT restores with the checkpoint as it
 * is (no gate); GV_RESTORE_NONE stops at the sparse model (no restore, no refine).
 *
 * DIR/metrics.json (documented in docs/RECONSTRUCT.md) records every number and each
 * finished stage with the inputs it was made from; it is rewritten atomically after every
 * stage, so a rerun skips the finished stages (after checking their inputs are the same and
 * their files exist) and continues with the first unfinished one. */
#ifndef GAUSSVID_PIPELINE_H
#define GAUSSVID_PIPELINE_H

#include <stddef.h>
#include <stdint.h>

#include "gaussvid/restore/adapt.h"

#define GV_RECONSTRUCT_FORMAT "gaussvid-reconstruct-1"
#define GV_RECONSTRUCT_MAX_INTERVALS 32

/* How the held-out frames are restored. */
typedef enum {
    GV_RESTORE_ADAPTED,          /* adapt the checkpoint to the scene; its gate decides (default) */
    GV_RESTORE_CHECKPOINT,       /* restore with the checkpoint as it is, ungated (a scene
                                    checkpoint given as ckpt still honours its own gate) */
    GV_RESTORE_NONE              /* no restoration and no refinement: the sparse model only */
} gv_restore_with;
#define GV_RESTORE_WITH_NAMES "adapted, checkpoint or none"
const char *gv_restore_with_name(int mode);
/* -1 when name is none of GV_RESTORE_WITH_NAMES. */
int gv_restore_with_parse(const char *name);

typedef struct {
    const char *scene_dir;
    int intervals[GV_RECONSTRUCT_MAX_INTERVALS];
    int n_intervals;
    const char *out_dir;
    const char *ckpt;            /* the restorer: a cross-scene checkpoint (or a scene checkpoint) */
    int downscale;               /* scene images: 1, 2, 4, 8; 0: chosen from their size
                                  * (gv_reconstruct_auto_downscale) */
    int iters;                   /* sparse 3DGS iterations */
    int densify;                 /* its density control (gv_splat_densify_mode) */
    int regularize;              /* its sparse-view regularisers (GV_REGULARIZE_* bits; 0: plain
                                  * 3DGS, the base "3dgs" of the paper's table) */
    int resolution_start;        /* its resolution schedule: the first iterations at 1/K of the
                                  * size (splat train's --resolution-schedule; 1: full size) */
    int refine_iters;            /* refinement iterations */
    double refine_weight;        /* the restored frames' loss weight (training views: 1) */
    int restore_with;            /* gv_restore_with */
    const char *preset;          /* the preset the settings came from (recorded; NULL: "default") */
    gv_adapt_options adapt_options; /* the adapt stage's settings (scene, interval, base, out set per run) */
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
 * weight 0.3, restoration adapted (gated), 8 frames per second, gv_adapt_defaults. */
void gv_reconstruct_defaults(gv_reconstruct_options *o);
/* The downscale reconstruct takes when none is given: the smallest of 1, 2, 4 and 8 that brings
 * the longer side of a width x height image to at most GV_RECONSTRUCT_AUTO_SIDE pixels (8 when
 * none does). A phone's 1080x1920 trains at 270x480, a 4032x3024 photo at 504x378; the shared
 * scenes (256x144) at their size. docs/RECONSTRUCT.md "Image size" gives the measured costs. */
#define GV_RECONSTRUCT_AUTO_SIDE 512
int gv_reconstruct_auto_downscale(int width, int height);

/* Presets (docs/RECONSTRUCT.md, "Presets"): the settings of "fast", "default" or "best" over
 * o (the sparse iterations, density control, refinement iterations, restoration, adaptation
 * steps); a caller sets its explicit flags afterwards, so they win. Fails on another name. */
#define GV_RECONSTRUCT_PRESET_NAMES "fast, default or best"
int gv_reconstruct_preset(const char *name, gv_reconstruct_options *o);

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
