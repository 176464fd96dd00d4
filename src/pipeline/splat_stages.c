/* The 3DGS stages of `reconstruct`: the sparse model (train), its renders (render) and the
 * refinement (refine): the sparse model optimised further on the training views and,
 * down-weighted, the restored frames (the paper's supplementary feeds restored frames back
 * into the 3DGS; docs/RECONSTRUCT.md "Refinement" says how and what it measured). */
#include <stdlib.h>
#include <string.h>

#include "gaussvid/core/core.h"
#include "gaussvid/io/ply.h"
#include "gaussvid/splat/splat_train.h"
#include "pipeline/pipeline_internal.h"

static const float BLACK[3] = {0, 0, 0}; /* the trainer's background (gv_splat_train_defaults) */

static int write_model(pipeline_run *r, const gv_gaussians *g, const char *stem)
{
    char ply[4200], splat[4200], name[64];
    snprintf(name, sizeof name, "%s.ply", stem);
    if (pipeline_file(r, name, ply, sizeof ply) || gv_gaussians_write_ply(ply, g)) return -1;
    snprintf(name, sizeof name, "%s.splat", stem);
    if (pipeline_file(r, name, splat, sizeof splat) || gv_gaussians_write_splat(splat, g)) return -1;
    cJSON *counts = cJSON_GetObjectItem(r->run, "gaussians");
    cJSON_ReplaceItemInObject(counts, stem, cJSON_CreateNumber(g->n));
    return 0;
}

static int read_model(pipeline_run *r, const char *stem, gv_gaussians *g)
{
    char path[4200], name[64];
    snprintf(name, sizeof name, "%s.ply", stem);
    return pipeline_file(r, name, path, sizeof path) || gv_gaussians_read_ply(path, g);
}

int pipeline_train(pipeline_run *r)
{
    gv_splat_train_options opt;
    gv_splat_train_defaults(&opt);
    opt.iterations = r->opt->iters;
    opt.densify_mode = (gv_splat_densify_mode)r->opt->densify;
    opt.regularize = r->opt->regularize;
    opt.resolution_start = gv_splat_resolution_fit(r->opt->resolution_start, r->scene->cameras, r->scene->n_frames);
    opt.seed = r->opt->seed;
    char label[32];
    snprintf(label, sizeof label, "train n=%d", r->interval);
    opt.progress_label = gv_log_level() >= GV_LOG_INFO ? label : NULL;
    gv_gaussians g;
    if (gv_splat_train(r->scene, r->interval, &opt, &g)) return -1;
    int rc = write_model(r, &g, "sparse");
    snprintf(r->summary, sizeof r->summary, "%d Gaussians from %d training views, %d iterations", g.n, r->n_train,
             opt.iterations);
    gv_gaussians_free(&g);
    return rc;
}

int pipeline_render_model(pipeline_run *r, const gv_gaussians *g, const char *what)
{
    char dir[4200], path[4200];
    snprintf(dir, sizeof dir, "%s/frames/%s", r->dir, what);
    if (gv_mkdirs(dir)) return -1;
    gv_splat_renderer renderer;
    memset(&renderer, 0, sizeof renderer);
    gv_progress bar;
    char label[48];
    snprintf(label, sizeof label, "%s n=%d", what, r->interval);
    gv_progress_start(&bar, label, r->n_frames);
    int rc = 0;
    for (int i = 0; i < r->n_frames && rc == 0; i++) {
        gv_image img = {0};
        rc = gv_splat_render_camera(&renderer, g, &r->frames[i].camera, BLACK, &img) ||
             pipeline_frame_path(r, what, r->frames[i].index, path, sizeof path) || gv_image_write_png(path, &img);
        gv_image_free(&img);
        gv_progress_update(&bar, i + 1, NULL);
    }
    gv_progress_finish(&bar);
    gv_splat_renderer_free(&renderer);
    return rc ? gv_fail_context("%s: rendering the %s frames", r->dir, what) : 0;
}

int pipeline_render(pipeline_run *r)
{
    gv_gaussians g;
    if (read_model(r, "sparse", &g)) return -1;
    int rc = pipeline_render_model(r, &g, "render");
    gv_gaussians_free(&g);
    snprintf(r->summary, sizeof r->summary, "%d %s frames rendered", r->n_frames,
             r->smooth_path ? "path" : "held-out");
    return rc;
}

/* The refinement's views: the training views (weight 1), then every restored frame (weight
 * refine_weight), with their images loaded. */
typedef struct {
    int n;
    gv_camera *cameras;
    gv_image *images;
    float *weights;
} view_set;

static void views_free(view_set *v)
{
    for (int i = 0; v->images && i < v->n; i++) gv_image_free(&v->images[i]);
    free(v->cameras), free(v->images), free(v->weights);
}

static int load_views(pipeline_run *r, view_set *v)
{
    int total = r->n_train + r->n_frames;
    memset(v, 0, sizeof *v);
    v->cameras = malloc((size_t)total * sizeof *v->cameras);
    v->images = calloc((size_t)total, sizeof *v->images);
    v->weights = malloc((size_t)total * sizeof *v->weights);
    if (!v->cameras || !v->images || !v->weights) return gv_fail("out of memory for %d views", total);
    for (int k = 0; k < r->n_train; k++, v->n++) {
        v->cameras[v->n] = r->scene->cameras[r->train[k]];
        v->weights[v->n] = 1.0f;
        if (gv_scene_load_image(r->scene, r->train[k], &v->images[v->n])) return -1;
    }
    for (int i = 0; i < r->n_frames; i++, v->n++) {
        char path[4200];
        v->cameras[v->n] = r->frames[i].camera;
        v->weights[v->n] = (float)r->opt->refine_weight;
        if (pipeline_frame_path(r, "restored", r->frames[i].index, path, sizeof path) ||
            gv_image_read_rgb(path, &v->images[v->n]))
            return -1;
    }
    return 0;
}

/* No restored frame differs from its render: refining on them would only overfit the
 * training views (docs/RESULTS.md, "reconstruct on the shared scenes": -0.18 dB on livingroom
 * n = 16 with the restored frames all but unused), so the refined model is the sparse one. */
static int keep_sparse(pipeline_run *r, const char *why)
{
    gv_gaussians g;
    if (read_model(r, "sparse", &g)) return -1;
    cJSON_ReplaceItemInObject(cJSON_GetObjectItem(r->run, "gaussians"), "refined", cJSON_CreateNumber(g.n));
    gv_gaussians_free(&g);
    pipeline_decision(r, "refinement", 0, why);
    snprintf(r->summary, sizeof r->summary, "skipped: %s; the refined model is the sparse model", why);
    return pipeline_copy_file(r, "sparse.ply", "refined.ply") || pipeline_copy_file(r, "sparse.splat", "refined.splat") ||
           pipeline_copy_frames(r, "render", "refined");
}

int pipeline_refine(pipeline_run *r)
{
    /* what the restore stage decided, here or in the run this one resumes (metrics.json) */
    int restored = pipeline_decision_ran(r, "restoration");
    if (restored < 0) return gv_fail("%s: metrics.json records no restoration decision", r->dir);
    if (restored == 0) return keep_sparse(r, "nothing was restored");
    pipeline_decision(r, "refinement", 1, NULL);
    gv_gaussians sparse = {0};
    view_set views = {0};
    gv_splat_trainer t;
    memset(&t, 0, sizeof t);
    int rc = -1;
    if (read_model(r, "sparse", &sparse) || load_views(r, &views)) goto done;
    gv_splat_train_options opt;
    gv_splat_train_defaults(&opt);
    opt.iterations = r->opt->refine_iters;
    opt.seed = r->opt->seed + 1;
    opt.sh_degree = sparse.sh_degree;
    opt.initial = &sparse;
    opt.view_weights = views.weights;
    /* No density control (the sparse model's Gaussians are refined, not regrown: restored
     * frames are not trusted to place new ones), and the position learning rate continues the
     * sparse run's decay from where it stopped, down to the reference's final rate. */
    opt.schedule.densify_until = 0;
    opt.adam.means_lr_init = gv_splat_expon_lr(r->opt->iters, opt.adam.means_lr_init, opt.adam.means_lr_final,
                                               opt.adam.means_lr_steps);
    opt.adam.means_lr_steps = opt.iterations;
    double extent = gv_scene_extent(r->scene, r->train, r->n_train);
    if (gv_splat_trainer_init(&t, &opt, views.n, views.cameras, views.images, extent, 0, NULL, NULL)) goto done;
    gv_progress bar;
    char label[32];
    snprintf(label, sizeof label, "refine n=%d", r->interval);
    gv_progress_start(&bar, label, opt.iterations);
    while (t.iteration < opt.iterations) {
        if (gv_splat_trainer_step(&t)) break;
        if (t.iteration % 10 == 0 || t.iteration == opt.iterations)
            gv_progress_update(&bar, t.iteration, "loss %.4f", t.ema_loss);
    }
    gv_progress_finish(&bar);
    if (t.iteration < opt.iterations || gv_gaussians_check_finite(&t.params, "refined model") ||
        write_model(r, &t.params, "refined") || pipeline_render_model(r, &t.params, "refined"))
        goto done;
    snprintf(r->summary, sizeof r->summary, "%d iterations on %d training views (weight 1) and %d restored frames "
             "(weight %g)", opt.iterations, r->n_train, r->n_frames, r->opt->refine_weight);
    rc = 0;
done:
    gv_splat_trainer_free(&t);
    views_free(&views);
    gv_gaussians_free(&sparse);
    return rc;
}
