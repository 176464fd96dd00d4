/* Training on the sparse split of a scene: frames 0, n, 2n, ... (docs/ARCHITECTURE.md section 5), or
 * on any list of its frames (the subsets of adapt's internal pairs), with a progress bar showing the iteration, the loss, the Gaussian count, the rate and
 * the time left. */
#include <stdlib.h>
#include <string.h>

#include "gaussvid/core/core.h"
#include "gaussvid/splat/splat_train.h"

/* CoR-GS's and SE-GS's second field trains with the seed plus this (its own view order and
 * splits). */
#define CORGS_SEED_OFFSET 7919

static void free_images(gv_image *images, int n)
{
    for (int i = 0; i < n; i++) gv_image_free(&images[i]);
    free(images);
}

/* The summary of a resolution schedule: "1/4 from iteration 1, 1/2 from 2001, full from 4001". */
static void print_resolution_schedule(const gv_splat_train_options *o)
{
    char steps[200] = "";
    int used = 0, previous = 0;
    for (int it = 1; it <= o->iterations && used < (int)sizeof steps - 40; it++) {
        int f = gv_splat_resolution_factor(it, o->iterations, o->resolution_start, o->resolution_full_at);
        if (f == previous) continue;
        char what[16];
        snprintf(what, sizeof what, f > 1 ? "1/%d" : "full", f);
        used += snprintf(steps + used, sizeof steps - (size_t)used, "%s%s from %s%d",
                         previous ? ", " : "", what, previous ? "" : "iteration ", it);
        previous = f;
    }
    gv_info("resolution schedule: %s (box-filtered views, intrinsics divided)", steps);
}

static void report_two_fields(const gv_splat_trainer *t, const gv_splat_trainer *b,
                              const gv_splat_corgs *c, const gv_splat_segs *segs,
                              const long coprune[2])
{
    if (t->opt.regularize & GV_REGULARIZE_CORGS)
        gv_info("CoR-GS co-pruning (within %g x extent): %ld and %ld Gaussians pruned",
                t->opt.corgs_distance, coprune[0], coprune[1]);
    gv_info("second field: %d Gaussians at the end; %ld pseudo views (weight %g)", b->params.n,
            c->pseudo_views, c->weight);
    if (segs)
        gv_info("SE-GS: %d perturbations of the second field (every %d iterations), %ld Gaussians "
                "perturbed in all, last noise ratio %.4f; noise scales: position %.3g %.3g %.3g, "
                "opacity %.3g, log-scale %.3g %.3g %.3g", segs->perturbations, segs->interval,
                segs->perturbed, segs->ratio, segs->noise_scale[0], segs->noise_scale[1],
                segs->noise_scale[2], segs->noise_scale[3], segs->noise_scale[4],
                segs->noise_scale[5], segs->noise_scale[6]);
}

/* Trains t (and with CoR-GS or SE-GS its partner field b, stepped together) to the end. */
static int run(gv_splat_trainer *t, gv_splat_trainer *b, gv_splat_corgs *c, gv_splat_segs *segs,
               const char *label)
{
    gv_progress bar;
    long coprune[2] = {0, 0};
    if (label) gv_progress_start(&bar, label, t->opt.iterations);
    while (t->iteration < t->opt.iterations) {
        if (b ? gv_splat_corgs_step(c, t, b, t->opt.corgs_distance, coprune, segs) != 0
              : gv_splat_trainer_step(t) != 0)
            return -1;
        if (label && (t->iteration % 10 == 0 || t->iteration == t->opt.iterations))
            gv_progress_update(&bar, t->iteration, "loss %.4f  %d Gaussians  SH %d%s", t->ema_loss,
                               t->params.n, t->active_degree, t->factor == 2 ? "  at 1/2"
                               : t->factor == 4 ? "  at 1/4" : t->factor == 8 ? "  at 1/8" : "");
    }
    if (label) gv_progress_finish(&bar);
    if (b) report_two_fields(t, b, c, segs, coprune);
    double per = 1000.0 / (t->iteration > 0 ? t->iteration : 1);
    gv_info("ms per iteration: render %.2f, loss %.2f, backward %.2f, densify %.2f, Adam %.2f",
            t->seconds[GV_PHASE_RENDER] * per, t->seconds[GV_PHASE_LOSS] * per,
            t->seconds[GV_PHASE_BACKWARD] * per, t->seconds[GV_PHASE_DENSIFY] * per,
            t->seconds[GV_PHASE_ADAM] * per);
    if (t->opt.densify_mode == GV_DENSIFY_MCMC)
        gv_info("MCMC density control: budget %d Gaussians, %ld relocated, %ld added",
                t->opt.mcmc.cap, t->relocated, t->added);
    else
        gv_info("%s density control (threshold %g): %d cloned, %d split, %d pruned",
                gv_splat_densify_mode_name(t->opt.densify_mode), t->opt.densify.grad_threshold,
                t->densified.cloned, t->densified.split, t->densified.pruned);
    if (t->opt.resolution_start > 1) print_resolution_schedule(&t->opt);
    char names[64];
    gv_splat_regularize_name(t->opt.regularize, names, sizeof names);
    gv_info("sparse-view regularisers: %s", names);
    if (t->opt.regularize & GV_REGULARIZE_FSGS)
        gv_info("FSGS unpooling (proximity above %g x extent): %ld Gaussians added",
                t->opt.fsgs_distance, t->unpooled);
    if (t->opt.regularize & GV_REGULARIZE_BINOCULAR) {
        const gv_splat_binocular *bi = &t->binocular;
        double views = bi->views > 0 ? (double)bi->views : 1;
        gv_info("Binocular3DGS consistency: after iteration %d, %ld shifted views, baseline up to "
                "%.4g (%g x the median depth %.4g; mean |b| %.4g), mean loss %.4f (L1 %.4f, "
                "smoothness %.4f x %g), %.1f ms per view", bi->from, bi->views, bi->baseline,
                t->opt.binocular_baseline, bi->depth, bi->baseline_sum / views, bi->loss_sum / views,
                bi->l1_sum / views, bi->smoothness_sum / views, GV_BINOCULAR_SMOOTH_WEIGHT,
                1000 * bi->seconds / views);
    }
    if (t->opt.regularize & GV_REGULARIZE_DROPGAUSSIAN)
        gv_info("DropGaussian: rate up to %.2f, %.1f Gaussians left out per render on average",
                gv_splat_drop_rate(t->iteration, t->opt.iterations, t->opt.drop_rate),
                (double)t->dropped / (t->iteration > 0 ? t->iteration : 1));
    return 0;
}

int gv_splat_train_views(const gv_scene *scene, const int *views, int n_views,
                         const gv_splat_train_options *opt, gv_gaussians *out)
{
    memset(out, 0, sizeof *out);
    gv_camera *cameras = malloc((size_t)(n_views > 0 ? n_views : 1) * sizeof(gv_camera));
    gv_image *images = calloc((size_t)(n_views > 0 ? n_views : 1), sizeof(gv_image));
    int loaded = 0, ok = -1;
    gv_splat_trainer t, partner; /* partner: CoR-GS's second field */
    gv_splat_corgs corgs_work;   /* its pseudo-view term */
    gv_splat_segs segs;          /* SE-GS's perturbation of the second field */
    memset(&t, 0, sizeof t), memset(&partner, 0, sizeof partner);
    memset(&corgs_work, 0, sizeof corgs_work), memset(&segs, 0, sizeof segs);
    int two_fields = (opt->regularize & GV_REGULARIZE_TWO_FIELDS) != 0;
    int with_segs = (opt->regularize & GV_REGULARIZE_SEGS) != 0;
    if (!cameras || !images) {
        gv_fail("%s: out of memory for %d views", scene->dir, n_views);
        goto done;
    }
    if (n_views < 2) {
        gv_fail("%s: %d training views: 3DGS needs at least two", scene->dir, n_views);
        goto done;
    }
    for (int i = 0; i < n_views; i++)
        if (views[i] < 0 || views[i] >= scene->n_frames) {
            gv_fail("%s: training view %d: the scene has frames 0..%d", scene->dir, views[i], scene->n_frames - 1);
            goto done;
        }
    for (; loaded < n_views; loaded++) {
        cameras[loaded] = scene->cameras[views[loaded]];
        if (gv_scene_load_image(scene, views[loaded], &images[loaded]) != 0) goto done;
    }
    double extent = gv_scene_extent(scene, views, n_views);
    gv_info("%s: training on %d of %d frames (%d, %d, ..., %d), extent %.3f, %d points", scene->dir, n_views,
            scene->n_frames, views[0], views[1], views[n_views - 1], extent, scene->n_points);
    if (gv_splat_trainer_init(&t, opt, n_views, cameras, images, extent, scene->n_points,
                              scene->points, scene->colors) != 0) {
        gv_fail_context("%s", scene->dir);
        goto done;
    }
    if (two_fields) { /* the same views and points, its own randomness */
        gv_splat_train_options second = *opt;
        second.seed = opt->seed + CORGS_SEED_OFFSET;
        corgs_work.weight = opt->corgs_pseudo_weight;
        corgs_work.from = opt->schedule.densify_from;
        gv_rng_init(&corgs_work.rng, opt->seed + 2 * CORGS_SEED_OFFSET);
        if (gv_splat_trainer_init(&partner, &second, n_views, cameras, images, extent, scene->n_points,
                                  scene->points, scene->colors) != 0) {
            gv_fail_context("%s (second field)", scene->dir);
            goto done;
        }
    }
    if (with_segs && gv_splat_segs_init(&segs, n_views, cameras, opt->segs_interval,
                                        opt->seed + 3 * CORGS_SEED_OFFSET) != 0) {
        gv_fail_context("%s", scene->dir);
        goto done;
    }
    if (run(&t, two_fields ? &partner : NULL, &corgs_work, with_segs ? &segs : NULL,
            opt->progress_label) != 0) {
        gv_fail_context("%s", scene->dir);
        goto done;
    }
    if (gv_gaussians_check_finite(&t.params, "trained model") != 0) goto done;
    *out = t.params;
    memset(&t.params, 0, sizeof t.params); /* ownership moves to the caller */
    ok = 0;
done:
    gv_splat_trainer_free(&t), gv_splat_trainer_free(&partner), gv_splat_corgs_free(&corgs_work);
    gv_splat_segs_free(&segs);
    if (images) free_images(images, loaded);
    free(cameras);
    return ok;
}

int gv_splat_train(const gv_scene *scene, int interval, const gv_splat_train_options *opt,
                   gv_gaussians *out)
{
    memset(out, 0, sizeof *out);
    int n = scene->n_frames, n_train = 0, n_held_out = 0, rc = -1;
    int *train = malloc((size_t)(n > 0 ? n : 1) * sizeof(int));
    int *held_out = malloc((size_t)(n > 0 ? n : 1) * sizeof(int));
    if (!train || !held_out) gv_fail("%s: out of memory for %d frames", scene->dir, n);
    else if (gv_scene_split(n, interval, train, &n_train, held_out, &n_held_out) != 0) gv_fail_context("%s", scene->dir);
    else rc = gv_splat_train_views(scene, train, n_train, opt, out);
    free(train), free(held_out);
    return rc;
}
