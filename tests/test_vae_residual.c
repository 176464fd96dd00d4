/* Residual decoding (docs/VAE.md): render + D(z_restored) - D(z_render) gives the render back
 * bit for bit when the latent is unchanged, equals that formula computed here from two plain
 * decodes otherwise, and stays in [-1, 1]; the clip scorer's numbers by hand (a render off by
 * a constant has a known PSNR; identical frames count 100 dB), its crop and its refusals. */
#include <omp.h>

#include "check.h"
#include "gaussvid/core/core.h"
#include "gaussvid/model/vae.h"
#include "gaussvid/eval/eval.h"

enum { T = 5, H = 16, W = 16, TL = 2 };

static void test_decode_residual(void)
{
    gv_model_config c;
    CHECK(gv_model_config_preset(&c, "tiny") == 0);
    gv_vae v;
    CHECK(gv_vae_init(&v, &c, 0, 5) == 0);
    const int z = v.cfg.z_dim, s = v.cfg.spatial_factor;
    const int64_t n = 3LL * T * H * W, nz = (int64_t)z * TL * (H / s) * (W / s);
    float *render = malloc(n * sizeof(float)), *out = malloc(n * sizeof(float));
    float *d1 = malloc(n * sizeof(float)), *d2 = malloc(n * sizeof(float));
    float *z1 = malloc(nz * sizeof(float)), *z2 = malloc(nz * sizeof(float));
    gv_fill_uniform(render, n, 1, 0, -1.0f, 1.0f);
    CHECK(gv_vae_encode(&v, render, T, H, W, 0, 4, z1) == 0);

    /* the latent unchanged: the render itself, bit for bit */
    CHECK(gv_vae_decode_residual(&v, render, z1, z1, TL, H / s, W / s, 0, out) == 0);
    CHECK(!memcmp(out, render, n * sizeof(float)));

    /* a changed latent: clamp(render + D(z2) - D(z1)) from two plain decodes, in double here */
    gv_fill_normal(z2, nz, 2, 0, 0.0f, 3.0f);
    for (int64_t i = 0; i < nz; i++) z2[i] += z1[i];
    CHECK(gv_vae_decode_residual(&v, render, z1, z2, TL, H / s, W / s, 0, out) == 0);
    CHECK(gv_vae_decode(&v, z1, TL, H / s, W / s, 0, 1, d1) == 0 && gv_vae_decode(&v, z2, TL, H / s, W / s, 0, 1, d2) == 0);
    double worst = 0, moved = 0;
    int clamped = 0, inside = 1;
    for (int64_t i = 0; i < n; i++) {
        double want = (double)render[i] + ((double)d2[i] - (double)d1[i]);
        want = want < -1 ? -1 : want > 1 ? 1 : want;
        worst = fmax(worst, fabs(want - out[i]));
        moved = fmax(moved, fabs((double)out[i] - render[i]));
        clamped += out[i] == 1.0f || out[i] == -1.0f;
        inside &= out[i] >= -1.0f && out[i] <= 1.0f;
    }
    printf("residual decode vs render + D(z2) - D(z1) computed here: max |diff| %.2e; largest change %.3f; %d values clamped\n",
           worst, moved, clamped);
    CHECK(worst <= 1e-6);
    CHECK(moved > 0.05 && clamped > 0 && inside);

    CHECK_FAILS_WITH(gv_vae_decode_residual(&v, render, z1, z1, TL, H / s, W / s, 1, out), "statistics");
    CHECK_FAILS_WITH(gv_vae_decode_residual(&v, render, z1, z1, 0, H / s, W / s, 0, out), "bad latent size");
    free(render), free(out), free(d1), free(d2), free(z1), free(z2);
    gv_vae_free(&v);
}

/* 8-bit frames [frames, h, w, 3] of a smooth pattern with values in 20..235. */
static uint8_t *pattern(int frames, int h, int w)
{
    uint8_t *p = malloc((size_t)frames * h * w * 3);
    for (int t = 0; t < frames; t++)
        for (int y = 0; y < h; y++)
            for (int x = 0; x < w; x++)
                for (int c = 0; c < 3; c++)
                    p[(((size_t)t * h + y) * w + x) * 3 + c] = (uint8_t)(20 + (7 * x + 11 * y + 29 * t + 60 * c) % 216);
    return p;
}

static void test_score_clip(void)
{
    gv_model_config c;
    CHECK(gv_model_config_preset(&c, "tiny") == 0);
    gv_vae v;
    CHECK(gv_vae_init(&v, &c, 0, 7) == 0);
    const int score[T] = {0, 1, 1, 1, 0};
    const size_t n = (size_t)T * H * W * 3;
    uint8_t *target = pattern(T, H, W), *render = malloc(n);

    /* render = ground truth: every comparison with the render is identical (100 dB) */
    gv_vae_residual_scores s;
    memset(&s, 0, sizeof s);
    CHECK(gv_vae_residual_score_clip(&v, target, target, T, H, W, score, &s) == 0);
    gv_vae_residual_finish(&s);
    CHECK(s.n_clips == 1 && s.n_frames == 3 && s.max_abs_same == 0);
    CHECK(s.psnr[GV_VAE_RESIDUAL_RENDER] == 100 && s.psnr[GV_VAE_RESIDUAL_SAME] == 100 && s.psnr[GV_VAE_RESIDUAL_UPPER] == 100);
    CHECK(s.ssim[GV_VAE_RESIDUAL_RENDER] > 0.999999 && s.psnr[GV_VAE_RESIDUAL_VAE_RENDER] < 60);
    CHECK(s.psnr[GV_VAE_RESIDUAL_VAE_RENDER] == s.psnr[GV_VAE_RESIDUAL_VAE_TARGET]);

    /* the scored frames 10 levels too bright: PSNR 20 log10(255 / 10) for the render and for
     * the residual with the latent unchanged; the anchors do not count */
    memcpy(render, target, n);
    for (size_t i = (size_t)H * W * 3; i < (size_t)4 * H * W * 3; i++) render[i] += 10;
    render[0] = 0; /* anchor 0 changed: not scored */
    memset(&s, 0, sizeof s);
    CHECK(gv_vae_residual_score_clip(&v, render, target, T, H, W, score, &s) == 0);
    gv_vae_residual_finish(&s);
    double want = 20 * log10(255.0 / 10.0);
    printf("render 10 levels off: PSNR %.4f (by hand %.4f); through the VAE %.2f; residual, perfect restorer %.2f\n",
           s.psnr[GV_VAE_RESIDUAL_RENDER], want, s.psnr[GV_VAE_RESIDUAL_VAE_RENDER], s.psnr[GV_VAE_RESIDUAL_UPPER]);
    CHECK_NEAR(s.psnr[GV_VAE_RESIDUAL_RENDER], want, 1e-3);
    CHECK_NEAR(s.psnr[GV_VAE_RESIDUAL_SAME], want, 1e-3);
    CHECK(s.max_abs_same == 0 && s.n_frames == 3);

    /* a frame off the spatial factor is centre-cropped; a clip length off the temporal one fails */
    uint8_t *odd = pattern(T, H + 3, W + 5);
    memset(&s, 0, sizeof s);
    CHECK(gv_vae_residual_score_clip(&v, odd, odd, T, H + 3, W + 5, score, &s) == 0 && s.n_frames == 3);
    CHECK_FAILS_WITH(gv_vae_residual_score_clip(&v, target, target, 4, H, W, score, &s), "1 + k x 4");
    CHECK_FAILS_WITH(gv_vae_residual_score_clip(&v, target, target, T, 7, W, score, &s), "spatial factor");
    free(odd), free(target), free(render);
    gv_vae_free(&v);
}

int main(void)
{
    omp_set_num_threads(1);
    test_decode_residual();
    test_score_clip();
    return check_summary();
}
