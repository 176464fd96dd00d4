/* `gaussvid bench raster`: the cost of each stage of a training iteration on a fixed
 * workload, so that a kernel change can be measured before and after on the same input.
 *
 * The workload: a trained model (a PLY file, e.g. `splat train --iters 2000`) and the
 * training views of a scene. Each pass renders the next training view (cycling through
 * them) with the model's full SH degree over a black background, takes the training loss
 * against that view's image and its gradient, runs the backward, and steps the reference's
 * dense Adam on a second copy of the model (so the rendered model, and with it the work of
 * every pass, never changes; Adam's cost does not depend on the values). That is exactly
 * the work of a training iteration without density control. Reported per stage: process
 * CPU milliseconds per pass (all threads), wall milliseconds per pass, and their ratio (the
 * cores the stage kept busy: about 1 for a stage that runs on one core). */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include <cjson/cJSON.h>
#include <omp.h>

#include "bench/bench.h"
#include "gaussvid/core/core.h"
#include "gaussvid/io/ply.h"
#include "gaussvid/splat/render.h"
#include "gaussvid/scene/scene.h"
#include "gaussvid/splat/splat_train.h"

/* The renderer's stages, then the two of the trainer. */
enum { STAGE_LOSS = GV_STAGES, STAGE_ADAM, ALL_STAGES };

typedef struct {
    double wall[ALL_STAGES], cpu[ALL_STAGES];
    double total_wall, total_cpu;
    long visible, entries;  /* summed over the passes */
    int gaussians, sh_degree, views, width, height, passes, threads;
} raster_result;

/* The training views of the scene with their images as floats. */
typedef struct {
    gv_scene scene;
    int n;
    gv_splat_view *views;
    float **targets;
} view_set;

static void view_set_free(view_set *v)
{
    for (int i = 0; v->targets && i < v->n; i++) free(v->targets[i]);
    free(v->targets), free(v->views);
    gv_scene_free(&v->scene);
}

static int load_views(const char *dir, int interval, view_set *v)
{
    memset(v, 0, sizeof *v);
    if (gv_scene_load(dir, NULL, &v->scene) != 0) return -1;
    int n = v->scene.n_frames, n_held;
    int *train = malloc((size_t)n * sizeof(int)), *held = malloc((size_t)n * sizeof(int));
    v->views = calloc((size_t)n, sizeof *v->views);
    v->targets = calloc((size_t)n, sizeof *v->targets);
    int ok = train && held && v->views && v->targets ? 0 : gv_fail("bench raster: out of memory");
    if (ok == 0) ok = gv_scene_split(n, interval, train, &v->n, held, &n_held);
    for (int i = 0; ok == 0 && i < v->n; i++) {
        gv_image img;
        const gv_camera *cam = &v->scene.cameras[train[i]];
        if (gv_splat_view_from_camera(&v->views[i], cam) != 0 ||
            gv_scene_load_image(&v->scene, train[i], &img) != 0) {
            ok = -1;
            break;
        }
        v->targets[i] = malloc((size_t)img.width * img.height * 3 * sizeof(float));
        if (v->targets[i]) gv_image_to_float(&img, v->targets[i]);
        else ok = gv_fail("bench raster: out of memory");
        gv_image_free(&img);
    }
    free(train), free(held);
    if (ok != 0) view_set_free(v);
    return ok;
}

static int run_passes(const gv_gaussians *model, gv_gaussians *stepped, const view_set *v,
                      int passes, raster_result *res)
{
    gv_splat_renderer r = {0};
    gv_splat_loss_work loss_work = {0};
    gv_splat_adam adam;
    gv_gaussians grad = {0};
    int w = v->views[0].width, h = v->views[0].height;
    float *image = malloc((size_t)w * h * 3 * sizeof(float));
    float *d_image = malloc((size_t)w * h * 3 * sizeof(float));
    gv_splat_adam_config config;
    gv_splat_adam_defaults(&config);
    int ok = image && d_image ? 0 : gv_fail("bench raster: out of memory");
    if (ok == 0) ok = gv_gaussians_alloc(&grad, model->n, model->sh_degree);
    if (ok == 0) ok = gv_splat_adam_init(&adam, &config, stepped, 1.0);
    if (ok != 0) {
        free(image), free(d_image), gv_gaussians_free(&grad);
        return -1;
    }
    float bg[3] = {0, 0, 0};
    int n_coeffs = gv_sh_coefficient_count(model->sh_degree);
    gv_progress bar;
    gv_progress_start(&bar, "raster passes", passes);
    double wall0 = gv_now(), cpu0 = gv_cpu_now();
    for (int p = 0; p < passes && ok == 0; p++) {
        const gv_splat_view *view = &v->views[p % v->n];
        if (view->width != w || view->height != h) {
            ok = gv_fail("bench raster: the training views differ in size");
            break;
        }
        if (gv_splat_render_forward(&r, model, view, model->sh_degree, bg, image) != 0) {
            ok = -1;
            break;
        }
        double w1 = gv_now(), c1 = gv_cpu_now();
        gv_splat_loss_value value;
        ok = gv_splat_loss(&loss_work, image, v->targets[p % v->n], w, h, 0.2, d_image, &value);
        double w2 = gv_now(), c2 = gv_cpu_now();
        if (ok == 0) ok = gv_splat_render_backward(&r, model, d_image, &grad, NULL);
        double w3 = gv_now(), c3 = gv_cpu_now();
        if (ok == 0)
            gv_splat_adam_step(&adam, stepped, &grad, r.tiles.visible, r.tiles.n_visible, 1,
                               n_coeffs, GV_ADAM_ALL_GROUPS);
        double w4 = gv_now(), c4 = gv_cpu_now();
        res->wall[STAGE_LOSS] += w2 - w1, res->cpu[STAGE_LOSS] += c2 - c1;
        res->wall[STAGE_ADAM] += w4 - w3, res->cpu[STAGE_ADAM] += c4 - c3;
        res->visible += r.tiles.n_visible, res->entries += r.tiles.n_entries;
        gv_progress_update(&bar, p + 1, "%d Gaussians", model->n);
    }
    res->total_wall = gv_now() - wall0, res->total_cpu = gv_cpu_now() - cpu0;
    gv_progress_finish(&bar);
    for (int s = 0; s < GV_STAGES; s++)
        res->wall[s] = r.stage_seconds[s], res->cpu[s] = r.stage_cpu_seconds[s];
    gv_splat_renderer_free(&r), gv_splat_loss_free(&loss_work), gv_splat_adam_free(&adam);
    gv_gaussians_free(&grad);
    free(image), free(d_image);
    return ok;
}

static const char *stage_name(int s)
{
    return s == STAGE_LOSS ? "loss" : s == STAGE_ADAM ? "Adam" : gv_stage_names[s];
}

static void print_result(const raster_result *r, int json, FILE *out)
{
    double per = 1e3 / r->passes;
    if (json) {
        cJSON *o = cJSON_CreateObject();
        cJSON_AddNumberToObject(o, "gaussians", r->gaussians);
        cJSON_AddNumberToObject(o, "sh_degree", r->sh_degree);
        cJSON_AddNumberToObject(o, "views", r->views);
        cJSON_AddNumberToObject(o, "passes", r->passes);
        cJSON_AddNumberToObject(o, "threads", r->threads);
        cJSON_AddNumberToObject(o, "mean_visible", (double)r->visible / r->passes);
        cJSON_AddNumberToObject(o, "mean_entries", (double)r->entries / r->passes);
        cJSON *st = cJSON_AddObjectToObject(o, "stages");
        for (int s = 0; s < ALL_STAGES; s++) {
            cJSON *j = cJSON_AddObjectToObject(st, stage_name(s));
            cJSON_AddNumberToObject(j, "cpu_ms", r->cpu[s] * per);
            cJSON_AddNumberToObject(j, "wall_ms", r->wall[s] * per);
        }
        cJSON_AddNumberToObject(o, "cpu_ms_per_pass", r->total_cpu * per);
        cJSON_AddNumberToObject(o, "wall_ms_per_pass", r->total_wall * per);
        char *text = cJSON_Print(o);
        if (text) fprintf(out, "%s\n", text);
        cJSON_free(text);
        cJSON_Delete(o);
        return;
    }
    fprintf(out, "%d Gaussians (SH degree %d), %d views of %dx%d, %d passes, %d threads; "
            "per pass %.0f visible, %.0f tile entries\n", r->gaussians, r->sh_degree, r->views,
            r->width, r->height, r->passes, r->threads, (double)r->visible / r->passes,
            (double)r->entries / r->passes);
    fprintf(out, "| stage | CPU ms / pass | wall ms / pass | CPU / wall |\n|---|---:|---:|---:|\n");
    double cpu_sum = 0, wall_sum = 0;
    for (int s = 0; s < ALL_STAGES; s++) {
        fprintf(out, "| %s | %.2f | %.2f | %.2f |\n", stage_name(s), r->cpu[s] * per,
                r->wall[s] * per, r->wall[s] > 0 ? r->cpu[s] / r->wall[s] : 0.0);
        cpu_sum += r->cpu[s], wall_sum += r->wall[s];
    }
    fprintf(out, "| sum of the stages | %.2f | %.2f | %.2f |\n", cpu_sum * per, wall_sum * per,
            wall_sum > 0 ? cpu_sum / wall_sum : 0.0);
    fprintf(out, "| whole pass | %.2f | %.2f | %.2f |\n", r->total_cpu * per,
            r->total_wall * per, r->total_wall > 0 ? r->total_cpu / r->total_wall : 0.0);
}

int gv_bench_raster_command(int argc, char **argv)
{
    const char *model_path = NULL, *scene_dir = NULL;
    int interval = 6, passes = 200, json = 0;
    const gv_flag flags[] = {
        {"model", GV_FLAG_STRING, &model_path, "MODEL.ply", "a trained 3DGS model", 1},
        {"scene", GV_FLAG_STRING, &scene_dir, "DIR", "the scene whose training views are rendered", 1},
        {"interval", GV_FLAG_INT, &interval, "N", "training views: frames 0, N, 2N, ... (default 6)", 0},
        {"passes", GV_FLAG_INT, &passes, "N", "forward + loss + backward + Adam passes (default 200)", 0},
        {"json", GV_FLAG_BOOL, &json, NULL, "print JSON instead of a table", 0},
    };
    const gv_command_spec spec = {
        "bench raster", NULL, "CPU time of each stage of a training iteration on a fixed model",
        "Renders the scene's training views in turn with the model (full SH degree, black\n"
        "background), takes the training loss and its gradient, runs the backward and a dense\n"
        "Adam step on a copy of the model, --passes times; prints per stage the process CPU\n"
        "milliseconds and wall milliseconds per pass and their ratio (the cores the stage\n"
        "kept busy). Results: docs/BENCHMARKS.md.",
        flags, sizeof flags / sizeof flags[0], 0, 0};
    int rc = gv_args_parse(&spec, argc, argv, NULL, NULL);
    if (rc != GV_ARGS_OK) return gv_args_exit_code(rc);
    if (passes < 1 || interval < 1) {
        fprintf(stderr, "gaussvid bench raster: --passes and --interval must be at least 1\n");
        return 2;
    }
    gv_gaussians model = {0}, stepped = {0};
    view_set views;
    if (gv_gaussians_read_ply(model_path, &model) != 0) return gv_report_failure();
    if (gv_gaussians_read_ply(model_path, &stepped) != 0) {
        gv_gaussians_free(&model);
        return gv_report_failure();
    }
    if (load_views(scene_dir, interval, &views) != 0) {
        gv_gaussians_free(&model), gv_gaussians_free(&stepped);
        return gv_report_failure();
    }
    raster_result res = {.gaussians = model.n, .sh_degree = model.sh_degree, .views = views.n,
                         .width = views.views[0].width, .height = views.views[0].height,
                         .passes = passes, .threads = omp_get_max_threads()};
    int ok = run_passes(&model, &stepped, &views, passes, &res);
    if (ok == 0) print_result(&res, json, stdout);
    view_set_free(&views);
    gv_gaussians_free(&model), gv_gaussians_free(&stepped);
    return ok == 0 ? 0 : gv_report_failure();
}
