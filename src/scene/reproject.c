/* Reprojection between two cameras by depth, and the warp of an anchor image into a target
 * view with an occlusion test against the anchor's own depth map (include/gaussvid/
 * reproject.h). Everything in double: the positions of a plane seen by two cameras land on
 * the hand-derived pixels to rounding. */
#include <math.h>

#include "gaussvid/core/core.h"
#include "gaussvid/scene/reproject.h"

int gv_reproject_point(const gv_camera *from, double u, double v, double z, const gv_camera *to,
                       double *u_to, double *v_to, double *z_to)
{
    /* view point of `from`, then world X = R^T (c - t), then view point of `to` */
    double c[3] = {(u - from->cx) / from->fx * z, (v - from->cy) / from->fy * z, z};
    double d[3] = {c[0] - from->t[0], c[1] - from->t[1], c[2] - from->t[2]}, X[3], p[3];
    for (int k = 0; k < 3; k++)
        X[k] = from->R[k] * d[0] + from->R[3 + k] * d[1] + from->R[6 + k] * d[2];
    for (int k = 0; k < 3; k++)
        p[k] = to->R[3 * k] * X[0] + to->R[3 * k + 1] * X[1] + to->R[3 * k + 2] * X[2] + to->t[k];
    if (!(p[2] > 0)) return 0;
    *u_to = to->fx * p[0] / p[2] + to->cx;
    *v_to = to->fy * p[1] / p[2] + to->cy;
    *z_to = p[2];
    return 1;
}

static int check_camera(const gv_camera *cam, const char *role)
{
    if (cam->width <= 0 || cam->height <= 0 || !(cam->fx > 0) || !(cam->fy > 0) ||
        !isfinite(cam->fx) || !isfinite(cam->fy) || !isfinite(cam->cx) || !isfinite(cam->cy))
        return gv_fail("reproject: %s camera %s has a bad size or intrinsics", role, cam->name);
    return 0;
}

/* Whether the anchor's depth at pixel (x, y) agrees with z (see the header). */
static int depth_agrees(const gv_camera *anchor, const float *anchor_depth, int x, int y,
                        double z, double tol)
{
    if (x < 0 || y < 0 || x >= anchor->width || y >= anchor->height) return 0;
    double D = anchor_depth[(size_t)y * anchor->width + x];
    return D > 0 && fabs(D - z) <= tol * z;
}

/* Warps one target pixel; returns 1 when covered. */
static int warp_pixel(const gv_camera *target, int i, int j, double z, const gv_camera *anchor,
                      const float *anchor_depth, const float *anchor_rgb, double tol,
                      float rgb[3])
{
    double ua, va, za;
    if (!(z > 0) || !isfinite(z)) return 0;
    if (!gv_reproject_point(target, i + 0.5, j + 0.5, z, anchor, &ua, &va, &za)) return 0;
    if (!(ua >= 0 && va >= 0 && ua < anchor->width && va < anchor->height)) return 0;
    if (!depth_agrees(anchor, anchor_depth, (int)ua, (int)va, za, tol)) return 0;
    if (!anchor_rgb) return 1; /* coverage only */
    /* bilinear between pixel centres, over the neighbours that see the same surface */
    double fx = ua - 0.5, fy = va - 0.5, x0 = floor(fx), y0 = floor(fy);
    double ax = fx - x0, ay = fy - y0, sum = 0, acc[3] = {0, 0, 0};
    for (int dy = 0; dy < 2; dy++)
        for (int dx = 0; dx < 2; dx++) {
            int x = (int)x0 + dx, y = (int)y0 + dy;
            double w = (dx ? ax : 1 - ax) * (dy ? ay : 1 - ay);
            if (w == 0 || !depth_agrees(anchor, anchor_depth, x, y, za, tol)) continue;
            const float *c = anchor_rgb + ((size_t)y * anchor->width + x) * 3;
            for (int k = 0; k < 3; k++) acc[k] += w * c[k];
            sum += w;
        }
    /* the pixel holding p is one of the four, with weight >= 1/4 */
    for (int k = 0; k < 3; k++) rgb[k] = (float)(acc[k] / sum);
    return 1;
}

int gv_reproject_anchor(const gv_camera *target, const float *target_depth,
                        const gv_camera *anchor, const float *anchor_depth,
                        const float *anchor_rgb, double rel_tolerance, float *warped_rgb,
                        uint8_t *covered)
{
    if (!(rel_tolerance > 0) || !isfinite(rel_tolerance))
        return gv_fail("reproject: depth tolerance %g is not a positive number", rel_tolerance);
    if (check_camera(target, "target") != 0 || check_camera(anchor, "anchor") != 0) return -1;
    int width = target->width, height = target->height;
#pragma omp parallel for schedule(static)
    for (int j = 0; j < height; j++)
        for (int i = 0; i < width; i++) {
            size_t p = (size_t)j * width + i;
            float *rgb = warped_rgb ? warped_rgb + 3 * p : NULL;
            covered[p] = (uint8_t)warp_pixel(target, i, j, target_depth[p], anchor, anchor_depth,
                                             rgb ? anchor_rgb : NULL, rel_tolerance, rgb);
            if (rgb && !covered[p]) rgb[0] = rgb[1] = rgb[2] = 0;
        }
    return 0;
}
