/* What residual decoding (gv_vae_decode_residual, docs/VAE.md "Residual decoding") gives on
 * dataset clips against the plain decode, with a perfect restorer (z_restored = E(ground
 * truth)) as the upper bound. */
#include <stdlib.h>
#include <string.h>

#include "gaussvid/core/core.h"
#include "gaussvid/io/metrics.h"
#include "gaussvid/eval/eval.h"

/* 8-bit [T, H, W, 3] frames, the w x h window at (x0, y0), as [3, T, h, w] in [-1, 1]. */
static void to_clip(const uint8_t *frames, int T, int H, int W, int x0, int y0, int h, int w, float *out)
{
    (void)H;
    for (int c = 0; c < 3; c++)
        for (int t = 0; t < T; t++)
            for (int y = 0; y < h; y++)
                for (int x = 0; x < w; x++)
                    out[(((int64_t)c * T + t) * h + y) * w + x] =
                        frames[(((int64_t)t * H + y0 + y) * W + x0 + x) * 3 + c] / 127.5f - 1.0f;
}

/* Frame t of a [3, T, h, w] clip in [-1, 1] as HWC in [0, 1]. */
static void frame_hwc(const float *clip, int T, int t, int h, int w, float *out)
{
    int64_t plane = (int64_t)h * w;
    for (int64_t i = 0; i < plane; i++)
        for (int c = 0; c < 3; c++) out[i * 3 + c] = 0.5f * (clip[((int64_t)c * T + t) * plane + i] + 1.0f);
}

/* Adds the PSNR and SSIM of frame t of `clip` against the target's to *psnr and *ssim. */
static int score_frame(const float *clip, const float *target, int T, int t, int h, int w, float *a, float *b,
                       double *psnr, double *ssim)
{
    frame_hwc(clip, T, t, h, w, a);
    frame_hwc(target, T, t, h, w, b);
    double p = gv_psnr(a, b, w, h, 3), s = gv_ssim(a, b, w, h, 3);
    if (s != s) return -1;
    *psnr += p > 100 ? 100 : p; /* identical frames: count 100 dB, not infinity */
    *ssim += s;
    return 0;
}

/* The five clips being compared, [3, T, h, w] each, and two HWC frame buffers. */
typedef struct {
    float *render, *target, *vae_render, *vae_target, *same, *upper, *a, *b, *z_render, *z_target;
} buffers;

static int score_all(const buffers *k, int T, int h, int w, const int *score, gv_vae_residual_scores *s)
{
    int64_t n = 3LL * T * h * w;
    gv_vae_compose_residual(k->render, k->vae_render, k->vae_render, n, k->same);
    gv_vae_compose_residual(k->render, k->vae_target, k->vae_render, n, k->upper);
    for (int64_t i = 0; i < n; i++) {
        double d = k->same[i] > k->render[i] ? k->same[i] - k->render[i] : k->render[i] - k->same[i];
        if (d > s->max_abs_same) s->max_abs_same = d;
    }
    for (int t = 0; t < T; t++) {
        if (!score[t]) continue;
        const float *clips[5] = {k->render, k->vae_render, k->vae_target, k->same, k->upper};
        for (int q = 0; q < 5; q++)
            if (score_frame(clips[q], k->target, T, t, h, w, k->a, k->b, &s->psnr[q], &s->ssim[q])) return -1;
        s->n_frames++;
    }
    s->n_clips++;
    return 0;
}

int gv_vae_residual_score_clip(gv_vae *v, const uint8_t *inputs, const uint8_t *targets, int frames, int height,
                               int width, const int *score, gv_vae_residual_scores *s)
{
    int sf = v->cfg.spatial_factor, r = v->cfg.temporal_factor, tl = 0;
    int h = height / sf * sf, w = width / sf * sf;
    if (gv_vae_latent_frames(&v->cfg, frames, &tl) || gv_vae_check_clip(&v->cfg, frames, h, w))
        return gv_fail_context("vae residual: a %d-frame %dx%d clip", frames, width, height);
    int64_t n = 3LL * frames * h * w, nz = (int64_t)v->cfg.z_dim * tl * (h / sf) * (w / sf);
    buffers k;
    float **all[10] = {&k.render, &k.target, &k.vae_render, &k.vae_target, &k.same, &k.upper, &k.a, &k.b, &k.z_render, &k.z_target};
    int64_t sizes[10] = {n, n, n, n, n, n, 3LL * h * w, 3LL * h * w, nz, nz};
    int rc = 0;
    for (int i = 0; i < 10; i++)
        if (!(*all[i] = malloc((size_t)sizes[i] * sizeof(float)))) rc = gv_fail("vae residual: out of memory");
    int x0 = (width - w) / 2, y0 = (height - h) / 2;
    if (rc == 0) {
        to_clip(inputs, frames, height, width, x0, y0, h, w, k.render);
        to_clip(targets, frames, height, width, x0, y0, h, w, k.target);
        rc = gv_vae_encode(v, k.render, frames, h, w, 0, r, k.z_render) ||
             gv_vae_encode(v, k.target, frames, h, w, 0, r, k.z_target) ||
             gv_vae_decode(v, k.z_render, tl, h / sf, w / sf, 0, 1, k.vae_render) ||
             gv_vae_decode(v, k.z_target, tl, h / sf, w / sf, 0, 1, k.vae_target);
    }
    if (rc == 0) rc = score_all(&k, frames, h, w, score, s);
    for (int i = 0; i < 10; i++) free(*all[i]);
    return rc ? -1 : 0;
}

void gv_vae_residual_finish(gv_vae_residual_scores *s)
{
    for (int q = 0; q < GV_VAE_RESIDUAL_KINDS && s->n_frames > 0; q++) {
        s->psnr[q] /= s->n_frames;
        s->ssim[q] /= s->n_frames;
    }
}
