/* The network's conditioning of one clip (paper 3.3, 3.4; docs/ARCHITECTURE.md 6.3, 7): VAE latents of the
 * ground truth and of the input, the VACE context of the anchors variant and the Plücker
 * field of the cameras. condition.h says what each array holds and why. */
#include <stdlib.h>
#include <string.h>

#include "gaussvid/train/condition.h"
#include "gaussvid/core/core.h"
#include "gaussvid/model/dit.h"
#include "gaussvid/model/plucker.h"

int64_t gv_clip_latents_z_count(const gv_clip_latents *l)
{
    return (int64_t)l->batch * l->z_dim * l->latent_frames * l->lh * l->lw;
}

int64_t gv_clip_latents_vace_count(const gv_clip_latents *l)
{
    return (int64_t)l->batch * l->vace_dim * l->latent_frames * l->lh * l->lw;
}

int64_t gv_clip_latents_plucker_count(const gv_clip_latents *l)
{
    return (int64_t)l->batch * 6 * l->plucker_frames * l->height * l->width;
}

int gv_clip_latents_masked(const gv_clip_latents *l)
{
    for (int i = 0; i < GV_CLIP_FRAMES; i++)
        if (l->no_target[i]) return 1;
    return 0;
}

double gv_clip_latents_identity_loss(const gv_clip_latents *l)
{
    const int64_t plane = (int64_t)l->lh * l->lw;
    double sum = 0;
    int64_t n = 0;
    for (int b = 0; b < l->batch; b++)
        for (int c = 0; c < l->z_dim; c++)
            for (int t = 0; t < l->latent_frames; t++) {
                if (l->no_target[b * l->latent_frames + t]) continue;
                const int64_t at = (((int64_t)b * l->z_dim + c) * l->latent_frames + t) * plane;
                for (int64_t i = at; i < at + plane; i++) {
                    double d = (double)l->z_clean[i] - l->z_corrupt[i];
                    sum += d * d;
                }
                n += plane;
            }
    return n ? sum / (double)n : 0;
}

void gv_clip_latents_free(gv_clip_latents *l)
{
    if (!l) return;
    free(l->z_clean), free(l->z_corrupt), free(l->vace), free(l->plucker);
    memset(l, 0, sizeof *l);
}

void gv_clip_cameras(const gv_clip *clip, gv_camera cams[GV_CLIP_FRAMES])
{
    for (int f = 0; f < GV_CLIP_FRAMES; f++) {
        gv_camera *c = &cams[f];
        memset(c, 0, sizeof *c);
        c->width = clip->info.width, c->height = clip->info.height;
        const float *k = clip->intrinsics[f], *p = clip->poses[f];
        c->fx = k[0], c->fy = k[1], c->cx = k[2], c->cy = k[3];
        for (int r = 0; r < 3; r++) {
            for (int j = 0; j < 3; j++) c->R[r * 3 + j] = p[r * 4 + j];
            c->t[r] = p[r * 4 + 3];
        }
    }
}

void gv_clip_video(const uint8_t *frames, const gv_clip_info *info, int first, int count, float *video)
{
    const int64_t plane = (int64_t)info->height * info->width;
    for (int f = 0; f < count; f++) {
        const uint8_t *src = frames + (int64_t)(first + f) * plane * 3;
        for (int c = 0; c < 3; c++) {
            float *dst = video + ((int64_t)c * count + f) * plane;
            for (int64_t p = 0; p < plane; p++) dst[p] = src[p * 3 + c] / 127.5f - 1.0f;
        }
    }
}

int gv_condition_frame_blanked(const gv_model_config *cfg, int frame)
{
    if (frame != 0 && frame != GV_CLIP_FRAMES - 1) return 0;
    float mask[GV_CLIP_FRAMES];
    gv_vace_frame_mask(cfg->variant.anchors, GV_CLIP_FRAMES, mask);
    return mask[frame] != 0.0f;
}

int gv_condition_padded_size(const gv_model_config *cfg, int width, int height, int *padded_width, int *padded_height)
{
    const int bh = cfg->vae.spatial_factor * cfg->dit.patch_size[1], bw = cfg->vae.spatial_factor * cfg->dit.patch_size[2];
    if (width < 1 || height < 1) return gv_fail("a %dx%d picture: the restorer needs at least one pixel", width, height);
    if (bh < 1 || bw < 1) return gv_fail("config %s: a block of %dx%d pixels", cfg->name, bw, bh);
    *padded_width = (width + bw - 1) / bw * bw, *padded_height = (height + bh - 1) / bh * bh;
    return 0;
}

/* The model config must describe this VAE, and the padded clip (width x height) must fit the
 * VAE and the DiT patch. */
static int check_sizes(const gv_vae *vae, const gv_model_config *cfg, int width, int height, int frames)
{
    const gv_vae_config *v = &vae->cfg;
    const gv_dit_config *d = &cfg->dit;
    if (!vae->has_stats)
        return gv_fail("the VAE has no latent statistics (the network works on normalised latents)");
    if (v->z_dim != cfg->vae.z_dim || v->spatial_factor != cfg->vae.spatial_factor ||
        v->temporal_factor != cfg->vae.temporal_factor || d->in_dim != v->z_dim)
        return gv_fail("the VAE (z_dim %d, factors %d x %d) is not the one of config %s (z_dim %d, factors %d x %d)",
                       v->z_dim, v->spatial_factor, v->temporal_factor, cfg->name, cfg->vae.z_dim,
                       cfg->vae.spatial_factor, cfg->vae.temporal_factor);
    if (d->vace_in_dim != 2 * v->z_dim + v->spatial_factor * v->spatial_factor)
        return gv_fail("config %s: vace_in_dim %d is not 2 x %d + %d^2", cfg->name, d->vace_in_dim, v->z_dim,
                       v->spatial_factor);
    if (gv_vae_check_clip(v, frames, height, width)) return -1;
    int lt = 1 + (frames - 1) / v->temporal_factor;
    if (lt % d->patch_size[0])
        return gv_fail("a %d-frame clip gives %d latent frames, not a multiple of the DiT patch %d", frames, lt,
                       d->patch_size[0]);
    return 0;
}

int gv_condition_vace_mask(const gv_model_config *cfg, const gv_clip *clip, float *mask)
{
    const gv_clip_info *info = &clip->info;
    const int64_t plane = (int64_t)info->height * info->width;
    float frame_mask[GV_CLIP_FRAMES];
    if (gv_vace_frame_mask(cfg->variant.anchors, GV_CLIP_FRAMES, frame_mask)) return -1;
    for (int f = 0; f < GV_CLIP_FRAMES; f++) {
        float *m = mask + f * plane;
        int per_pixel = cfg->variant.coverage && clip->coverage && f > 0 && f < GV_CLIP_FRAMES - 1;
        const uint8_t *seen = per_pixel ? clip->coverage + (f - 1) * plane : NULL;
        for (int64_t p = 0; p < plane; p++) m[p] = seen ? (seen[p] ? 0.0f : 1.0f) : frame_mask[f];
    }
    return 0;
}

/* The video model: one 5-frame clip, batch 1. The VACE context is built from the input clip
 * after blanking (condition.h) by gv_vace_context_build_masked (docs/reference/wan-vace-gaussvid.md
 * 3.3 steps 2-5). */
static int prepare_clip(gv_vae *vae, const gv_model_config *cfg, const gv_clip *clip, gv_clip_latents *l)
{
    const gv_clip_info *info = &clip->info;
    const int F = GV_CLIP_FRAMES, tf = vae->cfg.temporal_factor;
    const int64_t plane = (int64_t)info->height * info->width;
    float *gt = malloc((size_t)(3 * F * plane) * sizeof(float));
    float *in = malloc((size_t)(3 * F * plane) * sizeof(float));
    float *mask = malloc((size_t)(F * plane) * sizeof(float));
    int rc = -1;
    if (!gt || !in || !mask) {
        gv_fail("out of memory for a %dx%d clip", info->width, info->height);
        goto done;
    }
    gv_clip_video(clip->targets, info, 0, F, gt);
    gv_clip_video(clip->inputs, info, 0, F, in);
    for (int f = 0; f < F; f++)
        if (gv_condition_frame_blanked(cfg, f))
            for (int c = 0; c < 3; c++) memset(in + ((int64_t)c * F + f) * plane, 0, (size_t)plane * sizeof(float));
    if (gv_vae_encode(vae, gt, F, info->height, info->width, 1, tf, l->z_clean) ||
        gv_vae_encode(vae, in, F, info->height, info->width, 1, tf, l->z_corrupt) ||
        gv_condition_vace_mask(cfg, clip, mask) ||
        gv_vace_context_build_masked(vae, in, F, info->height, info->width, mask, l->vace))
        goto done;
    rc = 0;
done:
    free(gt), free(in), free(mask);
    return rc;
}

/* The per-frame restorer: the three intermediates, each a 1-frame clip (batch 3), with no
 * anchors (M = 1: inactive = zeros, reactive = the render). */
static int prepare_per_frame(gv_vae *vae, const gv_model_config *cfg, const gv_clip *clip, gv_clip_latents *l)
{
    const gv_clip_info *info = &clip->info;
    const int tf = vae->cfg.temporal_factor;
    const int64_t plane = (int64_t)info->height * info->width, per = (int64_t)l->z_dim * l->lh * l->lw;
    const int64_t vace_per = (int64_t)l->vace_dim * l->lh * l->lw;
    float *video = malloc((size_t)(3 * plane) * sizeof(float));
    if (!video) return gv_fail("out of memory for a %dx%d clip", info->width, info->height);
    int rc = 0;
    for (int b = 0; rc == 0 && b < l->batch; b++) {
        gv_clip_video(clip->targets, info, 1 + b, 1, video);
        rc = gv_vae_encode(vae, video, 1, info->height, info->width, 1, tf, l->z_clean + b * per);
        gv_clip_video(clip->inputs, info, 1 + b, 1, video);
        if (rc == 0) rc = gv_vae_encode(vae, video, 1, info->height, info->width, 1, tf, l->z_corrupt + b * per);
        if (rc == 0) rc = gv_vace_context_build(vae, video, 1, info->height, info->width, GV_ANCHORS_NONE, l->vace + b * vace_per);
    }
    free(video);
    return rc;
}

int gv_clip_latents_shape(const gv_vae *vae, const gv_model_config *cfg, const gv_clip_info *info, gv_clip_latents *l)
{
    memset(l, 0, sizeof *l);
    int per_frame = cfg->variant.per_frame, frames = per_frame ? 1 : GV_CLIP_FRAMES, width = 0, height = 0;
    if (gv_condition_padded_size(cfg, info->width, info->height, &width, &height) ||
        check_sizes(vae, cfg, width, height, frames))
        return gv_fail_context("clip %s n%d frames %d-%d", info->id.scene, info->id.interval, info->frames[0],
                               info->frames[GV_CLIP_FRAMES - 1]);
    l->interval = info->id.interval;
    l->frames = GV_CLIP_FRAMES, l->height = height, l->width = width;
    l->batch = per_frame ? GV_CLIP_FRAMES - 2 : 1;
    l->z_dim = vae->cfg.z_dim;
    l->latent_frames = 1 + (frames - 1) / vae->cfg.temporal_factor;
    l->lh = height / vae->cfg.spatial_factor, l->lw = width / vae->cfg.spatial_factor;
    l->vace_dim = cfg->dit.vace_in_dim;
    l->plucker_frames = gv_plucker_packed_frames(frames, vae->cfg.temporal_factor);
    /* frames without ground truth (target_mask): a latent frame packs the first frame alone,
     * then groups of the temporal factor, and has none when any frame it packs has none; the
     * per-frame restorer's batch b is intermediate b + 1 */
    const int tf = vae->cfg.temporal_factor;
    for (int b = 0; b < l->batch; b++)
        for (int t = 0; t < l->latent_frames; t++) {
            int from = per_frame ? 1 + b : t == 0 ? 0 : 1 + (t - 1) * tf, to = per_frame || t == 0 ? from : t * tf;
            for (int f = from; f <= to && f < GV_CLIP_FRAMES; f++)
                l->no_target[b * l->latent_frames + t] |= info->no_target[f];
        }
    return 0;
}

int gv_clip_latents_alloc(gv_clip_latents *l, int with_plucker)
{
    l->z_clean = malloc((size_t)gv_clip_latents_z_count(l) * sizeof(float));
    l->z_corrupt = malloc((size_t)gv_clip_latents_z_count(l) * sizeof(float));
    l->vace = malloc((size_t)gv_clip_latents_vace_count(l) * sizeof(float));
    if (with_plucker) l->plucker = malloc((size_t)gv_clip_latents_plucker_count(l) * sizeof(float));
    if (!l->z_clean || !l->z_corrupt || !l->vace || (with_plucker && !l->plucker)) {
        gv_clip_latents_free(l);
        return gv_fail("out of memory for the latents of a %dx%d clip", l->width, l->height);
    }
    return 0;
}

int gv_clip_latents_plucker(const gv_clip *clip, int temporal_factor, gv_clip_latents *l)
{
    /* the latents' (padded) size: rays through the padding's pixel centres, same intrinsics */
    const int height = l->height, width = l->width;
    gv_camera cams[GV_CLIP_FRAMES];
    gv_clip_cameras(clip, cams);
    for (int f = 0; f < GV_CLIP_FRAMES; f++) cams[f].width = width, cams[f].height = height;
    if (l->batch == 1) return gv_plucker_field(cams, GV_CLIP_FRAMES, height, width, temporal_factor, l->plucker, NULL);
    /* per-frame: each intermediate relative to the first anchor with the clip's length, its rays
     * repeated to fill the packed group of a 1-frame clip (plucker.h) */
    const int64_t plane = (int64_t)height * width;
    float *rays = malloc((size_t)(6 * plane) * sizeof *rays);
    if (!rays) return gv_fail("out of memory for %dx%d rays", width, height);
    double scale = gv_plucker_scale(cams, GV_CLIP_FRAMES);
    for (int b = 0; b < l->batch; b++) {
        if (gv_plucker_rays(&cams[1 + b], &cams[0], scale, height, width, rays)) {
            free(rays);
            return -1;
        }
        for (int c = 0; c < 6; c++)
            for (int k = 0; k < l->plucker_frames; k++)
                memcpy(l->plucker + (((int64_t)b * 6 + c) * l->plucker_frames + k) * plane, rays + c * plane,
                       (size_t)plane * sizeof(float));
    }
    free(rays);
    return 0;
}

int gv_clip_latents_prepare(gv_vae *vae, const gv_model_config *cfg, const gv_clip *clip, gv_clip_latents *out)
{
    const gv_clip_info *info = &clip->info;
    if (gv_clip_latents_shape(vae, cfg, info, out) ||
        gv_clip_latents_alloc(out, cfg->variant.camera != GV_CAMERA_NONE))
        return -1;
    /* a clip off the block is encoded padded (condition.h) */
    gv_clip padded;
    memset(&padded, 0, sizeof padded);
    int pad = out->width != info->width || out->height != info->height;
    int rc = pad ? gv_clip_pad(clip, out->width, out->height, &padded) : 0;
    const gv_clip *c = pad ? &padded : clip;
    if (rc == 0) rc = cfg->variant.per_frame ? prepare_per_frame(vae, cfg, c, out) : prepare_clip(vae, cfg, c, out);
    if (rc == 0 && out->plucker) rc = gv_clip_latents_plucker(c, vae->cfg.temporal_factor, out);
    gv_clip_free(&padded);
    if (rc) {
        gv_clip_latents_free(out);
        return gv_fail_context("clip %s n%d frames %d-%d", info->id.scene, info->id.interval, info->frames[0],
                               info->frames[GV_CLIP_FRAMES - 1]);
    }
    return 0;
}
