/* The artifact simulator of the paper (section 3.2, "Artifact Simulation via Controlled
 * Optimization"): 3DGS trained on the sparse views 0, n, 2n, ... (or the subset it is given)
 * and stopped early at --iters (8000 in the paper), rendered at the held-out cameras. */
#include <stdlib.h>
#include <string.h>

#include "gaussvid/splat/coverage.h"
#include "gaussvid/data/dataset.h"
#include "gaussvid/splat/render.h"
#include "gaussvid/splat/splat_train.h"

typedef struct {
    gv_gaussians gaussians;
    gv_splat_renderer renderer;
    float bg[3];
    float *pixels;        /* float render, the size of the last camera */
    size_t pixel_capacity;
} artifact_model;

static int train_3dgs(void *ctx, const gv_scene *scene, const int *views, int n_views, int iters,
                      int densify, uint64_t seed, void **model)
{
    (void)ctx;
    *model = NULL;
    artifact_model *m = calloc(1, sizeof *m);
    if (!m) return gv_fail("%s: out of memory", scene->dir);
    gv_splat_train_options opt;
    gv_splat_train_defaults(&opt);
    opt.iterations = iters;
    opt.densify_mode = (gv_splat_densify_mode)densify;
    opt.seed = seed;
    opt.progress_label = "3DGS";
    if (scene->white_background) opt.background = GV_BG_WHITE;
    /* Held-out views are rendered over the background the model was trained with. */
    float bg = opt.background == GV_BG_WHITE ? 1.0f : 0.0f;
    m->bg[0] = m->bg[1] = m->bg[2] = bg;
    if (gv_splat_train_views(scene, views, n_views, &opt, &m->gaussians) != 0) {
        free(m);
        return -1;
    }
    gv_info("%s: %d Gaussians after %d iterations", scene->dir, m->gaussians.n, iters);
    *model = m;
    return 0;
}

static int render_3dgs(void *ctx, void *model, const gv_scene *scene, int frame, gv_image *out)
{
    (void)ctx;
    artifact_model *m = model;
    const gv_camera *cam = &scene->cameras[frame];
    size_t count = (size_t)cam->width * cam->height * 3;
    if (count > m->pixel_capacity) {
        float *p = realloc(m->pixels, count * sizeof *p);
        if (!p) return gv_fail("%s: out of memory for a %dx%d render", scene->dir, cam->width, cam->height);
        m->pixels = p;
        m->pixel_capacity = count;
    }
    gv_splat_view view;
    if (gv_splat_view_from_camera(&view, cam) != 0 ||
        gv_splat_render_forward(&m->renderer, &m->gaussians, &view, m->gaussians.sh_degree,
                                m->bg, m->pixels) != 0 ||
        gv_image_alloc(out, cam->width, cam->height, 3) != 0)
        return gv_fail_context("%s: frame %d", scene->dir, frame);
    gv_image_from_float(out, m->pixels); /* clamped and quantised as 3DGS saves renders */
    return 0;
}

/* The depth the coverage plane uses (gv_coverage_depth at the default minimum opacity). */
static int depth_3dgs(void *ctx, void *model, const gv_scene *scene, int frame, float *depth)
{
    (void)ctx;
    artifact_model *m = model;
    gv_coverage_options opt;
    gv_coverage_options_default(&opt);
    memcpy(opt.bg, m->bg, sizeof opt.bg);
    return gv_coverage_depth(&m->renderer, &m->gaussians, &scene->cameras[frame], &opt, depth);
}

static void free_3dgs(void *ctx, void *model)
{
    (void)ctx;
    artifact_model *m = model;
    if (!m) return;
    gv_gaussians_free(&m->gaussians);
    gv_splat_renderer_free(&m->renderer);
    free(m->pixels);
    free(m);
}

const gv_artifact_simulator gv_artifact_3dgs = {"sparse 3DGS", train_3dgs, render_3dgs, free_3dgs, NULL, depth_3dgs};
