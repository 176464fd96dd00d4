/* One call to render a view of a set of Gaussians, and one for its backward to the raw
 * parameters: projection -> binning -> SH colour -> rasterisation, then back. */
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "gaussvid/core/core.h"
#include "gaussvid/splat/render.h"

const char *const gv_stage_names[GV_STAGES] = {
    "projection", "binning+sort", "SH", "opacity", "raster fwd", "raster bwd", "grads",
    "projection bwd", "SH bwd"};

/* Adds the time since *wall, *cpu to the stage and restarts both clocks. */
static void stage_done(gv_splat_renderer *r, int stage, double *wall, double *cpu)
{
    double w = gv_now(), c = gv_cpu_now();
    r->stage_seconds[stage] += w - *wall, r->stage_cpu_seconds[stage] += c - *cpu;
    *wall = w, *cpu = c;
}

static int grow(void **array, size_t bytes)
{
    void *p = realloc(*array, bytes > 0 ? bytes : 1);
    if (!p) return -1;
    *array = p;
    return 0;
}

static int ensure_capacity(gv_splat_renderer *r, int n, long pixels)
{
    if (n > r->capacity) {
        size_t cap = (size_t)n + (size_t)n / 4 + 16, f = sizeof(float);
        if (grow((void **)&r->means2d, cap * 2 * f) || grow((void **)&r->conics, cap * 3 * f) ||
            grow((void **)&r->depths, cap * f) || grow((void **)&r->colors, cap * 3 * f) ||
            grow((void **)&r->opacities, cap * f) || grow((void **)&r->radii, cap * sizeof(int)) ||
            grow((void **)&r->clamped, cap) || grow((void **)&r->d_means2d, cap * 2 * f) ||
            grow((void **)&r->d_conics, cap * 3 * f) || grow((void **)&r->d_colors, cap * 3 * f) ||
            grow((void **)&r->d_opacities, cap * f))
            return gv_fail("render: out of memory for %d Gaussians", n);
        r->capacity = (int)cap;
    }
    if (pixels > r->pixel_capacity) {
        if (grow((void **)&r->final_T, (size_t)pixels * sizeof(float)) ||
            grow((void **)&r->n_contrib, (size_t)pixels * sizeof(int)))
            return gv_fail("render: out of memory for %ld pixels", pixels);
        r->pixel_capacity = (int)pixels;
    }
    return 0;
}

int gv_splat_render_forward(gv_splat_renderer *r, const gv_gaussians *g,
                            const gv_splat_view *view, int active_degree, const float bg[3],
                            float *image)
{
    return gv_splat_render_forward_scaled(r, g, view, active_degree, bg, NULL, image);
}

static float sigmoid(float x)
{
    return 1.0f / (1.0f + expf(-x));
}

int gv_splat_render_forward_scaled(gv_splat_renderer *r, const gv_gaussians *g,
                                   const gv_splat_view *view, int active_degree,
                                   const float bg[3], const float *opacity_scale, float *image)
{
    if (g->sh_degree < 0 || g->sh_degree > 3 || active_degree < 0 ||
        active_degree > g->sh_degree)
        return gv_fail("render: active SH degree %d is not in 0..%d", active_degree,
                       g->sh_degree);
    if (g->n < 0) return gv_fail("render: negative Gaussian count %d", g->n);
    if (view->width <= 0 || view->height <= 0)
        return gv_fail("render: bad image size %dx%d", view->width, view->height);
    long pixels = (long)view->width * view->height;
    if (pixels > (long)1 << 30) return gv_fail("render: image of %ld pixels is too large", pixels);
    if (ensure_capacity(r, g->n, pixels)) return -1;
    r->n = g->n, r->sh_degree = g->sh_degree, r->active_degree = active_degree;
    r->view = *view;
    r->opacity_scale = opacity_scale;
    for (int c = 0; c < 3; c++) r->bg[c] = bg[c];

    double wall = gv_now(), cpu = gv_cpu_now();
    gv_splat_project_forward(g->n, g->means, g->scales, g->rotations, view, r->means2d,
                             r->conics, r->depths, r->radii);
    if (opacity_scale) /* a dropped Gaussian is culled: binning leaves it out */
        for (int i = 0; i < g->n; i++)
            if (opacity_scale[i] == 0) r->radii[i] = 0;
    stage_done(r, GV_STAGE_PROJECT, &wall, &cpu);
    if (gv_splat_tiles_build(&r->tiles, g->n, view->width, view->height, r->means2d, r->radii,
                             r->depths))
        return -1;
    stage_done(r, GV_STAGE_BIN, &wall, &cpu);
    int nv = r->tiles.n_visible;
    const int *vis = r->tiles.visible;
    gv_splat_sh_forward(nv, vis, g->sh_degree, active_degree, g->sh, g->means, view->campos,
                        r->colors, r->clamped);
    stage_done(r, GV_STAGE_SH, &wall, &cpu);
#pragma omp parallel for schedule(static)
    for (int k = 0; k < nv; k++) {
        int i = vis[k];
        r->opacities[i] = sigmoid(g->opacities[i]);
        if (opacity_scale) r->opacities[i] *= opacity_scale[i];
    }
    stage_done(r, GV_STAGE_OPACITY, &wall, &cpu);
    gv_splat_rasterize_forward(&r->tiles, view->width, view->height, r->means2d, r->conics,
                               r->colors, r->opacities, bg, image, r->final_T, r->n_contrib);
    stage_done(r, GV_STAGE_RASTER, &wall, &cpu);
    return 0;
}

int gv_splat_render_backward(gv_splat_renderer *r, const gv_gaussians *g,
                             const float *d_image, gv_gaussians *grad, float *densify_grad)
{
    return gv_splat_render_backward_depth(r, g, d_image, NULL, grad, densify_grad);
}

/* The depth backward's four per-Gaussian arrays in r->depth_grads (one allocation of the
 * renderer's capacity): d means2d, d conics, d opacities, d z. */
static int depth_grad_arrays(gv_splat_renderer *r, float *a[4])
{
    if (r->depth_capacity < r->capacity) {
        if (grow((void **)&r->depth_grads, (size_t)r->capacity * (2 + 3 + 1 + 1) * sizeof(float)))
            return gv_fail("render: out of memory for the depth gradients of %d Gaussians", r->n);
        r->depth_capacity = r->capacity;
    }
    size_t cap = (size_t)r->depth_capacity;
    a[0] = r->depth_grads, a[1] = a[0] + 2 * cap, a[2] = a[1] + 3 * cap, a[3] = a[2] + cap;
    return 0;
}

int gv_splat_render_backward_depth(gv_splat_renderer *r, const gv_gaussians *g,
                                   const float *d_image, const float *d_depth_sum,
                                   gv_gaussians *grad, float *densify_grad)
{
    if (g->n != r->n || g->sh_degree != r->sh_degree)
        return gv_fail("render: backward of %d Gaussians (SH degree %d) after a forward of %d "
                       "(degree %d)", g->n, g->sh_degree, r->n, r->sh_degree);
    if (grad->sh_degree != g->sh_degree || grad->capacity < g->n)
        return gv_fail("render: gradient holds %d Gaussians of SH degree %d, need %d of degree "
                       "%d", grad->capacity, grad->sh_degree, g->n, g->sh_degree);
    float *dd[4] = {NULL, NULL, NULL, NULL}; /* the depth's d means2d, conics, opacities, z */
    if (d_depth_sum && depth_grad_arrays(r, dd) != 0) return -1;
    const gv_splat_view *view = &r->view;
    double wall = gv_now(), cpu = gv_cpu_now();
    gv_splat_rasterize_backward(&r->tiles, view->width, view->height, r->bg, r->final_T,
                                r->n_contrib, d_image, r->d_means2d, r->d_conics, r->d_colors,
                                r->d_opacities);
    if (d_depth_sum) /* the colour backward is done with the tiles' scratch rows */
        gv_splat_rasterize_depth_backward(&r->tiles, view->width, view->height, r->means2d,
                                          r->conics, r->opacities, r->depths, r->final_T,
                                          r->n_contrib, d_depth_sum, dd[0], dd[1], dd[2], dd[3]);
    stage_done(r, GV_STAGE_RASTER_BWD, &wall, &cpu);
    int nv = r->tiles.n_visible;
    const int *vis = r->tiles.visible;
    float half_w = 0.5f * view->width, half_h = 0.5f * view->height;
#pragma omp parallel for schedule(static)
    for (int k = 0; k < nv; k++) {
        int i = vis[k];
        if (d_depth_sum) { /* the two losses' 2D gradients, summed */
            for (int j = 0; j < 2; j++) r->d_means2d[2 * i + j] += dd[0][2 * i + j];
            for (int j = 0; j < 3; j++) r->d_conics[3 * i + j] += dd[1][3 * i + j];
            r->d_opacities[i] += dd[2][i];
        }
        if (r->opacity_scale) { /* opacity = scale sigmoid(logit) */
            float o = sigmoid(g->opacities[i]);
            grad->opacities[i] = r->d_opacities[i] * r->opacity_scale[i] * o * (1.0f - o);
        } else {
            float o = r->opacities[i];
            grad->opacities[i] = r->d_opacities[i] * o * (1.0f - o); /* through the sigmoid */
        }
        if (densify_grad) {
            /* 3DGS accumulates the gradient w.r.t. NDC, i.e. pixels x (W/2, H/2). */
            float gx = r->d_means2d[2 * i] * half_w, gy = r->d_means2d[2 * i + 1] * half_h;
            densify_grad[i] = sqrtf(gx * gx + gy * gy);
        }
    }
    stage_done(r, GV_STAGE_GRADS, &wall, &cpu);
    gv_splat_project_backward(nv, vis, g->means, g->scales, g->rotations, view, r->d_means2d,
                              r->d_conics, grad->means, grad->scales, grad->rotations);
    if (d_depth_sum) {
        /* z = (R mean + t)_z: dL/dmean += dL/dz times the third row of R (the release's
         * rasteriser adds the same through its view matrix) */
        const float *R = view->R;
#pragma omp parallel for schedule(static)
        for (int k = 0; k < nv; k++) {
            size_t i = (size_t)vis[k];
            for (int j = 0; j < 3; j++) grad->means[3 * i + j] += R[6 + j] * dd[3][i];
        }
    }
    stage_done(r, GV_STAGE_PROJECT_BWD, &wall, &cpu);
    gv_splat_sh_backward(nv, vis, g->sh_degree, r->active_degree, g->sh, g->means,
                         view->campos, r->clamped, r->d_colors, grad->sh, grad->means);
    stage_done(r, GV_STAGE_SH_BWD, &wall, &cpu);
    return 0;
}

void gv_splat_renderer_free(gv_splat_renderer *r)
{
    free(r->means2d), free(r->conics), free(r->depths), free(r->colors), free(r->opacities);
    free(r->radii), free(r->clamped);
    free(r->d_means2d), free(r->d_conics), free(r->d_colors), free(r->d_opacities);
    free(r->final_T), free(r->n_contrib), free(r->depth_grads);
    gv_splat_tiles_free(&r->tiles);
    memset(r, 0, sizeof *r);
}
