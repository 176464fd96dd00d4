/* The projection's backward (docs/reference/gaussian-splatting.md sections 10.2-10.4, 10.6, 10.7;
 * [RAST] backward.cu), eight listed Gaussians at a time (projection_lanes.h): the forward's state
 * is recomputed, then the chain rule from the conic and the 2D mean back to the mean, the
 * log-scales and the raw quaternion. */
#include "splat/projection_lanes.h"

/* dL/dq (raw quaternion) from dL/dRq (section 10.6) and the normalisation
 * q = raw / |raw|: d/draw = (dq - q (q . dq)) / |raw|. */
static SIMD8_INLINE void rotmat_backward8(const lanes_state *p, const f8 gR[9], f8 d_rot[4])
{
    f8 w = p->q[0], x = p->q[1], y = p->q[2], z = p->q[3];
    f8 dq[4];
    dq[0] = 2 * (-z * gR[1] + y * gR[2] + z * gR[3] - x * gR[5] - y * gR[6] + x * gR[7]);
    dq[1] = 2 * (y * gR[1] + z * gR[2] + y * gR[3] - 2 * x * gR[4] - w * gR[5] + z * gR[6] +
                 w * gR[7] - 2 * x * gR[8]);
    dq[2] = 2 * (-2 * y * gR[0] + x * gR[1] + w * gR[2] + x * gR[3] + z * gR[5] - w * gR[6] +
                 z * gR[7] - 2 * y * gR[8]);
    dq[3] = 2 * (-2 * z * gR[0] - w * gR[1] + x * gR[2] + w * gR[3] - 2 * z * gR[4] +
                 y * gR[5] + x * gR[6] + y * gR[7]);
    f8 dot = w * dq[0] + x * dq[1] + y * dq[2] + z * dq[3];
    for (int i = 0; i < 4; i++) d_rot[i] = (dq[i] - p->q[i] * dot) / p->qnorm;
}

/* Gradients of eight Gaussians (lanes of g) from their d means2d (gm) and d conic (gc). */
static SIMD8_INLINE void backward8(const gv_splat_view *v, const lanes_in *g, const f8 gm[2],
                                   const f8 gc[3], f8 d_mean[3], f8 d_scale[3], f8 d_rot[4])
{
    lanes_state p;
    i8 ok = project_state8(v, g, &p); /* the listed Gaussians are visible: always true */
    const float *W = v->R;
    float fx = v->fx, fy = v->fy;
    f8 tz = p.t[2];
    f8 det = p.a * p.c - p.b * p.b, inv = 1.0f / det;
    f8 A = p.c * inv, B = -p.b * inv, C = p.a * inv;

    /* Conic K = Sigma2D^-1: dL/dSigma2D = -K G K with G the conic gradient as a symmetric
     * matrix (its off-diagonal elements get half of dL/dB) (section 10.2). */
    f8 gA = gc[0], gB = 0.5f * gc[1], gC = gc[2];
    f8 X00 = gA * A + gB * B, X01 = gA * B + gB * C;
    f8 X10 = gB * A + gC * B, X11 = gB * B + gC * C;
    f8 G00 = -(A * X00 + B * X10), G01 = -(A * X01 + B * X11), G11 = -(B * X01 + C * X11);

    /* Sigma2D = Am Sigma Am^T: dL/dSigma = Am^T G Am, dL/dAm = 2 G Am Sigma (section 10.3). */
    const f8 *Am = p.Am, *M = p.M;
    f8 Sigma[9];
    for (int i = 0; i < 3; i++)
        for (int j = 0; j < 3; j++)
            Sigma[i * 3 + j] = M[i * 3] * M[j * 3] + M[i * 3 + 1] * M[j * 3 + 1] +
                               M[i * 3 + 2] * M[j * 3 + 2];
    f8 GA[6];
    for (int j = 0; j < 3; j++) {
        GA[j] = G00 * Am[j] + G01 * Am[3 + j];
        GA[3 + j] = G01 * Am[j] + G11 * Am[3 + j];
    }
    f8 gSigma[9], gAm[6];
    for (int i = 0; i < 3; i++)
        for (int j = 0; j < 3; j++) gSigma[i * 3 + j] = Am[i] * GA[j] + Am[3 + i] * GA[3 + j];
    for (int r = 0; r < 2; r++)
        for (int j = 0; j < 3; j++)
            gAm[r * 3 + j] = 2 * (GA[r * 3] * Sigma[j] + GA[r * 3 + 1] * Sigma[3 + j] +
                                  GA[r * 3 + 2] * Sigma[6 + j]);
    /* Am = J W: dL/dJ = dL/dAm W^T; J has entries 00, 02, 11, 12 only. */
    f8 gJ00 = gAm[0] * W[0] + gAm[1] * W[1] + gAm[2] * W[2];
    f8 gJ02 = gAm[0] * W[6] + gAm[1] * W[7] + gAm[2] * W[8];
    f8 gJ11 = gAm[3] * W[3] + gAm[4] * W[4] + gAm[5] * W[5];
    f8 gJ12 = gAm[3] * W[6] + gAm[4] * W[7] + gAm[5] * W[8];
    f8 tz2 = tz * tz, tz3 = tz2 * tz;
    f8 gt[3];
    /* 3DGS: a clamped coordinate passes no gradient through J, and its z term keeps the
     * unclamped form with the clamped value. */
    gt[0] = f8_mask(~p.clamp_x, -fx / tz2 * gJ02);
    gt[1] = f8_mask(~p.clamp_y, -fy / tz2 * gJ12);
    gt[2] = -fx / tz2 * gJ00 - fy / tz2 * gJ11 + 2 * fx * p.tx_c / tz3 * gJ02 +
            2 * fy * p.ty_c / tz3 * gJ12;
    /* means2d = (fx x/z + cx, fy y/z + cy) (section 10.4). */
    gt[0] += gm[0] * fx / tz;
    gt[1] += gm[1] * fy / tz;
    gt[2] -= (gm[0] * fx * p.t[0] + gm[1] * fy * p.t[1]) / tz2;
    for (int j = 0; j < 3; j++)
        d_mean[j] = f8_mask(ok, W[j] * gt[0] + W[3 + j] * gt[1] + W[6 + j] * gt[2]);

    /* Sigma = M M^T, M = Rq diag(s): dL/dM = 2 gSigma M (section 10.6). */
    f8 gR[9];
    for (int j = 0; j < 3; j++) {
        f8 gs = f8_splat(0.0f);
        for (int i = 0; i < 3; i++) {
            f8 gM = 2 * (gSigma[i * 3] * M[j] + gSigma[i * 3 + 1] * M[3 + j] +
                         gSigma[i * 3 + 2] * M[6 + j]);
            gs += gM * p.Rq[i * 3 + j];
            gR[i * 3 + j] = gM * p.s[j];
        }
        d_scale[j] = f8_mask(ok, gs * p.s[j]); /* through s = exp(log-scale) */
    }
    rotmat_backward8(&p, gR, d_rot);
    for (int j = 0; j < 4; j++) d_rot[j] = f8_mask(ok, d_rot[j]);
}

/* The listed Gaussians list[k0 .. k1). */
static RASTER_CLONES void backward_span(int k0, int k1, const int *list, const float *means,
                                        const float *scales, const float *rotations,
                                        const gv_splat_view *v, const float *d_means2d,
                                        const float *d_conics, float *d_means, float *d_scales,
                                        float *d_rotations)
{
    for (int k = k0; k < k1; k += LANES) {
        int count = k1 - k < LANES ? k1 - k : LANES, idx[LANES];
        for (int l = 0; l < LANES && k + LANES + l < k1; l++) { /* the next group's rows */
            size_t h = (size_t)list[k + LANES + l];
            __builtin_prefetch(means + 3 * h), __builtin_prefetch(scales + 3 * h);
            __builtin_prefetch(rotations + 4 * h), __builtin_prefetch(d_means2d + 2 * h);
            __builtin_prefetch(d_conics + 3 * h), __builtin_prefetch(d_means + 3 * h, 1);
        }
        lane_indices(list + k, count, idx);
        lanes_in g;
        gather_lanes(idx, means, scales, rotations, &g);
        f8 gm[2], gc[3], d_mean[3], d_scale[3], d_rot[4];
        for (int l = 0; l < LANES; l++) {
            size_t i = (size_t)idx[l];
            for (int j = 0; j < 2; j++) gm[j][l] = d_means2d[2 * i + j];
            for (int j = 0; j < 3; j++) gc[j][l] = d_conics[3 * i + j];
        }
        backward8(v, &g, gm, gc, d_mean, d_scale, d_rot);
        for (int l = 0; l < count; l++) {
            size_t i = (size_t)idx[l];
            for (int j = 0; j < 3; j++) d_means[3 * i + j] = d_mean[j][l];
            for (int j = 0; j < 3; j++) d_scales[3 * i + j] = d_scale[j][l];
            for (int j = 0; j < 4; j++) d_rotations[4 * i + j] = d_rot[j][l];
        }
    }
}

void gv_splat_project_backward(int n_list, const int *list, const float *means,
                               const float *scales, const float *rotations,
                               const gv_splat_view *view, const float *d_means2d,
                               const float *d_conics, float *d_means, float *d_scales,
                               float *d_rotations)
{
    enum { SPAN = 256 };
    int n_spans = (n_list + SPAN - 1) / SPAN;
#pragma omp parallel for schedule(static)
    for (int k = 0; k < n_spans; k++) {
        int k0 = k * SPAN, k1 = k0 + SPAN < n_list ? k0 + SPAN : n_list;
        backward_span(k0, k1, list, means, scales, rotations, view, d_means2d, d_conics,
                      d_means, d_scales, d_rotations);
    }
}
