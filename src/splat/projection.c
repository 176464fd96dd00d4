/* Projection of 3D Gaussians to screen-space 2D Gaussians (EWA splatting): the views, one
 * Gaussian's forward as the backward recomputes it, and the backward (reference doc sections
 * 2, 4, 5, 6, 10.2-10.4, 10.6, 10.7; [RAST] forward.cu preprocessCUDA/computeCov2D/
 * computeCov3D and backward.cu). The forward over all Gaussians is projection_forward.c. */
#include <math.h>
#include <string.h>

#include "gaussvid/core.h"
#include "gaussvid/splat.h"

int gv_splat_view_init(gv_splat_view *v, int width, int height, double fx, double fy,
                       double cx, double cy, const double R[9], const double t[3])
{
    memset(v, 0, sizeof *v);
    if (width <= 0 || height <= 0 || width > GV_SPLAT_MAX_RADIUS || height > GV_SPLAT_MAX_RADIUS)
        return gv_fail("camera: bad image size %dx%d", width, height);
    if (!(fx > 0) || !(fy > 0) || !isfinite(fx) || !isfinite(fy) || !isfinite(cx) ||
        !isfinite(cy))
        return gv_fail("camera: bad intrinsics fx %g fy %g cx %g cy %g", fx, fy, cx, cy);
    for (int i = 0; i < 9; i++)
        if (!isfinite(R[i])) return gv_fail("camera: non-finite rotation");
    for (int i = 0; i < 3; i++)
        if (!isfinite(t[i])) return gv_fail("camera: non-finite translation");
    v->width = width;
    v->height = height;
    v->fx = (float)fx, v->fy = (float)fy, v->cx = (float)cx, v->cy = (float)cy;
    for (int i = 0; i < 9; i++) v->R[i] = (float)R[i];
    for (int i = 0; i < 3; i++) v->t[i] = (float)t[i];
    for (int j = 0; j < 3; j++)
        v->campos[j] = (float)-(R[0 * 3 + j] * t[0] + R[1 * 3 + j] * t[1] + R[2 * 3 + j] * t[2]);
    /* gsplat's asymmetric limits: the image edge plus 0.3 of the half width beyond it. With
     * cx = W/2 each is W/(2 fx) + 0.3 W/(2 fx) = 1.3 tan(fov_x/2), the 3DGS clamp. */
    double margin_x = (GV_SPLAT_CLAMP_FOV - 1.0) * width / (2.0 * fx);
    double margin_y = (GV_SPLAT_CLAMP_FOV - 1.0) * height / (2.0 * fy);
    v->lim_x_neg = (float)(cx / fx + margin_x);
    v->lim_x_pos = (float)((width - cx) / fx + margin_x);
    v->lim_y_neg = (float)(cy / fy + margin_y);
    v->lim_y_pos = (float)((height - cy) / fy + margin_y);
    return 0;
}

int gv_splat_view_from_camera(gv_splat_view *v, const gv_camera *cam)
{
    return gv_splat_view_init(v, cam->width, cam->height, cam->fx, cam->fy, cam->cx, cam->cy,
                              cam->R, cam->t);
}

/* max and min without libm calls (NaN gives the second operand). */
static inline float max_f(float a, float b)
{
    return a > b ? a : b;
}

static inline float min_f(float a, float b)
{
    return a < b ? a : b;
}

/* Rotation matrix (row-major) of the unit quaternion (w, x, y, z) (section 2). */
static void quat_to_rotmat(const float q[4], float R[9])
{
    float w = q[0], x = q[1], y = q[2], z = q[3];
    R[0] = 1 - 2 * (y * y + z * z), R[1] = 2 * (x * y - w * z), R[2] = 2 * (x * z + w * y);
    R[3] = 2 * (x * y + w * z), R[4] = 1 - 2 * (x * x + z * z), R[5] = 2 * (y * z - w * x);
    R[6] = 2 * (x * z - w * y), R[7] = 2 * (y * z + w * x), R[8] = 1 - 2 * (x * x + y * y);
}

/* Normalised quaternion (torch normalize, eps 1e-12); returns the norm used. */
static float normalize_quat(const float *raw, float q[4])
{
    float norm = sqrtf(raw[0] * raw[0] + raw[1] * raw[1] + raw[2] * raw[2] + raw[3] * raw[3]);
    norm = max_f(norm, 1e-12f);
    for (int i = 0; i < 4; i++) q[i] = raw[i] / norm;
    return norm;
}

/* Everything the forward computes for one Gaussian, kept so the backward can recompute it
 * instead of storing it. projection_forward.c runs the same arithmetic eight Gaussians at a
 * time, in the same order of operations. */
typedef struct {
    float t[3];          /* camera-space mean */
    float tx_c, ty_c;    /* x, y clamped for the Jacobian */
    int clamp_x, clamp_y;
    float s[3], q[4], qnorm, Rq[9];
    float M[9];          /* Rq diag(s): Sigma = M M^T */
    float Am[6];         /* J W, 2x3 */
    float a, b, c;       /* dilated 2D covariance [[a, b], [b, c]] */
} projection_state;

/* Forward up to the 2D covariance; returns 0 when the Gaussian is behind the near plane
 * (or not finite). */
static int project_state(const float *mean, const float *log_scale, const float *rot,
                         const gv_splat_view *v, projection_state *p)
{
    const float *W = v->R;
    for (int i = 0; i < 3; i++)
        p->t[i] = W[i * 3] * mean[0] + W[i * 3 + 1] * mean[1] + W[i * 3 + 2] * mean[2] + v->t[i];
    float tz = p->t[2];
    if (!(tz > GV_SPLAT_NEAR) || !isfinite(tz)) return 0;

    /* Jacobian of the perspective map at the clamped point (section 5 step 1-2). */
    float txtz = p->t[0] / tz, tytz = p->t[1] / tz;
    p->clamp_x = txtz < -v->lim_x_neg || txtz > v->lim_x_pos;
    p->clamp_y = tytz < -v->lim_y_neg || tytz > v->lim_y_pos;
    p->tx_c = min_f(max_f(txtz, -v->lim_x_neg), v->lim_x_pos) * tz;
    p->ty_c = min_f(max_f(tytz, -v->lim_y_neg), v->lim_y_pos) * tz;
    float J00 = v->fx / tz, J02 = -v->fx * p->tx_c / (tz * tz);
    float J11 = v->fy / tz, J12 = -v->fy * p->ty_c / (tz * tz);
    for (int j = 0; j < 3; j++) {
        p->Am[j] = J00 * W[j] + J02 * W[6 + j];
        p->Am[3 + j] = J11 * W[3 + j] + J12 * W[6 + j];
    }

    /* Sigma = R diag(s^2) R^T = M M^T with M = R diag(s) (section 2). */
    for (int i = 0; i < 3; i++) p->s[i] = expf(log_scale[i]);
    p->qnorm = normalize_quat(rot, p->q);
    quat_to_rotmat(p->q, p->Rq);
    for (int i = 0; i < 3; i++)
        for (int j = 0; j < 3; j++) p->M[i * 3 + j] = p->Rq[i * 3 + j] * p->s[j];

    /* Sigma2D = Am Sigma Am^T = (Am M)(Am M)^T, plus the low-pass dilation (section 5
     * steps 3-4). */
    float U[6];
    for (int r = 0; r < 2; r++)
        for (int j = 0; j < 3; j++)
            U[r * 3 + j] = p->Am[r * 3] * p->M[j] + p->Am[r * 3 + 1] * p->M[3 + j] +
                           p->Am[r * 3 + 2] * p->M[6 + j];
    p->a = U[0] * U[0] + U[1] * U[1] + U[2] * U[2] + GV_SPLAT_DILATION;
    p->b = U[0] * U[3] + U[1] * U[4] + U[2] * U[5];
    p->c = U[3] * U[3] + U[4] * U[4] + U[5] * U[5] + GV_SPLAT_DILATION;
    return 1;
}

/* d L / d q (raw quaternion) from d L / d Rq (section 10.6 and the normalisation). */
static void rotmat_backward(const projection_state *p, const float *gR, float *d_rot)
{
    float w = p->q[0], x = p->q[1], y = p->q[2], z = p->q[3];
    float dq[4];
    dq[0] = 2 * (-z * gR[1] + y * gR[2] + z * gR[3] - x * gR[5] - y * gR[6] + x * gR[7]);
    dq[1] = 2 * (y * gR[1] + z * gR[2] + y * gR[3] - 2 * x * gR[4] - w * gR[5] + z * gR[6] +
                 w * gR[7] - 2 * x * gR[8]);
    dq[2] = 2 * (-2 * y * gR[0] + x * gR[1] + w * gR[2] + x * gR[3] + z * gR[5] - w * gR[6] +
                 z * gR[7] - 2 * y * gR[8]);
    dq[3] = 2 * (-2 * z * gR[0] - w * gR[1] + x * gR[2] + w * gR[3] - 2 * z * gR[4] +
                 y * gR[5] + x * gR[6] + y * gR[7]);
    /* q = raw / |raw|: d/draw = (dq - q (q . dq)) / |raw|. */
    float dot = w * dq[0] + x * dq[1] + y * dq[2] + z * dq[3];
    for (int i = 0; i < 4; i++) d_rot[i] = (dq[i] - p->q[i] * dot) / p->qnorm;
}

static void project_one_backward(const float *mean, const float *log_scale, const float *rot,
                                 const gv_splat_view *v, const float *g_mean2d,
                                 const float *g_conic, float *d_mean, float *d_scale,
                                 float *d_rot)
{
    projection_state p;
    if (!project_state(mean, log_scale, rot, v, &p)) { /* cannot happen for visible ones */
        for (int i = 0; i < 3; i++) d_mean[i] = d_scale[i] = 0;
        for (int i = 0; i < 4; i++) d_rot[i] = 0;
        return;
    }
    const float *W = v->R;
    float tz = p.t[2], fx = v->fx, fy = v->fy;
    float det = p.a * p.c - p.b * p.b, inv = 1.0f / det;
    float A = p.c * inv, B = -p.b * inv, C = p.a * inv;

    /* Conic K = Sigma2D^-1: dL/dSigma2D = -K G K with G the conic gradient as a symmetric
     * matrix (its off-diagonal elements get half of dL/dB) (section 10.2). */
    float gA = g_conic[0], gB = 0.5f * g_conic[1], gC = g_conic[2];
    float X00 = gA * A + gB * B, X01 = gA * B + gB * C;
    float X10 = gB * A + gC * B, X11 = gB * B + gC * C;
    float G00 = -(A * X00 + B * X10), G01 = -(A * X01 + B * X11), G11 = -(B * X01 + C * X11);

    /* Sigma2D = Am Sigma Am^T: dL/dSigma = Am^T G Am, dL/dAm = 2 G Am Sigma (section 10.3). */
    const float *Am = p.Am;
    float Sigma[9];
    for (int i = 0; i < 3; i++)
        for (int j = 0; j < 3; j++)
            Sigma[i * 3 + j] = p.M[i * 3] * p.M[j * 3] + p.M[i * 3 + 1] * p.M[j * 3 + 1] +
                               p.M[i * 3 + 2] * p.M[j * 3 + 2];
    float GA[6];
    for (int j = 0; j < 3; j++) {
        GA[j] = G00 * Am[j] + G01 * Am[3 + j];
        GA[3 + j] = G01 * Am[j] + G11 * Am[3 + j];
    }
    float gSigma[9], gAm[6];
    for (int i = 0; i < 3; i++)
        for (int j = 0; j < 3; j++) gSigma[i * 3 + j] = Am[i] * GA[j] + Am[3 + i] * GA[3 + j];
    for (int r = 0; r < 2; r++)
        for (int j = 0; j < 3; j++)
            gAm[r * 3 + j] = 2 * (GA[r * 3] * Sigma[j] + GA[r * 3 + 1] * Sigma[3 + j] +
                                  GA[r * 3 + 2] * Sigma[6 + j]);
    /* Am = J W: dL/dJ = dL/dAm W^T; J has entries 00, 02, 11, 12 only. */
    float gJ00 = gAm[0] * W[0] + gAm[1] * W[1] + gAm[2] * W[2];
    float gJ02 = gAm[0] * W[6] + gAm[1] * W[7] + gAm[2] * W[8];
    float gJ11 = gAm[3] * W[3] + gAm[4] * W[4] + gAm[5] * W[5];
    float gJ12 = gAm[3] * W[6] + gAm[4] * W[7] + gAm[5] * W[8];
    float tz2 = tz * tz, tz3 = tz2 * tz;
    float gt[3];
    /* 3DGS: a clamped coordinate passes no gradient through J, and its z term keeps the
     * unclamped form with the clamped value. */
    gt[0] = p.clamp_x ? 0 : -fx / tz2 * gJ02;
    gt[1] = p.clamp_y ? 0 : -fy / tz2 * gJ12;
    gt[2] = -fx / tz2 * gJ00 - fy / tz2 * gJ11 + 2 * fx * p.tx_c / tz3 * gJ02 +
            2 * fy * p.ty_c / tz3 * gJ12;
    /* means2d = (fx x/z + cx, fy y/z + cy) (section 10.4). */
    gt[0] += g_mean2d[0] * fx / tz;
    gt[1] += g_mean2d[1] * fy / tz;
    gt[2] -= (g_mean2d[0] * fx * p.t[0] + g_mean2d[1] * fy * p.t[1]) / tz2;
    for (int j = 0; j < 3; j++) d_mean[j] = W[j] * gt[0] + W[3 + j] * gt[1] + W[6 + j] * gt[2];

    /* Sigma = M M^T, M = Rq diag(s): dL/dM = 2 gSigma M (section 10.6). */
    float gR[9];
    for (int j = 0; j < 3; j++) {
        float gs = 0;
        for (int i = 0; i < 3; i++) {
            float gM = 2 * (gSigma[i * 3] * p.M[j] + gSigma[i * 3 + 1] * p.M[3 + j] +
                            gSigma[i * 3 + 2] * p.M[6 + j]);
            gs += gM * p.Rq[i * 3 + j];
            gR[i * 3 + j] = gM * p.s[j];
        }
        d_scale[j] = gs * p.s[j]; /* through s = exp(log-scale) */
    }
    rotmat_backward(&p, gR, d_rot);
}

void gv_splat_project_backward(int n_list, const int *list, const float *means,
                               const float *scales, const float *rotations,
                               const gv_splat_view *view, const float *d_means2d,
                               const float *d_conics, float *d_means, float *d_scales,
                               float *d_rotations)
{
#pragma omp parallel for schedule(static)
    for (int k = 0; k < n_list; k++) {
        size_t i = (size_t)list[k];
        if (k + 8 < n_list) { /* the list is sparse: fetch its rows ahead */
            size_t h = (size_t)list[k + 8];
            __builtin_prefetch(means + 3 * h), __builtin_prefetch(scales + 3 * h);
            __builtin_prefetch(rotations + 4 * h), __builtin_prefetch(d_means2d + 2 * h);
            __builtin_prefetch(d_conics + 3 * h), __builtin_prefetch(d_means + 3 * h, 1);
        }
        project_one_backward(means + 3 * i, scales + 3 * i, rotations + 4 * i, view,
                             d_means2d + 2 * i, d_conics + 3 * i, d_means + 3 * i,
                             d_scales + 3 * i, d_rotations + 4 * i);
    }
}
