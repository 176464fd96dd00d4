/* Conv3D and Conv2D as im2col + sgemm, over chunks of output positions so that the column
 * buffer stays bounded (CHUNK_FLOATS) whatever the video size. A 1x1x1 convolution with unit
 * stride and no padding multiplies the input directly (no column buffer).
 *
 * x [B, Cin, T, H, W] (or [B, Cin, H, W]: T = 1), w [Cout, Cin, kt, kh, kw] (or 4-D: kt = 1),
 * bias [Cout]; out [B, Cout, To, Ho, Wo]; column k = ((ci*kt + dt)*kh + dy)*kw + dx, which is
 * w's row-major order, so w is the [Cout, K] matrix as it is stored. */
#include <cblas.h>

#include "nn/nn_internal.h"

#define CHUNK_FLOATS ((int64_t)1 << 22) /* 16 MiB of columns at a time */

typedef struct {
    int B, Cin, T, H, W, Cout, kt, kh, kw, To, Ho, Wo;
    gv_conv_geom geom;
    int64_t K, P; /* GEMM inner size and output positions per sample */
    int pointwise;
} conv_dims;

static void dims5(const gv_tensor *t, int d[5])
{
    if (t->ndim == 5)
        for (int i = 0; i < 5; i++) d[i] = t->shape[i];
    else
        d[0] = t->shape[0], d[1] = t->shape[1], d[2] = 1, d[3] = t->shape[2], d[4] = t->shape[3];
}

static conv_dims conv_layout(const gv_tensor *x, const gv_tensor *w, const gv_conv_geom *geom)
{
    int xd[5], wd[5];
    dims5(x, xd);
    dims5(w, wd);
    conv_dims c = {xd[0], xd[1], xd[2], xd[3], xd[4], wd[0], wd[2], wd[3], wd[4], 0, 0, 0, *geom, 0, 0, 0};
    const int *s = geom->stride, *p = geom->pad;
    c.To = (c.T + p[0] + p[1] - c.kt) / s[0] + 1;
    c.Ho = (c.H + p[2] + p[3] - c.kh) / s[1] + 1;
    c.Wo = (c.W + p[4] + p[5] - c.kw) / s[2] + 1;
    c.K = (int64_t)c.Cin * c.kt * c.kh * c.kw;
    c.P = (int64_t)c.To * c.Ho * c.Wo;
    c.pointwise = c.kt * c.kh * c.kw == 1 && s[0] == 1 && s[1] == 1 && s[2] == 1 &&
                  !p[0] && !p[1] && !p[2] && !p[3] && !p[4] && !p[5];
    return c;
}

static int64_t chunk_columns(const conv_dims *c)
{
    if (c->pointwise) return c->P;
    int64_t pc = CHUNK_FLOATS / c->K;
    return pc < 1 ? 1 : (pc > c->P ? c->P : pc);
}

/* Output positions whose input column x = wo*s - pad + d lies inside [0, W): [*lo, *hi). */
static void valid_range(int W, int s, int pad, int d, int Wo, int *lo, int *hi)
{
    int first = pad - d, last = W - 1 + pad - d; /* wo*s must lie in [first, last] */
    *lo = first <= 0 ? 0 : (first + s - 1) / s;
    *hi = last < 0 ? 0 : last / s + 1;
    if (*hi > Wo) *hi = Wo;
    if (*lo > *hi) *lo = *hi;
}

/* Walks the positions p0 .. p0+pc-1 of one tap (dt, dy, dx) of input channel plane xc in
 * runs along an output row: col row[j] <-> xc[ti, yi, wo*s - pad + dx]. Positions outside
 * the input read as zero (im2col) or are skipped (col2im). A run with unit stride is one
 * contiguous copy. */
static void tap_rows(const conv_dims *c, int dt, int dy, int dx, int64_t p0, int64_t pc,
                     float *xc, float *row, int to_col)
{
    const int *s = c->geom.stride, *pad = c->geom.pad;
    int lo, hi;
    valid_range(c->W, s[2], pad[4], dx, c->Wo, &lo, &hi);
    for (int64_t j = 0, p = p0; j < pc;) {
        int wo0 = (int)(p % c->Wo), ho = (int)(p / c->Wo % c->Ho), to = (int)(p / c->Wo / c->Ho);
        int n = (int)(c->Wo - wo0 < pc - j ? c->Wo - wo0 : pc - j);
        int ti = to * s[0] - pad[0] + dt, yi = ho * s[1] - pad[2] + dy;
        int a = wo0 > lo ? wo0 : lo, b = wo0 + n < hi ? wo0 + n : hi; /* inside: [a, b) */
        if (ti < 0 || ti >= c->T || yi < 0 || yi >= c->H || b < a) a = b = wo0;
        float *run = row + j - wo0 + a; /* column entries of wo = a .. b-1 */
        float *src = b > a ? xc + ((int64_t)ti * c->H + yi) * c->W + (int64_t)a * s[2] - pad[4] + dx : NULL;
        if (to_col) {
            memset(row + j, 0, (size_t)(a - wo0) * sizeof(float));
            if (b > a && s[2] == 1) memcpy(run, src, (size_t)(b - a) * sizeof(float));
            else for (int i = 0; i < b - a; i++) run[i] = src[(int64_t)i * s[2]];
            memset(row + j + (b - wo0), 0, (size_t)(wo0 + n - b) * sizeof(float));
        } else {
            for (int i = 0; i < b - a; i++) src[(int64_t)i * s[2]] += run[i];
        }
        j += n;
        p += n;
    }
}

/* col [K, pc] = input patches of output positions p0 .. p0+pc-1 of one sample xb. */
static void im2col(const conv_dims *c, const float *xb, int64_t p0, int64_t pc, float *col)
{
#pragma omp parallel for schedule(static) if (c->K * pc >= GV_OMP_MIN)
    for (int64_t k = 0; k < c->K; k++) {
        int dx = (int)(k % c->kw), dy = (int)(k / c->kw % c->kh), dt = (int)(k / c->kw / c->kh % c->kt);
        float *xc = (float *)xb + k / ((int64_t)c->kw * c->kh * c->kt) * c->T * c->H * c->W;
        tap_rows(c, dt, dy, dx, p0, pc, xc, col + k * pc, 1);
    }
}

/* dxb += the columns scattered back to their input positions (the adjoint of im2col). One
 * thread per input channel, so no two threads write the same element. */
static void col2im(const conv_dims *c, const float *col, int64_t p0, int64_t pc, float *dxb)
{
    int taps = c->kt * c->kh * c->kw;
#pragma omp parallel for schedule(static) if (c->K * pc >= GV_OMP_MIN)
    for (int ci = 0; ci < c->Cin; ci++) {
        float *dxc = dxb + (int64_t)ci * c->T * c->H * c->W;
        for (int tap = 0; tap < taps; tap++)
            tap_rows(c, tap / c->kw / c->kh, tap / c->kw % c->kh, tap % c->kw, p0, pc, dxc,
                     (float *)col + ((int64_t)ci * taps + tap) * pc, 0);
    }
}

/* out[b] [Cout, P] = W [Cout, K] col [K, P] + bias; saved = the geometry */
int gv_conv_op_forward(gv_graph *g, gv_tensor *out)
{
    const gv_tensor *x = out->src[0], *w = out->src[1];
    conv_dims c = conv_layout(x, w, out->saved);
    int64_t pc = chunk_columns(&c), in_size = (int64_t)c.Cin * c.T * c.H * c.W;
    gv_arena_mark m = gv_arena_get_mark(&g->arena);
    float *col = c.pointwise ? NULL : gv_scratch(g, c.K * pc);
    if (!c.pointwise && !col) return -1;
    for (int b = 0; b < c.B; b++) {
        const float *xb = x->data + b * in_size;
        float *yb = out->data + b * c.Cout * c.P;
        for (int64_t p0 = 0; p0 < c.P; p0 += pc) {
            int64_t n = c.P - p0 < pc ? c.P - p0 : pc;
            if (!c.pointwise) im2col(&c, xb, p0, n, col);
            cblas_sgemm(CblasRowMajor, CblasNoTrans, CblasNoTrans, c.Cout, (int)n, (int)c.K, 1.0f,
                        w->data, (int)c.K, c.pointwise ? xb + p0 : col, (int)(c.pointwise ? c.P : n),
                        0.0f, yb + p0, (int)c.P);
        }
    }
    gv_arena_rewind(&g->arena, m);
    if (out->n_src > 2) {
        const float *bias = out->src[2]->data;
#pragma omp parallel for schedule(static) if (c.B * c.Cout * c.P >= GV_OMP_MIN)
        for (int64_t bc = 0; bc < (int64_t)c.B * c.Cout; bc++)
            for (int64_t p = 0; p < c.P; p++) out->data[bc * c.P + p] += bias[bc % c.Cout];
    }
    return 0;
}

/* dW += dOut[b] col^T; dcol = W^T dOut[b] scattered into dx; dbias += sum over b, p. */
int gv_conv_op_backward(gv_graph *g, gv_tensor *out)
{
    gv_tensor *x = out->src[0], *w = out->src[1];
    conv_dims c = conv_layout(x, w, out->saved);
    int want_x = gv_wants_grad(out, 0), want_w = gv_wants_grad(out, 1), want_b = gv_wants_grad(out, 2);
    int64_t pc = chunk_columns(&c), in_size = (int64_t)c.Cin * c.T * c.H * c.W;
    float *col = NULL, *dcol = NULL;
    if (!c.pointwise && want_w && !(col = gv_scratch(g, c.K * pc))) return -1;
    if (!c.pointwise && want_x && !(dcol = gv_scratch(g, c.K * pc))) return -1;
    for (int b = 0; b < c.B && (want_w || want_x); b++) {
        const float *xb = x->data + b * in_size, *dyb = out->grad + b * c.Cout * c.P;
        for (int64_t p0 = 0; p0 < c.P; p0 += pc) {
            int n = (int)(c.P - p0 < pc ? c.P - p0 : pc);
            if (want_w) {
                if (!c.pointwise) im2col(&c, xb, p0, n, col);
                cblas_sgemm(CblasRowMajor, CblasNoTrans, CblasTrans, c.Cout, (int)c.K, n, 1.0f,
                            dyb + p0, (int)c.P, c.pointwise ? xb + p0 : col,
                            (int)(c.pointwise ? c.P : n), 1.0f, w->grad, (int)c.K);
            }
            if (want_x && c.pointwise) {
                cblas_sgemm(CblasRowMajor, CblasTrans, CblasNoTrans, (int)c.K, n, c.Cout, 1.0f,
                            w->data, (int)c.K, dyb + p0, (int)c.P, 1.0f, x->grad + b * in_size + p0,
                            (int)c.P);
            } else if (want_x) {
                cblas_sgemm(CblasRowMajor, CblasTrans, CblasNoTrans, (int)c.K, n, c.Cout, 1.0f,
                            w->data, (int)c.K, dyb + p0, (int)c.P, 0.0f, dcol, n);
                col2im(&c, dcol, p0, n, x->grad + b * in_size);
            }
        }
    }
    if (want_b) {
        float *db = out->src[2]->grad;
#pragma omp parallel for schedule(static) if (c.B * c.Cout * c.P >= GV_OMP_MIN)
        for (int co = 0; co < c.Cout; co++) {
            double s = 0;
            for (int b = 0; b < c.B; b++)
                for (int64_t p = 0; p < c.P; p++) s += out->grad[((int64_t)b * c.Cout + co) * c.P + p];
            db[co] += (float)s;
        }
    }
    return 0;
}

gv_conv_geom gv_conv_geom_same(int s, int p_t, int p_h, int p_w)
{
    gv_conv_geom geom = {{s, s, s}, {p_t, p_t, p_h, p_h, p_w, p_w}};
    return geom;
}

gv_conv_geom gv_conv_geom_causal(int s_t, int s_hw, int p_t, int p_h, int p_w)
{
    gv_conv_geom geom = {{s_t, s_hw, s_hw}, {2 * p_t, 0, p_h, p_h, p_w, p_w}};
    return geom;
}

static gv_tensor *conv(gv_graph *g, int nd, gv_tensor *x, gv_tensor *w, gv_tensor *bias,
                       const gv_conv_geom *geom)
{
    if (!x || !w) return NULL;
    char sx[64], sw[64];
    const char *op = nd == 5 ? "conv3d" : "conv2d";
    if (x->ndim != nd || w->ndim != nd || w->shape[1] != x->shape[1]) {
        gv_fail("%s: input %s and weight %s do not match (expected %d-D, same Cin)", op,
                gv_shape_str(x, sx, sizeof sx), gv_shape_str(w, sw, sizeof sw), nd);
        return NULL;
    }
    for (int i = 0; i < 3; i++)
        if (geom->stride[i] < 1 || geom->pad[2 * i] < 0 || geom->pad[2 * i + 1] < 0) {
            gv_fail("%s: bad stride or padding in axis %d", op, i);
            return NULL;
        }
    if (nd == 4 && (geom->stride[0] != 1 || geom->pad[0] || geom->pad[1])) {
        gv_fail("conv2d: the temporal stride must be 1 and its padding 0");
        return NULL;
    }
    if (bias && (bias->ndim != 1 || bias->shape[0] != w->shape[0])) {
        gv_fail("%s: bias %s does not match %d output channels", op,
                gv_shape_str(bias, sx, sizeof sx), w->shape[0]);
        return NULL;
    }
    conv_dims c = conv_layout(x, w, geom);
    if (c.T + geom->pad[0] + geom->pad[1] < c.kt || c.H + geom->pad[2] + geom->pad[3] < c.kh ||
        c.W + geom->pad[4] + geom->pad[5] < c.kw) {
        gv_fail("%s: input %s is smaller than the kernel %s after padding", op,
                gv_shape_str(x, sx, sizeof sx), gv_shape_str(w, sw, sizeof sw));
        return NULL;
    }
    if (gv_check_blas_dims(op, c.K, c.P, c.Cout) != 0) return NULL;
    int shape5[5] = {c.B, c.Cout, c.To, c.Ho, c.Wo}, shape4[4] = {c.B, c.Cout, c.Ho, c.Wo};
    gv_tensor *src[3] = {x, w, bias};
    gv_tensor *out = gv_op_new(g, GV_OP_CONV, nd, nd == 5 ? shape5 : shape4, bias ? 3 : 2, src, 0);
    if (!out) return NULL;
    gv_conv_geom *saved = gv_arena_alloc(&g->arena, sizeof *saved);
    if (!saved) return NULL;
    *saved = *geom;
    out->saved = saved;
    return gv_op_run(g, out);
}

gv_tensor *gv_conv3d(gv_graph *g, gv_tensor *x, gv_tensor *w, gv_tensor *bias,
                     const gv_conv_geom *geom)
{
    return conv(g, 5, x, w, bias, geom);
}

gv_tensor *gv_conv2d(gv_graph *g, gv_tensor *x, gv_tensor *w, gv_tensor *bias,
                     const gv_conv_geom *geom)
{
    return conv(g, 4, x, w, bias, geom);
}
