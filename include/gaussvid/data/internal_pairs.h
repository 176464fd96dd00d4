/* Scene-internal pairs (docs/ARCHITECTURE.md section 12; docs/FORMATS-DATASET.md "Scene-internal pairs"):
 * the supervision a sparse scene holds about itself, for adapting the restorer to it.
 *
 * With interval n the scene's training views are frames 0, n, 2n, ... (T = 1 + (F - 1) / n of
 * them; every other frame is held out and never read). K subsets (K >= 2; 2 by default) each
 * leave out one residue class of the views: subset j holds the views v with v mod K != (j + 1)
 * mod K. K = 2 is every other view (subset 0: views 0, 2n, 4n, ...; subset 1: n, 3n, ...); a K
 * of T or more leaves each interior view out alone, the rest of the scene kept. The
 * artifact simulator trains on each subset that leaves out an interior view and renders the
 * views between. Interior training view k (1 <= k <= T - 2) makes one clip, rendered by
 * subset (k - 1) mod K, which holds both its neighbours:
 *   frame 0  view (k - 1) n, clean (a training view of the subset)
 *   frame 1  the render of the held-out frame at the uniform position of a 2n clip (about
 *            (k - 1/2) n): no ground truth, masked
 *   frame 2  the render of view k n, left out of the subset: its ground truth is known
 *   frame 3  the render of the held-out frame at about (k + 1/2) n: masked
 *   frame 4  view (k + 1) n, clean
 * so every interior training view is left out once, and the only frames with ground truth are
 * training views. The clips are those of a dataset folder (clip.c, manifest.c) with interval
 * 2n, the window's first view mod 2n ((k - 1) mod 2 times n) as "offset" and the mask as
 * "target_mask" (dataset.h); the manifest records K as "subsets".
 *
 * The do-no-harm clips (full_model) have the same frames and mask, rendered by the simulator
 * trained on every training view at n (their metadata stay the pairs'): frames 1 and 3 are renders like
 * those the restorer must restore, and frame 2, a training view of that model, is nearly clean.
 * A restorer that changes it for the worse overshoots (the gate's second test, adapt.h). */
#ifndef GAUSSVID_INTERNAL_PAIRS_H
#define GAUSSVID_INTERNAL_PAIRS_H

#include <stdint.h>

#include "gaussvid/data/dataset.h"
#include "gaussvid/scene/scene.h"

/* Training views a scene needs at its interval: three clips, so that part of them can be held
 * back for validation and each subset has at least two views. */
#define GV_INTERNAL_MIN_VIEWS 5
/* The default number of subsets: every other training view. */
#define GV_INTERNAL_SUBSETS 2

typedef struct {
    int view;                        /* k: the left-out training view is frame k n */
    int subset;                      /* the subset that renders the clip: (k - 1) mod K */
    int frames[GV_CLIP_FRAMES];      /* frame indices in the scene */
} gv_internal_clip;

/* Training views of a scene of n_frames frames at interval n: 1 + (n_frames - 1) / n. */
int gv_internal_views(int n_frames, int interval);
/* Checks that a scene of n_frames frames gives internal pairs at interval n (n >= 2, at least
 * GV_INTERNAL_MIN_VIEWS training views); the message says how many views and frames it needs. */
int gv_internal_check(int n_frames, int interval);
/* The clips (T - 2, in order of k) into clips (room for n_frames rows), with K = subsets. */
int gv_internal_plan(int n_frames, int interval, int subsets, gv_internal_clip *clips, int *count);
/* The frames subset `subset` of K trains on, ascending, into frames (room for T). */
int gv_internal_subset_views(int n_frames, int interval, int subsets, int subset, int *frames, int *count);

typedef struct {
    int interval;                    /* n */
    int iters;                       /* the simulator's iterations per subset */
    int subsets;                     /* K (0: GV_INTERNAL_SUBSETS); ignored for the do-no-harm clips */
    int densify;                     /* its density control (gv_splat_densify_mode) */
    uint64_t seed;                   /* subset j trains with gv_run_seed(seed, scene, 2n) ^ (j * golden) */
    const gv_artifact_simulator *simulator; /* NULL: sparse 3DGS (gv_artifact_3dgs) */
    const char *out_dir;             /* the dataset folder written */
    int full_model;                  /* 1: the do-no-harm clips instead of the internal pairs */
    int coverage;                    /* 1: every clip must carry its coverage plane (the variant
                                        coverage): needs a simulator that renders depth, and a
                                        folder built before the plane is rebuilt. 0: the plane
                                        is written when the simulator renders depth, and older
                                        folders are taken as they are */
} gv_internal_options;

typedef struct {
    int clips;                       /* clips in the folder */
    int subsets_trained;             /* subsets trained by this call (0 when resumed whole) */
    double psnr, ssim;               /* mean over the left-out views of their renders */
    double seconds;
} gv_internal_result;

/* Builds, or resumes, the internal clips of a loaded scene in o->out_dir: one manifest run
 * (scene, 2n, split train) whose record scores the left-out views' renders. A subset whose
 * clips are all present (written by the same options) is not trained again; the manifest is
 * written last, so a folder it lists is complete. A folder built with other options is
 * refused. Progress: one line per subset and the simulator's own bar. */
int gv_internal_build(const gv_scene *scene, const gv_internal_options *o, gv_internal_result *result);

#endif
