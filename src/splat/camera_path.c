/* Cameras between the cameras of a scene, for rendering a path: the world-to-camera
 * rotations are interpolated by quaternion slerp (shortest arc), the camera centres and the
 * intrinsics linearly. */
#include <math.h>
#include <string.h>

#include "gaussvid/scene/scene.h"
#include "gaussvid/splat/splat_train.h"

/* Unit quaternion (w, x, y, z) of a rotation matrix (row-major), Shepperd's method: the
 * largest of the four diagonal combinations is used for the square root. */
static void quat_from_matrix(const double R[9], double q[4])
{
    double tr = R[0] + R[4] + R[8];
    if (tr > 0) {
        double s = 2 * sqrt(1 + tr);
        q[0] = 0.25 * s, q[1] = (R[7] - R[5]) / s, q[2] = (R[2] - R[6]) / s, q[3] = (R[3] - R[1]) / s;
    } else if (R[0] > R[4] && R[0] > R[8]) {
        double s = 2 * sqrt(1 + R[0] - R[4] - R[8]);
        q[0] = (R[7] - R[5]) / s, q[1] = 0.25 * s, q[2] = (R[1] + R[3]) / s, q[3] = (R[2] + R[6]) / s;
    } else if (R[4] > R[8]) {
        double s = 2 * sqrt(1 + R[4] - R[0] - R[8]);
        q[0] = (R[2] - R[6]) / s, q[1] = (R[1] + R[3]) / s, q[2] = 0.25 * s, q[3] = (R[5] + R[7]) / s;
    } else {
        double s = 2 * sqrt(1 + R[8] - R[0] - R[4]);
        q[0] = (R[3] - R[1]) / s, q[1] = (R[2] + R[6]) / s, q[2] = (R[5] + R[7]) / s, q[3] = 0.25 * s;
    }
}

static void matrix_from_quat(const double q_in[4], double R[9])
{
    double n = sqrt(q_in[0] * q_in[0] + q_in[1] * q_in[1] + q_in[2] * q_in[2] + q_in[3] * q_in[3]);
    double w = q_in[0] / n, x = q_in[1] / n, y = q_in[2] / n, z = q_in[3] / n;
    R[0] = 1 - 2 * (y * y + z * z), R[1] = 2 * (x * y - w * z), R[2] = 2 * (x * z + w * y);
    R[3] = 2 * (x * y + w * z), R[4] = 1 - 2 * (x * x + z * z), R[5] = 2 * (y * z - w * x);
    R[6] = 2 * (x * z - w * y), R[7] = 2 * (y * z + w * x), R[8] = 1 - 2 * (x * x + y * y);
}

static void slerp(const double a[4], const double b_in[4], double s, double out[4])
{
    double b[4], dot = 0;
    for (int i = 0; i < 4; i++) dot += a[i] * b_in[i];
    double sign = dot < 0 ? -1 : 1; /* q and -q are the same rotation: take the short arc */
    for (int i = 0; i < 4; i++) b[i] = sign * b_in[i];
    dot *= sign;
    double wa = 1 - s, wb = s;
    if (dot < 0.9995) { /* else nearly parallel: linear, then normalised */
        double theta = acos(dot), st = sin(theta);
        wa = sin((1 - s) * theta) / st, wb = sin(s * theta) / st;
    }
    double n = 0;
    for (int i = 0; i < 4; i++) out[i] = wa * a[i] + wb * b[i], n += out[i] * out[i];
    for (int i = 0; i < 4; i++) out[i] /= sqrt(n);
}

void gv_camera_interpolate(const gv_camera *a, const gv_camera *b, double s, gv_camera *out)
{
    double qa[4], qb[4], q[4], ca[3], cb[3], c[3];
    quat_from_matrix(a->R, qa);
    quat_from_matrix(b->R, qb);
    slerp(qa, qb, s, q);
    gv_camera_center(a, ca);
    gv_camera_center(b, cb);
    gv_camera r = *a;
    matrix_from_quat(q, r.R);
    for (int i = 0; i < 3; i++) c[i] = (1 - s) * ca[i] + s * cb[i];
    for (int i = 0; i < 3; i++) r.t[i] = -(r.R[3 * i] * c[0] + r.R[3 * i + 1] * c[1] + r.R[3 * i + 2] * c[2]);
    r.fx = (1 - s) * a->fx + s * b->fx, r.fy = (1 - s) * a->fy + s * b->fy;
    r.cx = (1 - s) * a->cx + s * b->cx, r.cy = (1 - s) * a->cy + s * b->cy;
    *out = r;
}

void gv_camera_path(const gv_camera *keys, int n_keys, int n_out, gv_camera *out)
{
    for (int i = 0; i < n_out; i++) {
        if (n_keys < 2 || n_out < 2) { out[i] = keys[0]; continue; }
        double u = (double)i * (n_keys - 1) / (n_out - 1); /* 0 .. n_keys - 1 */
        int k = (int)u;
        if (k >= n_keys - 1) k = n_keys - 2;
        gv_camera_interpolate(&keys[k], &keys[k + 1], u - k, &out[i]);
    }
}
