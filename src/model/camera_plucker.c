/* Plücker ray fields (paper 3.3.1, docs/ARCHITECTURE.md 6.4; the authors' construction in
 * docs/reference/wan-vace-gaussvid.md 1.4 and 6.1): unit directions and moments per pixel centre,
 * relative to the first anchor camera, translations divided by a per-clip length, packed in time
 * like the VAE packs frames. */
#include "gaussvid/model/plucker.h"
#include "gaussvid/core/core.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

/* C = -R^T t (world coordinates). */
static void centre(const gv_camera *c, double C[3])
{
    for (int i = 0; i < 3; i++) C[i] = -(c->R[0 * 3 + i] * c->t[0] + c->R[1 * 3 + i] * c->t[1] + c->R[2 * 3 + i] * c->t[2]);
}

double gv_plucker_scale(const gv_camera *cams, int n)
{
    double C0[3], best = 0;
    centre(&cams[0], C0);
    for (int i = 1; i < n; i++) {
        double C[3];
        centre(&cams[i], C);
        double d = sqrt((C[0] - C0[0]) * (C[0] - C0[0]) + (C[1] - C0[1]) * (C[1] - C0[1]) + (C[2] - C0[2]) * (C[2] - C0[2]));
        if (d > best) best = d;
    }
    /* every centre at the first one: moments are zero whatever the scale */
    return best > 1e-12 ? best : 1.0;
}

/* Finite intrinsics, fx, fy > 0, and R orthonormal (R^-1 = R^T is used below). */
static int check_camera(const gv_camera *c, const char *which)
{
    if (!(isfinite(c->fx) && isfinite(c->fy) && c->fx > 0 && c->fy > 0 && isfinite(c->cx) && isfinite(c->cy)))
        return gv_fail("%s: focal lengths must be positive and intrinsics finite", which);
    for (int i = 0; i < 3; i++) {
        if (!isfinite(c->t[i])) return gv_fail("%s: translation is not finite", which);
        for (int j = 0; j < 3; j++) {
            double dot = 0;
            for (int k = 0; k < 3; k++) dot += c->R[i * 3 + k] * c->R[j * 3 + k];
            if (!(fabs(dot - (i == j)) < 1e-4)) return gv_fail("%s: R is not a rotation", which);
        }
    }
    return 0;
}

int gv_plucker_rays(const gv_camera *cam, const gv_camera *ref, double scale, int height, int width, float *out)
{
    if (height < 1 || width < 1) return gv_fail("plucker: image size %dx%d", width, height);
    if (!(isfinite(scale) && scale > 0)) return gv_fail("plucker: translation scale %g must be positive", scale);
    if (check_camera(cam, "plucker: camera") || check_camera(ref, "plucker: reference camera")) return -1;
    /* In the reference frame: directions rotate by Q = R_ref R^T, centres map to
     * R_ref C + t_ref (docs/ARCHITECTURE.md 6.4: poses relative to the first anchor camera). */
    double Q[9], C[3], Cr[3];
    for (int i = 0; i < 3; i++)
        for (int j = 0; j < 3; j++) {
            double s = 0;
            for (int k = 0; k < 3; k++) s += ref->R[i * 3 + k] * cam->R[j * 3 + k];
            Q[i * 3 + j] = s;
        }
    centre(cam, C);
    for (int i = 0; i < 3; i++)
        Cr[i] = (ref->R[i * 3 + 0] * C[0] + ref->R[i * 3 + 1] * C[1] + ref->R[i * 3 + 2] * C[2] + ref->t[i]) / scale;
    const int64_t plane = (int64_t)height * width;
    for (int y = 0; y < height; y++)
        for (int x = 0; x < width; x++) {
            double dc[3] = {(x + 0.5 - cam->cx) / cam->fx, (y + 0.5 - cam->cy) / cam->fy, 1.0};
            double len = sqrt(dc[0] * dc[0] + dc[1] * dc[1] + 1.0), d[3];
            for (int i = 0; i < 3; i++) d[i] = (Q[i * 3] * dc[0] + Q[i * 3 + 1] * dc[1] + Q[i * 3 + 2] * dc[2]) / len;
            double m[3] = {Cr[1] * d[2] - Cr[2] * d[1], Cr[2] * d[0] - Cr[0] * d[2], Cr[0] * d[1] - Cr[1] * d[0]};
            int64_t p = (int64_t)y * width + x;
            for (int i = 0; i < 3; i++) {
                out[i * plane + p] = (float)m[i];
                out[(3 + i) * plane + p] = (float)d[i];
            }
        }
    return 0;
}

int gv_plucker_packed_frames(int frames, int temporal_factor)
{
    if (frames < 1 || temporal_factor < 1 || (frames - 1) % temporal_factor) return -1;
    return temporal_factor > 1 ? frames + temporal_factor - 1 : frames;
}

int gv_plucker_field(const gv_camera *cams, int frames, int height, int width, int temporal_factor, float *out,
                     double *scale_out)
{
    int packed = gv_plucker_packed_frames(frames, temporal_factor);
    if (packed < 0)
        return gv_fail("plucker: %d frames do not pack with temporal factor %d (need 1 + k x %d)", frames, temporal_factor,
                       temporal_factor);
    if (height < 1 || width < 1) return gv_fail("plucker: image size %dx%d", width, height);
    double scale = gv_plucker_scale(cams, frames);
    const int64_t plane = (int64_t)height * width;
    float *rays = malloc((size_t)(6 * plane) * sizeof *rays);
    if (!rays) return gv_fail("plucker: out of memory for %dx%d rays", width, height);
    int first_copy = packed - frames; /* the first frame fills slots 0..first_copy
                                         (docs/reference/wan-vace-gaussvid.md 1.4) */
    for (int f = 0; f < frames; f++) {
        if (gv_plucker_rays(&cams[f], &cams[0], scale, height, width, rays) != 0) {
            free(rays);
            return gv_fail_context("frame %d", f);
        }
        int lo = f == 0 ? 0 : f + first_copy, hi = f + first_copy;
        for (int p = lo; p <= hi; p++)
            for (int c = 0; c < 6; c++)
                memcpy(out + ((int64_t)c * packed + p) * plane, rays + c * plane, (size_t)plane * sizeof *out);
    }
    free(rays);
    if (scale_out) *scale_out = scale;
    return 0;
}
