/* The 3DGS training loss and its gradient (docs/reference/gaussian-splatting.md sections 11, 11.1
 * and 19.2; 3DGS train.py, utils/loss_utils.py): L = (1 - lambda) L1 + lambda (1 - SSIM) of a
 * render against its target, in float32 as the reference computes it. SSIM: 11-tap Gaussian window
 * (sigma 1.5) applied separably, zero "same" padding, C1 = 0.01^2, C2 = 0.03^2, mean over every
 * value; L1 is the mean absolute difference and its gradient uses sign(0) = 0 (autograd).
 *
 * Images are HWC with 3 channels. A row of an image is a line of 3W floats in which the
 * horizontal neighbours of a value are 3 floats apart, so both passes of the separable
 * window run along whole lines, every channel at once, and vectorise.
 *
 * Precision: the variances are differences of nearly equal sums (sigma_aa = w*(a^2) -
 * mu_a^2), and float32 leaves ~5e-8 of them on flat areas (5e-5 of C2), as in the reference.
 * The moments are taken of the values minus 1/2 (a' = a - 1/2), which halves the magnitudes
 * for values spread over [0, 1]; measured against double precision: SSIM within 2e-7 on
 * textured images, 2e-6 on flat ones. The zero padding is of the images themselves, so
 * where the window's mass M inside the image is below 1 (the 5 rows and columns at the
 * borders) the moments are corrected exactly: with u = w*a', v = w*b', p = w*(a'^2),
 * r = w*(b'^2), q = w*(a'b'),
 *   mu_a = u + M/2,  sigma_aa = p - u^2 + (1 - M)(u + M/4),
 *   sigma_ab = q - u v + (1 - M)(u + v + M/2)/2      (M = 1: the plain centred moments).
 * The gradient goes through the same variables (the symmetric window is its own adjoint):
 *   dL/da = w*(g dS/du) + 2 a' w*(g dS/dp) + b' w*(g dS/dq) + (1 - lambda) sign(a - b) / N,
 * with g = dL/dS = -lambda / N. Sums over rows are kept per row and added in order, so the
 * result does not depend on the number of threads. */
#include <math.h>
#include <omp.h>
#include <stdlib.h>
#include <string.h>

#include "gaussvid/core/core.h"
#include "gaussvid/io/metrics.h"
#include "gaussvid/splat/splat_train.h"
#include "splat/clones.h"

#define TAPS GV_SSIM_WINDOW  /* 11 */
#define HALF (TAPS / 2)      /* 5 */
#define STRIDE 3             /* channels: horizontal neighbours are 3 floats apart */
#define PAD (STRIDE * HALF)  /* 15 zeros on each side of a padded line */

/* Maps of the work area, each height lines of 3W floats. The first three are reused for
 * the horizontally filtered gradient terms once the moments have been used. */
enum { MAP_U, MAP_V, MAP_P, MAP_R, MAP_Q, MAP_DU, MAP_DP, MAP_DQ, N_MAPS };
enum { N_MOMENTS = 5, SCRATCH_LINES = 6 };

int gv_splat_loss_reserve(gv_splat_loss_work *w, int width, int height)
{
    if (width < 1 || height < 1 || (double)width * height > 1e9)
        return gv_fail("loss: invalid image size %dx%d", width, height);
    int threads = omp_get_max_threads();
    if (width == w->width && height == w->height && threads <= w->threads) return 0;
    gv_splat_loss_free(w);
    size_t line = (size_t)STRIDE * width;
    w->maps = malloc(sizeof(float) * N_MAPS * line * height);
    w->scratch = malloc(sizeof(float) * (size_t)threads * SCRATCH_LINES * (line + 2 * PAD));
    w->mass_x = malloc(sizeof(float) * line);
    w->mass_y = malloc(sizeof(float) * height);
    w->zeros = calloc(line, sizeof(float));
    w->row_sums = malloc(sizeof(double) * 2 * height);
    if (!w->maps || !w->scratch || !w->mass_x || !w->mass_y || !w->zeros || !w->row_sums) {
        gv_splat_loss_free(w);
        return gv_fail("loss: out of memory for a %dx%d image", width, height);
    }
    w->width = width, w->height = height, w->threads = threads;
    double g[TAPS];
    gv_ssim_window(g);
    for (int k = 0; k < TAPS; k++) w->g[k] = (float)g[k], g[k] = w->g[k];
    /* The window's mass inside the image, M(x, y) = mass_x(x) mass_y(y), of the float taps
     * actually used (they sum to 1 only up to rounding; this mass keeps constant images at
     * zero variance). */
    for (int x = 0; x < width; x++) {
        double m = 0;
        for (int k = 0; k < TAPS; k++) m += x + k - HALF >= 0 && x + k - HALF < width ? g[k] : 0;
        for (int c = 0; c < STRIDE; c++) w->mass_x[STRIDE * x + c] = (float)m;
    }
    for (int y = 0; y < height; y++) {
        double m = 0;
        for (int k = 0; k < TAPS; k++) m += y + k - HALF >= 0 && y + k - HALF < height ? g[k] : 0;
        w->mass_y[y] = (float)m;
    }
    return 0;
}

void gv_splat_loss_free(gv_splat_loss_work *w)
{
    free(w->maps), free(w->scratch), free(w->mass_x), free(w->mass_y), free(w->zeros);
    free(w->row_sums);
    memset(w, 0, sizeof *w);
}

static size_t line_of(const gv_splat_loss_work *w)
{
    return (size_t)STRIDE * w->width;
}

static float *map_line(const gv_splat_loss_work *w, int map, int y)
{
    return w->maps + ((size_t)map * w->height + y) * line_of(w);
}

/* This thread's scratch: SCRATCH_LINES padded lines. */
static float *scratch_of(const gv_splat_loss_work *w)
{
    return w->scratch + (size_t)omp_get_thread_num() * SCRATCH_LINES * (line_of(w) + 2 * PAD);
}

/* out[i] = sum_k g[k] in[i + 3 (k - 5)] for a line of n values; in[-15 .. n + 15) holds
 * zeros outside [0, n). */
static SIMD8_CLONES void filter_line(const float *restrict in, float *restrict out, size_t n,
                                     const float *g)
{
    const float g0 = g[0], g1 = g[1], g2 = g[2], g3 = g[3], g4 = g[4], g5 = g[5];
    const float g6 = g[6], g7 = g[7], g8 = g[8], g9 = g[9], g10 = g[10];
    const float *restrict p = in - PAD;
#pragma omp simd
    for (size_t i = 0; i < n; i++)
        out[i] = g0 * p[i] + g1 * p[i + 3] + g2 * p[i + 6] + g3 * p[i + 9] + g4 * p[i + 12] +
                 g5 * p[i + 15] + g6 * p[i + 18] + g7 * p[i + 21] + g8 * p[i + 24] +
                 g9 * p[i + 27] + g10 * p[i + 30];
}

/* acc[m][i] = sum_k g[k] map_(first + m)[y + k - 5][i], rows outside the image being zero:
 * the eleven rows are summed in registers, left to right, one store per value. */
static SIMD8_CLONES void filter_column(const gv_splat_loss_work *w, int first, int n_maps,
                                       int y, float *restrict acc)
{
    size_t n = line_of(w);
    const float g0 = w->g[0], g1 = w->g[1], g2 = w->g[2], g3 = w->g[3], g4 = w->g[4];
    const float g5 = w->g[5], g6 = w->g[6], g7 = w->g[7], g8 = w->g[8], g9 = w->g[9];
    const float g10 = w->g[10];
    for (int m = 0; m < n_maps; m++) {
        const float *rows[TAPS];
        for (int k = 0; k < TAPS; k++) {
            int yy = y + k - HALF;
            rows[k] = yy >= 0 && yy < w->height ? map_line(w, first + m, yy) : w->zeros;
        }
        const float *restrict r0 = rows[0], *restrict r1 = rows[1], *restrict r2 = rows[2];
        const float *restrict r3 = rows[3], *restrict r4 = rows[4], *restrict r5 = rows[5];
        const float *restrict r6 = rows[6], *restrict r7 = rows[7], *restrict r8 = rows[8];
        const float *restrict r9 = rows[9], *restrict r10 = rows[10];
        float *restrict dst = acc + m * n;
#pragma omp simd
        for (size_t i = 0; i < n; i++)
            dst[i] = g0 * r0[i] + g1 * r1[i] + g2 * r2[i] + g3 * r3[i] + g4 * r4[i] + g5 * r5[i] +
                     g6 * r6[i] + g7 * r7[i] + g8 * r8[i] + g9 * r9[i] + g10 * r10[i];
    }
}

/* Pass 1: the horizontally filtered moments of line y. */
static SIMD8_CLONES void moments_line(const gv_splat_loss_work *w, const float *a,
                                      const float *b, int y)
{
    size_t n = line_of(w), padded = n + 2 * PAD;
    float *pad = scratch_of(w);
    for (int m = 0; m < N_MOMENTS; m++) {
        memset(pad + m * padded, 0, sizeof(float) * PAD);
        memset(pad + m * padded + PAD + n, 0, sizeof(float) * PAD);
    }
    const float *restrict ra = a + y * n, *restrict rb = b + y * n;
    float *restrict u = pad + PAD, *restrict v = u + padded, *restrict p = v + padded;
    float *restrict r = p + padded, *restrict q = r + padded;
#pragma omp simd
    for (size_t i = 0; i < n; i++) {
        float ai = ra[i] - 0.5f, bi = rb[i] - 0.5f;
        u[i] = ai, v[i] = bi, p[i] = ai * ai, r[i] = bi * bi, q[i] = ai * bi;
    }
    for (int m = 0; m < N_MOMENTS; m++)
        filter_line(pad + m * padded + PAD, map_line(w, MAP_U + m, y), n, w->g);
}

/* Pass 2: vertical filter of line y, its SSIM values (summed into row_sums) and the
 * gradient terms g dS/du, g dS/dp, g dS/dq. */
static SIMD8_CLONES void ssim_line(gv_splat_loss_work *w, int y, float g)
{
    size_t n = line_of(w);
    float *acc = scratch_of(w), *ssim = acc + N_MOMENTS * n;
    filter_column(w, MAP_U, N_MOMENTS, y, acc);
    const float *restrict u = acc, *restrict v = u + n, *restrict p = v + n;
    const float *restrict r = p + n, *restrict q = r + n;
    float *restrict du = map_line(w, MAP_DU, y), *restrict dp = map_line(w, MAP_DP, y);
    float *restrict dq = map_line(w, MAP_DQ, y);
    const float *restrict mass_x = w->mass_x;
    const float C1 = (float)GV_SSIM_C1, C2 = (float)GV_SSIM_C2, my = w->mass_y[y];
#pragma omp simd
    for (size_t i = 0; i < n; i++) {
        float M = mass_x[i] * my, out = 1.0f - M;
        float mu_a = u[i] + 0.5f * M, mu_b = v[i] + 0.5f * M;
        float s_aa = p[i] - u[i] * u[i] + out * (u[i] + 0.25f * M);
        float s_bb = r[i] - v[i] * v[i] + out * (v[i] + 0.25f * M);
        float s_ab = q[i] - u[i] * v[i] + 0.5f * out * (u[i] + v[i] + 0.5f * M);
        float A1 = 2 * mu_a * mu_b + C1, A2 = 2 * s_ab + C2;
        float B1 = mu_a * mu_a + mu_b * mu_b + C1, B2 = s_aa + s_bb + C2;
        float inv_D = 1.0f / (B1 * B2), S = A1 * A2 * inv_D;
        /* partial derivatives of S in mu_a, sigma_aa, sigma_ab (1/B1 = B2/D, 1/B2 = B1/D) */
        float d_mu = 2 * (mu_b * A2 - mu_a * S * B2) * inv_D;
        float d_aa = -S * B1 * inv_D, d_ab = 2 * A1 * inv_D;
        du[i] = g * (d_mu + d_aa * (out - 2 * u[i]) + d_ab * (0.5f * out - v[i]));
        dp[i] = g * d_aa;
        dq[i] = g * d_ab;
        ssim[i] = S;
    }
    double sum = 0;
    for (size_t i = 0; i < n; i++) sum += ssim[i];
    w->row_sums[2 * y] = sum;
}

/* Pass 3: horizontal filter of the gradient terms of line y, into the first three maps. */
static SIMD8_CLONES void gradient_line(const gv_splat_loss_work *w, int y)
{
    size_t n = line_of(w), padded = n + 2 * PAD;
    float *pad = scratch_of(w);
    for (int m = 0; m < 3; m++) {
        float *l = pad + m * padded;
        memset(l, 0, sizeof(float) * PAD);
        memcpy(l + PAD, map_line(w, MAP_DU + m, y), sizeof(float) * n);
        memset(l + PAD + n, 0, sizeof(float) * PAD);
        filter_line(l + PAD, map_line(w, MAP_U + m, y), n, w->g);
    }
}

/* Pass 4: vertical filter of the gradient terms and dL/drender of line y; L1 into
 * row_sums. */
static SIMD8_CLONES void output_line(gv_splat_loss_work *w, const float *a, const float *b,
                                     int y, float w_l1, float *d_render)
{
    size_t n = line_of(w);
    float *acc = scratch_of(w);
    filter_column(w, MAP_U, 3, y, acc);
    const float *restrict gu = acc, *restrict gp = gu + n, *restrict gq = gp + n;
    const float *restrict ra = a + y * n, *restrict rb = b + y * n;
    float *restrict out = d_render + y * n;
#pragma omp simd
    for (size_t i = 0; i < n; i++) {
        float ai = ra[i] - 0.5f, bi = rb[i] - 0.5f, d = ra[i] - rb[i];
        float sign = d > 0 ? 1.0f : d < 0 ? -1.0f : 0.0f;
        out[i] = w_l1 * sign + gu[i] + 2 * ai * gp[i] + bi * gq[i];
    }
    double l1 = 0;
    for (size_t i = 0; i < n; i++) l1 += fabsf(ra[i] - rb[i]);
    w->row_sums[2 * y + 1] = l1;
}

int gv_splat_loss(gv_splat_loss_work *w, const float *render, const float *target, int width,
                  int height, double lambda, float *d_render, gv_splat_loss_value *value)
{
    if (gv_splat_loss_reserve(w, width, height) != 0) return -1;
    double count = 3.0 * width * height;
    float g = (float)(-lambda / count), w_l1 = (float)((1.0 - lambda) / count);
#pragma omp parallel
    {
#pragma omp for schedule(static)
        for (int y = 0; y < height; y++) moments_line(w, render, target, y);
#pragma omp for schedule(static)
        for (int y = 0; y < height; y++) ssim_line(w, y, g);
        if (d_render) {
#pragma omp for schedule(static)
            for (int y = 0; y < height; y++) gradient_line(w, y);
#pragma omp for schedule(static)
            for (int y = 0; y < height; y++) output_line(w, render, target, y, w_l1, d_render);
        }
    }
    double ssim = 0, l1 = 0;
    for (int y = 0; y < height; y++) ssim += w->row_sums[2 * y];
    if (d_render)
        for (int y = 0; y < height; y++) l1 += w->row_sums[2 * y + 1];
    else
        for (int i = 0; i < 3 * width * height; i++) l1 += fabsf(render[i] - target[i]);
    value->ssim = ssim / count, value->l1 = l1 / count;
    value->loss = (1.0 - lambda) * value->l1 + lambda * (1.0 - value->ssim);
    if (!isfinite(value->loss))
        return gv_fail("loss: not finite (%g): the render holds NaN or infinity", value->loss);
    return 0;
}
