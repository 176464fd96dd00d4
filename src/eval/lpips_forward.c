/* LPIPS (AlexNet) forward pass, as lpips.LPIPS(net='alex', version='0.1').forward in eval
 * mode (lpips/lpips.py, lpips/pretrained_networks.py):
 *
 *   x' = (x - shift) / scale                      ScalingLayer, x in [-1, 1]
 *   relu1..relu5 = the five slices of AlexNet's features
 *   f_l = relu_l / (sqrt(sum_c relu_l^2) + 1e-10)  normalize_tensor, per pixel
 *   d = sum_l mean_{h,w} sum_c w_l[c] (f_l(a) - f_l(b))^2
 *
 * (dropout in the heads is the identity in eval mode). Convolutions are im2col + gv_gemm over
 * bands of output rows; every buffer belongs to the call, so concurrent calls on one net
 * only share the read-only weights. */
#include "gaussvid/eval/lpips.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "eval/lpips_internal.h"
#include "gaussvid/core/core.h"
#include "gaussvid/nn/ops.h"

/* normalize_tensor's eps (lpips/__init__.py). */
#define NORM_EPS 1e-10
/* Floats of the im2col buffer (16 MiB): a band of output rows is as tall as fits. */
enum { COLS_CAP = 1 << 22 };
/* Larger sides are refused so plane sizes stay far from int overflow in the GEMM. */
enum { MAX_SIDE = 1 << 16 };
/* Elements below which the memory-bound loops stay on one thread: a fork and join costs more
 * than they do (the GEMMs thread themselves). */
enum { PARALLEL_MIN = 1 << 20 };

/* Sizes of every stage for one image size. */
typedef struct {
    int width, height;
    int pool_w[GV_LPIPS_LAYERS], pool_h[GV_LPIPS_LAYERS]; /* conv input after the pool */
    int w[GV_LPIPS_LAYERS], h[GV_LPIPS_LAYERS];           /* relu_l */
    size_t feat_size[GV_LPIPS_LAYERS], feat_total, pool_max, cols;
} lpips_geometry;

static void geometry(lpips_geometry *g, int width, int height)
{
    memset(g, 0, sizeof *g);
    g->width = width, g->height = height;
    int w = width, h = height;
    for (int l = 0; l < GV_LPIPS_LAYERS; l++) {
        const gv_lpips_layer *L = &gv_lpips_layers[l];
        if (L->pool_before) { /* MaxPool2d(kernel_size=3, stride=2), floor mode */
            w = gv_lpips_out_size(w, 3, 2, 0), h = gv_lpips_out_size(h, 3, 2, 0);
            size_t pooled = (size_t)L->c_in * (size_t)w * (size_t)h;
            if (pooled > g->pool_max) g->pool_max = pooled;
        }
        g->pool_w[l] = w, g->pool_h[l] = h;
        w = gv_lpips_out_size(w, L->kernel, L->stride, L->pad);
        h = gv_lpips_out_size(h, L->kernel, L->stride, L->pad);
        g->w[l] = w, g->h[l] = h;
        g->feat_size[l] = (size_t)L->c_out * (size_t)w * (size_t)h;
        g->feat_total += g->feat_size[l];
        size_t k = (size_t)L->c_in * (size_t)(L->kernel * L->kernel);
        size_t all = k * (size_t)w * (size_t)h, one_row = k * (size_t)w;
        size_t need = all < COLS_CAP ? all : one_row > COLS_CAP ? one_row : COLS_CAP;
        if (need > g->cols) g->cols = need;
    }
}

int gv_lpips_check_size(int width, int height)
{
    if (width < GV_LPIPS_MIN_SIZE || height < GV_LPIPS_MIN_SIZE)
        return gv_fail("LPIPS: a %dx%d image is too small: AlexNet needs at least %dx%d "
                       "pixels", width, height, GV_LPIPS_MIN_SIZE, GV_LPIPS_MIN_SIZE);
    if (width > MAX_SIDE || height > MAX_SIDE)
        return gv_fail("LPIPS: a %dx%d image is too large (at most %d pixels a side)", width,
                       height, MAX_SIDE);
    return 0;
}

/* ---- layers --------------------------------------------------------------------------- */
/* 3x3 stride-2 max-pool without padding; every window lies inside the input (floor mode). */
static void max_pool(const float *in, int C, int H, int W, float *out, int Ho, int Wo)
{
#pragma omp parallel for schedule(static) if ((size_t)C * Ho * Wo > PARALLEL_MIN)
    for (int c = 0; c < C; c++) {
        const float *src = in + (size_t)c * H * W;
        float *dst = out + (size_t)c * Ho * Wo;
        for (int y = 0; y < Ho; y++)
            for (int x = 0; x < Wo; x++) {
                float m = src[(size_t)(2 * y) * W + 2 * x];
                for (int dy = 0; dy < 3; dy++)
                    for (int dx = 0; dx < 3; dx++) {
                        float v = src[(size_t)(2 * y + dy) * W + 2 * x + dx];
                        if (v > m) m = v;
                    }
                dst[(size_t)y * Wo + x] = m;
            }
    }
}

/* Columns of output rows [y0, y1): row k = (c, ky, kx) of the kernel, column (y, x) holds
 * in[c, y*s - p + ky, x*s - p + kx], zero outside (the convolution's zero padding). */
static void im2col_band(const float *in, int H, int W, const gv_lpips_layer *L, int Wo, int y0,
                        int y1, float *cols)
{
    int kk = L->kernel, K = L->c_in * kk * kk;
    size_t n = (size_t)(y1 - y0) * Wo;
#pragma omp parallel for schedule(static) if ((size_t)K * n > PARALLEL_MIN)
    for (int k = 0; k < K; k++) {
        int c = k / (kk * kk), ky = (k / kk) % kk, kx = k % kk;
        const float *src = in + (size_t)c * H * W;
        float *row = cols + (size_t)k * n;
        for (int y = y0; y < y1; y++) {
            float *dst = row + (size_t)(y - y0) * Wo;
            int iy = y * L->stride - L->pad + ky;
            for (int x = 0; x < Wo; x++) {
                int ix = x * L->stride - L->pad + kx;
                dst[x] = iy >= 0 && iy < H && ix >= 0 && ix < W ? src[(size_t)iy * W + ix] : 0.0f;
            }
        }
    }
}

/* out = ReLU(conv(in) + bias), out [C_out, Ho, Wo]; cols holds at least one output row. */
static void conv_relu(const float *in, int H, int W, const gv_lpips_layer *L, const float *w,
                      const float *bias, float *out, int Ho, int Wo, float *cols, size_t n_cols)
{
    int K = L->c_in * L->kernel * L->kernel;
    size_t rows = n_cols / ((size_t)K * Wo);
    int band = rows < 1 ? 1 : rows > (size_t)Ho ? Ho : (int)rows;
    for (int y0 = 0; y0 < Ho; y0 += band) {
        int y1 = y0 + band < Ho ? y0 + band : Ho, n = (y1 - y0) * Wo;
        im2col_band(in, H, W, L, Wo, y0, y1, cols);
        gv_gemm(L->c_out, n, K, w, K, cols, n, out + (size_t)y0 * Wo, Ho * Wo);
    }
    size_t plane = (size_t)Ho * Wo;
#pragma omp parallel for schedule(static) if ((size_t)L->c_out * plane > PARALLEL_MIN)
    for (int c = 0; c < L->c_out; c++) {
        float *o = out + (size_t)c * plane;
        for (size_t i = 0; i < plane; i++) {
            float v = o[i] + bias[c];
            o[i] = v > 0.0f ? v : 0.0f;
        }
    }
}

/* f / (||f|| + eps) at every pixel, the norm over channels (normalize_tensor, dim=1). */
static void unit_normalize(float *f, int C, size_t n, double *sum)
{
    memset(sum, 0, n * sizeof *sum);
    for (int c = 0; c < C; c++)
        for (size_t i = 0; i < n; i++) sum[i] += (double)f[(size_t)c * n + i] * f[(size_t)c * n + i];
    for (size_t i = 0; i < n; i++) sum[i] = sqrt(sum[i]) + NORM_EPS;
    for (int c = 0; c < C; c++)
        for (size_t i = 0; i < n; i++) f[(size_t)c * n + i] = (float)(f[(size_t)c * n + i] / sum[i]);
}

/* relu1..relu5 of one scaled input x [3, H, W], each unit-normalised. */
static void features(const gv_lpips *net, const lpips_geometry *g, const float *x,
                     float *feat[GV_LPIPS_LAYERS], float *pool, float *cols, double *sum)
{
    const float *in = x;
    int W = g->width, H = g->height;
    for (int l = 0; l < GV_LPIPS_LAYERS; l++) {
        const gv_lpips_layer *L = &gv_lpips_layers[l];
        if (L->pool_before) {
            max_pool(in, L->c_in, H, W, pool, g->pool_h[l], g->pool_w[l]);
            in = pool, H = g->pool_h[l], W = g->pool_w[l];
        }
        conv_relu(in, H, W, L, net->conv_weight[l], net->conv_bias[l], feat[l], g->h[l],
                  g->w[l], cols, g->cols);
        in = feat[l], H = g->h[l], W = g->w[l];
    }
    /* after the whole trunk: each relu_l is also the next slice's input */
    for (int l = 0; l < GV_LPIPS_LAYERS; l++)
        unit_normalize(feat[l], gv_lpips_layers[l].c_out, (size_t)g->w[l] * g->h[l], sum);
}

/* mean over pixels of sum_c lin[c] (fa - fb)^2 (the 1x1 head, then spatial_average). */
static double layer_distance(const float *fa, const float *fb, const float *lin, int C, size_t n)
{
    double total = 0.0;
    for (int c = 0; c < C; c++) {
        double s = 0.0;
        for (size_t i = 0; i < n; i++) {
            double d = (double)(fa[(size_t)c * n + i] - fb[(size_t)c * n + i]);
            s += d * d;
        }
        total += lin[c] * s;
    }
    return total / (double)n;
}

/* ---- the distance ----------------------------------------------------------------------- */
/* xa, xb: scaled inputs [3, H, W]. */
static int distance_scaled(const gv_lpips *net, const float *xa, const float *xb, int width,
                           int height, double per_layer[GV_LPIPS_LAYERS], double *distance)
{
    lpips_geometry g;
    geometry(&g, width, height);
    size_t sum_n = (size_t)g.w[0] * g.h[0]; /* relu1 has the most pixels */
    size_t floats = 2 * g.feat_total + g.pool_max + g.cols;
    float *buffer = malloc(floats * sizeof(float));
    double *sum = malloc(sum_n * sizeof(double));
    if (!buffer || !sum) {
        free(buffer);
        free(sum);
        return gv_fail("LPIPS: out of memory for a %dx%d image (%zu MiB)", width, height,
                       floats * sizeof(float) >> 20);
    }
    float *fa[GV_LPIPS_LAYERS], *fb[GV_LPIPS_LAYERS], *p = buffer;
    for (int l = 0; l < GV_LPIPS_LAYERS; l++) fa[l] = p, p += g.feat_size[l];
    for (int l = 0; l < GV_LPIPS_LAYERS; l++) fb[l] = p, p += g.feat_size[l];
    float *pool = p, *cols = p + g.pool_max;
    features(net, &g, xa, fa, pool, cols, sum);
    features(net, &g, xb, fb, pool, cols, sum);
    double total = 0.0;
    for (int l = 0; l < GV_LPIPS_LAYERS; l++) {
        double d = layer_distance(fa[l], fb[l], net->lin_weight[l], gv_lpips_layers[l].c_out,
                                  (size_t)g.w[l] * g.h[l]);
        if (per_layer) per_layer[l] = d;
        total += d;
    }
    *distance = total;
    free(buffer);
    free(sum);
    return 0;
}

/* x in [-1, 1] at pixel i, channel c of an HWC image -> ScalingLayer output in CHW. */
static inline float scaled(float x, int c)
{
    return (x - gv_lpips_shift[c]) / gv_lpips_scale[c];
}

int gv_lpips_distance(const gv_lpips *net, const gv_image *a, const gv_image *b,
                      double *distance)
{
    if (a->channels != 3 || b->channels != 3)
        return gv_fail("LPIPS: images must be RGB (3 channels), got %d and %d channels",
                       a->channels, b->channels);
    if (a->width != b->width || a->height != b->height)
        return gv_fail("LPIPS: images must have the same size, got %dx%d and %dx%d",
                       a->width, a->height, b->width, b->height);
    if (gv_lpips_check_size(a->width, a->height) != 0) return -1;
    size_t n = (size_t)a->width * a->height;
    float *x = malloc(2 * 3 * n * sizeof *x);
    if (!x) return gv_fail("LPIPS: out of memory for a %dx%d image", a->width, a->height);
    for (size_t i = 0; i < n; i++)
        for (int c = 0; c < 3; c++) { /* im2tensor: v / (255 / 2) - 1, in double, then float */
            x[c * n + i] = scaled((float)(a->pixels[3 * i + c] / 127.5 - 1.0), c);
            x[(3 + c) * n + i] = scaled((float)(b->pixels[3 * i + c] / 127.5 - 1.0), c);
        }
    int rc = distance_scaled(net, x, x + 3 * n, a->width, a->height, NULL, distance);
    free(x);
    return rc;
}

int gv_lpips_distance_f32(const gv_lpips *net, const float *a, const float *b, int width,
                          int height, double per_layer[GV_LPIPS_LAYERS], double *distance)
{
    if (gv_lpips_check_size(width, height) != 0) return -1;
    size_t n = (size_t)width * height;
    for (size_t i = 0; i < 3 * n; i++)
        if (!isfinite(a[i]) || !isfinite(b[i]))
            return gv_fail("LPIPS: image %s has a non-finite value at pixel (%zu, %zu)",
                           isfinite(a[i]) ? "b" : "a", i / 3 % (size_t)width,
                           i / 3 / (size_t)width);
    float *x = malloc(2 * 3 * n * sizeof *x);
    if (!x) return gv_fail("LPIPS: out of memory for a %dx%d image", width, height);
    for (size_t i = 0; i < n; i++)
        for (int c = 0; c < 3; c++) { /* LPIPS(normalize=True): 2 x - 1 */
            x[c * n + i] = scaled(2.0f * a[3 * i + c] - 1.0f, c);
            x[(3 + c) * n + i] = scaled(2.0f * b[3 * i + c] - 1.0f, c);
        }
    int rc = distance_scaled(net, x, x + 3 * n, width, height, per_layer, distance);
    free(x);
    return rc;
}
