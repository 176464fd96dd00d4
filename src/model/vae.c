/* Encoding and decoding whole clips (docs/reference/wan-vace-gaussvid.md 4.4, 4.5): temporal
 * packing (the first frame alone, then groups of the temporal factor r), the per-channel latent
 * normalisation, and the chunked mode that streams a clip through the causal caches as Wan does
 * (the first frame, then chunks of r frames to encode; one latent frame at a time to decode). */
#include <stdlib.h>
#include <string.h>

#include "gaussvid/core/core.h"
#include "gaussvid/model/vae.h"
#include "model/vae_internal.h"

int gv_vae_latent_frames(const gv_vae_config *c, int frames, int *latent_frames)
{
    int r = c->temporal_factor;
    if (frames < 1 || (frames - 1) % r)
        return gv_fail("vae: %d frames; the temporal factor %d needs 1 + k x %d (the first frame alone, then groups of %d)",
                       frames, r, r, r);
    *latent_frames = 1 + (frames - 1) / r;
    return 0;
}

int gv_vae_check_clip(const gv_vae_config *c, int frames, int height, int width)
{
    int t, s = c->spatial_factor;
    if (gv_vae_latent_frames(c, frames, &t)) return -1;
    if (height < s || width < s || height % s || width % s)
        return gv_fail("vae: a %dx%d frame is not a multiple of the spatial factor %d", width, height, s);
    return 0;
}

/* [1, z, 1, 1, 1] leaf holding values[0..z). */
static gv_tensor *channel_values(gv_graph *g, const float *values, int z)
{
    const int shape[5] = {1, z, 1, 1, 1};
    return gv_tensor_from(g, 5, shape, values);
}

gv_tensor *gv_vae_normalize(gv_graph *g, const gv_vae *v, gv_tensor *mu)
{
    if (!mu) return NULL;
    if (!v->has_stats) {
        gv_fail("vae: no latent statistics to normalise with (train them with 'gaussvid vae train')");
        return NULL;
    }
    int z = v->cfg.z_dim;
    return gv_mul(g, gv_sub(g, mu, channel_values(g, v->mean, z)), channel_values(g, v->inv_std, z));
}

gv_tensor *gv_vae_denormalize(gv_graph *g, const gv_vae *v, gv_tensor *z)
{
    if (!z) return NULL;
    if (!v->has_stats) {
        gv_fail("vae: no latent statistics to undo the normalisation with");
        return NULL;
    }
    int c = v->cfg.z_dim;
    return gv_add(g, gv_mul(g, z, channel_values(g, v->std, c)), channel_values(g, v->mean, c));
}

/* frames [t0, t0 + n) of a channel-first [C, T, H, W] array as a leaf [1, C, n, H, W] */
static gv_tensor *frames_leaf(gv_graph *g, const float *src, int C, int T, int64_t hw, int t0, int n, int H, int W)
{
    const int shape[5] = {1, C, n, H, W};
    gv_tensor *t = gv_tensor_new(g, 5, shape);
    if (!t) return NULL;
    for (int c = 0; c < C; c++)
        memcpy(t->data + (int64_t)c * n * hw, src + ((int64_t)c * T + t0) * hw, (size_t)(n * hw) * sizeof(float));
    return t;
}

/* y [1, C, n, H, W] into frames [t0, t0 + n) of dst [C, T, H, W], clamped to [lo, hi]. */
static void store_frames(const gv_tensor *y, float *dst, int T, int t0, float lo, float hi)
{
    int C = y->shape[1], n = y->shape[2];
    int64_t hw = (int64_t)y->shape[3] * y->shape[4];
    for (int c = 0; c < C; c++)
        for (int64_t i = 0; i < n * hw; i++) {
            float a = y->data[(int64_t)c * n * hw + i];
            dst[((int64_t)c * T + t0) * hw + i] = a < lo ? lo : a > hi ? hi : a;
        }
}

int gv_vae_encode_whole(gv_vae *v, const float *video, int frames, int height, int width, int normalize,
                  int chunk_frames, float *latent)
{
    const gv_vae_config *c = &v->cfg;
    int r = c->temporal_factor, z = c->z_dim, tl = 0;
    if (gv_vae_check_clip(c, frames, height, width) || gv_vae_latent_frames(c, frames, &tl)) return -1;
    if (chunk_frames < 0 || chunk_frames % r)
        return gv_fail("vae encode: chunks of %d frames; use a multiple of the temporal factor %d", chunk_frames, r);
    if (normalize && !v->has_stats) return gv_fail("vae encode: no latent statistics to normalise with");
    gv_graph g;
    gv_vae_stream stream;
    gv_graph_init(&g, (size_t)64 << 20);
    gv_graph_set_grad(&g, 0);
    if (chunk_frames && gv_vae_stream_init(&stream, v->encoder.n_slots)) {
        gv_graph_free(&g);
        return -1;
    }
    int rc = 0;
    for (int t0 = 0, l0 = 0; t0 < frames && rc == 0;) {
        int n = !chunk_frames ? frames : t0 == 0 ? 1 : (frames - t0 < chunk_frames ? frames - t0 : chunk_frames);
        gv_graph_reset(&g);
        gv_tensor *x = frames_leaf(&g, video, 3, frames, (int64_t)height * width, t0, n, height, width);
        gv_tensor *mu = gv_slice(&g, gv_vae_encoder_forward(&g, v, x, chunk_frames ? &stream : NULL), 1, 0, z);
        if (normalize) mu = gv_vae_normalize(&g, v, mu);
        if (!mu) {
            rc = -1;
            break;
        }
        store_frames(mu, latent, tl, l0, -3.4e38f, 3.4e38f);
        l0 += mu->shape[2];
        t0 += n;
    }
    if (chunk_frames) gv_vae_stream_free(&stream);
    gv_graph_free(&g);
    return rc;
}

int gv_vae_decode_whole(gv_vae *v, const float *latent, int latent_frames, int lh, int lw, int normalized,
                        int chunked, float *video)
{
    const gv_vae_config *c = &v->cfg;
    int r = c->temporal_factor, s = c->spatial_factor, z = c->z_dim;
    if (latent_frames < 1 || lh < 1 || lw < 1)
        return gv_fail("vae decode: bad latent size %d x %d x %d", latent_frames, lh, lw);
    if (normalized && !v->has_stats) return gv_fail("vae decode: no latent statistics to undo the normalisation with");
    int frames = 1 + r * (latent_frames - 1);
    gv_graph g;
    gv_vae_stream stream;
    gv_graph_init(&g, (size_t)64 << 20);
    gv_graph_set_grad(&g, 0);
    if (chunked && gv_vae_stream_init(&stream, v->decoder.n_slots)) {
        gv_graph_free(&g);
        return -1;
    }
    int rc = 0;
    for (int l0 = 0, t0 = 0; l0 < latent_frames;) {
        int n = chunked ? 1 : latent_frames;
        gv_graph_reset(&g);
        gv_tensor *zt = frames_leaf(&g, latent, z, latent_frames, (int64_t)lh * lw, l0, n, lh, lw);
        if (normalized) zt = gv_vae_denormalize(&g, v, zt);
        gv_tensor *y = gv_vae_decoder_forward(&g, v, zt, chunked ? &stream : NULL);
        if (!y) {
            rc = -1;
            break;
        }
        if (y->shape[3] != s * lh || y->shape[4] != s * lw || t0 + y->shape[2] > frames) {
            rc = gv_fail("vae decode: the decoder gave %d frames of %dx%d", y->shape[2], y->shape[4], y->shape[3]);
            break;
        }
        store_frames(y, video, frames, t0, -1.0f, 1.0f); /* Wan clamps the output to [-1, 1] */
        t0 += y->shape[2];
        l0 += n;
    }
    if (chunked) gv_vae_stream_free(&stream);
    gv_graph_free(&g);
    return rc;
}

/* Residual decoding (docs/VAE.md): out = clamp(render + restored - rendered, -1, 1) over n
 * values. Where restored and rendered are equal the difference is exactly 0, so out is the
 * render (already in [-1, 1]): the VAE's reconstruction error cancels. */
int gv_vae_encode(gv_vae *v, const float *video, int frames, int height, int width, int normalize,
                  int chunk_frames, float *latent)
{
    if (v->tiling) return gv_vae_encode_tiled(v, v->tiling, video, frames, height, width, normalize, chunk_frames, latent);
    return gv_vae_encode_whole(v, video, frames, height, width, normalize, chunk_frames, latent);
}

int gv_vae_decode(gv_vae *v, const float *latent, int latent_frames, int lh, int lw, int normalized,
                  int chunked, float *video)
{
    if (v->tiling) return gv_vae_decode_tiled(v, v->tiling, latent, latent_frames, lh, lw, normalized, chunked, video);
    return gv_vae_decode_whole(v, latent, latent_frames, lh, lw, normalized, chunked, video);
}

void gv_vae_compose_residual(const float *render, const float *restored, const float *rendered, int64_t n, float *out)
{
    for (int64_t i = 0; i < n; i++) {
        float a = render[i] + (restored[i] - rendered[i]);
        out[i] = a < -1.0f ? -1.0f : a > 1.0f ? 1.0f : a;
    }
}

int gv_vae_decode_residual(gv_vae *v, const float *render, const float *z_render, const float *z_restored,
                           int latent_frames, int lh, int lw, int normalized, float *out)
{
    int s = v->cfg.spatial_factor, frames = 1 + v->cfg.temporal_factor * (latent_frames - 1);
    if (latent_frames < 1 || lh < 1 || lw < 1)
        return gv_fail("vae residual decode: bad latent size %d x %d x %d", latent_frames, lh, lw);
    int64_t n = 3LL * frames * (int64_t)(s * lh) * (s * lw);
    float *a = malloc((size_t)n * sizeof *a), *b = malloc((size_t)n * sizeof *b);
    int rc = a && b ? 0 : gv_fail("vae residual decode: out of memory for two %lld-value clips", (long long)n);
    if (rc == 0) rc = gv_vae_decode(v, z_restored, latent_frames, lh, lw, normalized, 1, a);
    if (rc == 0) rc = gv_vae_decode(v, z_render, latent_frames, lh, lw, normalized, 1, b);
    if (rc == 0) gv_vae_compose_residual(render, a, b, n, out);
    free(a);
    free(b);
    return rc;
}
