/* Resolution scheduling (`splat train --resolution-schedule K`): the first iterations train
 * on the training views at 1/K of their size, the size doubling at evenly spaced steps until
 * full resolution at a given share of the run (docs/SPLAT_TRAINING.md, "Resolution
 * scheduling"). The idea is DashGaussian's (Chen et al., "DashGaussian: Optimizing 3D
 * Gaussian Splatting in 200 Seconds", CVPR 2025): early on the model is sparse and fits the
 * low frequencies of the views, which a smaller render shows as well as a full one, at a
 * fraction of the rasterisation cost. The step schedule is ours (DashGaussian derives its
 * steps from the frequency content of the views).
 *
 * A level (factor f) sees each training view through the same pose with every intrinsic
 * divided by f and the size floor(W / f) x floor(H / f): since pixel (i, j) has its centre at
 * (i + 0.5, j + 0.5), the low-resolution pixel (i, j) is exactly the f x f block of full
 * pixels i f .. i f + f - 1, j f .. j f + f - 1 (the last W mod f columns and H mod f rows are
 * left out at that level). Its target is the mean of that block (a box filter), computed once
 * per level and kept. */
#include <stdlib.h>
#include <string.h>

#include "gaussvid/core/core.h"
#include "gaussvid/splat/splat_train.h"

int gv_splat_resolution_factor(int iteration, int iterations, int start, double full_at)
{
    int steps = 0; /* halvings from start to 1 */
    while (steps < 3 && (1 << (steps + 1)) <= start) steps++;
    long coarse = (long)(full_at * iterations + 0.5); /* iterations before full resolution */
    if (steps == 0 || iteration > coarse || coarse < 1) return 1;
    long k = (long)(iteration - 1) * steps / coarse; /* 0 .. steps - 1 */
    return 1 << (steps - k);
}

int gv_splat_resolution_check(int start, double full_at)
{
    if (start != 0 && start != 1 && start != 2 && start != 4 && start != GV_RESOLUTION_MAX_FACTOR)
        return gv_fail("train: resolution schedule start factor %d; expected 2, 4 or 8 (0: off)", start);
    if (start > 1 && !(full_at > 0 && full_at <= 1))
        return gv_fail("train: the resolution schedule reaches full resolution at %g of the "
                       "iterations; expected a share in (0, 1]", full_at);
    return 0;
}

int gv_splat_resolution_fit(int start, const gv_camera *cameras, int n)
{
    for (; start > 1; start /= 2) {
        int fits = 1;
        for (int i = 0; i < n && fits; i++) fits = cameras[i].width >= start && cameras[i].height >= start;
        if (fits) break;
    }
    return start;
}

void gv_splat_box_downsample(const float *in, int width, int height, int f, float *out)
{
    int w = width / f, h = height / f;
    float inv = 1.0f / (float)(f * f);
    for (int j = 0; j < h; j++)
        for (int i = 0; i < w; i++)
            for (int c = 0; c < 3; c++) {
                float sum = 0;
                for (int y = j * f; y < j * f + f; y++)
                    for (int x = i * f; x < i * f + f; x++) sum += in[((size_t)y * width + x) * 3 + c];
                out[((size_t)j * w + i) * 3 + c] = sum * inv;
            }
}

void gv_camera_downsampled(const gv_camera *cam, int f, gv_camera *out)
{
    *out = *cam;
    out->width = cam->width / f, out->height = cam->height / f;
    out->fx = cam->fx / f, out->fy = cam->fy / f;
    out->cx = cam->cx / f, out->cy = cam->cy / f;
}

static int level_index(int factor)
{
    return factor == 2 ? 0 : factor == 4 ? 1 : 2;
}

/* The views and box-filtered targets of level `factor`, made on first use. */
static int build_level(gv_splat_trainer *t, int factor, gv_splat_resolution_level *l)
{
    l->views = calloc((size_t)t->n_views, sizeof *l->views);
    l->targets = calloc((size_t)t->n_views, sizeof *l->targets);
    if (!l->views || !l->targets) return gv_fail("train: out of memory for the 1/%d views", factor);
    for (int v = 0; v < t->n_views; v++) {
        gv_camera small;
        gv_camera_downsampled(&t->cameras[v], factor, &small);
        if (small.width < 1 || small.height < 1)
            return gv_fail("train: %s: %dx%d is too small for the resolution schedule's 1/%d",
                           t->cameras[v].name, t->cameras[v].width, t->cameras[v].height, factor);
        if (gv_splat_view_from_camera(&l->views[v], &small) != 0)
            return gv_fail_context("train: camera %s at 1/%d", t->cameras[v].name, factor);
        l->targets[v] = malloc((size_t)small.width * small.height * 3 * sizeof(float));
        if (!l->targets[v]) return gv_fail("train: out of memory for the 1/%d views", factor);
        gv_image_to_float(&t->images[v], t->target); /* the full view, as a scratch */
        gv_splat_box_downsample(t->target, t->cameras[v].width, t->cameras[v].height, factor,
                                l->targets[v]);
    }
    l->factor = factor;
    return 0;
}

int gv_splat_trainer_level(gv_splat_trainer *t, int factor, const gv_splat_resolution_level **out)
{
    gv_splat_resolution_level *l = &t->levels[level_index(factor)];
    if (l->factor != factor && build_level(t, factor, l) != 0) return -1;
    *out = l;
    return 0;
}

void gv_splat_resolution_levels_free(gv_splat_resolution_level *levels, int n_levels, int n_views)
{
    for (int k = 0; k < n_levels; k++) {
        for (int v = 0; levels[k].targets && v < n_views; v++) free(levels[k].targets[v]);
        free(levels[k].targets), free(levels[k].views);
        memset(&levels[k], 0, sizeof levels[k]);
    }
}
