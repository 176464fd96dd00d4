/* The projection of eight Gaussians at a time (simd8.h lanes), shared by the forward
 * (projection_forward.c) and the backward (projection_backward.c), which recomputes the
 * forward's state instead of storing it. Every expression keeps the order of operations of
 * the one-Gaussian formulas in the comments, and the files that include this one are
 * compiled without fused multiply-adds (CMakeLists.txt), so each lane gives the same floats
 * as the scalar arithmetic would. The exponentials of the log-scales stay libm's expf, lane
 * by lane: a vector exponential would round differently. */
#ifndef GAUSSVID_SPLAT_PROJECTION_LANES_H
#define GAUSSVID_SPLAT_PROJECTION_LANES_H

#include <math.h>

#include "gaussvid/splat/splat.h"
#include "splat/simd8.h"

enum { LANES = 8 };

/* a > b ? a : b and a < b ? a : b, lane by lane (NaN gives the second operand). */
static SIMD8_INLINE f8 max8(f8 a, f8 b)
{
    return f8_select(a > b, a, b);
}

static SIMD8_INLINE f8 min8(f8 a, f8 b)
{
    return f8_select(a < b, a, b);
}

/* All ones where x is finite: x - x is 0 there and NaN for infinities and NaN. */
static SIMD8_INLINE i8 finite8(f8 x)
{
    return (x - x) == f8_splat(0.0f);
}

/* Correctly rounded, as sqrtf (the files are compiled without errno, so this vectorises). */
static SIMD8_INLINE f8 sqrt8(f8 x)
{
    f8 r;
    for (int l = 0; l < LANES; l++) r[l] = __builtin_sqrtf(x[l]);
    return r;
}

static SIMD8_INLINE f8 expf8(f8 x)
{
    f8 r;
    for (int l = 0; l < LANES; l++) r[l] = expf(x[l]);
    return r;
}

/* Eight Gaussians' parameter rows, lane by lane. */
typedef struct {
    f8 mean[3], log_scale[3], rot[4];
} lanes_in;

/* Lane l takes row idx[l]. */
static SIMD8_INLINE void gather_lanes(const int idx[LANES], const float *means, const float *scales,
                                      const float *rotations, lanes_in *g)
{
    for (int l = 0; l < LANES; l++) {
        size_t i = (size_t)idx[l];
        for (int j = 0; j < 3; j++)
            g->mean[j][l] = means[3 * i + j], g->log_scale[j][l] = scales[3 * i + j];
        for (int j = 0; j < 4; j++) g->rot[j][l] = rotations[4 * i + j];
    }
}

/* Lanes [0, count) take list[0 .. count); the last is repeated to fill eight. */
static SIMD8_INLINE void lane_indices(const int *list, int count, int idx[LANES])
{
    for (int l = 0; l < LANES; l++) idx[l] = list[l < count ? l : count - 1];
}

/* Camera-space mean t = W mean + t_view. */
static SIMD8_INLINE void camera_point(const gv_splat_view *v, const lanes_in *g, f8 t[3])
{
    const float *W = v->R;
    for (int i = 0; i < 3; i++)
        t[i] = W[i * 3] * g->mean[0] + W[i * 3 + 1] * g->mean[1] + W[i * 3 + 2] * g->mean[2] +
               v->t[i];
}

/* Everything the forward computes up to the 2D covariance, as the backward needs it. */
typedef struct {
    f8 t[3];            /* camera-space mean */
    f8 tx_c, ty_c;      /* x, y clamped for the Jacobian */
    i8 clamp_x, clamp_y;
    f8 s[3], q[4], qnorm, Rq[9];
    f8 M[9];            /* Rq diag(s): Sigma = M M^T */
    f8 Am[6];           /* J W, 2x3 */
    f8 a, b, c;         /* dilated 2D covariance [[a, b], [b, c]] */
} lanes_state;

/* The forward up to the 2D covariance (docs/reference/gaussian-splatting.md sections 2 and 5);
 * returns all ones in the lanes in front of the near plane with a finite depth, zeros in the others
 * (whose state is meaningless). */
static SIMD8_INLINE i8 project_state8(const gv_splat_view *v, const lanes_in *g, lanes_state *p)
{
    const float *W = v->R;
    camera_point(v, g, p->t);
    f8 tz = p->t[2];
    i8 ok = (tz > GV_SPLAT_NEAR) & finite8(tz);

    /* Jacobian of the perspective map at the clamped point (section 5 steps 1-2). */
    f8 txtz = p->t[0] / tz, tytz = p->t[1] / tz;
    p->clamp_x = (txtz < -v->lim_x_neg) | (txtz > v->lim_x_pos);
    p->clamp_y = (tytz < -v->lim_y_neg) | (tytz > v->lim_y_pos);
    p->tx_c = min8(max8(txtz, f8_splat(-v->lim_x_neg)), f8_splat(v->lim_x_pos)) * tz;
    p->ty_c = min8(max8(tytz, f8_splat(-v->lim_y_neg)), f8_splat(v->lim_y_pos)) * tz;
    f8 J00 = v->fx / tz, J02 = -v->fx * p->tx_c / (tz * tz);
    f8 J11 = v->fy / tz, J12 = -v->fy * p->ty_c / (tz * tz);
    for (int j = 0; j < 3; j++) {
        p->Am[j] = J00 * W[j] + J02 * W[6 + j];
        p->Am[3 + j] = J11 * W[3 + j] + J12 * W[6 + j];
    }

    /* Sigma = R diag(s^2) R^T = M M^T with M = R diag(s) (section 2); q is the quaternion
     * normalised as torch.nn.functional.normalize (eps 1e-12). */
    for (int j = 0; j < 3; j++) p->s[j] = expf8(g->log_scale[j]);
    const f8 *r = g->rot;
    p->qnorm = max8(sqrt8(r[0] * r[0] + r[1] * r[1] + r[2] * r[2] + r[3] * r[3]),
                    f8_splat(1e-12f));
    for (int j = 0; j < 4; j++) p->q[j] = r[j] / p->qnorm;
    f8 w = p->q[0], x = p->q[1], y = p->q[2], z = p->q[3], *R = p->Rq;
    R[0] = 1 - 2 * (y * y + z * z), R[1] = 2 * (x * y - w * z), R[2] = 2 * (x * z + w * y);
    R[3] = 2 * (x * y + w * z), R[4] = 1 - 2 * (x * x + z * z), R[5] = 2 * (y * z - w * x);
    R[6] = 2 * (x * z - w * y), R[7] = 2 * (y * z + w * x), R[8] = 1 - 2 * (x * x + y * y);
    for (int i = 0; i < 3; i++)
        for (int j = 0; j < 3; j++) p->M[i * 3 + j] = R[i * 3 + j] * p->s[j];

    /* Sigma2D = Am Sigma Am^T = (Am M)(Am M)^T, plus the low-pass dilation (section 5
     * steps 3-4). */
    f8 U[6];
    for (int k = 0; k < 2; k++)
        for (int j = 0; j < 3; j++)
            U[k * 3 + j] = p->Am[k * 3] * p->M[j] + p->Am[k * 3 + 1] * p->M[3 + j] +
                           p->Am[k * 3 + 2] * p->M[6 + j];
    p->a = U[0] * U[0] + U[1] * U[1] + U[2] * U[2] + GV_SPLAT_DILATION;
    p->b = U[0] * U[3] + U[1] * U[4] + U[2] * U[5];
    p->c = U[3] * U[3] + U[4] * U[4] + U[5] * U[5] + GV_SPLAT_DILATION;
    return ok;
}

#endif
