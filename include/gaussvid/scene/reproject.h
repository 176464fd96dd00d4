/* Reprojection of one view into another by a depth map, with an occlusion test: the warp of
 * a clean anchor image into a target view and the mask of the target pixels the anchor
 * sees (docs/SPLAT_TRAINING.md, "Coverage by the anchors").
 *
 * Depth maps hold per pixel the view-space z (OpenCV axes, as gv_camera) of the surface
 * seen there, 0 where there is none, e.g. the expected depth of a 3DGS render
 * (gv_splat_render_depth). Pixel (i, j) has its centre at (i + 0.5, j + 0.5). */
#ifndef GAUSSVID_REPROJECT_H
#define GAUSSVID_REPROJECT_H

#include <stdint.h>

#include "gaussvid/scene/scene.h"

/* The point seen at continuous pixel position (u, v) of camera `from` at view depth z, in
 * camera `to`: its pixel position (u_to, v_to) and view depth z_to. Returns 1 when the point
 * is in front of `to` (z_to > 0), else 0 (the outputs are then not set). */
int gv_reproject_point(const gv_camera *from, double u, double v, double z, const gv_camera *to,
                       double *u_to, double *v_to, double *z_to);

/* Warps an anchor into a target view. For each target pixel with depth z > 0, its surface
 * point is projected into the anchor (depth z_a, position p); the pixel is covered when p
 * falls inside the anchor image, z_a > 0, and the anchor's own depth D at the pixel holding
 * p agrees: |D - z_a| <= rel_tolerance z_a (D = 0, no surface, never agrees). A covered
 * pixel's colour is the bilinear interpolation of anchor_rgb at p over those of the four
 * nearest anchor pixels that pass the same depth test (weights renormalised), so colours
 * from across a depth edge are not mixed in. Uncovered pixels get colour 0.
 * Sizes are the cameras': target_depth, covered target W x H; warped_rgb target W x H x 3;
 * anchor_depth anchor W x H; anchor_rgb anchor W x H x 3 (HWC floats). covered gets 1 or 0
 * per pixel. With warped_rgb NULL only the coverage is computed (anchor_rgb is then not read
 * and may be NULL). Fails on a non-positive or non-finite tolerance or a bad camera. */
int gv_reproject_anchor(const gv_camera *target, const float *target_depth,
                        const gv_camera *anchor, const float *anchor_depth,
                        const float *anchor_rgb, double rel_tolerance, float *warped_rgb,
                        uint8_t *covered);

#endif
