/* Binocular3DGS's binocular consistency loss (Han, Zhou, Liu and Han, "Binocular-Guided 3D
 * Gaussian Splatting with View Consistency for Sparse View Synthesis", NeurIPS 2024; read in
 * its release, hanl2010/Binocular3DGS: train.py, utils/graphics_utils.py inverse_warp_images,
 * utils/loss_utils.py SmoothLoss, scene/__init__.py getShiftedCamera).
 *
 * With few views 3DGS can fit each training photo with a wrong geometry: the colour is right
 * from the training camera whatever the depth. A camera moved a little sideways sees the
 * same surfaces shifted by a disparity that depends on their depth only. The model renders
 * that second camera itself; warped back into the training view through the disparity of its
 * own rendered depth, it must reproduce the training photo, which holds only where the
 * rendered depth is right. The gradient reaches both the shifted render (colour and
 * geometry) and the training render's depth (rasterize_depth_backward.c).
 *
 * As the release: the shift b is uniform in [0, b_max) with a random sign, along the
 * training camera's x axis; d = -fx b / (D + 1e-5) with D the un-normalised accumulated depth
 * sum_i w_i z_i (so transparent pixels get large disparities and fall outside the image);
 * the warp samples each row linearly and marks pixels whose two samples are not both inside
 * (warped 0, mask 0); loss = mean |mask warped - mask photo| over 3 W H + 0.05 x the
 * edge-aware smoothness of mask d along the photo. The release's b_max (0.4) is in its
 * scenes' COLMAP units; here it is a share of the initial model's median view depth
 * (docs/SPLAT_TRAINING.md, "binocular"). */
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "gaussvid/core/core.h"
#include "gaussvid/splat/splat_train.h"

void gv_splat_warp_rows(const float *image, int width, int height, const float *disparity,
                        float *warped, float *valid)
{
    for (int y = 0; y < height; y++)
        for (int x = 0; x < width; x++) {
            size_t p = (size_t)y * width + x;
            float d = disparity[p];
            /* floor(x + d) and floor(x + d) + 1 in [0, width - 1]; also false for NaN */
            if (!(d >= -(float)x && d < (float)(width - 1 - x))) {
                warped[3 * p] = warped[3 * p + 1] = warped[3 * p + 2] = 0;
                valid[p] = 0;
                continue;
            }
            float x0 = floorf(d), w0 = (x0 + 1.0f) - d, w1 = d - x0;
            const float *a = image + 3 * ((size_t)y * width + x + (int)x0), *b = a + 3;
            for (int c = 0; c < 3; c++) warped[3 * p + c] = w0 * a[c] + w1 * b[c];
            valid[p] = 1;
        }
}

void gv_splat_warp_rows_backward(const float *image, int width, int height,
                                 const float *disparity, const float *d_warped, float *d_image,
                                 float *d_disparity)
{
    for (int y = 0; y < height; y++)
        for (int x = 0; x < width; x++) {
            size_t p = (size_t)y * width + x;
            float d = disparity[p];
            if (!(d >= -(float)x && d < (float)(width - 1 - x))) {
                if (d_disparity) d_disparity[p] = 0;
                continue;
            }
            float x0 = floorf(d), w0 = (x0 + 1.0f) - d, w1 = d - x0;
            size_t a = 3 * ((size_t)y * width + x + (int)x0), b = a + 3;
            float dd = 0;
            for (int c = 0; c < 3; c++) {
                float g = d_warped[3 * p + c];
                if (d_image) d_image[a + c] += w0 * g, d_image[b + c] += w1 * g;
                dd += g * (image[b + c] - image[a + c]);
            }
            if (d_disparity) d_disparity[p] = dd;
        }
}

static float sign_of(float v)
{
    return v > 0 ? 1.0f : v < 0 ? -1.0f : 0.0f; /* torch's abs: 0 at 0 */
}

double gv_splat_edge_smoothness(const float *disparity, const float *image, int width,
                                int height, float *d_disparity)
{
    if (width < 3 || height < 3) return 0;
    double n = (double)(width - 2) * (height - 2), sum = 0;
    float step = (float)(0.5 / n); /* d|w dx| / d d(x +- 1) = +- sign w / 2, over the mean */
    for (int y = 1; y < height - 1; y++)
        for (int x = 1; x < width - 1; x++) {
            size_t p = (size_t)y * width + x, right = p + 1, left = p - 1;
            size_t down = p + (size_t)width, up = p - (size_t)width;
            float gx = 0, gy = 0;
            for (int c = 0; c < 3; c++) {
                gx += 0.5f * (image[3 * right + c] - image[3 * left + c]);
                gy += 0.5f * (image[3 * down + c] - image[3 * up + c]);
            }
            float wx = expf(-GV_BINOCULAR_EDGE_DECAY * fabsf(gx));
            float wy = expf(-GV_BINOCULAR_EDGE_DECAY * fabsf(gy));
            float tx = wx * (0.5f * (disparity[right] - disparity[left]));
            float ty = wy * (0.5f * (disparity[down] - disparity[up]));
            sum += fabsf(tx) + fabsf(ty);
            if (d_disparity) {
                float sx = sign_of(tx) * wx * step, sy = sign_of(ty) * wy * step;
                d_disparity[right] += sx, d_disparity[left] -= sx;
                d_disparity[down] += sy, d_disparity[up] -= sy;
            }
        }
    return sum / n;
}

static int reserve_work(gv_splat_binocular_work *w, long pixels)
{
    if (pixels <= w->pixels) return 0;
    float **one[] = {&w->disparity, &w->valid, &w->d_disparity, &w->masked, &w->d_smooth};
    float **three[] = {&w->warped, &w->d_warped};
    for (int k = 0; k < 5; k++) {
        float *p = realloc(*one[k], (size_t)pixels * sizeof(float));
        if (!p) return gv_fail("binocular: out of memory for %ld pixels", pixels);
        *one[k] = p;
    }
    for (int k = 0; k < 2; k++) {
        float *p = realloc(*three[k], (size_t)pixels * 3 * sizeof(float));
        if (!p) return gv_fail("binocular: out of memory for %ld pixels", pixels);
        *three[k] = p;
    }
    w->pixels = pixels;
    return 0;
}

void gv_splat_binocular_work_free(gv_splat_binocular_work *w)
{
    free(w->disparity), free(w->valid), free(w->warped), free(w->d_warped);
    free(w->d_disparity), free(w->masked), free(w->d_smooth);
    memset(w, 0, sizeof *w);
}

int gv_splat_binocular_loss(gv_splat_binocular_work *w, const float *target,
                            const float *depth_sum, const float *shifted, int width, int height,
                            double fx, double baseline, double weight, float *d_shifted,
                            float *d_depth_sum, gv_splat_binocular_value *value)
{
    if (width <= 0 || height <= 0) return gv_fail("binocular: bad image size %dx%d", width, height);
    long pixels = (long)width * height;
    if (reserve_work(w, pixels) != 0) return -1;
    float numerator = (float)(fx * -baseline);
    for (long p = 0; p < pixels; p++)
        w->disparity[p] = numerator / (depth_sum[p] + GV_BINOCULAR_DEPTH_EPS);
    gv_splat_warp_rows(shifted, width, height, w->disparity, w->warped, w->valid);

    /* L1 on the valid pixels, over all 3 W H values (the release's masked mean) */
    double l1 = 0;
    int valid_pixels = 0;
    float unit = (float)(weight / (3.0 * pixels));
    for (long p = 0; p < pixels; p++) {
        valid_pixels += w->valid[p] > 0;
        for (int c = 0; c < 3; c++) {
            float diff = w->valid[p] * (w->warped[3 * p + c] - target[3 * p + c]);
            l1 += fabsf(diff);
            w->d_warped[3 * p + c] = w->valid[p] * sign_of(diff) * unit;
        }
    }
    l1 /= 3.0 * pixels;

    memset(d_shifted, 0, (size_t)pixels * 3 * sizeof(float));
    gv_splat_warp_rows_backward(shifted, width, height, w->disparity, w->d_warped, d_shifted,
                                w->d_disparity);

    /* 0.05 x the smoothness of the masked disparity (the mask passes no gradient) */
    for (long p = 0; p < pixels; p++) w->masked[p] = w->disparity[p] * w->valid[p], w->d_smooth[p] = 0;
    double smooth = gv_splat_edge_smoothness(w->masked, target, width, height, w->d_smooth);
    float smooth_scale = (float)(weight * GV_BINOCULAR_SMOOTH_WEIGHT);

    /* d = -fx b / (D + eps): dd/dD = -d / (D + eps) */
    for (long p = 0; p < pixels; p++) {
        float dd = w->d_disparity[p] + w->d_smooth[p] * smooth_scale * w->valid[p];
        d_depth_sum[p] = dd == 0 ? 0.0f : dd * -w->disparity[p] / (depth_sum[p] + GV_BINOCULAR_DEPTH_EPS);
    }
    value->l1 = l1, value->smoothness = smooth;
    value->loss = weight * (l1 + GV_BINOCULAR_SMOOTH_WEIGHT * smooth);
    value->valid_pixels = valid_pixels;
    if (!isfinite(value->loss)) return gv_fail("binocular: the loss is not finite (%g)", value->loss);
    return 0;
}

void gv_splat_view_shifted(const gv_splat_view *v, double baseline, gv_splat_view *out)
{
    *out = *v;
    out->t[0] = (float)(v->t[0] - baseline); /* x_cam = R X + t - (b, 0, 0) */
    for (int a = 0; a < 3; a++) /* the centre moves along R^T (1, 0, 0), R's first row */
        out->campos[a] = (float)(v->campos[a] + baseline * v->R[a]);
}

static int compare_float(const void *a, const void *b)
{
    float x = *(const float *)a, y = *(const float *)b;
    return x < y ? -1 : x > y;
}

double gv_splat_median_view_depth(const gv_gaussians *g, int n_views, const gv_splat_view *views)
{
    size_t cap = (size_t)(g->n > 0 ? g->n : 1) * (size_t)(n_views > 0 ? n_views : 1);
    float *z = malloc(cap * sizeof(float));
    if (!z) return -1;
    size_t count = 0;
    for (int v = 0; v < n_views; v++) {
        const gv_splat_view *w = &views[v];
        for (int i = 0; i < g->n; i++) {
            const float *m = g->means + 3 * i;
            double c[3];
            for (int a = 0; a < 3; a++)
                c[a] = w->R[3 * a] * m[0] + w->R[3 * a + 1] * m[1] + w->R[3 * a + 2] * m[2] + w->t[a];
            if (!(c[2] > GV_SPLAT_NEAR)) continue;
            double u = w->fx * c[0] / c[2] + w->cx, s = w->fy * c[1] / c[2] + w->cy;
            if (u >= 0 && u < w->width && s >= 0 && s < w->height) z[count++] = (float)c[2];
        }
    }
    double median = 0;
    if (count > 0) {
        qsort(z, count, sizeof(float), compare_float);
        median = count % 2 ? z[count / 2] : 0.5 * ((double)z[count / 2 - 1] + z[count / 2]);
    }
    free(z);
    return median;
}

/* ---- the term in a training run ------------------------------------------------------ */

static int reserve_images(gv_splat_binocular *b, long pixels)
{
    if (pixels <= b->pixels) return 0;
    float **images[] = {&b->shifted, &b->d_shifted};
    float **maps[] = {&b->depth_sum, &b->d_depth_sum};
    for (int k = 0; k < 2; k++) {
        float *p = realloc(*images[k], (size_t)pixels * 3 * sizeof(float));
        if (!p) return gv_fail("binocular: out of memory for %ld pixels", pixels);
        *images[k] = p;
        p = realloc(*maps[k], (size_t)pixels * sizeof(float));
        if (!p) return gv_fail("binocular: out of memory for %ld pixels", pixels);
        *maps[k] = p;
    }
    b->pixels = pixels;
    return 0;
}

int gv_splat_binocular_forward_backward(gv_splat_binocular *b, gv_splat_trainer *t,
                                        const gv_splat_view *view, const float bg[3],
                                        const float *opacity_scale, const float *target,
                                        double weight)
{
    long pixels = (long)view->width * view->height;
    if (reserve_images(b, pixels) != 0) return -1;
    gv_gaussians *grad = &b->grad;
    if (grad->capacity == 0 && gv_gaussians_alloc(grad, t->params.n, t->params.sh_degree) != 0) return -1;
    if (gv_gaussians_reserve(grad, t->params.capacity) != 0) return -1;
    grad->n = t->params.n;
    /* the release: trans_dist = U[0, 1) x cam_trans_dist, times -1 or 1 */
    double shift = gv_rng_uniform(&b->rng) * b->baseline;
    if (gv_rng_uniform(&b->rng) < 0.5) shift = -shift;
    gv_splat_view moved;
    gv_splat_view_shifted(view, shift, &moved);
    gv_splat_binocular_value value;
    if (gv_splat_render_depth_sum(&t->renderer, b->depth_sum) != 0 ||
        gv_splat_render_forward_scaled(&b->renderer, &t->params, &moved, t->active_degree, bg,
                                       opacity_scale, b->shifted) != 0 ||
        gv_splat_binocular_loss(&b->work, target, b->depth_sum, b->shifted, view->width,
                                view->height, view->fx, shift, weight, b->d_shifted,
                                b->d_depth_sum, &value) != 0 ||
        gv_splat_render_backward(&b->renderer, &t->params, b->d_shifted, grad, NULL) != 0)
        return gv_fail_context("binocular: shifted view (baseline %g)", shift);
    b->views++;
    b->loss_sum += value.loss, b->l1_sum += value.l1, b->smoothness_sum += value.smoothness;
    b->baseline_sum += fabs(shift);
    return 0;
}

void gv_splat_binocular_free(gv_splat_binocular *b)
{
    gv_splat_renderer_free(&b->renderer);
    gv_splat_binocular_work_free(&b->work);
    gv_gaussians_free(&b->grad);
    free(b->shifted), free(b->d_shifted), free(b->depth_sum), free(b->d_depth_sum), free(b->rows);
    memset(b, 0, sizeof *b);
}
