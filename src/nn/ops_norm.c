/* Normalisations: LayerNorm over the last axis (with or without affine) and RMSNorm over any
 * axis (Wan DiT's q/k norm with eps inside the root; Wan VAE's RMS_norm with a floor on the
 * norm). Weight gradients are summed per fixed chunk of rows and the chunks added in order,
 * so they do not depend on the thread count. */
#include "nn/nn_internal.h"

#define ROWS_PER_CHUNK 32

/* Adds the per-chunk partial sums part[n_chunks][n] into dst in chunk order. */
static void add_partials(float *dst, const float *part, int64_t n_chunks, int64_t n)
{
#pragma omp parallel for schedule(static) if (n * n_chunks >= GV_OMP_MIN)
    for (int64_t j = 0; j < n; j++) {
        double s = 0;
        for (int64_t c = 0; c < n_chunks; c++) s += part[c * n + j];
        dst[j] += (float)s;
    }
}

/* ---- LayerNorm ----------------------------------------------------------------------------
 * y [R, D] = (x - mean) * rstd * w + b; x [R, D]; src = {x, w if any, b if any} with w, b
 * [D]; iparam = {has_w, has_b}; fparam[0] = eps; saved = {mean[R], rstd[R]} */
int gv_layer_norm_op_forward(gv_graph *g, gv_tensor *out)
{
    const gv_tensor *x = out->src[0];
    int has_w = out->iparam[0], has_b = out->iparam[1];
    const float *w = has_w ? out->src[1]->data : NULL;
    const float *b = has_b ? out->src[1 + has_w]->data : NULL;
    int64_t D = gv_dim(x, -1), R = x->numel / D;
    float *saved = out->saved = gv_scratch(g, 2 * R);
    if (!saved) return -1;
    float eps = out->fparam[0];
#pragma omp parallel for schedule(static) if (R * D >= GV_OMP_MIN)
    for (int64_t r = 0; r < R; r++) {
        const float *xr = x->data + r * D;
        double s = 0, ss = 0;
#pragma omp simd reduction(+ : s)
        for (int64_t i = 0; i < D; i++) s += xr[i];
        double mean = s / D;
#pragma omp simd reduction(+ : ss)
        for (int64_t i = 0; i < D; i++) ss += (xr[i] - mean) * (xr[i] - mean);
        float m = (float)mean, rstd = (float)(1.0 / sqrt(ss / D + eps));
        float *y = out->data + r * D;
#pragma omp simd
        for (int64_t i = 0; i < D; i++) y[i] = (xr[i] - m) * rstd * (w ? w[i] : 1.0f) + (b ? b[i] : 0.0f);
        saved[r] = m;
        saved[R + r] = rstd;
    }
    return 0;
}

/* dx = rstd (dn - mean(dn) - n mean(dn n)) with dn = dy w; dw += sum dy n; db += sum dy. */
int gv_layer_norm_op_backward(gv_graph *g, gv_tensor *out)
{
    gv_tensor *x = out->src[0];
    int has_w = out->iparam[0], has_b = out->iparam[1];
    gv_tensor *wt = has_w ? out->src[1] : NULL, *bt = has_b ? out->src[1 + has_w] : NULL;
    int want_x = gv_wants_grad(out, 0), want_w = wt && wt->requires_grad && wt->grad;
    int want_b = bt && bt->requires_grad && bt->grad;
    int64_t D = gv_dim(x, -1), R = x->numel / D, n_chunks = (R + ROWS_PER_CHUNK - 1) / ROWS_PER_CHUNK;
    const float *mean = out->saved, *rstd = (const float *)out->saved + R;
    float *pw = NULL, *pb = NULL;
    if (want_w && !(pw = gv_scratch(g, n_chunks * D))) return -1;
    if (want_b && !(pb = gv_scratch(g, n_chunks * D))) return -1;
#pragma omp parallel for schedule(static) if (R * D >= GV_OMP_MIN)
    for (int64_t c = 0; c < n_chunks; c++) {
        if (pw) memset(pw + c * D, 0, (size_t)D * sizeof(float));
        if (pb) memset(pb + c * D, 0, (size_t)D * sizeof(float));
        int64_t end = (c + 1) * ROWS_PER_CHUNK < R ? (c + 1) * ROWS_PER_CHUNK : R;
        for (int64_t r = c * ROWS_PER_CHUNK; r < end; r++) {
            const float *xr = x->data + r * D, *dy = out->grad + r * D, *w = wt ? wt->data : NULL;
            float m = mean[r], rs = rstd[r];
            if (pw) {
                float *p = pw + c * D;
#pragma omp simd
                for (int64_t i = 0; i < D; i++) p[i] += dy[i] * (xr[i] - m) * rs;
            }
            if (pb) {
                float *p = pb + c * D;
#pragma omp simd
                for (int64_t i = 0; i < D; i++) p[i] += dy[i];
            }
            if (!want_x) continue;
            double sum_dn = 0, sum_dn_n = 0;
#pragma omp simd reduction(+ : sum_dn, sum_dn_n)
            for (int64_t i = 0; i < D; i++) {
                float n = (xr[i] - m) * rs, dn = dy[i] * (w ? w[i] : 1.0f);
                sum_dn += dn;
                sum_dn_n += dn * n;
            }
            float mean_dn = (float)(sum_dn / D), mean_dn_n = (float)(sum_dn_n / D);
            float *dx = x->grad + r * D;
#pragma omp simd
            for (int64_t i = 0; i < D; i++) {
                float n = (xr[i] - m) * rs, dn = dy[i] * (w ? w[i] : 1.0f);
                dx[i] += rs * (dn - mean_dn - n * mean_dn_n);
            }
        }
    }
    if (pw) add_partials(wt->grad, pw, n_chunks, D);
    if (pb) add_partials(bt->grad, pb, n_chunks, D);
    return 0;
}

gv_tensor *gv_layer_norm(gv_graph *g, gv_tensor *x, gv_tensor *w, gv_tensor *b, float eps)
{
    if (!x) return NULL;
    int D = gv_dim(x, -1);
    gv_tensor *affine[2] = {w, b};
    for (int i = 0; i < 2; i++) {
        if (affine[i] && affine[i]->numel != D) {
            char buf[64];
            gv_fail("layer_norm: %s %s does not match the last axis %d", i ? "bias" : "weight",
                    gv_shape_str(affine[i], buf, sizeof buf), D);
            return NULL;
        }
    }
    gv_tensor *src[3] = {x};
    int n = 1;
    if (w) src[n++] = w;
    if (b) src[n++] = b;
    gv_tensor *out = gv_op_new(g, GV_OP_LAYER_NORM, x->ndim, x->shape, n, src, 0);
    if (!out) return NULL;
    out->iparam[0] = w != NULL;
    out->iparam[1] = b != NULL;
    out->fparam[0] = eps;
    return gv_op_run(g, out);
}

/* ---- RMSNorm over an axis -------------------------------------------------------------------
 * x viewed as [outer, C, inner]; for each position (o, i): r = max(sqrt(mean_c x^2 + eps),
 * floor), y = x / r * w[c]. iparam = {axis, has_w}; fparam = {eps, floor}; saved = r per
 * position. Positions are processed in tiles of up to TILE consecutive i, so that the loops
 * over c read contiguous memory whether the axis is last (inner = 1) or first. */
#define TILE 64

typedef struct {
    int64_t outer, C, inner, tiles_per_outer, n_tiles;
} rms_dims;

static rms_dims rms_layout(const gv_tensor *x, int axis)
{
    rms_dims d = {1, x->shape[axis], 1, 0, 0};
    for (int k = 0; k < axis; k++) d.outer *= x->shape[k];
    for (int k = axis + 1; k < x->ndim; k++) d.inner *= x->shape[k];
    d.tiles_per_outer = (d.inner + TILE - 1) / TILE;
    d.n_tiles = d.outer * d.tiles_per_outer;
    return d;
}

/* One position whose C values are contiguous (the axis is the last one). */
static float rms_row_forward(const float *x, const float *w, float *y, int64_t C, float eps,
                             float floor_r)
{
    double ms = 0;
#pragma omp simd reduction(+ : ms)
    for (int64_t c = 0; c < C; c++) ms += (double)x[c] * x[c];
    float r = (float)sqrt(ms / C + eps);
    r = r > floor_r ? r : floor_r;
    float inv = 1.0f / r;
#pragma omp simd
    for (int64_t c = 0; c < C; c++) y[c] = x[c] * inv * (w ? w[c] : 1.0f);
    return r;
}

int gv_rms_norm_op_forward(gv_graph *g, gv_tensor *out)
{
    const gv_tensor *x = out->src[0];
    const float *w = out->iparam[1] ? out->src[1]->data : NULL;
    rms_dims d = rms_layout(x, out->iparam[0]);
    float eps = out->fparam[0], floor_r = out->fparam[1];
    float *r_saved = out->saved = gv_scratch(g, d.outer * d.inner);
    if (!r_saved) return -1;
    if (d.inner == 1) {
#pragma omp parallel for schedule(static) if (d.outer * d.C >= GV_OMP_MIN)
        for (int64_t o = 0; o < d.outer; o++)
            r_saved[o] = rms_row_forward(x->data + o * d.C, w, out->data + o * d.C, d.C, eps, floor_r);
        return 0;
    }
#pragma omp parallel for schedule(static) if (d.outer * d.C * d.inner >= GV_OMP_MIN)
    for (int64_t t = 0; t < d.n_tiles; t++) {
        int64_t o = t / d.tiles_per_outer, i0 = t % d.tiles_per_outer * TILE;
        int64_t n = d.inner - i0 < TILE ? d.inner - i0 : TILE;
        const float *xo = x->data + o * d.C * d.inner + i0;
        float *yo = out->data + o * d.C * d.inner + i0;
        double ms[TILE] = {0};
        for (int64_t c = 0; c < d.C; c++)
#pragma omp simd
            for (int64_t k = 0; k < n; k++) ms[k] += (double)xo[c * d.inner + k] * xo[c * d.inner + k];
        float inv[TILE];
        for (int64_t k = 0; k < n; k++) {
            float r = (float)sqrt(ms[k] / d.C + eps);
            r = r > floor_r ? r : floor_r;
            r_saved[o * d.inner + i0 + k] = r;
            inv[k] = 1.0f / r;
        }
        for (int64_t c = 0; c < d.C; c++) {
            float wc = w ? w[c] : 1.0f;
#pragma omp simd
            for (int64_t k = 0; k < n; k++) yo[c * d.inner + k] = xo[c * d.inner + k] * inv[k] * wc;
        }
    }
    return 0;
}

/* dx_c = (w_c dy_c - x_c s / (C r^2)) / r with s = sum_c dy_c w_c x_c (the second term
 * vanishes where r was clamped to the floor); dw_c += sum over positions dy_c x_c / r.
 * n positions (n = 1 for a contiguous row) with their C values at stride `stride`. */
static void rms_backward_positions(const float *x, const float *dy, const float *w, const float *r,
                                   float *dx, float *pw, int64_t C, int64_t stride, int64_t n,
                                   float floor_r)
{
    double s[TILE] = {0};
    float inv[TILE], coef[TILE];
    for (int64_t k = 0; k < n; k++) inv[k] = 1.0f / r[k];
    if (n == 1) { /* a contiguous row (stride 1): the loops over c are the long ones */
        double acc = 0;
#pragma omp simd reduction(+ : acc)
        for (int64_t c = 0; c < C; c++) acc += (double)(dy[c] * x[c]) * (w ? w[c] : 1.0f);
        s[0] = acc;
        if (pw)
#pragma omp simd
            for (int64_t c = 0; c < C; c++) pw[c] += dy[c] * x[c] * inv[0];
    } else {
        for (int64_t c = 0; c < C; c++) {
            float wc = w ? w[c] : 1.0f;
            const float *xc = x + c * stride, *dyc = dy + c * stride;
            for (int64_t k = 0; k < n; k++) {
                float dyx = dyc[k] * xc[k];
                s[k] += (double)dyx * wc;
                if (pw) pw[c] += dyx * inv[k];
            }
        }
    }
    if (!dx) return;
    for (int64_t k = 0; k < n; k++)
        coef[k] = (floor_r > 0 && r[k] <= floor_r) ? 0.0f : (float)(s[k] / (C * (double)r[k] * r[k]));
    if (n == 1) {
#pragma omp simd
        for (int64_t c = 0; c < C; c++) dx[c] += ((w ? w[c] : 1.0f) * dy[c] - x[c] * coef[0]) * inv[0];
        return;
    }
    for (int64_t c = 0; c < C; c++) {
        float wc = w ? w[c] : 1.0f;
#pragma omp simd
        for (int64_t k = 0; k < n; k++) {
            int64_t j = c * stride + k;
            dx[j] += (wc * dy[j] - x[j] * coef[k]) * inv[k];
        }
    }
}

int gv_rms_norm_op_backward(gv_graph *g, gv_tensor *out)
{
    gv_tensor *x = out->src[0], *wt = out->iparam[1] ? out->src[1] : NULL;
    rms_dims d = rms_layout(x, out->iparam[0]);
    float floor_r = out->fparam[1];
    const float *r_saved = out->saved, *w = wt ? wt->data : NULL;
    int want_x = gv_wants_grad(out, 0), want_w = wt && wt->requires_grad && wt->grad;
    int64_t n_chunks = (d.n_tiles + ROWS_PER_CHUNK - 1) / ROWS_PER_CHUNK;
    float *pw = NULL;
    if (want_w && !(pw = gv_scratch(g, n_chunks * d.C))) return -1;
#pragma omp parallel for schedule(static) if (d.outer * d.C * d.inner >= GV_OMP_MIN)
    for (int64_t ch = 0; ch < n_chunks; ch++) {
        if (pw) memset(pw + ch * d.C, 0, (size_t)d.C * sizeof(float));
        int64_t end = (ch + 1) * ROWS_PER_CHUNK < d.n_tiles ? (ch + 1) * ROWS_PER_CHUNK : d.n_tiles;
        for (int64_t t = ch * ROWS_PER_CHUNK; t < end; t++) {
            int64_t o = t / d.tiles_per_outer, i0 = t % d.tiles_per_outer * TILE;
            int64_t n = d.inner - i0 < TILE ? d.inner - i0 : TILE, base = o * d.C * d.inner + i0;
            rms_backward_positions(x->data + base, out->grad + base, w, r_saved + o * d.inner + i0,
                                   want_x ? x->grad + base : NULL, pw ? pw + ch * d.C : NULL, d.C,
                                   d.inner, n, floor_r);
        }
    }
    if (pw) add_partials(wt->grad, pw, n_chunks, d.C);
    return 0;
}

static gv_tensor *rms_norm(gv_graph *g, gv_tensor *x, gv_tensor *w, int axis, float eps, float floor_norm)
{
    if (!x) return NULL;
    int a = axis < 0 ? axis + x->ndim : axis;
    if (a < 0 || a >= x->ndim) {
        gv_fail("rms_norm: axis %d out of range for %d dimensions", axis, x->ndim);
        return NULL;
    }
    if (w && w->numel != x->shape[a]) {
        char sw[64], sx[64];
        gv_fail("rms_norm: weight %s does not match axis %d of %s", gv_shape_str(w, sw, sizeof sw),
                a, gv_shape_str(x, sx, sizeof sx));
        return NULL;
    }
    gv_tensor *src[2] = {x, w};
    gv_tensor *out = gv_op_new(g, GV_OP_RMS_NORM, x->ndim, x->shape, w ? 2 : 1, src, 0);
    if (!out) return NULL;
    out->iparam[0] = a;
    out->iparam[1] = w != NULL;
    out->fparam[0] = eps;
    out->fparam[1] = floor_norm;
    return gv_op_run(g, out);
}

gv_tensor *gv_rms_norm(gv_graph *g, gv_tensor *x, gv_tensor *w, float eps)
{
    return rms_norm(g, x, w, -1, eps, 0.0f);
}

/* x / max(||x||, floor) * sqrt(C) = x / max(rms(x), floor / sqrt(C)). */
gv_tensor *gv_rms_norm_axis(gv_graph *g, gv_tensor *x, gv_tensor *gamma, int axis, float floor)
{
    if (!x) return NULL;
    int a = axis < 0 ? axis + x->ndim : axis;
    float c = (a >= 0 && a < x->ndim) ? (float)x->shape[a] : 1.0f;
    return rms_norm(g, x, gamma, axis, 0.0f, floor / sqrtf(c));
}
