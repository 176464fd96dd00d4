/* The paired clip dataset of the paper's section 3.2 (docs/ARCHITECTURE.md section 8;
 * docs/FORMATS-DATASET.md): for every scene and sparsity interval n, a sparse 3DGS trained on frames 0, n, 2n, ...
 * and stopped early renders the held-out frames (artifact simulation); 5-frame clips are
 * sampled clean anchor, three corrupted frames, clean anchor, with their ground truth,
 * intrinsics and poses, one safetensors file each, listed in manifest.json.
 *
 * Folder layout of a dataset:
 *   manifest.json                   every finished run and clip (the commit point of a run)
 *   clips/<scene>_n<NN>_<KKK>.safetensors
 *   runs/<scene>_n<NN>.json         per run: baseline PSNR/SSIM of every held-out frame, time */
#ifndef GAUSSVID_DATASET_H
#define GAUSSVID_DATASET_H

#include <stdint.h>

#include "gaussvid/core/core.h"
#include "gaussvid/io/gaussians.h"
#include "gaussvid/io/image.h"
#include "gaussvid/scene/scene.h"

#define GV_CLIP_FRAMES 5             /* anchor, three intermediates, anchor (paper 3.2) */
#define GV_CLIP_FORMAT "gaussvid.clip"
#define GV_CLIP_FORMAT_VERSION 1
#define GV_MANIFEST_FORMAT "gaussvid.clips"
#define GV_MANIFEST_FORMAT_VERSION 1
#define GV_SCENE_NAME_MAX 128        /* scene names are folder names; they name files */
#define GV_MAX_INTERVALS 256

/* What one run of the builder is, and each clip, manifest entry and record of it carries:
 * a scene (its folder name), the scene's split and the interval n of the sparse views. */
typedef struct {
    char scene[GV_SCENE_NAME_MAX];
    char split[8];                   /* "train" or "eval" */
    int interval;
} gv_run_id;

/* ---- sampling.c: which frames make a clip ----------------------------------------------
 * An interval n makes frames 0, n, 2n, ... training views. The anchors of a clip are the
 * training views s and e = s + gap, gap = anchor_gap * n (anchor_gap 1: consecutive training
 * views). The three intermediates are held-out frames strictly between them:
 *   uniform   round(s + j gap / 4), j = 1, 2, 3, round half to even (Python's round); a
 *             position that is a training frame (or repeats the previous one) moves to the
 *             nearest free held-out frame, the lower one on a tie;
 *   random    three distinct held-out frames drawn uniformly from (s, e), sorted;
 *   released  s + 1, s + gap / 2 (rounded down), s + gap - 1: the authors' released test
 *             clips (docs/reference/wan-vace-gaussvid.md section 1.3), moved as uniform is. */
typedef enum { GV_SAMPLING_UNIFORM, GV_SAMPLING_RANDOM, GV_SAMPLING_RELEASED } gv_clip_sampling;

/* "uniform", "random" or "released". */
const char *gv_sampling_name(gv_clip_sampling sampling);
/* Parses a sampling name; fails naming it. */
int gv_sampling_from_name(const char *name, gv_clip_sampling *out);
/* Checks that a scene of n_frames frames has at least one clip at interval n and anchor gap
 * g: gv_interval_check(n, 0, GV_INTERVAL_CLIPS) (n >= 2), g >= 1, g * n <= n_frames - 1 and g * (n - 1) >= 3 held-out frames between the
 * anchors. Fails with a message naming the numbers. */
int gv_clip_check_interval(int n_frames, int interval, int anchor_gap);
/* Number of anchor pairs (s, s + g n) with s a multiple of n and s + g n < n_frames. */
int gv_clip_anchor_count(int n_frames, int interval, int anchor_gap);
/* The 5 frame indices of the clip whose first anchor is s (a multiple of n); rng is used by
 * random sampling only (may be NULL otherwise). */
int gv_clip_frames(int n_frames, int interval, int anchor_gap, gv_clip_sampling sampling,
                   int s, gv_rng *rng, int frames[GV_CLIP_FRAMES]);
/* Up to k clips for one (scene, n), chosen with the seeded Philox generator and sorted by
 * frame indices: distinct anchor pairs while there are enough; beyond that random sampling
 * reuses anchor pairs with other intermediates, while uniform and released, which have one
 * clip per anchor pair, stop at the number of pairs. frames holds k rows. */
int gv_sample_clips(int n_frames, int interval, int anchor_gap, gv_clip_sampling sampling,
                    int k, uint64_t seed, int (*frames)[GV_CLIP_FRAMES], int *n_clips);

/* ---- clip.c: one clip = one safetensors file -------------------------------------------
 * Tensors: inputs U8 [5, H, W, 3] (anchor ground truth, 3 corrupted renders, anchor ground
 * truth), targets U8 [5, H, W, 3] (ground truth of all five), intrinsics F32 [5, 4]
 * (fx, fy, cx, cy in pixels), poses F32 [5, 3, 4] (world-to-camera [R | t], OpenCV axes).
 * __metadata__: format, format_version, scene, split, n, anchor_gap, frame_indices (JSON
 * list), frame_names (JSON list), iters, sampling, seed, width, height; and, only when they
 * are not 0, offset and target_mask (JSON list of 5: 1 ground truth, 0 none). Optional
 * tensor coverage U8 [3, H, W]: the coverage plane of frames 1-3 (gv_clip.coverage; written by
 * builders whose simulator renders depth, clip_coverage.c); a clip without it reads with
 * coverage NULL. */
typedef struct {
    gv_run_id id;
    int anchor_gap, iters;
    int width, height;
    gv_clip_sampling sampling;
    uint64_t seed;                   /* the build's --seed */
    int frames[GV_CLIP_FRAMES];      /* frame indices in the scene, increasing */
    char frame_names[GV_CLIP_FRAMES][256]; /* image names (may be empty when read) */
    /* Scene-internal pairs (internal_pairs.h); 0 in the clips of `dataset build`, and then
     * absent from the file: */
    int offset;                      /* the sparse model's training views are offset + k n */
    int subsets;                     /* K, the subsets of the training views that rendered the
                                        pairs, when not 2 (internal_pairs.h); 0 when 2 */
    uint8_t no_target[GV_CLIP_FRAMES]; /* 1: an intermediate without ground truth (its targets
                                          frame repeats its input; losses skip it) */
    uint8_t has_coverage;            /* read: the file holds the coverage plane (gv_clip.coverage) */
} gv_clip_info;

typedef struct {
    gv_clip_info info;
    uint8_t *inputs;                 /* 5 * height * width * 3, [frame][y][x][rgb] */
    uint8_t *targets;                /* the same layout */
    float intrinsics[GV_CLIP_FRAMES][4];
    float poses[GV_CLIP_FRAMES][12]; /* row-major 3 x 4 */
    uint8_t *coverage;               /* NULL, or the coverage plane of the intermediates (frames
                                        1-3): 3 * height * width bytes, [frame - 1][y][x], per pixel
                                        the bits of coverage.h (GV_COVERED_FIRST: anchor 0 sees it,
                                        GV_COVERED_LAST: anchor 4 does; 0: no anchor) */
} gv_clip;

/* Allocates zeroed inputs and targets for info->width x info->height and copies info (no
 * coverage plane). */
int gv_clip_alloc(gv_clip *clip, const gv_clip_info *info);
void gv_clip_free(gv_clip *clip);
/* Pointer to frame f (0..4) of inputs or targets. */
uint8_t *gv_clip_frame(uint8_t *frames, const gv_clip_info *info, int f);
/* Sets frame f's intrinsics and pose from a camera. */
void gv_clip_set_camera(gv_clip *clip, int f, const gv_camera *cam);
/* Fills frames 0..4 of a clip allocated for its info (clip_fill.c): frame indices, image
 * names and cameras, inputs[f] and targets[f] (RGB images of the clip's size). Fails naming
 * the frame whose image has another size. */
int gv_clip_fill(gv_clip *clip, const int frames[GV_CLIP_FRAMES], const gv_image *const inputs[GV_CLIP_FRAMES],
                 const gv_image *const targets[GV_CLIP_FRAMES], const gv_camera *const cameras[GV_CLIP_FRAMES]);
/* Checks the fields of info (the rules the reader applies); fails naming `what`. */
int gv_clip_check_info(const gv_clip_info *info, const char *what);
/* Writes the clip atomically. */
int gv_clip_write(const char *path, const gv_clip *clip);
/* Reads and validates a clip (every tensor, metadata field and their consistency). */
int gv_clip_read(const char *path, gv_clip *clip);
/* The clip padded to width x height (at least its size) on the right and bottom by
 * reflection (clip_pad.c, gv_image_pad_reflect): inputs, targets and the coverage plane when
 * it has one (mirrored with the pixels it describes); info and cameras the same but for the
 * size. For the restorer, which takes only multiples of its block (condition.h). */
int gv_clip_pad(const gv_clip *src, int width, int height, gv_clip *dst);
/* The 5 frames of a padded clip's layout (width x height) cropped to info's size into out
 * ([5, info->height, info->width, 3]): undoes gv_clip_pad. */
int gv_clip_crop_frames(const uint8_t *padded, int width, int height, const gv_clip_info *info, uint8_t *out);
/* Reads and validates only the metadata and the tensors' dtypes and shapes. */
int gv_clip_read_info(const char *path, gv_clip_info *info);

/* ---- clip_coverage.c: the coverage plane of a clip ---------------------------------------
 * Each intermediate's pixels seen by the clip's anchors (frames 0 and 4) through the depth of
 * the sparse model that rendered it (gv_coverage_plane, coverage.h). The functions allocate
 * clip->coverage when it is NULL. cams are the cameras of the clip's 5 frames. */
/* From the model's depth at the 5 frames (gv_coverage_depth's convention: 0 = no surface). */
int gv_clip_coverage_from_depths(gv_clip *clip, const gv_camera *const cams[GV_CLIP_FRAMES],
                                 const float *const depths[GV_CLIP_FRAMES], double rel_tolerance);
/* From a 3DGS model (what `reconstruct` has when it builds its clips): its depth where the
 * accumulated opacity reaches min_opacity (GV_COVERAGE_MIN_OPACITY, GV_COVERAGE_TOLERANCE are
 * the defaults of coverage.h). */
int gv_clip_coverage_gaussians(gv_clip *clip, const gv_gaussians *g, const gv_camera *const cams[GV_CLIP_FRAMES],
                               double rel_tolerance, double min_opacity);

/* ---- sheet.c ---------------------------------------------------------------------------- */
/* Contact sheet of a clip: the 5 inputs in a row above the 5 targets, frames separated by
 * GV_SHEET_GAP dark pixels and the two rows by a light line of the same width. */
#define GV_SHEET_GAP 2
int gv_clip_contact_sheet(const gv_clip *clip, gv_image *out);

/* ---- manifest.c: manifest.json ----------------------------------------------------------
 * The list of every finished run and clip of a dataset folder, with the options of the build
 * that made them. Rewritten atomically after every run, so that after an interruption it
 * lists exactly the runs that finished. */
typedef struct {
    int iters, anchor_gap, clips_per_run, downscale;
    gv_clip_sampling sampling;
    uint64_t seed;
    int densify;                     /* the simulator's density control (gv_splat_densify_mode) */
    int subsets;                     /* scene-internal pairs: their K when not 2, else 0 (absent) */
} gv_dataset_params;

typedef struct {
    gv_run_id id;
    int n_clips;
    double seconds;                  /* wall time of the run */
} gv_manifest_run;

typedef struct {
    char file[GV_SCENE_NAME_MAX + 64]; /* relative to the dataset folder */
    gv_run_id id;
    int frames[GV_CLIP_FRAMES];
} gv_manifest_clip;

typedef struct {
    gv_dataset_params params;
    int n_runs, cap_runs;
    gv_manifest_run *runs;
    int n_clips, cap_clips;
    gv_manifest_clip *clips;
} gv_manifest;

/* The build options as `dataset build` flags ("--iters 3000 --densify reference ..."); out
 * holds GV_DATASET_FLAGS_MAX bytes. */
#define GV_DATASET_FLAGS_MAX 240
void gv_dataset_params_flags(const gv_dataset_params *p, char *out, size_t size);
/* The build options as the manifest's "params" object (a new cJSON object, the caller's). */
struct cJSON;
struct cJSON *gv_dataset_params_json(const gv_dataset_params *p);
void gv_manifest_init(gv_manifest *m, const gv_dataset_params *params);
void gv_manifest_free(gv_manifest *m);
/* Reads dir/manifest.json; *found = 0 (and an empty manifest with zeroed params) when there
 * is none. Fails on a malformed file, naming it and the problem. */
int gv_manifest_read(const char *dir, gv_manifest *m, int *found);
/* As gv_manifest_read for a folder that must be a dataset: no manifest.json fails with
 * "DIR: no manifest.json (not a dataset folder)". */
int gv_manifest_read_dataset(const char *dir, gv_manifest *m);
/* Writes dir/manifest.json atomically. */
int gv_manifest_write(const char *dir, const gv_manifest *m);
/* Index of the run (scene, n), or -1. */
int gv_manifest_find_run(const gv_manifest *m, const char *scene, int n);
/* Adds a run and its clips, replacing any previous entries of the same (scene, n). Runs and
 * clips are kept sorted by (scene, n, file) so the file does not depend on build order. */
int gv_manifest_add_run(gv_manifest *m, const gv_manifest_run *run,
                        const gv_manifest_clip *clips, int n_clips);
/* File names: clips/<scene>_n<NN>_<KKK>.safetensors and runs/<scene>_n<NN>.json. */
int gv_clip_file_name(char *out, size_t size, const char *scene, int n, int k);
int gv_run_file_name(char *out, size_t size, const char *scene, int n);

/* ---- runs.c: runs/<scene>_n<NN>.json -----------------------------------------------------
 * What a run measured: PSNR and SSIM of the corrupted render of every held-out frame against
 * its ground truth (as the 3DGS evaluation computes them), the mean over the training views,
 * and its timings. */
typedef struct {
    gv_run_id id;
    int iters, n_train;
    int n_held_out;
    int *held_out;                   /* frame indices */
    double *psnr, *ssim;             /* per held-out frame */
    double psnr_mean, ssim_mean;     /* over the held-out frames */
    int train_frames;                /* training views scored (0: not recorded) */
    double train_psnr, train_ssim;   /* their mean: how well the sparse model fits its views */
    double train_seconds, render_seconds, seconds;
    int n_clips;
} gv_run_record;

/* Allocates the per-frame arrays for n_held_out frames. */
int gv_run_record_alloc(gv_run_record *r, int n_held_out);
void gv_run_record_free(gv_run_record *r);
/* Sets psnr_mean and ssim_mean from the per-frame values. */
void gv_run_record_summarise(gv_run_record *r);
int gv_run_record_write(const char *path, const gv_run_record *r);
int gv_run_record_read(const char *path, gv_run_record *r);

/* ---- build.c: `dataset build` ------------------------------------------------------------
 * The artifact simulator: trains a degraded model of a scene from some of its views (the
 * training views 0, n, 2n, ... for `dataset build`; a subset of them for adapt's internal
 * pairs) and renders any of its cameras through it. The default is sparse 3DGS stopped early
 * (gv_artifact_3dgs, artifact_3dgs.c); tests plug in cheap ones. */
typedef struct {
    const char *name;
    /* Trains on the listed frames of the scene (ascending, at least two), stopped at iters,
     * with density control densify (a gv_splat_densify_mode); *model belongs to the simulator. */
    int (*train)(void *ctx, const gv_scene *scene, const int *views, int n_views, int iters, int densify,
                 uint64_t seed, void **model);
    /* Renders frame `frame` of the scene into out (newly allocated, RGB, camera size). */
    int (*render)(void *ctx, void *model, const gv_scene *scene, int frame, gv_image *out);
    void (*free_model)(void *ctx, void *model);
    void *ctx;
    /* Optional (NULL: the clips get no coverage plane): the model's view depth at frame `frame`
     * into depth (camera size), 0 where it shows no surface (gv_coverage_depth). */
    int (*depth)(void *ctx, void *model, const gv_scene *scene, int frame, float *depth);
} gv_artifact_simulator;

/* The coverage plane of a simulated clip: the simulator's depth at the clip's frames (indices
 * in `scene`, the scene the model was trained on), then gv_clip_coverage_from_depths at the
 * default tolerance. Fails when the simulator renders no depth. */
int gv_clip_coverage_simulated(gv_clip *clip, const gv_artifact_simulator *sim, void *model, const gv_scene *scene,
                               const int frames[GV_CLIP_FRAMES]);

/* Sparse 3DGS (gv_splat_train's defaults, stopped at --iters), rendered
 * with every SH degree over the training background and quantised to 8 bits; its depth is
 * gv_coverage_depth's at the default minimum opacity, so its clips carry the coverage plane. */
extern const gv_artifact_simulator gv_artifact_3dgs;

typedef struct {
    const char **scene_dirs;
    int n_scenes;
    const int *intervals;
    int n_intervals;
    const char **eval_scenes;        /* scene names (folder names) of the "eval" split */
    int n_eval_scenes;
    gv_dataset_params params;
    const char *out_dir;
    const gv_artifact_simulator *simulator; /* NULL: sparse 3DGS */
    int jobs;                        /* runs side by side, one thread each (0 or 1: one run at a
                                        time with every thread) */
} gv_dataset_build_options;

typedef struct {
    int runs_total, runs_skipped, runs_built;
    int clips_written;
    double seconds;
} gv_dataset_build_result;

/* The defaults: 8000 iterations (paper 3.2), 1 clip per run, anchor gap 1, uniform, seed 0,
 * no downscale, the trainer's default density control. */
void gv_dataset_default_params(gv_dataset_params *p);
/* The scene name of a scene folder: its last path component. */
int gv_scene_name_of(const char *dir, char *out, size_t size);
/* Builds (or resumes) a dataset. Every scene and interval is checked before any training. */
int gv_dataset_build(const gv_dataset_build_options *opt, gv_dataset_build_result *result);
/* Derived seed of a run, independent of the build's order: Philox of (seed, scene, n). */
uint64_t gv_run_seed(uint64_t seed, const char *scene, int n);

/* ---- stats.c: `dataset stats` ------------------------------------------------------------ */
typedef struct {
    int interval;
    int clips_train, clips_eval;
    int runs;
    int frames;                      /* held-out frames measured */
    double psnr, ssim;               /* mean over those frames */
    double seconds;                  /* mean seconds per run */
} gv_dataset_stats_row;

typedef struct {
    gv_dataset_params params;
    int n_runs, n_clips, n_scenes;
    int n_rows;
    gv_dataset_stats_row rows[GV_MAX_INTERVALS];
} gv_dataset_stats;

/* Reads the manifest and every run record of a dataset folder and aggregates per n. */
int gv_dataset_stats_read(const char *dir, gv_dataset_stats *out);

#endif
