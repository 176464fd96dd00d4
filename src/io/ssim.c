/* SSIM as the official 3DGS computes it (docs/reference/gaussian-splatting.md 19.2,
 * utils/loss_utils.py ssim) and its gradient with respect to the first image
 * (docs/reference/gaussian-splatting.md 11.1).
 *
 * The 11x11 window is the outer product g g^T of a normalised 1-D Gaussian, so the zero-
 * padded "same" 2-D convolution is a horizontal 11-tap pass followed by a vertical one, both
 * with zero padding. Five maps are filtered: a, b, a^2, b^2, ab. Per pixel
 *   S = (2 mu_a mu_b + C1)(2 s_ab + C2) / ((mu_a^2 + mu_b^2 + C1)(s_aa + s_bb + C2))
 * with population moments s_aa = w*(a^2) - mu_a^2 etc., and the result is the mean of S over
 * every pixel of every channel (borders included).
 *
 * Precision: PyTorch computes all of this in float32, where s_aa = w*(a^2) - mu_a^2 cancels
 * badly on flat regions (measured on constant images 0.125 vs 0.75: 0.19769 in float32
 * against the exact 0.19764). Here the window and the moments are in double, so the result
 * is the definition's value to ~1e-12, for about 20 % more time than float32. Row sums are
 * added in a fixed order, so the result does not depend on the thread count.
 *
 * Layout: planes[m][c][y][x] for the filtered maps; rows are processed in parallel over
 * (channel, row) pairs. */
#include "gaussvid/io/metrics.h"
#include "gaussvid/core/core.h"

#include <math.h>
#include <omp.h>
#include <stdlib.h>
#include <string.h>

#define R (GV_SSIM_WINDOW / 2) /* 5: the zero padding on each side */

void gv_ssim_window(double g[GV_SSIM_WINDOW])
{
    double sum = 0.0;
    for (int i = 0; i < GV_SSIM_WINDOW; i++) {
        double d = i - R;
        g[i] = exp(-d * d / (2.0 * GV_SSIM_SIGMA * GV_SSIM_SIGMA));
        sum += g[i];
    }
    for (int i = 0; i < GV_SSIM_WINDOW; i++) g[i] /= sum;
}

/* out[x] = sum_k g[k] padded[x + k], where padded holds the row with R zeros each side.
 * The taps are the inner loop so each output is summed in registers. */
static void filter_row(const double *restrict padded, double *restrict out, int W,
                       const double *restrict g)
{
#pragma omp simd
    for (int x = 0; x < W; x++) {
        double s = 0.0;
        for (int k = 0; k < GV_SSIM_WINDOW; k++) s += g[k] * padded[x + k];
        out[x] = s;
    }
}

/* acc[m][x] = sum_k g[k] plane_m[y + k - R][x] over the rows inside the image (rows outside
 * are the zero padding). */
static void filter_column(double *const *planes, int n_maps, size_t plane_offset, int y,
                          int H, int W, const double *restrict g, double *restrict acc)
{
    memset(acc, 0, sizeof *acc * (size_t)n_maps * W);
    for (int k = 0; k < GV_SSIM_WINDOW; k++) {
        int yy = y + k - R;
        if (yy < 0 || yy >= H) continue;
        for (int m = 0; m < n_maps; m++) {
            const double *restrict src = planes[m] + plane_offset + (size_t)yy * W;
            double *restrict dst = acc + (size_t)m * W;
            const double gk = g[k];
#pragma omp simd
            for (int x = 0; x < W; x++) dst[x] += gk * src[x];
        }
    }
}

typedef struct {
    int W, H, C;
    size_t plane;      /* W * H values: one channel of one map */
    double g[GV_SSIM_WINDOW];
    double *maps[5];   /* horizontally filtered a, b, a^2, b^2, ab: [C][H][W] each */
    double *dmaps[3];  /* dS/dmu_a, dS/dm_aa, dS/dm_ab divided by N: [C][H][W] each */
    double *scratch;   /* per thread: 5 * (W + 2R) values */
    double *row_sums;  /* C * H */
} ssim_work;

/* Horizontal pass of a, b, a^2, b^2, ab from HWC input into work->maps. */
static void ssim_horizontal(ssim_work *w, const float *a, const float *b)
{
    const int W = w->W, H = w->H, C = w->C, P = W + 2 * R;
#pragma omp parallel for schedule(static)
    for (int row = 0; row < C * H; row++) {
        int c = row / H, y = row % H;
        double *pad = w->scratch + (size_t)omp_get_thread_num() * 5 * P;
        memset(pad, 0, sizeof *pad * 5 * P);
        for (int x = 0; x < W; x++) {
            double va = a[((size_t)y * W + x) * C + c], vb = b[((size_t)y * W + x) * C + c];
            pad[R + x] = va;
            pad[P + R + x] = vb;
            pad[2 * P + R + x] = va * va;
            pad[3 * P + R + x] = vb * vb;
            pad[4 * P + R + x] = va * vb;
        }
        for (int m = 0; m < 5; m++)
            filter_row(pad + (size_t)m * P, w->maps[m] + c * w->plane + (size_t)y * W, W, w->g);
    }
}

/* Vertical pass and the SSIM map; with dmaps, also the per-pixel partial derivatives of
 * S / N with respect to mu_a, m_aa = w*(a^2) and m_ab = w*(ab)
 * (docs/reference/gaussian-splatting.md 11.1). */
static void ssim_vertical(ssim_work *w, int with_gradient)
{
    const int W = w->W, H = w->H, C = w->C;
    const double C1 = GV_SSIM_C1, C2 = GV_SSIM_C2;
    const double inv_n = 1.0 / ((double)W * H * C);
#pragma omp parallel for schedule(static)
    for (int row = 0; row < C * H; row++) {
        int c = row / H, y = row % H;
        double *acc = w->scratch + (size_t)omp_get_thread_num() * 5 * (W + 2 * R);
        filter_column(w->maps, 5, c * w->plane, y, H, W, w->g, acc);
        double sum = 0.0;
        for (int x = 0; x < W; x++) {
            double mu_a = acc[x], mu_b = acc[W + x];
            double s_aa = acc[2 * W + x] - mu_a * mu_a, s_bb = acc[3 * W + x] - mu_b * mu_b;
            double s_ab = acc[4 * W + x] - mu_a * mu_b;
            double A1 = 2 * mu_a * mu_b + C1, A2 = 2 * s_ab + C2;
            double B1 = mu_a * mu_a + mu_b * mu_b + C1, B2 = s_aa + s_bb + C2;
            double inv_D = 1.0 / (B1 * B2), S = A1 * A2 * inv_D;
            sum += S;
            if (with_gradient) { /* 1/B1 = B2/D and 1/B2 = B1/D: one division per pixel */
                size_t i = c * w->plane + (size_t)y * W + x;
                w->dmaps[0][i] = inv_n * inv_D * (2 * mu_b * (A2 - A1) +
                                                  2 * mu_a * S * (B1 - B2));
                w->dmaps[1][i] = inv_n * inv_D * (-S * B1);
                w->dmaps[2][i] = inv_n * inv_D * (2 * A1);
            }
        }
        w->row_sums[row] = sum;
    }
}

/* Adjoint of the filtering (the zero-padded symmetric window is its own adjoint), then the
 * chain rule through m_aa = w*(a^2) and m_ab = w*(ab):
 *   dS/da = G_mu + 2 a G_aa + b G_ab,  G = w * (dS/d moment). */
static void ssim_backward(ssim_work *w, const float *a, const float *b, float *grad_a)
{
    const int W = w->W, H = w->H, C = w->C, P = W + 2 * R;
#pragma omp parallel for schedule(static)
    for (int row = 0; row < C * H; row++) {
        int c = row / H, y = row % H;
        double *pad = w->scratch + (size_t)omp_get_thread_num() * 5 * P;
        for (int m = 0; m < 3; m++) {
            double *p = pad + (size_t)m * P;
            memset(p, 0, sizeof *p * R);
            memset(p + R + W, 0, sizeof *p * R);
            memcpy(p + R, w->dmaps[m] + c * w->plane + (size_t)y * W, sizeof *p * W);
            filter_row(p, w->maps[m] + c * w->plane + (size_t)y * W, W, w->g);
        }
    }
#pragma omp parallel for schedule(static)
    for (int row = 0; row < C * H; row++) {
        int c = row / H, y = row % H;
        double *acc = w->scratch + (size_t)omp_get_thread_num() * 5 * P;
        filter_column(w->maps, 3, c * w->plane, y, H, W, w->g, acc);
        for (int x = 0; x < W; x++) {
            size_t i = ((size_t)y * W + x) * C + c;
            grad_a[i] = (float)(acc[x] + 2 * a[i] * acc[W + x] + b[i] * acc[2 * W + x]);
        }
    }
}

/* One allocation for every buffer: fewer calls, and a block that glibc keeps for the next
 * call instead of returning it to the system (measured: ~300 page faults and ~1 ms less per
 * 256x144 gradient call than with separate buffers). */
static int ssim_work_alloc(ssim_work *w, int W, int H, int C, int with_gradient)
{
    memset(w, 0, sizeof *w);
    if (W < 1 || H < 1 || C < 1 || (double)W * H * C > 1e10)
        return gv_fail("ssim: invalid image size %dx%dx%d", W, H, C);
    w->W = W;
    w->H = H;
    w->C = C;
    w->plane = (size_t)W * H;
    gv_ssim_window(w->g);
    size_t map = w->plane * C, n_maps = with_gradient ? 8 : 5;
    size_t scratch = (size_t)omp_get_max_threads() * 5 * (W + 2 * R);
    double *block = malloc(sizeof(double) * (n_maps * map + scratch + (size_t)C * H));
    if (!block) return gv_fail("ssim: out of memory for %dx%dx%d", W, H, C);
    for (int m = 0; m < 5; m++) w->maps[m] = block + m * map;
    for (int m = 0; m < 3 && with_gradient; m++) w->dmaps[m] = block + (5 + m) * map;
    w->scratch = block + n_maps * map;
    w->row_sums = w->scratch + scratch;
    return 0;
}

double gv_ssim_with_gradient(const float *a, const float *b, int width, int height,
                             int channels, float *grad_a)
{
    ssim_work w;
    if (ssim_work_alloc(&w, width, height, channels, grad_a != NULL) != 0) return NAN;
    ssim_horizontal(&w, a, b);
    ssim_vertical(&w, grad_a != NULL);
    if (grad_a) ssim_backward(&w, a, b, grad_a);
    double total = 0.0;
    for (int row = 0; row < channels * height; row++) total += w.row_sums[row];
    free(w.maps[0]); /* the start of the single block */
    return total / ((double)width * height * channels);
}

double gv_ssim(const float *a, const float *b, int width, int height, int channels)
{
    return gv_ssim_with_gradient(a, b, width, height, channels, NULL);
}
