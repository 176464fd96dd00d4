/* The VACE context of a clip from its frames (docs/reference/wan-vace-gaussvid.md 3.3 steps 2-5;
 * docs/ARCHITECTURE.md 6.3): the inactive part V (1 - M) and the reactive part V M encoded by the
 * VAE, and the mask on the latent grid, concatenated. For restoration M = 0 on the anchors (the
 * anchors variant) and 1 on the frames to restore; the coverage variant gives M per pixel
 * (condition.h). */
#include <stdlib.h>
#include <string.h>

#include "gaussvid/core/core.h"
#include "gaussvid/model/dit.h"
#include "gaussvid/model/vae.h"

int gv_vace_context_build_masked(gv_vae *v, const float *video, int frames, int height, int width,
                                 const float *mask, float *out)
{
    int tl = 0, z = v->cfg.z_dim, sf = v->cfg.spatial_factor;
    if (gv_vae_check_clip(&v->cfg, frames, height, width) || gv_vae_latent_frames(&v->cfg, frames, &tl))
        return gv_fail_context("vace context");
    int64_t plane = (int64_t)height * width, n = 3 * frames * plane, nz = (int64_t)z * tl * (plane / (sf * sf));
    float *part = malloc((size_t)n * sizeof *part), *zs = malloc((size_t)2 * nz * sizeof *zs);
    float *mask_latent = malloc((size_t)sf * sf * (nz / z) * sizeof *mask_latent);
    int rc = part && zs && mask_latent ? 0 : gv_fail("vace context: out of memory");
    for (int k = 0; rc == 0 && k < 2; k++) { /* k = 0: inactive V (1 - M); k = 1: reactive V M */
        for (int64_t i = 0; i < n; i++) {
            float m = mask[i % (frames * plane)];
            part[i] = video[i] * (k ? m : 1.0f - m);
        }
        rc = gv_vae_encode(v, part, frames, height, width, v->has_stats, v->cfg.temporal_factor, zs + k * nz);
    }
    if (rc == 0) rc = gv_vace_mask_latent(mask, frames, height, width, tl, sf, mask_latent);
    if (rc == 0) rc = gv_vace_context_concat(zs, zs + nz, mask_latent, z, sf * sf, tl, height / sf, width / sf, out);
    free(part), free(zs), free(mask_latent);
    return rc;
}

int gv_vace_context_build(gv_vae *v, const float *video, int frames, int height, int width, gv_anchors anchors,
                          float *out)
{
    if (frames < 1 || height < 1 || width < 1) return gv_vace_context_build_masked(v, video, frames, height, width, NULL, out);
    int64_t plane = (int64_t)height * width;
    float *frame_mask = malloc((size_t)frames * sizeof *frame_mask), *mask = malloc((size_t)frames * plane * sizeof *mask);
    int rc = frame_mask && mask ? gv_vace_frame_mask(anchors, frames, frame_mask) : gv_fail("vace context: out of memory");
    for (int f = 0; rc == 0 && f < frames; f++)
        for (int64_t i = 0; i < plane; i++) mask[f * plane + i] = frame_mask[f];
    if (rc == 0) rc = gv_vace_context_build_masked(v, video, frames, height, width, mask, out);
    free(frame_mask), free(mask);
    return rc;
}
