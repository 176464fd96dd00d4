/* Training 3D Gaussian Splatting from the views of a scene, as the official 3DGS does
 * (docs/reference/gaussian-splatting.md sections 3, 12-14; docs/SPLAT_TRAINING.md):
 * initialisation from the sparse points, Adam with the reference learning rates, adaptive
 * density control (clone, split, prune, opacity reset), the training loop, and evaluation
 * of a model on a scene's views. Rendering itself is in render.h. */
#ifndef GAUSSVID_SPLAT_TRAIN_H
#define GAUSSVID_SPLAT_TRAIN_H

#include <stdint.h>

#include "gaussvid/core/core.h"
#include "gaussvid/io/gaussians.h"
#include "gaussvid/io/image.h"
#include "gaussvid/io/metrics.h"
#include "gaussvid/splat/render.h"
#include "gaussvid/scene/scene.h"

/* ---- knn.c ------------------------------------------------------------------------------
 * Exact k nearest neighbours with a kd-tree: out[i] = mean squared distance from point i
 * to its k nearest other points (fewer when the cloud has fewer; 0 when it has one point).
 * xyz is n * 3. Fails on k < 1 or when memory runs out. */
int gv_knn_mean_sq_dist(int n, const float *xyz, int k, float *out);
/* The k nearest of the n points xyz to each of n_query points query (NULL: to each of the
 * points themselves, each excluding itself): index and sq_dist are n_query * k, nearest
 * first; -1 and INFINITY where there are fewer than k. Exact; ties keep the tree's order
 * (the same for any thread count). Fails on k outside 1..16 or when memory runs out. */
int gv_knn_neighbors(int n, const float *xyz, int n_query, const float *query, int k,
                     int *index, double *sq_dist);

/* ---- init.c -----------------------------------------------------------------------------
 * 3DGS create_from_pcd (section 3.1): SH DC from the colour, (rgb - 0.5) / C0, higher SH 0;
 * isotropic log-scale log sqrt(max(mean sq. distance to the 3 nearest neighbours, 1e-7));
 * rotation (1, 0, 0, 0); opacity logit(0.1). rgb is n * 3 bytes (NULL: grey 128). */
int gv_splat_init_from_points(gv_gaussians *g, int n, const float *xyz, const uint8_t *rgb,
                              int sh_degree);
/* Random initialisation when a scene has no points (section 3.2): n points uniform in the
 * axis-aligned cube center +- half_size, SH DC uniform in [0, 1/255) as 3DGS draws it,
 * then create_from_pcd's scales, rotations and opacities. */
int gv_splat_init_random(gv_gaussians *g, int n, const double center[3], double half_size,
                         int sh_degree, uint64_t seed);

/* ---- splat_adam.c -----------------------------------------------------------------------
 * Adam (PyTorch form) with one parameter group per attribute (section 13). */
enum {
    GV_ADAM_MEANS, GV_ADAM_SH_DC, GV_ADAM_SH_REST, GV_ADAM_OPACITY, GV_ADAM_SCALES,
    GV_ADAM_ROTATIONS, GV_ADAM_GROUPS
};
#define GV_ADAM_ALL_GROUPS ((1u << GV_ADAM_GROUPS) - 1u)

typedef struct {
    double means_lr_init, means_lr_final; /* multiplied by the scene extent */
    long means_lr_steps;                  /* log-linear decay over this many iterations */
    double sh_dc_lr, sh_rest_lr, opacity_lr, scales_lr, rotations_lr;
    double beta1, beta2, eps;
} gv_splat_adam_config;

typedef struct {
    gv_splat_adam_config config;
    double spatial_lr_scale;     /* the scene extent */
    double lr[GV_ADAM_GROUPS];   /* current learning rates */
    long step[GV_ADAM_GROUPS];   /* steps taken per group (bias correction) */
    gv_gaussians m, v;           /* first and second moments, rows parallel to the model */
} gv_splat_adam;

/* The official 3DGS values (section 13.1, the 2023 release: opacity 0.05). */
void gv_splat_adam_defaults(gv_splat_adam_config *c);
/* get_expon_lr_func without delay: exp((1 - t) ln lr_init + t ln lr_final), t =
 * clamp(step / max_steps, 0, 1); 0 when both rates are 0. */
double gv_splat_expon_lr(long step, double lr_init, double lr_final, long max_steps);
/* Zero moments for the rows of params, step counts 0, rates at iteration 0. */
int gv_splat_adam_init(gv_splat_adam *a, const gv_splat_adam_config *c,
                       const gv_gaussians *params, double spatial_lr_scale);
/* update_learning_rate(iteration): the position rate of this iteration. */
void gv_splat_adam_set_iteration(gv_splat_adam *a, long iteration);
/* One Adam step of the groups in group_mask. Only the listed rows (ascending) have a
 * gradient, and the step consumes it: their rows of grad are zero afterwards; every other
 * row of grad must be zero. With all_rows every row of params steps, the reference's dense
 * Adam; otherwise only the listed rows do, and the others keep their values and moments.
 * Only the first n_coeffs SH coefficients per channel are touched: those above the active
 * degree have zero gradient and zero moments, so Adam would leave them unchanged anyway. */
void gv_splat_adam_step(gv_splat_adam *a, gv_gaussians *params, gv_gaussians *grad,
                        const int *rows, int n_rows, int all_rows, int n_coeffs,
                        unsigned group_mask);
void gv_splat_adam_free(gv_splat_adam *a);

/* ---- loss.c -----------------------------------------------------------------------------
 * The training loss (section 11): L = (1 - lambda) L1 + lambda (1 - SSIM) of a render
 * against its target (float HWC, 3 channels), SSIM as section 19.2, computed in float32 as
 * the reference does, and dL/drender (section 11.1). */
typedef struct {
    int width, height, threads;  /* what the buffers were made for */
    float g[GV_SSIM_WINDOW];     /* the normalised 1-D window */
    float *maps, *scratch, *mass_x, *mass_y, *zeros;
    double *row_sums;
} gv_splat_loss_work;

typedef struct { double loss, l1, ssim; } gv_splat_loss_value;

/* Buffers for width x height images (w starts zeroed); fails on a bad size or no memory. */
int gv_splat_loss_reserve(gv_splat_loss_work *w, int width, int height);
/* The loss of render against target, and dL/drender into d_render (may be NULL). Fails on a
 * bad size, no memory, or a non-finite loss. */
int gv_splat_loss(gv_splat_loss_work *w, const float *render, const float *target, int width,
                  int height, double lambda, float *d_render, gv_splat_loss_value *value);
void gv_splat_loss_free(gv_splat_loss_work *w);

/* ---- densify.c --------------------------------------------------------------------------
 * Adaptive density control (section 14.2-14.3). */
typedef struct {
    int capacity;
    float *grad_accum;  /* sum over views of |dL/d means2d| in NDC units (render.h) */
    int *denom;         /* number of views in which the Gaussian was visible */
    int *max_radii;     /* largest screen radius seen, pixels */
} gv_splat_densify_stats;

typedef struct {
    double grad_threshold;   /* clone or split when the mean statistic is >= this; 0: the
                              * mode's (gv_splat_densify_threshold) */
    double percent_dense;    /* 0.01: clone when max scale <= this x extent, else split */
    double min_opacity;      /* 0.005: prune below */
    double extent;           /* the scene extent */
    int prune_big;           /* also prune max scale > 0.1 x extent (after the first reset) */
    int max_screen_size;     /* prune max radius > this (pixels); 0 = off, as the reference
                              * effectively runs (its statistic is zeroed before the test) */
} gv_splat_densify_params;

typedef struct { int cloned, split, pruned; } gv_splat_densify_counts;

/* Makes room for `capacity` rows; new rows are zero. */
int gv_splat_densify_stats_reserve(gv_splat_densify_stats *s, int capacity);
/* Zeroes the statistics of rows [0, n). */
void gv_splat_densify_stats_clear(gv_splat_densify_stats *s, int n);
/* add_densification_stats for the visible Gaussians of one view. */
void gv_splat_densify_accumulate(gv_splat_densify_stats *s, int n_visible, const int *visible,
                                 const float *densify_grad, const int *radii);
/* The same for a render at 1/radius_scale of the full size: the radii are counted in full
 * resolution pixels (radius x radius_scale), so max_screen_size keeps its meaning. */
void gv_splat_densify_accumulate_scaled(gv_splat_densify_stats *s, int n_visible,
                                        const int *visible, const float *densify_grad,
                                        const int *radii, int radius_scale);
/* densify_and_prune: clone, then split (2 children sampled from the Gaussian with rng,
 * scales / 1.6, parent removed), then prune; the Adam moments follow every row (new rows
 * zero), and the statistics are zeroed. counts may be NULL. */
int gv_splat_densify_and_prune(gv_gaussians *g, gv_splat_adam *adam,
                               gv_splat_densify_stats *s, const gv_splat_densify_params *p,
                               gv_rng *rng, gv_splat_densify_counts *counts);
/* reset_opacity: opacity <= 0.01 for every Gaussian and zero opacity moments. */
void gv_splat_reset_opacity(gv_gaussians *g, gv_splat_adam *adam);
/* Binocular3DGS's opacity decay: every opacity times factor (on the sigmoid), Adam's moments
 * kept, as the release assigns the tensor's data in place. */
void gv_splat_decay_opacity(gv_gaussians *g, double factor);
void gv_splat_densify_stats_free(gv_splat_densify_stats *s);

/* ---- mcmc.c -----------------------------------------------------------------------------
 * Density control as MCMC (Kheradmand et al. 2024; gsplat's MCMCStrategy): a budget of
 * Gaussians, dead ones relocated onto live ones, growth by a share of the count, noise on
 * the positions of transparent ones, L1 regularisers on opacity and scale. */
typedef struct {
    int cap;                 /* the budget; 0 = no budget */
    double growth;           /* 0.05: each refinement adds this share of the count */
    double min_opacity;      /* 0.005: at or below, a Gaussian is dead and relocated */
    double noise_lr;         /* 5e5: noise scale, times the position learning rate */
    double opacity_reg;      /* 0.01: loss + opacity_reg mean(opacity) */
    double scale_reg;        /* 0.01: loss + scale_reg mean(scale) */
} gv_splat_mcmc_params;

void gv_splat_mcmc_defaults(gv_splat_mcmc_params *p);
/* Paper eq. 9: the opacity and the scale factor that let n copies of a Gaussian of the
 * given opacity render like it (n is clamped to 1..51; n = 1 gives it back unchanged). */
void gv_splat_mcmc_share(double opacity, int n, double *new_opacity, double *scale_factor);
/* Moves every Gaussian with opacity <= min_opacity onto a live one drawn in proportion to
 * opacity, sharing the drawn one's contribution; the touched rows' moments start at zero. */
int gv_splat_mcmc_relocate(gv_gaussians *g, gv_splat_adam *adam, const gv_splat_mcmc_params *p,
                           gv_rng *rng, int *relocated);
/* Adds min(growth x count, cap - count) Gaussians the same way (new rows at the end). */
int gv_splat_mcmc_grow(gv_gaussians *g, gv_splat_adam *adam, const gv_splat_mcmc_params *p,
                       gv_rng *rng, int *added);
/* Paper eq. 10: means += Sigma eps op_sigmoid(1 - opacity) noise_lr means_lr, eps ~ N(0, I)
 * drawn from (seed, 3 i + axis): the same whatever the thread count. */
void gv_splat_mcmc_noise(gv_gaussians *g, const gv_splat_mcmc_params *p, double means_lr,
                         uint64_t seed);
/* ADDS the regularisers' gradients to every row of grad (opacity logits, log-scales). */
void gv_splat_mcmc_regularize(const gv_gaussians *g, const gv_splat_mcmc_params *p,
                              gv_gaussians *grad);

/* ---- dropgaussian.c ---------------------------------------------------------------------
 * DropGaussian (Park et al., CVPR 2025): each training render leaves out a random share of
 * the Gaussians, the rate growing linearly to options.drop_rate over the run, and multiplies
 * the opacity of the kept ones by 1 / (1 - rate), so that the expected render is the full
 * one; renders outside training are untouched. */
/* The final rate by default: half the paper's 0.2, which cost up to half a dB where the
 * views are many (docs/RESULTS.md section 5, "the user's default with the resolution
 * schedule"). */
#define GV_DROP_RATE 0.1
/* final x iteration / iterations (iteration 1 .. iterations; the last rate after them). */
double gv_splat_drop_rate(int iteration, int iterations, double final);
/* scale[i] for i < n: 0 (dropped, with probability rate) or 1 / (1 - rate), from the
 * uniform number (seed, i): the same whatever the thread count. Returns the number dropped.
 * rate must be in [0, 1). */
int gv_splat_drop_draw(int n, double rate, uint64_t seed, float *scale);

/* ---- fsgs.c -----------------------------------------------------------------------------
 * FSGS's proximity-guided unpooling (Zhu et al., ECCV 2024): a Gaussian whose proximity
 * score, sqrt(mean squared distance to its GV_FSGS_NEIGHBORS nearest), exceeds threshold
 * (and is at most 10 x threshold: farther, it is an isolated floater) gets a new Gaussian at the midpoint to each of those neighbours: the source's scale,
 * opacity and rotation, the mean of the two ends' SH. An edge between two such Gaussians
 * that are each other's neighbours is grown once (from the lower row). New rows follow the
 * model's (ordered by source row, then neighbour nearest first) with zero Adam moments. */
#define GV_FSGS_NEIGHBORS 3
int gv_splat_fsgs_unpool(gv_gaussians *g, gv_splat_adam *adam, double threshold, int *added);

/* ---- corgs.c ----------------------------------------------------------------------------
 * CoR-GS's co-pruning (Zhang et al., ECCV 2024): two fields trained together; a Gaussian of
 * either with no Gaussian of the other within tau (world units) is removed, both fields
 * judged before either is pruned (rows keep their order, Adam moments follow). */
int gv_splat_corgs_coprune(gv_gaussians *a, gv_splat_adam *adam_a, gv_gaussians *b,
                           gv_splat_adam *adam_b, double tau, int *pruned_a, int *pruned_b);

/* ---- resolution.c -----------------------------------------------------------------------
 * Resolution scheduling (docs/SPLAT_TRAINING.md, "Resolution scheduling"; the idea of
 * DashGaussian, CVPR 2025): the first iterations train on the views at 1/start of their size
 * (cameras with every intrinsic divided by the factor, box-filtered targets), the factor
 * halving at evenly spaced steps until full resolution. */
#define GV_RESOLUTION_MAX_FACTOR 8
/* The downsample factor of iteration (1 .. iterations): with start 2, 4 or 8 (s = 1, 2, 3
 * halvings) and c = round(full_at x iterations), iteration i <= c trains at
 * start / 2^floor((i - 1) s / c), later ones at 1; start 0 or 1 (off) always gives 1. */
int gv_splat_resolution_factor(int iteration, int iterations, int start, double full_at);
/* Fails unless start is 0, 1, 2, 4 or 8 and (with start > 1) full_at is in (0, 1]. */
int gv_splat_resolution_check(int start, double full_at);
/* The largest factor up to start (halving it) at which each of the n cameras keeps at least a
 * pixel on each side: the user's default schedule on views of a few pixels (an explicit
 * factor too large for a view is refused when its level is made). */
int gv_splat_resolution_fit(int start, const gv_camera *cameras, int n);
/* out (floor(width / f) x floor(height / f) x 3, HWC) = the mean of each f x f block of in
 * (width x height x 3); the last width mod f columns and height mod f rows are left out. */
void gv_splat_box_downsample(const float *in, int width, int height, int f, float *out);
/* The camera cam seen at 1/f: the same pose, size floor(W / f) x floor(H / f), fx, fy, cx, cy
 * divided by f (its pixel (i, j) is the f x f block of cam's pixels from (i f, j f)). */
void gv_camera_downsampled(const gv_camera *cam, int f, gv_camera *out);
/* One level of a training run: the training views at 1/factor and their targets. */
typedef struct {
    int factor;                 /* 0 until built */
    gv_splat_view *views;       /* n_views */
    float **targets;            /* n_views box-filtered views, HWC floats in [0, 1] */
} gv_splat_resolution_level;
void gv_splat_resolution_levels_free(gv_splat_resolution_level *levels, int n_levels, int n_views);

/* ---- binocular.c ------------------------------------------------------------------------
 * Binocular3DGS's binocular consistency loss (Han, Zhou, Liu and Han, NeurIPS 2024; the
 * release hanl2010/Binocular3DGS, train.py): the training camera shifted sideways by a random
 * baseline b is rendered, warped back into the training view with the disparity of the
 * model's own accumulated depth D (rasterize_depth_backward.c), d = -fx b / (D + 1e-5), and
 * compared with the training photo; an edge-aware smoothness of d is added. The constants are
 * the release's (docs/SPLAT_TRAINING.md, "binocular"). */
#define GV_BINOCULAR_SMOOTH_WEIGHT 0.05 /* loss = L1 + 0.05 smoothness */
#define GV_BINOCULAR_EDGE_DECAY 0.33f   /* the smoothness's weight exp(-0.33 |image gradient|) */
#define GV_BINOCULAR_DEPTH_EPS 1e-5f    /* d = -fx b / (D + 1e-5) */

/* Row-wise linear sampling, the release's inverse warp (monodepth's): warped(x, y) =
 * (x0 + 1 - s) image(x0, y) + (s - x0) image(x0 + 1, y) at s = x + disparity(x, y), x0 =
 * floor(s) (pixel indices; pixel x is centred at x + 0.5 in both images, which share
 * intrinsics). valid(x, y) = 1 when x0 and x0 + 1 are both columns of the image, else 0 and
 * warped = 0 there. image and warped are HWC, 3 channels; disparity and valid W x H. */
void gv_splat_warp_rows(const float *image, int width, int height, const float *disparity,
                        float *warped, float *valid);
/* Its backward from d_warped: ADDS dL/dimage into d_image and WRITES dL/d disparity (either
 * may be NULL); x0 is piecewise constant, so dwarped/ddisparity = image(x0 + 1) - image(x0);
 * zero where not valid. */
void gv_splat_warp_rows_backward(const float *image, int width, int height,
                                 const float *disparity, const float *d_warped, float *d_image,
                                 float *d_disparity);
/* The release's edge-aware smoothness of a disparity map (W x H) along an image (HWC): over
 * the (W - 2)(H - 2) interior pixels, mean |exp(-0.33 |gx|) dx| + mean |exp(-0.33 |gy|) dy|
 * with dx = (d(x+1) - d(x-1)) / 2 and gx the same of the image summed over its channels (and
 * in y alike). ADDS its gradient into d_disparity (NULL: none). 0 for images under 3 x 3. */
double gv_splat_edge_smoothness(const float *disparity, const float *image, int width,
                                int height, float *d_disparity);

typedef struct { double loss, l1, smoothness; int valid_pixels; } gv_splat_binocular_value;
typedef struct {
    long pixels;                /* what the buffers hold */
    float *disparity, *valid, *warped, *d_warped, *d_disparity, *masked, *d_smooth;
} gv_splat_binocular_work;

/* The release's term for one training view: from the accumulated depth D of its render
 * (depth_sum, W x H) and the render of the camera shifted by baseline b along its x axis
 * (shifted, HWC), d = -fx b / (D + 1e-5), loss = mean over 3 W H of valid |warped - target| +
 * 0.05 smoothness(valid d, target). WRITES dL/dshifted (HWC) and dL/d depth_sum (W x H),
 * scaled by weight (as the loss is). Fails on a bad size, no memory or a non-finite loss. */
int gv_splat_binocular_loss(gv_splat_binocular_work *w, const float *target,
                            const float *depth_sum, const float *shifted, int width, int height,
                            double fx, double baseline, double weight, float *d_shifted,
                            float *d_depth_sum, gv_splat_binocular_value *value);
void gv_splat_binocular_work_free(gv_splat_binocular_work *w);
/* The view v with its centre moved by baseline along its own x axis (the release's
 * getShiftedCamera): the same rotation and intrinsics, t - (b, 0, 0). */
void gv_splat_view_shifted(const gv_splat_view *v, double baseline, gv_splat_view *out);
/* The median view depth z of the centres of g over the views, counting each (Gaussian,
 * view) pair whose centre is beyond the near plane and projects into the image; 0 when none
 * does, -1 when memory runs out. The scale of the baseline. */
double gv_splat_median_view_depth(const gv_gaussians *g, int n_views, const gv_splat_view *views);

/* The term's state in a training run. */
typedef struct {
    gv_splat_renderer renderer; /* the shifted camera's */
    gv_splat_binocular_work work;
    gv_gaussians grad;          /* the shifted render's gradient (valid on its visible rows) */
    float *shifted, *d_shifted, *depth_sum, *d_depth_sum;
    long pixels;
    int *rows, rows_capacity;   /* Adam's rows: the two renders' visible ones */
    gv_rng rng;                 /* the baselines */
    int from;                   /* the term runs in the iterations after this one */
    double depth;               /* the initial model's median view depth */
    double baseline;            /* the largest |b|: options.binocular_baseline x depth */
    long views;                 /* shifted views rendered */
    double loss_sum, l1_sum, smoothness_sum, baseline_sum; /* over them: the term, its two
                                 * parts (unweighted), |b| */
    double seconds;             /* the depth pass, the shifted render, the loss and the
                                 * shifted backward (the depth backward counts in the
                                 * trainer's backward) */
} gv_splat_binocular;

/* ---- train.c ----------------------------------------------------------------------------
 * The loop of 3DGS train.py (section 14.1). Iteration numbers start at 1. */
typedef enum { GV_BG_BLACK, GV_BG_WHITE, GV_BG_RANDOM } gv_splat_background;

typedef struct {
    int sh_interval;            /* 1000: one more SH degree at each multiple */
    int densify_from;           /* 500: densify when iteration > this ... */
    int densify_until;          /* 15000: ... and < this ... */
    int densify_interval;       /* 100: ... and a multiple of this */
    int opacity_reset_interval; /* 3000 (while < densify_until) */
} gv_splat_schedule;

/* How the model grows (docs/SPLAT_TRAINING.md, "Density control"):
 * - reference (the library's default): the paper's clone / split / prune with opacity
 *   resets; `dataset build` and `adapt` keep it (set explicitly there), so the restorer's
 *   training pairs carry the paper's artifacts;
 * - lean: the same with the gradient threshold doubled (0.0004): a third of the Gaussians
 *   at 256x144 and 1.9x faster at the same mean held-out PSNR (0.001 lower SSIM over the
 *   15-cell baseline table); the default of `splat train`;
 * - mcmc: a budget that follows the training pixels, relocation of dead Gaussians. */
typedef enum { GV_DENSIFY_MCMC, GV_DENSIFY_REFERENCE, GV_DENSIFY_LEAN } gv_splat_densify_mode;
#define GV_DENSIFY_DEFAULT GV_DENSIFY_REFERENCE
#define GV_DENSIFY_MODE_NAMES "lean, reference or mcmc"
/* "lean", "reference" or "mcmc"; -1 for anything else. */
int gv_splat_densify_mode_parse(const char *name);
const char *gv_splat_densify_mode_name(gv_splat_densify_mode mode);

/* Prior-free sparse-view regularisers (docs/SPLAT_TRAINING.md, "Sparse-view regularisers"),
 * a set of bits; none of them is the plain 3DGS of the reference. */
enum { GV_REGULARIZE_DROPGAUSSIAN = 1 << 0, GV_REGULARIZE_FSGS = 1 << 1, GV_REGULARIZE_CORGS = 1 << 2,
       GV_REGULARIZE_SEGS = 1 << 3, GV_REGULARIZE_DECAY = 1 << 4, GV_REGULARIZE_BINOCULAR = 1 << 5 };
/* The regularisers that train a second field alongside the model. */
#define GV_REGULARIZE_TWO_FIELDS (GV_REGULARIZE_CORGS | GV_REGULARIZE_SEGS)
#define GV_REGULARIZE_NAMES "none or a comma-separated list of dropgaussian, fsgs, corgs, segs, decay, binocular"
/* The regularisers of the model a user gets (`splat train`, `reconstruct`; issue 38): the
 * opacity decay up to half the iterations with DropGaussian, the best measured over the
 * 15-cell table (docs/RESULTS.md section 5, "the user's default"). The library's default
 * stays plain 3DGS: `dataset build` and `adapt` train the paper's artifacts. */
#define GV_REGULARIZE_USER (GV_REGULARIZE_DROPGAUSSIAN | GV_REGULARIZE_DECAY)
/* The regularisers when the user names none: GV_REGULARIZE_USER, or none with mcmc (the
 * decay needs the lean or reference control; mcmc prunes and relocates its own way). */
int gv_splat_regularize_default(gv_splat_densify_mode mode);
/* The resolution schedule of the model a user gets (`splat train`, `reconstruct`'s default
 * preset, `bench splat`'s default run): the first quarter of the iterations at 1/4 of the
 * size, the second at 1/2 (resolution.c). With the user's regularisers it kept the held-out
 * quality and met issue 38's time target (docs/RESULTS.md section 5); the library's default
 * is full resolution throughout. */
#define GV_RESOLUTION_USER 4
/* "none", or names separated by commas (each once) -> the set; -1 for anything else. */
int gv_splat_regularize_parse(const char *list);
/* The set as the parser reads it ("none", "dropgaussian", ...) into buf of size n. */
void gv_splat_regularize_name(int set, char *buf, size_t n);

typedef struct {
    int iterations;             /* 30000 (the reference); --iters 8000 for the dataset */
    int sh_degree;              /* 3 */
    uint64_t seed;
    gv_splat_background background;
    int sparse_adam;            /* Adam on the visible Gaussians only (see docs) */
    int random_points;          /* 100000: initial points when the scene has none */
    double lambda_dssim;        /* 0.2 */
    gv_splat_adam_config adam;
    gv_splat_schedule schedule;
    gv_splat_densify_mode densify_mode;
    int regularize;             /* GV_REGULARIZE_* bits; 0: plain 3DGS */
    double fsgs_distance;       /* FSGS: unpool above this proximity score x extent (0.1) */
    double corgs_distance;      /* CoR-GS: prune without a counterpart within this x extent
                                 * (0.05) */
    double corgs_pseudo_weight; /* CoR-GS and SE-GS: weight of the pseudo-view term of the
                                 * two fields (1; 0: off) */
    int segs_interval;          /* SE-GS: iterations between the pseudo-view renders (500) */
    double decay_factor;        /* decay: opacity times this every iteration after
                                 * densify_from (0.995, Binocular3DGS's) */
    double decay_until;         /* decay: ... up to this share of the iterations (0.5; 1: to
                                 * the end, the release's) */
    double drop_rate;           /* DropGaussian: the share left out at the last iteration,
                                 * in [0, 1) (GV_DROP_RATE) */
    double binocular_from;      /* binocular: the term after this share of the iterations
                                 * (2/3: the release's 20000 of 30000) */
    double binocular_baseline;  /* binocular: the largest shift, x the initial model's median
                                 * view depth (0.015) */
    gv_splat_densify_params densify; /* lean and reference; extent is set by the trainer */
    gv_splat_mcmc_params mcmc;  /* MCMC mode; cap 0 = gaussians_per_pixel x training pixels */
    double gaussians_per_pixel;
    double initial_opacity;     /* 0: the mode's own (lean and reference: 0.1, MCMC: 0.5) */
    const char *progress_label; /* NULL: no progress bar */
    /* Refinement (docs/RECONSTRUCT.md): training continues from a copy of this model at its
     * full SH degree instead of starting from the points (NULL: from the points). Borrowed. */
    const gv_gaussians *initial;
    /* The loss of view i (and its gradient) is scaled by view_weights[i]: down-weighted
     * supervision by restored frames (NULL: every view 1). Borrowed, n_views long. */
    const float *view_weights;
    /* Resolution scheduling (resolution.c): 0 (off, the reference) or the first iterations'
     * downsample factor 2, 4 or 8; full resolution from resolution_full_at x iterations. */
    int resolution_start;
    double resolution_full_at;  /* 0.5 */
} gv_splat_train_options;

enum { GV_PHASE_RENDER, GV_PHASE_LOSS, GV_PHASE_BACKWARD, GV_PHASE_DENSIFY, GV_PHASE_ADAM,
       GV_PHASES };

typedef struct {
    gv_splat_train_options opt;
    int n_views;
    const gv_camera *cameras;   /* borrowed: n_views cameras and their images */
    const gv_image *images;
    gv_splat_view *views;       /* the cameras as the renderer takes them */
    double extent;
    gv_gaussians params, grad;
    gv_splat_adam adam;
    gv_splat_densify_stats stats;
    gv_splat_renderer renderer;
    gv_splat_loss_work loss_work;
    float *render, *target, *d_render, *densify_grad;
    float *drop_scale;          /* DropGaussian: this iteration's opacity scales (capacity) */
    long dropped;               /* DropGaussian: Gaussians left out, summed over iterations */
    long unpooled;              /* FSGS: Gaussians added by unpooling */
    int last_control;           /* the last iteration's density control: 1 densified, 2 reset */
    const int *update_rows;     /* NULL: Adam's rows are the render's visible ones; else these
                                 * (ascending, borrowed, for one update) */
    int n_update_rows;
    int *all_rows;              /* 0, 1, 2, ...: Adam's list when every row has a gradient */
    int *order, order_pos;      /* this epoch's shuffled view order */
    gv_rng view_rng, bg_rng, split_rng;
    int iteration, active_degree;
    double loss, ema_loss;      /* last loss; 0.4 last + 0.6 previous (train.py) */
    gv_splat_densify_counts densified; /* totals (lean and reference) */
    long relocated, added;      /* totals (MCMC mode) */
    double seconds[GV_PHASES];  /* time spent per phase */
    gv_splat_resolution_level levels[3]; /* 1/2, 1/4, 1/8: built when first used */
    int factor;                 /* this iteration's downsample factor (1: full resolution) */
    gv_splat_binocular binocular; /* Binocular3DGS's consistency term */
} gv_splat_trainer;

/* The reference's values (sections 13-14) and the values above. */
void gv_splat_train_defaults(gv_splat_train_options *opt);
/* The gradient threshold a run uses: densify.grad_threshold when set, else the mode's own
 * (lean: 0.0004, reference: 0.0002; MCMC does not use it). */
double gv_splat_densify_threshold(const gv_splat_train_options *opt);
/* Sets up training on n_views cameras and their RGB images (kept by the caller until
 * gv_splat_trainer_free), initialised from the points (random points when n_points is 0).
 * extent is the 3DGS scene extent of the training cameras. */
int gv_splat_trainer_init(gv_splat_trainer *t, const gv_splat_train_options *opt, int n_views,
                          const gv_camera *cameras, const gv_image *images, double extent,
                          int n_points, const float *xyz, const uint8_t *rgb);
/* Runs the next iteration: gv_splat_trainer_forward_backward, then gv_splat_trainer_update.
 * Between the two a caller may add gradients of its own to t->grad (CoR-GS's pseudo-view
 * term): on rows outside the render's visible list it must then set update_rows to the
 * ascending list of every row with a gradient (gv_splat_trainer_add_gradient does both). */
int gv_splat_trainer_step(gv_splat_trainer *t);
/* Steps 1-4: the next iteration's view, render, loss and backward into t->grad. */
int gv_splat_trainer_forward_backward(gv_splat_trainer *t);
/* Steps 5-6: density control and Adam (which consumes t->grad). */
int gv_splat_trainer_update(gv_splat_trainer *t);
/* After rows of t->params (and its Adam moments) were added or removed outside the step:
 * the gradient and statistics buffers follow, zeroed (as after a densification). */
int gv_splat_trainer_rows_changed(gv_splat_trainer *t);
/* Between the two halves of an iteration, for a term that renders t->params again (CoR-GS's
 * pseudo view, Binocular3DGS's shifted view): adds grad, that render's gradient, on its
 * visible rows seen[0 .. n_seen) (ascending) to t->grad, and gives Adam the union of those
 * rows and the rows with a gradient so far (update_rows when a term set it, else t's render's
 * visible rows). The union is kept in *rows, grown to *capacity as needed (the caller's,
 * which frees it; not the list update_rows points to). */
int gv_splat_trainer_add_gradient(gv_splat_trainer *t, const gv_gaussians *grad, const int *seen,
                                  int n_seen, int **rows, int *capacity);
/* Binocular3DGS's term at the iteration's view (after t's render of it, before its
 * backward): renders the view shifted by a random baseline, computes the loss (times weight)
 * and the shifted render's gradient; b->d_depth_sum is then dL/d the accumulated depth of
 * t's render, for gv_splat_render_backward_depth. */
int gv_splat_binocular_forward_backward(gv_splat_binocular *b, gv_splat_trainer *t,
                                        const gv_splat_view *view, const float bg[3],
                                        const float *opacity_scale, const float *target,
                                        double weight);
void gv_splat_binocular_free(gv_splat_binocular *b);
/* CoR-GS's pseudo-view co-regularisation (corgs.c): the two fields rendered at a camera
 * between two training views, each pulled towards the other's render by
 * weight x ((1 - lambda) L1 + lambda (1 - SSIM)) of the pair, the training loss's form. */
typedef struct {
    gv_splat_renderer renderer[2];
    gv_splat_loss_work loss_work;
    gv_gaussians grad[2];       /* the pseudo-view's gradients (valid on its visible rows) */
    float *image[2], *d_image[2];
    long pixels;                /* what image and d_image hold */
    int *rows[2], rows_capacity[2]; /* each field's rows with a gradient this iteration */
    gv_rng rng;                 /* the pseudo cameras */
    double weight;              /* 1: as heavy as the training view */
    int from;                   /* only after this iteration (the densification start) */
    long pseudo_views;
} gv_splat_corgs;

/* The pair's loss at view and its gradient: grad[k] (SH degree of g[k], capacity >= its
 * rows) gets dL/dparams on the rows visible in c->renderer[k] (the others untouched). */
int gv_splat_corgs_pseudo_grad(gv_splat_corgs *c, const gv_gaussians *g0, const gv_gaussians *g1,
                               const gv_splat_view *view, int active_degree, double lambda,
                               double weight, gv_gaussians *grad0, gv_gaussians *grad1,
                               double *loss);
void gv_splat_corgs_free(gv_splat_corgs *c);
/* ---- segs.c -----------------------------------------------------------------------------
 * SE-GS's uncertainty-aware perturbation (Zhao et al., ICCV 2025): the model (Sigma) is
 * rendered at GV_SEGS_VIEWS fixed pseudo views near the training cameras every interval
 * iterations; the per-pixel spread of its last GV_SEGS_STACK renders marks where the views do
 * not pin the scene down, and the second field's (Delta's) Gaussians covering those pixels
 * get noise. The hyper-parameters are the release's (docs/SPLAT_TRAINING.md). */
#define GV_SEGS_VIEWS 24          /* pseudo views watched (num_val) */
#define GV_SEGS_STACK 3           /* renders kept per view (len_stack) */
#define GV_SEGS_BOX 5             /* the uncertainty map is box-averaged over 5 x 5 pixels */
#define GV_SEGS_TOP_SHARE 0.05    /* uncertain: the top 5 % of a view's pixels (reset_ratio) ... */
#define GV_SEGS_MIN_STD 0.01      /* ... and above this (reset_thr) */
#define GV_SEGS_NOISE_MAX 0.08    /* noise ratio, log-linear from this ... */
#define GV_SEGS_NOISE_MIN 0.02    /* ... to this over the run */
#define GV_SEGS_NEAR_DISTANCE 0.5 /* pseudo views within 0.5 x the closest two training cameras' */
#define GV_SEGS_NEAR_DEGREES 15.0 /* distance and 15 degrees of a training camera */

typedef struct {
    gv_camera cameras[GV_SEGS_VIEWS];
    gv_splat_view views[GV_SEGS_VIEWS];
    float *renders[GV_SEGS_VIEWS][GV_SEGS_STACK]; /* the model's last renders, a ring */
    int stored;                 /* renders stored per view so far */
    long pixels;                /* the largest view's */
    float *image, *map, *scratch, *dist2;
    unsigned char *mark;
    int mark_capacity;
    gv_splat_renderer renderer;
    int interval;
    uint64_t seed;
    double ratio;               /* the last noise ratio */
    double noise_scale[13];     /* the last noise scales (position, opacity, scale, rotation) */
    long perturbed;             /* Gaussians perturbed, summed over the perturbations */
    int perturbations;
} gv_splat_segs;

/* The share t of the way from camera k to k + 1 (and from k + 1 back) that stays within
 * GV_SEGS_NEAR_DISTANCE x the distance of the closest two cameras and GV_SEGS_NEAR_DEGREES
 * of the nearer end (at most 0.5). */
double gv_splat_segs_near_share(const gv_camera *cameras, int n_views, int k);
/* Picks the pseudo views (gap i mod (n_views - 1), a uniform position within the near
 * share of either end) and allocates the buffers. */
int gv_splat_segs_init(gv_splat_segs *s, int n_views, const gv_camera *cameras, int interval,
                       uint64_t seed);
/* out[p] = the 5 x 5 box mean (zeros outside) of the mean over channels of the unbiased
 * standard deviation of the k renders (HWC) at pixel p; scratch is width x height. */
void gv_splat_segs_uncertainty(const float *const *renders, int k, int width, int height,
                               float *scratch, float *out);
/* max(the value at index floor(GV_SEGS_TOP_SHARE x pixels) of u sorted descending,
 * GV_SEGS_MIN_STD); scratch holds pixels floats. */
double gv_splat_segs_threshold(const float *u, long pixels, float *scratch);
/* dist2[p] = squared distance from pixel p to the nearest pixel with u > threshold (exact;
 * about 4 (W^2 + H^2) when there is none). */
int gv_splat_segs_distance(const float *u, int width, int height, double threshold, float *dist2);
/* mark[i] = 1 for each Gaussian with radius r > 0 whose centre's pixel is in the image at a
 * squared distance below r (the release's test: within sqrt(r) pixels) from an uncertain
 * pixel; returns how many were newly marked. */
int gv_splat_segs_mark(const float *dist2, int width, int height, int n, const float *means2d,
                       const int *radii, unsigned char *mark);
/* The noise ratio at an iteration: log-linear from GV_SEGS_NOISE_MAX at the first
 * perturbation (from + interval x GV_SEGS_STACK) to GV_SEGS_NOISE_MIN at iterations - interval. */
double gv_splat_segs_noise_ratio(int iteration, int iterations, int from, int interval);
/* Adds ratio x scale x N(0, 1) (normals at (seed, 13 i + j)) to the position, opacity logit,
 * log-scales and the 6-D rotation (the first two rows of R(q), back by Gram-Schmidt) of the
 * marked rows, scale the mean magnitude of that column over the field, at least 1 (for the
 * position: extent); their Adam moments of those groups start from zero. Returns the count;
 * scale_out (may be NULL) gets the 13 scales. */
int gv_splat_segs_perturb(gv_gaussians *g, gv_splat_adam *adam, const unsigned char *mark,
                          double ratio, double extent, uint64_t seed, double scale_out[13]);
/* At iterations past the model's densify_from, before iterations - interval, multiples of
 * interval: renders sigma at the pseudo views into the ring; once it is full, perturbs
 * delta. */
int gv_splat_segs_observe(gv_splat_segs *s, gv_splat_trainer *sigma, gv_splat_trainer *delta);
void gv_splat_segs_free(gv_splat_segs *s);

/* CoR-GS and SE-GS: one iteration of both trainers with the pseudo-view term after c->from;
 * with corgs, if either densified, co-pruning at tau x a's extent (pruned[0] and pruned[1]
 * count the removed Gaussians of a and b); with segs (segs not NULL), its perturbation of b. */
int gv_splat_corgs_step(gv_splat_corgs *c, gv_splat_trainer *a, gv_splat_trainer *b, double tau,
                        long *pruned, gv_splat_segs *segs);
void gv_splat_trainer_free(gv_splat_trainer *t);
/* The views and targets of t's level `factor` (2, 4 or 8), box-filtered from t's images on
 * the first call and kept until gv_splat_trainer_free (resolution.c). */
int gv_splat_trainer_level(gv_splat_trainer *t, int factor, const gv_splat_resolution_level **out);
/* Trains on the frames 0, n, 2n, ... (n = interval) of a scene and returns the model in
 * out (to be freed with gv_gaussians_free). */
int gv_splat_train(const gv_scene *scene, int interval, const gv_splat_train_options *opt,
                   gv_gaussians *out);
/* The same on the listed frames of the scene, in that order (at least two): gv_splat_train is
 * this on the frames 0, n, 2n, ..., so the same list gives the same model. */
int gv_splat_train_views(const gv_scene *scene, const int *views, int n_views,
                         const gv_splat_train_options *opt, gv_gaussians *out);

/* ---- evaluate.c -------------------------------------------------------------------------
 * Rendering a model from a scene camera to 8 bits, and metrics as 3DGS metrics.py computes
 * them: on the clamped, 8-bit-quantised render against the 8-bit ground truth. */
int gv_splat_render_camera(gv_splat_renderer *r, const gv_gaussians *g, const gv_camera *cam,
                           const float bg[3], gv_image *out);
typedef struct {
    int frame;
    int train;          /* 1 for a training view */
    double psnr, ssim;
} gv_splat_frame_metrics;
/* Renders and scores the listed frames of a scene; metrics is n_frames long. */
int gv_splat_evaluate(const gv_gaussians *g, const gv_scene *scene, const int *frames,
                      int n_frames, const float bg[3], gv_splat_frame_metrics *metrics);

/* ---- camera_path.c ----------------------------------------------------------------------
 * A camera between a (s = 0) and b (s = 1): rotation by quaternion slerp, centre and
 * intrinsics linearly; the size and name are a's. */
void gv_camera_interpolate(const gv_camera *a, const gv_camera *b, double s, gv_camera *out);
/* n_out cameras evenly spaced in the path parameter along the keys (piecewise between
 * consecutive keys), from the first key to the last. */
void gv_camera_path(const gv_camera *keys, int n_keys, int n_out, gv_camera *out);

#endif
