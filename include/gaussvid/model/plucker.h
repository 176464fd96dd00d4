/* Plücker ray fields of a clip's cameras (paper 3.3.1, docs/ARCHITECTURE.md 6.4): for every pixel centre
 * the unit direction d = R^-1 K^-1 (u, v, 1)^T and the moment m = C x d with C = -R^-1 T, all
 * poses expressed in the first anchor camera's frame and translations divided by a per-clip
 * length (gv_plucker_scale), then packed in time as the VAE packs frames, so that the camera
 * encoder's Conv3D yields one token per video token. Channel order [m (3), d (3)] as the
 * authors' code (docs/reference/wan-vace-gaussvid.md 1.4, 6.1). Cameras are OpenCV world-to-camera
 * (camera.h). */
#ifndef GAUSSVID_PLUCKER_H
#define GAUSSVID_PLUCKER_H

#include "gaussvid/core/camera.h"

/* The per-clip length: the largest distance of a camera centre from the first camera's
 * centre (1 when every centre coincides), so that moments are of order 1 across scenes. */
double gv_plucker_scale(const gv_camera *cams, int n);
/* The rays of `cam` at height x width pixel centres ((i + 0.5, j + 0.5), intrinsics in those
 * pixels) in the frame of `ref`, translations divided by `scale`: out [6, height, width]. */
int gv_plucker_rays(const gv_camera *cam, const gv_camera *ref, double scale, int height,
                    int width, float *out);
/* Frames after temporal packing: frames + factor - 1 (the first frame repeated to fill the
 * first group) for factor > 1, else frames; -1 when frames is not 1 + k factor. */
int gv_plucker_packed_frames(int frames, int temporal_factor);
/* The packed field of a clip: out [6, packed, height, width] (gv_plucker_packed_frames),
 * relative to cams[0]; *scale_out (may be NULL) receives the length used. */
int gv_plucker_field(const gv_camera *cams, int frames, int height, int width, int temporal_factor,
                     float *out, double *scale_out);

#endif
