/* Resampling: pixel (un)shuffle generalised to time, and nearest-neighbour upsampling. */
#include "nn/nn_internal.h"

/* Sizes of a 4-D or 5-D tensor as [B, C, T, H, W] (T = 1 for 4-D). */
static void dims5(const gv_tensor *t, int64_t d[5])
{
    if (t->ndim == 5)
        for (int i = 0; i < 5; i++) d[i] = t->shape[i];
    else
        d[0] = t->shape[0], d[1] = t->shape[1], d[2] = 1, d[3] = t->shape[2], d[4] = t->shape[3];
}

/* ---- pixel unshuffle / shuffle ----------------------------------------------------------------
 * small [B, C*rt*rh*rw, T/rt, H/rh, W/rw] and big [B, C, T, H, W]:
 * small[b, ((c*rt + dt)*rh + dy)*rw + dx, t, y, x] = big[b, c, t*rt + dt, y*rh + dy, x*rw + dx].
 * Unshuffle reads big into small, shuffle writes small into big; each backward is the other
 * direction. mode: 0 small <- big, 1 big <- small, 2 big += small, 3 small += big. */
static void s2d_copy(const int64_t big[5], const int r[3], float *small, float *bigp, int mode)
{
    int64_t C = big[1], T = big[2] / r[0], H = big[3] / r[1], W = big[4] / r[2];
    int64_t rows = big[0] * C * r[0] * r[1] * r[2] * T * H; /* rows of small, W each */
#pragma omp parallel for schedule(static) if (rows * W >= GV_OMP_MIN)
    for (int64_t row = 0; row < rows; row++) {
        int64_t y = row % H, t = row / H % T, ch = row / (H * T);
        int64_t dx = ch % r[2], dy = ch / r[2] % r[1], dt = ch / r[2] / r[1] % r[0];
        int64_t c = ch / ((int64_t)r[0] * r[1] * r[2]) % C, b = ch / ((int64_t)r[0] * r[1] * r[2] * C);
        float *s = small + row * W;
        float *p = bigp + (((b * C + c) * big[2] + t * r[0] + dt) * big[3] + y * r[1] + dy) * big[4] + dx;
        for (int64_t x = 0; x < W; x++) {
            float *q = p + x * r[2];
            switch (mode) {
            case 0: s[x] = *q; break;
            case 1: *q = s[x]; break;
            case 2: *q += s[x]; break;
            default: s[x] += *q; break;
            }
        }
    }
}

int gv_space_to_depth_op_forward(gv_graph *g, gv_tensor *out)
{
    int64_t big[5];
    dims5(out->src[0], big);
    s2d_copy(big, out->iparam, out->data, out->src[0]->data, 0);
    return 0;
}

int gv_space_to_depth_op_backward(gv_graph *g, gv_tensor *out)
{
    int64_t big[5];
    dims5(out->src[0], big);
    s2d_copy(big, out->iparam, out->grad, out->src[0]->grad, 2);
    return 0;
}

int gv_depth_to_space_op_forward(gv_graph *g, gv_tensor *out)
{
    int64_t big[5];
    dims5(out, big);
    s2d_copy(big, out->iparam, out->src[0]->data, out->data, 1);
    return 0;
}

int gv_depth_to_space_op_backward(gv_graph *g, gv_tensor *out)
{
    int64_t big[5];
    dims5(out, big);
    s2d_copy(big, out->iparam, out->src[0]->grad, out->grad, 3);
    return 0;
}

static int check_video(const char *op, const gv_tensor *x, int rt)
{
    char buf[64];
    if (x->ndim != 5 && x->ndim != 4)
        return gv_fail("%s: input %s is not [B, C, T, H, W] or [B, C, H, W]", op,
                       gv_shape_str(x, buf, sizeof buf));
    if (x->ndim == 4 && rt != 1) return gv_fail("%s: a 4-D input needs a temporal factor of 1", op);
    return 0;
}

gv_tensor *gv_pixel_unshuffle(gv_graph *g, gv_tensor *x, int rt, int rh, int rw)
{
    if (!x || check_video("pixel_unshuffle", x, rt) != 0) return NULL;
    int64_t d[5];
    dims5(x, d);
    if (rt < 1 || rh < 1 || rw < 1 || d[2] % rt || d[3] % rh || d[4] % rw) {
        char buf[64];
        gv_fail("pixel_unshuffle: %s does not divide by factors (%d, %d, %d)",
                gv_shape_str(x, buf, sizeof buf), rt, rh, rw);
        return NULL;
    }
    int shape[5] = {(int)d[0], (int)(d[1] * rt * rh * rw), (int)(d[2] / rt), (int)(d[3] / rh), (int)(d[4] / rw)};
    if (x->ndim == 4) shape[2] = shape[3], shape[3] = shape[4];
    gv_tensor *out = gv_op_new(g, GV_OP_SPACE_TO_DEPTH, x->ndim, shape, 1, &x, 0);
    if (!out) return NULL;
    out->iparam[0] = rt, out->iparam[1] = rh, out->iparam[2] = rw;
    return gv_op_run(g, out);
}

gv_tensor *gv_pixel_shuffle(gv_graph *g, gv_tensor *x, int rt, int rh, int rw)
{
    if (!x || check_video("pixel_shuffle", x, rt) != 0) return NULL;
    int64_t d[5];
    dims5(x, d);
    int64_t r = (int64_t)rt * rh * rw;
    if (rt < 1 || rh < 1 || rw < 1 || d[1] % r || d[2] * rt * d[3] * rh * d[4] * rw > INT32_MAX) {
        char buf[64];
        gv_fail("pixel_shuffle: %s channels do not divide by %lld", gv_shape_str(x, buf, sizeof buf),
                (long long)r);
        return NULL;
    }
    int shape[5] = {(int)d[0], (int)(d[1] / r), (int)(d[2] * rt), (int)(d[3] * rh), (int)(d[4] * rw)};
    if (x->ndim == 4) shape[2] = shape[3], shape[3] = shape[4];
    gv_tensor *out = gv_op_new(g, GV_OP_DEPTH_TO_SPACE, x->ndim, shape, 1, &x, 0);
    if (!out) return NULL;
    out->iparam[0] = rt, out->iparam[1] = rh, out->iparam[2] = rw;
    return gv_op_run(g, out);
}

/* ---- nearest upsampling: out [B, C, T*ft, H*fh, W*fw], out[.., t, y, x] = x[.., t/ft, y/fh,
 * x/fw]; iparam = {ft, fh, fw}. The backward sums each block; one thread per (b, c) plane. */
int gv_upsample_op_forward(gv_graph *g, gv_tensor *out)
{
    int64_t d[5];
    dims5(out->src[0], d);
    const int *f = out->iparam;
    int64_t To = d[2] * f[0], Ho = d[3] * f[1], Wo = d[4] * f[2], rows = d[0] * d[1] * To * Ho;
    const float *x = out->src[0]->data;
#pragma omp parallel for schedule(static) if (rows * Wo >= GV_OMP_MIN)
    for (int64_t row = 0; row < rows; row++) {
        int64_t y = row % Ho, t = row / Ho % To, bc = row / (Ho * To);
        const float *in = x + ((bc * d[2] + t / f[0]) * d[3] + y / f[1]) * d[4];
        float *o = out->data + row * Wo;
        for (int64_t i = 0; i < Wo; i++) o[i] = in[i / f[2]];
    }
    return 0;
}

int gv_upsample_op_backward(gv_graph *g, gv_tensor *out)
{
    int64_t d[5];
    dims5(out->src[0], d);
    const int *f = out->iparam;
    int64_t To = d[2] * f[0], Ho = d[3] * f[1], Wo = d[4] * f[2];
    float *dx = out->src[0]->grad;
#pragma omp parallel for schedule(static) if (out->numel >= GV_OMP_MIN)
    for (int64_t bc = 0; bc < d[0] * d[1]; bc++)
        for (int64_t t = 0; t < To; t++)
            for (int64_t y = 0; y < Ho; y++) {
                const float *dy = out->grad + ((bc * To + t) * Ho + y) * Wo;
                float *in = dx + ((bc * d[2] + t / f[0]) * d[3] + y / f[1]) * d[4];
                for (int64_t i = 0; i < Wo; i++) in[i / f[2]] += dy[i];
            }
    return 0;
}

gv_tensor *gv_upsample_nearest(gv_graph *g, gv_tensor *x, int ft, int fh, int fw)
{
    if (!x || check_video("upsample_nearest", x, ft) != 0) return NULL;
    int64_t d[5];
    dims5(x, d);
    if (ft < 1 || fh < 1 || fw < 1 || d[2] * ft * d[3] * fh * d[4] * fw > INT32_MAX) {
        gv_fail("upsample_nearest: bad factors (%d, %d, %d)", ft, fh, fw);
        return NULL;
    }
    int shape[5] = {(int)d[0], (int)d[1], (int)(d[2] * ft), (int)(d[3] * fh), (int)(d[4] * fw)};
    if (x->ndim == 4) shape[2] = shape[3], shape[3] = shape[4];
    gv_tensor *out = gv_op_new(g, GV_OP_UPSAMPLE, x->ndim, shape, 1, &x, 0);
    if (!out) return NULL;
    out->iparam[0] = ft, out->iparam[1] = fh, out->iparam[2] = fw;
    return gv_op_run(g, out);
}
