/* The 3DGS training iteration (docs/reference/gaussian-splatting.md section 14.1; 3DGS train.py),
 * in the reference order:
 *   1. position learning rate of this iteration;
 *   2. one more SH degree at every multiple of sh_interval;
 *   3. next training view from a shuffled epoch order (train.py pops a random view from a
 *      stack refilled when empty: a permutation per epoch);
 *   4. background, render (with DropGaussian, of a random share of the Gaussians:
 *      src/splat/dropgaussian.c), loss 0.8 L1 + 0.2 (1 - SSIM), backward;
 *   5. while iteration < densify_until: densification statistics of the visible Gaussians;
 *      densify_and_prune when iteration > densify_from and a multiple of densify_interval;
 *      opacity reset at multiples of opacity_reset_interval;
 *   6. Adam step.
 * In an iteration that densifies, the reference replaces every parameter tensor (new
 * nn.Parameter objects without .grad), so torch's Adam skips them all: no Adam step and no
 * step count for that iteration. A reset alone replaces only the opacity tensor. Both are
 * reproduced. The last iteration (iteration == iterations) neither densifies nor steps:
 * train.py saves the model at that iteration before its densification, and steps Adam only
 * while iteration < iterations, so the model returned is the one the reference saves. */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "gaussvid/core/core.h"
#include "gaussvid/splat/splat_train.h"

/* gsplat's MCMC preset starts from opacity 0.5: relocation draws by opacity, and 0.1 would
 * leave the first draws to chance. */
#define MCMC_INITIAL_OPACITY 0.5

/* Philox streams of one training run, derived from the seed. */
enum { STREAM_VIEWS = 1, STREAM_BACKGROUND = 2, STREAM_SPLIT = 3, STREAM_INIT = 4,
       STREAM_NOISE = 5, STREAM_DROP = 6, STREAM_BINOCULAR = 7 };

static uint64_t stream_seed(uint64_t seed, int stream)
{
    return seed * 0x9E3779B97F4A7C15ull + (uint64_t)stream * 0xD1B54A32D192ED03ull;
}

void gv_splat_train_defaults(gv_splat_train_options *opt)
{
    memset(opt, 0, sizeof *opt);
    opt->iterations = 30000;
    opt->sh_degree = 3;
    opt->background = GV_BG_BLACK;
    opt->sparse_adam = 0;
    opt->random_points = 100000;
    opt->lambda_dssim = 0.2;
    gv_splat_adam_defaults(&opt->adam);
    opt->schedule = (gv_splat_schedule){.sh_interval = 1000, .densify_from = 500,
                                        .densify_until = 15000, .densify_interval = 100,
                                        .opacity_reset_interval = 3000};
    opt->densify = (gv_splat_densify_params){.percent_dense = 0.01, .min_opacity = 0.005};
    opt->densify_mode = GV_DENSIFY_DEFAULT;
    gv_splat_mcmc_defaults(&opt->mcmc);
    opt->gaussians_per_pixel = 0.02;
    opt->fsgs_distance = 0.1;
    opt->corgs_distance = 0.05;
    opt->corgs_pseudo_weight = 1.0;
    opt->segs_interval = 500; /* SE-GS's release, noise_interval */
    opt->decay_factor = 0.995; /* Binocular3DGS's release, opacity_decay_factor */
    /* Half the iterations, not the release's whole run: decay to the end costs up to 1.7 dB
     * where the views are many (docs/RESULTS.md section 5, "opacity decay"). */
    opt->decay_until = 0.5;
    opt->drop_rate = GV_DROP_RATE;
    /* Binocular3DGS's release starts the term after iteration 20000 of 30000 (LLFF, DTU). */
    opt->binocular_from = 2.0 / 3.0;
    /* Its largest shift, 0.4 COLMAP units, is 0.5-2.4 % of the depths of the points of its
     * LLFF fern scene (17-78 units): about 1.5 % of a middle depth (docs/SPLAT_TRAINING.md). */
    opt->binocular_baseline = 0.015;
    opt->resolution_full_at = 0.5;
}

double gv_splat_densify_threshold(const gv_splat_train_options *opt)
{
    if (opt->densify.grad_threshold > 0) return opt->densify.grad_threshold;
    /* The reference's densify_grad_threshold; lean doubles it (docs/RESULTS.md section 1;
     * docs/history/RESULTS-2026-11.md, "Lean density control"). */
    return opt->densify_mode == GV_DENSIFY_LEAN ? 0.0004 : 0.0002;
}

int gv_splat_densify_mode_parse(const char *name)
{
    if (strcmp(name, "lean") == 0) return GV_DENSIFY_LEAN;
    if (strcmp(name, "reference") == 0) return GV_DENSIFY_REFERENCE;
    if (strcmp(name, "mcmc") == 0) return GV_DENSIFY_MCMC;
    return -1;
}

const char *gv_splat_densify_mode_name(gv_splat_densify_mode mode)
{
    return mode == GV_DENSIFY_MCMC ? "mcmc" : mode == GV_DENSIFY_LEAN ? "lean" : "reference";
}

static const struct { const char *name; int bit; } REGULARIZERS[] = {
    {"dropgaussian", GV_REGULARIZE_DROPGAUSSIAN},
    {"fsgs", GV_REGULARIZE_FSGS},
    {"corgs", GV_REGULARIZE_CORGS},
    {"segs", GV_REGULARIZE_SEGS},
    {"decay", GV_REGULARIZE_DECAY},
    {"binocular", GV_REGULARIZE_BINOCULAR},
};
enum { N_REGULARIZERS = sizeof REGULARIZERS / sizeof REGULARIZERS[0] };

int gv_splat_regularize_parse(const char *list)
{
    if (strcmp(list, "none") == 0) return 0;
    int set = 0;
    const char *p = list;
    for (;;) {
        size_t len = strcspn(p, ",");
        int bit = 0;
        for (int k = 0; k < N_REGULARIZERS; k++)
            if (strlen(REGULARIZERS[k].name) == len && strncmp(p, REGULARIZERS[k].name, len) == 0)
                bit = REGULARIZERS[k].bit;
        if (bit == 0 || (set & bit)) return -1; /* unknown, empty or repeated */
        set |= bit;
        if (p[len] == '\0') return set;
        p += len + 1;
    }
}

int gv_splat_regularize_default(gv_splat_densify_mode mode)
{
    return mode == GV_DENSIFY_MCMC ? 0 : GV_REGULARIZE_USER;
}

void gv_splat_regularize_name(int set, char *buf, size_t n)
{
    if (n == 0) return;
    snprintf(buf, n, "%s", set == 0 ? "none" : "");
    for (int k = 0; k < N_REGULARIZERS; k++)
        if (set & REGULARIZERS[k].bit) {
            size_t used = strlen(buf);
            snprintf(buf + used, n - used, "%s%s", used ? "," : "", REGULARIZERS[k].name);
        }
}

/* The list 0 .. capacity - 1 (Adam's rows when a regulariser gives every row a gradient),
 * and DropGaussian's scales, for every row of the capacity. */
static int grow_all_rows(gv_splat_trainer *t)
{
    int *rows = realloc(t->all_rows, (size_t)t->params.capacity * sizeof(int));
    if (!rows) return -1;
    for (int i = 0; i < t->params.capacity; i++) rows[i] = i;
    t->all_rows = rows;
    if (t->opt.regularize & GV_REGULARIZE_DROPGAUSSIAN) {
        float *scale = realloc(t->drop_scale, (size_t)t->params.capacity * sizeof(float));
        if (!scale) return -1;
        t->drop_scale = scale;
    }
    return 0;
}

static int check_inputs(const gv_splat_train_options *opt, int n_views,
                        const gv_camera *cameras, const gv_image *images, double extent)
{
    if (opt->initial && (opt->initial->n < 1 || opt->initial->sh_degree != opt->sh_degree))
        return gv_fail("train: the initial model has %d Gaussians of SH degree %d; need at least 1 of degree %d",
                       opt->initial->n, opt->initial->sh_degree, opt->sh_degree);
    for (int i = 0; opt->view_weights && i < n_views; i++)
        if (!(opt->view_weights[i] >= 0) || !isfinite(opt->view_weights[i]))
            return gv_fail("train: view %d has weight %g; weights must be finite and >= 0", i, opt->view_weights[i]);
    if (opt->iterations < 1) return gv_fail("train: %d iterations; need at least 1", opt->iterations);
    if (gv_splat_resolution_check(opt->resolution_start, opt->resolution_full_at) != 0) return -1;
    if ((opt->regularize & GV_REGULARIZE_FSGS) && opt->densify_mode == GV_DENSIFY_MCMC)
        return gv_fail("train: fsgs unpools at the densification steps of lean or reference density control, not mcmc");
    if ((opt->regularize & GV_REGULARIZE_DECAY) && opt->densify_mode == GV_DENSIFY_MCMC)
        return gv_fail("train: decay replaces the opacity reset of lean or reference density control, not mcmc");
    if ((opt->regularize & GV_REGULARIZE_DECAY) && !(opt->decay_factor > 0 && opt->decay_factor < 1))
        return gv_fail("train: the opacity decay factor is %g; it must be in (0, 1)", opt->decay_factor);
    if ((opt->regularize & GV_REGULARIZE_DECAY) && !(opt->decay_until > 0 && opt->decay_until <= 1))
        return gv_fail("train: the opacity decay's end is %g of the iterations; it must be in (0, 1]", opt->decay_until);
    if ((opt->regularize & GV_REGULARIZE_DROPGAUSSIAN) && !(opt->drop_rate >= 0 && opt->drop_rate < 1))
        return gv_fail("train: the DropGaussian rate is %g; it must be in [0, 1)", opt->drop_rate);
    if ((opt->regularize & GV_REGULARIZE_BINOCULAR) && !(opt->binocular_from >= 0 && opt->binocular_from < 1))
        return gv_fail("train: the binocular loss starts at %g of the iterations; it must be in [0, 1)", opt->binocular_from);
    if ((opt->regularize & GV_REGULARIZE_BINOCULAR) && !(opt->binocular_baseline > 0 && opt->binocular_baseline < 1))
        return gv_fail("train: the binocular baseline is %g of the median depth; it must be in (0, 1)", opt->binocular_baseline);
    if ((opt->regularize & GV_REGULARIZE_CORGS) && opt->densify_mode == GV_DENSIFY_MCMC)
        return gv_fail("train: corgs co-prunes at the densification steps of lean or reference density control, not mcmc");
    if ((opt->regularize & GV_REGULARIZE_TWO_FIELDS) && !(opt->corgs_pseudo_weight >= 0 && isfinite(opt->corgs_pseudo_weight)))
        return gv_fail("train: the pseudo-view weight is %g; it must be finite and >= 0", opt->corgs_pseudo_weight);
    if ((opt->regularize & GV_REGULARIZE_SEGS) && opt->segs_interval < 1)
        return gv_fail("train: the segs interval is %d; it must be at least 1", opt->segs_interval);
    if ((opt->regularize & GV_REGULARIZE_CORGS) && !(opt->corgs_distance > 0))
        return gv_fail("train: the corgs distance is %g; it must be positive", opt->corgs_distance);
    if ((opt->regularize & GV_REGULARIZE_FSGS) && !(opt->fsgs_distance > 0))
        return gv_fail("train: the fsgs distance is %g; it must be positive", opt->fsgs_distance);
    if (opt->sh_degree < 0 || opt->sh_degree > 3)
        return gv_fail("train: SH degree %d is not in 0..3", opt->sh_degree);
    const gv_splat_schedule *s = &opt->schedule;
    if (s->sh_interval < 1 || s->densify_interval < 1 || s->opacity_reset_interval < 1)
        return gv_fail("train: schedule intervals must be at least 1");
    if (n_views < 1) return gv_fail("train: no training views");
    if (!(extent > 0) || !isfinite(extent))
        return gv_fail("train: the scene extent of the training cameras is %g (all cameras at one "
                       "place?); it scales the position learning rate and must be positive", extent);
    for (int i = 0; i < n_views; i++)
        if (images[i].width != cameras[i].width || images[i].height != cameras[i].height ||
            images[i].channels != 3)
            return gv_fail("train: %s: image is %dx%dx%d but the camera is %dx%d (RGB expected)",
                           cameras[i].name, images[i].width, images[i].height, images[i].channels,
                           cameras[i].width, cameras[i].height);
    return 0;
}

/* Binocular3DGS's term: its start, and the baseline's scale from the initial model. */
static int binocular_init(gv_splat_trainer *t)
{
    gv_splat_binocular *b = &t->binocular;
    b->from = (int)floor(t->opt.binocular_from * t->opt.iterations + 0.5);
    b->depth = gv_splat_median_view_depth(&t->params, t->n_views, t->views);
    if (b->depth < 0)
        return gv_fail("train: binocular: out of memory for the depths of %d Gaussians in %d views",
                       t->params.n, t->n_views);
    if (!(b->depth > 0))
        return gv_fail("train: binocular: no initial Gaussian is in front of a training camera, "
                       "so there is no depth to scale the baseline by");
    b->baseline = t->opt.binocular_baseline * b->depth;
    gv_rng_init(&b->rng, stream_seed(t->opt.seed, STREAM_BINOCULAR));
    return 0;
}

/* dst = a copy of src's rows (refinement starts from a trained model). */
static int copy_model(gv_gaussians *dst, const gv_gaussians *src)
{
    if (gv_gaussians_alloc(dst, src->n, src->sh_degree) != 0) return -1;
    size_t n = (size_t)src->n;
    memcpy(dst->means, src->means, 3 * n * sizeof(float));
    memcpy(dst->sh, src->sh, (size_t)3 * gv_sh_coefficient_count(src->sh_degree) * n * sizeof(float));
    memcpy(dst->opacities, src->opacities, n * sizeof(float));
    memcpy(dst->scales, src->scales, 3 * n * sizeof(float));
    memcpy(dst->rotations, src->rotations, 4 * n * sizeof(float));
    return 0;
}

/* The initial Gaussians: a given model (refinement), the points, or random points in a cube of half-size 3 x extent
 * around the mean camera centre (gsplat's init_extent; docs/SPLAT_TRAINING.md). */
static int initial_gaussians(gv_splat_trainer *t, int n_points, const float *xyz,
                             const uint8_t *rgb)
{
    if (t->opt.initial) return copy_model(&t->params, t->opt.initial);
    if (n_points > 0)
        return gv_splat_init_from_points(&t->params, n_points, xyz, rgb, t->opt.sh_degree);
    double center[3] = {0, 0, 0}, c[3];
    for (int i = 0; i < t->n_views; i++) {
        gv_camera_center(&t->cameras[i], c);
        for (int a = 0; a < 3; a++) center[a] += c[a] / t->n_views;
    }
    gv_info("no points in the scene: %d random points in a cube of half-size %.3g around the "
            "cameras", t->opt.random_points, 3.0 * t->extent);
    return gv_splat_init_random(&t->params, t->opt.random_points, center, 3.0 * t->extent,
                                t->opt.sh_degree, stream_seed(t->opt.seed, STREAM_INIT));
}

int gv_splat_trainer_init(gv_splat_trainer *t, const gv_splat_train_options *opt, int n_views,
                          const gv_camera *cameras, const gv_image *images, double extent,
                          int n_points, const float *xyz, const uint8_t *rgb)
{
    memset(t, 0, sizeof *t);
    if (check_inputs(opt, n_views, cameras, images, extent) != 0) return -1;
    t->opt = *opt;
    t->opt.densify.extent = extent;
    t->opt.densify.grad_threshold = gv_splat_densify_threshold(opt);
    t->n_views = n_views, t->cameras = cameras, t->images = images, t->extent = extent;
    long pixels = 0, all_pixels = 0;
    t->views = calloc((size_t)n_views, sizeof *t->views);
    t->order = malloc((size_t)n_views * sizeof(int));
    if (!t->views || !t->order) goto out_of_memory;
    for (int i = 0; i < n_views; i++) {
        if (gv_splat_view_from_camera(&t->views[i], &cameras[i]) != 0) {
            gv_fail_context("train: camera %s", cameras[i].name);
            goto fail;
        }
        long p = (long)cameras[i].width * cameras[i].height;
        if (p > pixels) pixels = p;
        all_pixels += p;
    }
    if (opt->densify_mode == GV_DENSIFY_MCMC && opt->mcmc.cap == 0)
        t->opt.mcmc.cap = (int)fmin(opt->gaussians_per_pixel * (double)all_pixels, 1e9);
    t->render = malloc((size_t)pixels * 3 * sizeof(float));
    t->target = malloc((size_t)pixels * 3 * sizeof(float));
    t->d_render = malloc((size_t)pixels * 3 * sizeof(float));
    if (!t->render || !t->target || !t->d_render) goto out_of_memory;
    if (initial_gaussians(t, n_points, xyz, rgb) != 0) goto fail;
    double o = opt->initial ? 0 : opt->initial_opacity > 0 ? opt->initial_opacity
               : opt->densify_mode == GV_DENSIFY_MCMC ? MCMC_INITIAL_OPACITY : 0;
    if (o > 0 && o < 1)
        for (int i = 0; i < t->params.n; i++) t->params.opacities[i] = (float)log(o / (1.0 - o));
    if (gv_gaussians_alloc(&t->grad, t->params.n, t->params.sh_degree) != 0 ||
        gv_gaussians_reserve(&t->grad, t->params.capacity) != 0 ||
        gv_splat_adam_init(&t->adam, &opt->adam, &t->params, extent) != 0 ||
        gv_splat_densify_stats_reserve(&t->stats, t->params.capacity) != 0)
        goto fail;
    t->densify_grad = calloc((size_t)t->params.capacity, sizeof(float));
    if (!t->densify_grad || grow_all_rows(t) != 0) goto out_of_memory;
    if ((opt->regularize & GV_REGULARIZE_BINOCULAR) && binocular_init(t) != 0) goto fail;
    t->order_pos = n_views; /* empty: the first step shuffles */
    t->factor = 1;
    if (opt->initial) t->active_degree = opt->sh_degree; /* a trained model has every degree */
    gv_rng_init(&t->view_rng, stream_seed(opt->seed, STREAM_VIEWS));
    gv_rng_init(&t->bg_rng, stream_seed(opt->seed, STREAM_BACKGROUND));
    gv_rng_init(&t->split_rng, stream_seed(opt->seed, STREAM_SPLIT));
    return 0;
out_of_memory:
    gv_fail("train: out of memory for %d views", n_views);
fail:
    gv_splat_trainer_free(t);
    return -1;
}

void gv_splat_trainer_free(gv_splat_trainer *t)
{
    gv_gaussians_free(&t->params), gv_gaussians_free(&t->grad);
    gv_splat_adam_free(&t->adam);
    gv_splat_densify_stats_free(&t->stats);
    gv_splat_renderer_free(&t->renderer);
    gv_splat_loss_free(&t->loss_work);
    free(t->views), free(t->order), free(t->render), free(t->target), free(t->d_render);
    free(t->densify_grad), free(t->all_rows), free(t->drop_scale);
    gv_splat_binocular_free(&t->binocular);
    gv_splat_resolution_levels_free(t->levels, 3, t->n_views);
    memset(t, 0, sizeof *t);
}

/* Next view of the epoch; a new Fisher-Yates permutation when the epoch is over. */
static int next_view(gv_splat_trainer *t)
{
    if (t->order_pos >= t->n_views) {
        for (int i = 0; i < t->n_views; i++) t->order[i] = i;
        for (int i = t->n_views - 1; i > 0; i--) {
            int j = (int)(gv_rng_uniform(&t->view_rng) * (i + 1));
            int tmp = t->order[i];
            t->order[i] = t->order[j], t->order[j] = tmp;
        }
        t->order_pos = 0;
    }
    return t->order[t->order_pos++];
}

static void background(gv_splat_trainer *t, float bg[3])
{
    for (int c = 0; c < 3; c++)
        bg[c] = t->opt.background == GV_BG_WHITE ? 1.0f
                : t->opt.background == GV_BG_RANDOM ? (float)gv_rng_uniform(&t->bg_rng) : 0.0f;
}

/* Step 5. Returns a bit mask: 1 = densified, 2 = opacity reset; -1 on failure.
 * With decay (Binocular3DGS's release), every iteration after densify_from (up to decay_until
 * x iterations) first multiplies the opacities by the decay factor, the control runs to the
 * last iteration, and there is
 * no opacity reset and no screen-size pruning: the decay does their work, fading what the
 * training views do not keep opaque. */
static int density_control(gv_splat_trainer *t)
{
    const gv_splat_schedule *s = &t->opt.schedule;
    int it = t->iteration, done = 0, decay = (t->opt.regularize & GV_REGULARIZE_DECAY) != 0;
    if ((!decay && it >= s->densify_until) || it >= t->opt.iterations) return 0;
    if (decay && it > s->densify_from && it <= t->opt.decay_until * t->opt.iterations)
        gv_splat_decay_opacity(&t->params, t->opt.decay_factor);
    gv_splat_renderer *r = &t->renderer;
    /* At 1/f of the size (resolution scheduling) the statistic needs no rescaling: it is the
     * gradient in NDC units, pixels x (W/2, H/2) of the render's own size, and for the same
     * residual image that is independent of the resolution (a Gaussian of sigma pixels at
     * full size covers sigma^2 / f^2 pixels at 1/f, each weighing f^2 more in the mean loss,
     * its profile's slope per pixel f times steeper, and W/2 f times smaller: f^0). What
     * differs is the residual itself: the box-filtered target has no detail finer than the
     * level, so the control grows Gaussians only for what the level shows, which is the
     * point of the schedule. So the lean and reference thresholds stay. The radii are
     * counted in full-resolution pixels so that max_screen_size keeps its meaning. */
    gv_splat_densify_accumulate_scaled(&t->stats, r->tiles.n_visible, r->tiles.visible,
                                       t->densify_grad, r->radii, t->factor);
    if (it > s->densify_from && it % s->densify_interval == 0) {
        gv_splat_densify_params p = t->opt.densify;
        p.prune_big = !decay && it > s->opacity_reset_interval; /* size_threshold given after 3000 */
        gv_splat_densify_counts c;
        if (gv_splat_densify_and_prune(&t->params, &t->adam, &t->stats, &p, &t->split_rng, &c))
            return -1;
        t->densified.cloned += c.cloned, t->densified.split += c.split;
        t->densified.pruned += c.pruned;
        if (t->opt.regularize & GV_REGULARIZE_FSGS) { /* after the reference's control */
            int added;
            if (gv_splat_fsgs_unpool(&t->params, &t->adam, t->opt.fsgs_distance * t->extent, &added))
                return -1;
            t->unpooled += added;
        }
        done |= 1;
    }
    if (!decay && (it % s->opacity_reset_interval == 0 ||
                   (t->opt.background == GV_BG_WHITE && it == s->densify_from))) {
        gv_splat_reset_opacity(&t->params, &t->adam);
        done |= 2;
    }
    return done;
}

/* After densification the rows moved: the gradient buffers follow the new capacity and
 * start from zero (the reference's new tensors have no gradient). Between densifications
 * they stay zero outside the rows the backward writes, because Adam consumes (zeroes)
 * those. */
static int resize_buffers(gv_splat_trainer *t)
{
    int cap = t->params.capacity;
    if (gv_gaussians_reserve(&t->grad, cap) != 0) return -1;
    if (cap > t->stats.capacity && gv_splat_densify_stats_reserve(&t->stats, cap) != 0) return -1;
    gv_splat_densify_stats_clear(&t->stats, t->params.n); /* zero after a densification */
    float *d = realloc(t->densify_grad, (size_t)cap * sizeof(float));
    if (!d) return gv_fail("train: out of memory for %d Gaussians", cap);
    t->densify_grad = d;
    if (grow_all_rows(t) != 0) return gv_fail("train: out of memory for %d Gaussians", cap);
    t->grad.n = t->params.n;
    int w = 3 * gv_sh_coefficient_count(t->grad.sh_degree);
    size_t n = (size_t)t->grad.n;
    memset(t->grad.means, 0, 3 * n * sizeof(float));
    memset(t->grad.sh, 0, (size_t)w * n * sizeof(float));
    memset(t->grad.opacities, 0, n * sizeof(float));
    memset(t->grad.scales, 0, 3 * n * sizeof(float));
    memset(t->grad.rotations, 0, 4 * n * sizeof(float));
    return 0;
}

int gv_splat_trainer_rows_changed(gv_splat_trainer *t)
{
    return resize_buffers(t);
}

/* out = the union of the ascending lists x and y, ascending; returns its length. */
static int merge_rows(const int *x, int nx, const int *y, int ny, int *out)
{
    int i = 0, j = 0, n = 0;
    while (i < nx || j < ny) {
        int v = j >= ny || (i < nx && x[i] <= y[j]) ? x[i] : y[j];
        if (i < nx && x[i] == v) i++;
        if (j < ny && y[j] == v) j++;
        out[n++] = v;
    }
    return n;
}

int gv_splat_trainer_add_gradient(gv_splat_trainer *t, const gv_gaussians *grad, const int *seen,
                                  int n_seen, int **rows, int *capacity)
{
    /* the rows with a gradient so far: the render's, or those another term listed */
    const int *own = t->update_rows ? t->update_rows : t->renderer.tiles.visible;
    int n_own = t->update_rows ? t->n_update_rows : t->renderer.tiles.n_visible;
    int need = n_own + n_seen;
    if (need > *capacity) {
        int *r = realloc(*rows, (size_t)(need > 0 ? need : 1) * sizeof(int));
        if (!r) return gv_fail("train: out of memory for a list of %d rows", need);
        *rows = r, *capacity = need;
    }
    gv_gaussians *dst = &t->grad;
    int w = 3 * gv_sh_coefficient_count(dst->sh_degree);
#pragma omp parallel for schedule(static)
    for (int m = 0; m < n_seen; m++) {
        size_t i = (size_t)seen[m];
        for (int a = 0; a < 3; a++) dst->means[3 * i + a] += grad->means[3 * i + a];
        for (int a = 0; a < 3; a++) dst->scales[3 * i + a] += grad->scales[3 * i + a];
        for (int a = 0; a < 4; a++) dst->rotations[4 * i + a] += grad->rotations[4 * i + a];
        for (int a = 0; a < w; a++) dst->sh[w * i + a] += grad->sh[w * i + a];
        dst->opacities[i] += grad->opacities[i];
    }
    t->n_update_rows = merge_rows(own, n_own, seen, n_seen, *rows);
    t->update_rows = *rows;
    return 0;
}

/* Steps 5 and 6 of the reference: density control, then Adam (skipped in an iteration
 * that densified). */
static int reference_update(gv_splat_trainer *t, double seconds[2])
{
    double t0 = gv_now();
    int control = density_control(t);
    if (control < 0) return -1;
    t->last_control = control;
    double t1 = gv_now();
    if (control & 1) {
        if (resize_buffers(t) != 0) return -1;
    } else {
        unsigned groups = GV_ADAM_ALL_GROUPS & ~(control & 2 ? 1u << GV_ADAM_OPACITY : 0u);
        const gv_splat_renderer *r = &t->renderer;
        int n_coeffs = gv_sh_coefficient_count(t->active_degree);
        /* The last iteration does not step (train.py): its gradient is only dropped. */
        if (t->iteration >= t->opt.iterations) groups = 0;
        const int *rows = t->update_rows ? t->update_rows : r->tiles.visible;
        int n_rows = t->update_rows ? t->n_update_rows : r->tiles.n_visible;
        gv_splat_adam_step(&t->adam, &t->params, &t->grad, rows, n_rows,
                           groups != 0 && !t->opt.sparse_adam, n_coeffs, groups);
    }
    seconds[0] = t1 - t0, seconds[1] = gv_now() - t1;
    return 0;
}

/* gsplat's MCMC order: Adam with the regularisers' gradients (every row has one, so every
 * row steps), then at refinement iterations relocation and growth, then noise. The last
 * iteration neither steps nor moves anything, as in the reference mode. */
static int mcmc_update(gv_splat_trainer *t, double seconds[2])
{
    int it = t->iteration, last = it >= t->opt.iterations;
    const gv_splat_mcmc_params *p = &t->opt.mcmc;
    double t0 = gv_now();
    gv_splat_mcmc_regularize(&t->params, p, &t->grad);
    unsigned groups = last ? 0 : GV_ADAM_ALL_GROUPS;
    gv_splat_adam_step(&t->adam, &t->params, &t->grad, t->all_rows, t->params.n, groups != 0,
                       gv_sh_coefficient_count(t->active_degree), groups);
    double t1 = gv_now();
    const gv_splat_schedule *s = &t->opt.schedule;
    if (!last && it > s->densify_from && it < s->densify_until && it % s->densify_interval == 0) {
        int moved, added;
        if (gv_splat_mcmc_relocate(&t->params, &t->adam, p, &t->split_rng, &moved) != 0 ||
            gv_splat_mcmc_grow(&t->params, &t->adam, p, &t->split_rng, &added) != 0 ||
            resize_buffers(t) != 0)
            return -1;
        t->relocated += moved, t->added += added;
    }
    if (!last)
        gv_splat_mcmc_noise(&t->params, p, t->adam.lr[GV_ADAM_MEANS],
                            stream_seed(t->opt.seed, STREAM_NOISE) + (uint64_t)it);
    seconds[0] = gv_now() - t1, seconds[1] = t1 - t0;
    return 0;
}

int gv_splat_trainer_forward_backward(gv_splat_trainer *t)
{
    int it = ++t->iteration;
    gv_splat_adam_set_iteration(&t->adam, it);
    if (it % t->opt.schedule.sh_interval == 0 && t->active_degree < t->opt.sh_degree)
        t->active_degree++;
    int v = next_view(t);
    const gv_splat_view *view = &t->views[v];
    const gv_splat_resolution_level *level = NULL; /* resolution scheduling: a smaller view */
    t->factor = gv_splat_resolution_factor(it, t->opt.iterations, t->opt.resolution_start,
                                           t->opt.resolution_full_at);
    if (t->factor > 1) {
        if (gv_splat_trainer_level(t, t->factor, &level) != 0)
            return gv_fail_context("train: iteration %d", it);
        view = &level->views[v];
    }
    float bg[3];
    background(t, bg);

    double t0 = gv_now();
    const float *scale = NULL; /* DropGaussian: this render's opacity scales */
    if (t->opt.regularize & GV_REGULARIZE_DROPGAUSSIAN) {
        double rate = gv_splat_drop_rate(it, t->opt.iterations, t->opt.drop_rate);
        t->dropped += gv_splat_drop_draw(t->params.n, rate,
                                         stream_seed(t->opt.seed, STREAM_DROP) + (uint64_t)it,
                                         t->drop_scale);
        scale = t->drop_scale;
    }
    if (gv_splat_render_forward_scaled(&t->renderer, &t->params, view, t->active_degree, bg,
                                       scale, t->render))
        return gv_fail_context("train: iteration %d", it);
    double t1 = gv_now();
    const float *target = t->target;
    if (level) target = level->targets[v];
    else gv_image_to_float(&t->images[v], t->target);
    gv_splat_loss_value loss;
    if (gv_splat_loss(&t->loss_work, t->render, target, view->width, view->height,
                      t->opt.lambda_dssim, t->d_render, &loss) != 0)
        return gv_fail_context("train: iteration %d (view %s)", it, t->cameras[v].name);
    float weight = t->opt.view_weights ? t->opt.view_weights[v] : 1.0f;
    if (t->opt.view_weights) { /* a down-weighted view: its loss and gradient scaled */
        for (long i = 0; i < (long)view->width * view->height * 3; i++) t->d_render[i] *= weight;
        loss.loss *= weight;
    }
    t->loss = loss.loss;
    t->ema_loss = it == 1 ? t->loss : 0.4 * t->loss + 0.6 * t->ema_loss;
    double t2 = gv_now();
    /* Binocular3DGS: a render of the view shifted sideways, warped back with this render's
     * depth; its gradient reaches this render's depth and the shifted render. */
    gv_splat_binocular *bino = NULL;
    if ((t->opt.regularize & GV_REGULARIZE_BINOCULAR) && it > t->binocular.from) {
        bino = &t->binocular;
        if (gv_splat_binocular_forward_backward(bino, t, view, bg, scale, target, weight) != 0)
            return gv_fail_context("train: iteration %d (view %s)", it, t->cameras[v].name);
    }
    double t3 = gv_now();
    if (gv_splat_render_backward_depth(&t->renderer, &t->params, t->d_render,
                                       bino ? bino->d_depth_sum : NULL, &t->grad, t->densify_grad) ||
        (bino && gv_splat_trainer_add_gradient(t, &bino->grad, bino->renderer.tiles.visible,
                                                bino->renderer.tiles.n_visible, &bino->rows,
                                                &bino->rows_capacity) != 0))
        return gv_fail_context("train: iteration %d", it);
    double t4 = gv_now();
    t->seconds[GV_PHASE_RENDER] += t1 - t0, t->seconds[GV_PHASE_LOSS] += t2 - t1;
    if (bino) bino->seconds += t3 - t2;
    t->seconds[GV_PHASE_BACKWARD] += t4 - t3;
    return 0;
}

int gv_splat_trainer_update(gv_splat_trainer *t)
{
    double seconds[2]; /* densification, Adam */
    int rc = t->opt.densify_mode == GV_DENSIFY_MCMC ? mcmc_update(t, seconds)
                                                    : reference_update(t, seconds);
    t->update_rows = NULL, t->n_update_rows = 0; /* one iteration's */
    if (rc != 0) return gv_fail_context("train: iteration %d", t->iteration);
    t->seconds[GV_PHASE_DENSIFY] += seconds[0];
    t->seconds[GV_PHASE_ADAM] += seconds[1];
    return 0;
}

int gv_splat_trainer_step(gv_splat_trainer *t)
{
    return gv_splat_trainer_forward_backward(t) != 0 || gv_splat_trainer_update(t) != 0 ? -1 : 0;
}
