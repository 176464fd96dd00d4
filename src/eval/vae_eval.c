/* Reconstruction quality of the VAE on whole frames: clips encoded and decoded as the
 * restorer will use them (chunked through the caches, output clamped), PSNR and SSIM per frame
 * as the 3DGS evaluation computes them (metrics.h), on images in [0, 1]. */
#include <stdlib.h>
#include <string.h>

#include "gaussvid/core/core.h"
#include "gaussvid/io/metrics.h"
#include "gaussvid/eval/eval.h"

/* Frame t of a channel-first clip [3, T, h, w] in [-1, 1] as HWC in [0, 1]. */
static void frame_hwc(const float *clip, int T, int t, int h, int w, float *out)
{
    int64_t plane = (int64_t)h * w;
    for (int64_t i = 0; i < plane; i++)
        for (int c = 0; c < 3; c++) out[i * 3 + c] = 0.5f * (clip[((int64_t)c * T + t) * plane + i] + 1.0f);
}

static int evaluate_clip(gv_vae *v, const float *x, int T, int h, int w, float *lat, float *y, float *a, float *b,
                         gv_vae_eval_result *r)
{
    int s = v->cfg.spatial_factor, tl = 1 + (T - 1) / v->cfg.temporal_factor;
    if (gv_vae_encode(v, x, T, h, w, 0, v->cfg.temporal_factor, lat) ||
        gv_vae_decode(v, lat, tl, h / s, w / s, 0, 1, y))
        return -1;
    for (int t = 0; t < T; t++) {
        frame_hwc(y, T, t, h, w, a);
        frame_hwc(x, T, t, h, w, b);
        double psnr = gv_psnr(a, b, w, h, 3), ssim = gv_ssim(a, b, w, h, 3);
        if (ssim != ssim) return -1;
        r->psnr += psnr;
        r->ssim += ssim;
        if (t == 0) r->psnr_first += psnr;
        else r->psnr_grouped += psnr;
        r->n_frames++;
    }
    r->n_clips++;
    return 0;
}

int gv_vae_evaluate(gv_vae *v, const gv_vae_frames *f, int frames, int stride, int max_clips, gv_vae_eval_result *r)
{
    memset(r, 0, sizeof *r);
    if (gv_vae_latent_frames(&v->cfg, frames, &(int){0})) return -1;
    if (stride < 1 || max_clips < 0) return gv_fail("vae eval: stride must be positive and max clips non-negative");
    double start = gv_now();
    int s = v->cfg.spatial_factor, rc = 0;
    for (int i = 0; i < f->n && rc == 0; i++) {
        const gv_vae_scene *sc = &f->scenes[i];
        int h = sc->height / s * s, w = sc->width / s * s, span = (frames - 1) * stride + 1;
        if (h < s || w < s || sc->n_frames < span) {
            rc = gv_fail("%s: %d frames of %dx%d hold no %d-frame clip (spacing %d) of a multiple of %d pixels", sc->dir,
                         sc->n_frames, sc->width, sc->height, frames, stride, s);
            break;
        }
        int n_clips = sc->n_frames / span;
        if (max_clips && n_clips > max_clips) n_clips = max_clips;
        int64_t plane = (int64_t)h * w, lat_n = (int64_t)v->cfg.z_dim * frames * (plane / (s * s));
        float *x = malloc(sizeof(float) * 3 * frames * plane), *y = malloc(sizeof(float) * 3 * frames * plane);
        float *lat = malloc(sizeof(float) * lat_n), *a = malloc(sizeof(float) * 3 * plane), *b = malloc(sizeof(float) * 3 * plane);
        if (!x || !y || !lat || !a || !b) rc = gv_fail("vae eval: out of memory");
        for (int k = 0; k < n_clips && rc == 0; k++) {
            /* clips spread evenly over the scene, centred crop */
            int t0 = n_clips > 1 ? (int)((int64_t)k * (sc->n_frames - span) / (n_clips - 1)) : 0;
            gv_vae_clip_extract(sc, t0, stride, frames, (sc->width - w) / 2, (sc->height - h) / 2, w, h, 0, x);
            rc = evaluate_clip(v, x, frames, h, w, lat, y, a, b, r);
            if (rc) gv_fail_context("%s", sc->dir);
        }
        free(x);
        free(y);
        free(lat);
        free(a);
        free(b);
    }
    if (rc == 0 && r->n_frames == 0) rc = gv_fail("vae eval: no frames to evaluate");
    if (rc) return -1;
    int grouped = r->n_frames - r->n_clips;
    r->psnr /= r->n_frames;
    r->ssim /= r->n_frames;
    r->psnr_first /= r->n_clips;
    r->psnr_grouped = grouped ? r->psnr_grouped / grouped : 0;
    r->seconds = gv_now() - start;
    return 0;
}
