/* The official GaussVid camera code (include/gaussvid/model/plucker_official.h): the Plücker map,
 * its packing and the PluckerTokenEncoder with the release's parameter names, outside any
 * graph (a reference implementation for comparison, not a trainable module). The map is
 * computed in double from the float32 inputs (the official code runs float32), the encoder
 * in float32 with double accumulations in the convolutions and the LayerNorm. */
#include "gaussvid/model/plucker_official.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "gaussvid/core/core.h"
#include "gaussvid/nn/ops.h"

/* The inverse of a rigid or general 4x4 (row-major) by Gauss-Jordan elimination with partial
 * pivoting, as torch.inverse; -1 when singular. */
static int invert4(const double *m, double *inv)
{
    double a[4][8];
    for (int r = 0; r < 4; r++)
        for (int c = 0; c < 8; c++) a[r][c] = c < 4 ? m[r * 4 + c] : (c - 4 == r);
    for (int c = 0; c < 4; c++) {
        int p = c;
        for (int r = c + 1; r < 4; r++)
            if (fabs(a[r][c]) > fabs(a[p][c])) p = r;
        if (fabs(a[p][c]) < 1e-12) return -1;
        for (int k = 0; k < 8; k++) {
            double t = a[c][k];
            a[c][k] = a[p][k], a[p][k] = t;
        }
        double d = a[c][c];
        for (int k = 0; k < 8; k++) a[c][k] /= d;
        for (int r = 0; r < 4; r++) {
            if (r == c) continue;
            double f = a[r][c];
            for (int k = 0; k < 8; k++) a[r][k] -= f * a[c][k];
        }
    }
    for (int r = 0; r < 4; r++)
        for (int c = 0; c < 4; c++) inv[r * 4 + c] = a[r][c + 4];
    return 0;
}

int gv_official_plucker(const float *Ks, const float *c2ws, int frames, int height, int width, float *out)
{
    if (frames < 1 || height < 1 || width < 1) return gv_fail("plucker: %d frames of %dx%d", frames, width, height);
    double first[16], inv0[16];
    for (int k = 0; k < 16; k++) first[k] = c2ws[k];
    if (invert4(first, inv0)) return gv_fail("plucker: c2ws[0] is singular");
    for (int f = 0; f < frames; f++) {
        const float *K = Ks + 9 * f, *P = c2ws + 16 * f;
        double rel[16];
        for (int r = 0; r < 4; r++)
            for (int c = 0; c < 4; c++) {
                double s = 0;
                for (int k = 0; k < 4; k++) s += inv0[r * 4 + k] * P[k * 4 + c];
                rel[r * 4 + c] = f == 0 ? (r == c) : s; /* frame 0: the identity exactly */
            }
        double fx = K[0], fy = K[4], cx = K[2], cy = K[5], o[3] = {rel[3], rel[7], rel[11]};
        if (fx == 0 || fy == 0) return gv_fail("plucker: frame %d has a zero focal length", f);
        for (int j = 0; j < height; j++)
            for (int i = 0; i < width; i++) {
                double cam[3] = {(i + 0.5 - cx) / fx, (j + 0.5 - cy) / fy, 1.0};
                double n = sqrt(cam[0] * cam[0] + cam[1] * cam[1] + cam[2] * cam[2]), d[3];
                for (int r = 0; r < 3; r++) d[r] = (rel[r * 4] * cam[0] + rel[r * 4 + 1] * cam[1] + rel[r * 4 + 2] * cam[2]) / n;
                float *px = out + (((size_t)f * height + j) * width + i) * 6;
                px[0] = (float)(o[1] * d[2] - o[2] * d[1]);
                px[1] = (float)(o[2] * d[0] - o[0] * d[2]);
                px[2] = (float)(o[0] * d[1] - o[1] * d[0]);
                px[3] = (float)d[0], px[4] = (float)d[1], px[5] = (float)d[2];
            }
    }
    return 0;
}

void gv_official_pack(const float *plucker, int frames, int height, int width, float *packed)
{
    const int tp = frames + 3;
    const size_t plane = (size_t)height * width;
    for (int c = 0; c < 6; c++)
        for (int t = 0; t < tp; t++) {
            int f = t < 3 ? 0 : t - 3;
            float *dst = packed + ((size_t)c * tp + t) * plane;
            for (size_t p = 0; p < plane; p++) dst[p] = plucker[((size_t)f * plane + p) * 6 + c];
        }
}

/* ---- the encoder -------------------------------------------------------------------------- */

typedef struct {
    const gv_st_file *file;
    float *values[24];
    int n;
} weights;

/* A weight by name and shape into float32 (owned by w); NULL after a recorded failure. */
static const float *weight(weights *w, const char *name, int rank, int64_t d0, int64_t d1, int64_t d2, int64_t d3,
                           int64_t d4)
{
    const int64_t shape[5] = {d0, d1, d2, d3, d4};
    int64_t n = 1;
    for (int k = 0; k < rank; k++) n *= shape[k];
    float *x = w->n < 24 ? malloc((size_t)n * sizeof *x) : NULL;
    if (!x) {
        gv_fail("camera: out of memory for %s", name);
        return NULL;
    }
    w->values[w->n++] = x;
    return gv_st_read_f32(w->file, name, x, shape, rank) ? NULL : x;
}

/* A Conv3D with kernel = stride, no padding, on `in_ch` channels of packed starting at
 * channel c0: out [N, co] tokens in (t, h, w) order. */
static void patch_conv(const float *packed, int c0, int in_ch, int tp, int height, int width, const int k[3],
                       const float *w, const float *b, int co, float *out)
{
    const int nt = tp / k[0], nh = height / k[1], nw = width / k[2], patch = in_ch * k[0] * k[1] * k[2];
    const int64_t n = (int64_t)nt * nh * nw;
#pragma omp parallel for schedule(static)
    for (int64_t tok = 0; tok < n; tok++) {
        int t = (int)(tok / ((int64_t)nh * nw)), y = (int)(tok / nw % nh), x = (int)(tok % nw);
        float *dst = out + tok * co;
        for (int o = 0; o < co; o++) {
            double s = b[o];
            const float *wo = w + (int64_t)o * patch;
            for (int ic = 0; ic < in_ch; ic++)
                for (int dt = 0; dt < k[0]; dt++)
                    for (int dy = 0; dy < k[1]; dy++) {
                        const float *src = packed + ((((int64_t)(c0 + ic) * tp + t * k[0] + dt) * height + y * k[1] + dy) * width +
                                                     (int64_t)x * k[2]);
                        const float *wr = wo + ((ic * k[0] + dt) * k[1] + dy) * k[2];
                        for (int dx = 0; dx < k[2]; dx++) s += (double)wr[dx] * src[dx];
                    }
            dst[o] = (float)s;
        }
    }
}

/* y [n, out] = x [n, in] W^T + b; act 1: SiLU after. */
static void linear(const float *x, int64_t n, int in, const float *w, const float *b, int out, int silu, float *y)
{
    gv_gemm_nt((int)n, out, in, x, in, w, in, y, out);
    for (int64_t r = 0; r < n; r++)
        for (int o = 0; o < out; o++) {
            float v = y[r * out + o] + b[o];
            y[r * out + o] = silu ? v / (1.0f + expf(-v)) : v;
        }
}

/* gate = sigmoid(L2(SiLU(L1(src)))); dst = feat * gate, row by row into dst at stride `ld`. */
static int gated(const float *src, const float *feat, int64_t n, int h, int bott, const float *w0, const float *b0,
                 const float *w2, const float *b2, float *dst, int ld)
{
    float *mid = malloc((size_t)n * bott * sizeof *mid), *g = malloc((size_t)n * h * sizeof *g);
    if (!mid || !g) {
        free(mid), free(g);
        return gv_fail("camera: out of memory");
    }
    linear(src, n, h, w0, b0, bott, 1, mid);
    linear(mid, n, bott, w2, b2, h, 0, g);
    for (int64_t r = 0; r < n; r++)
        for (int c = 0; c < h; c++) dst[r * ld + c] = feat[r * h + c] / (1.0f + expf(-g[r * h + c]));
    free(mid), free(g);
    return 0;
}

/* LayerNorm over D (eps 1e-5, affine), then the scale, in place. */
static void norm_scale(float *y, int64_t n, int D, const float *gain, const float *bias, float scale)
{
    for (int64_t r = 0; r < n; r++) {
        float *row = y + r * D;
        double mean = 0, var = 0;
        for (int c = 0; c < D; c++) mean += row[c];
        mean /= D;
        for (int c = 0; c < D; c++) var += (row[c] - mean) * (row[c] - mean);
        double inv = 1.0 / sqrt(var / D + 1e-5);
        for (int c = 0; c < D; c++) row[c] = (float)(((row[c] - mean) * inv * gain[c] + bias[c]) * scale);
    }
}

int gv_official_camera_encode(const gv_model_config *c, const gv_st_file *file, const float *packed, int tp, int height,
                              int width, float *tokens)
{
    int k[3];
    gv_model_camera_kernel(c, k);
    const int h = c->camera.channels, bott = c->camera.gate_hidden, D = c->dit.dim;
    if (c->camera.proj_hidden != D)
        return gv_fail("camera: the official out_proj is %d -> %d -> %d, so camera.proj_hidden must be dit.dim (%d), not %d",
                       2 * h, D, D, D, c->camera.proj_hidden);
    if (tp < k[0] || tp % k[0] || height % k[1] || width % k[2] || height < k[1] || width < k[2])
        return gv_fail("camera: a packed field of %d frames of %dx%d is not a whole number of %dx%dx%d patches", tp, width,
                       height, k[0], k[2], k[1]);
    const int64_t n = (int64_t)(tp / k[0]) * (height / k[1]) * (width / k[2]);
    weights w = {file, {0}, 0};
    const float *mw = weight(&w, "dxo_patch_embed.weight", 5, h, 3, k[0], k[1], k[2]);
    const float *mb = mw ? weight(&w, "dxo_patch_embed.bias", 1, h, 0, 0, 0, 0) : NULL;
    const float *dw = mb ? weight(&w, "d_patch_embed.weight", 5, h, 3, k[0], k[1], k[2]) : NULL;
    const float *db = dw ? weight(&w, "d_patch_embed.bias", 1, h, 0, 0, 0, 0) : NULL;
    const float *g0[2] = {0}, *gb0[2] = {0}, *g2[2] = {0}, *gb2[2] = {0};
    const char *gates[2] = {"gate_dxo_from_d", "gate_d_from_dxo"};
    int ok = db != NULL;
    for (int s = 0; ok && s < 2; s++) {
        char name[64];
        snprintf(name, sizeof name, "%s.0.weight", gates[s]), ok = (g0[s] = weight(&w, name, 2, bott, h, 0, 0, 0)) != NULL;
        snprintf(name, sizeof name, "%s.0.bias", gates[s]), ok = ok && (gb0[s] = weight(&w, name, 1, bott, 0, 0, 0, 0));
        snprintf(name, sizeof name, "%s.2.weight", gates[s]), ok = ok && (g2[s] = weight(&w, name, 2, h, bott, 0, 0, 0));
        snprintf(name, sizeof name, "%s.2.bias", gates[s]), ok = ok && (gb2[s] = weight(&w, name, 1, h, 0, 0, 0, 0));
    }
    const float *p0 = ok ? weight(&w, "out_proj.0.weight", 2, D, 2 * h, 0, 0, 0) : NULL;
    const float *pb0 = p0 ? weight(&w, "out_proj.0.bias", 1, D, 0, 0, 0, 0) : NULL;
    const float *p2 = pb0 ? weight(&w, "out_proj.2.weight", 2, D, D, 0, 0, 0) : NULL;
    const float *pb2 = p2 ? weight(&w, "out_proj.2.bias", 1, D, 0, 0, 0, 0) : NULL;
    const float *ng = pb2 ? weight(&w, "out_norm.weight", 1, D, 0, 0, 0, 0) : NULL;
    const float *nb = ng ? weight(&w, "out_norm.bias", 1, D, 0, 0, 0, 0) : NULL;
    const float *scale = nb ? weight(&w, "scale", 1, 1, 0, 0, 0, 0) : NULL;
    float *fm = scale ? malloc((size_t)n * h * sizeof *fm) : NULL, *fd = fm ? malloc((size_t)n * h * sizeof *fd) : NULL;
    float *fu = fd ? malloc((size_t)n * 2 * h * sizeof *fu) : NULL, *mid = fu ? malloc((size_t)n * D * sizeof *mid) : NULL;
    int rc = mid ? 0 : scale ? gv_fail("camera: out of memory for %lld tokens", (long long)n) : -1;
    if (rc == 0) {
        patch_conv(packed, 0, 3, tp, height, width, k, mw, mb, h, fm);
        patch_conv(packed, 3, 3, tp, height, width, k, dw, db, h, fd);
        /* both gates read the un-gated features */
        rc = gated(fd, fm, n, h, bott, g0[0], gb0[0], g2[0], gb2[0], fu, 2 * h);
        if (rc == 0) rc = gated(fm, fd, n, h, bott, g0[1], gb0[1], g2[1], gb2[1], fu + h, 2 * h);
    }
    if (rc == 0) {
        linear(fu, n, 2 * h, p0, pb0, D, 1, mid);
        linear(mid, n, D, p2, pb2, D, 0, tokens);
        norm_scale(tokens, n, D, ng, nb, scale[0]);
    }
    free(fm), free(fd), free(fu), free(mid);
    for (int i = 0; i < w.n; i++) free(w.values[i]);
    return rc;
}
