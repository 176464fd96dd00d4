/* The VAE's building blocks (docs/reference/wan-vace-gaussvid.md 4.2) and their causal caches
 * (docs/reference/wan-vace-gaussvid.md 4.4).
 *
 * Every block works on videos [B, C, T, H, W]. A stream carries, per cache slot, what a block
 * keeps from one chunk for the next: a k_t = 3 convolution its last 2 input frames (zeros
 * before the first frame, which is Wan's causal padding), a downsample3d its last spatially
 * downsampled frame. With stream NULL a block sees the whole clip at once; feeding the same
 * clip chunk by chunk through a stream gives the same result (tested). */
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "gaussvid/core/core.h"
#include "model/vae_internal.h"

int gv_vae_stream_init(gv_vae_stream *s, int n_slots)
{
    memset(s, 0, sizeof *s);
    s->n_slots = n_slots;
    size_t n = n_slots > 0 ? (size_t)n_slots : 1;
    s->started = calloc(n, sizeof *s->started);
    s->frames = calloc(n, sizeof *s->frames);
    s->channels = calloc(n, sizeof *s->channels);
    s->height = calloc(n, sizeof *s->height);
    s->width = calloc(n, sizeof *s->width);
    s->data = calloc(n, sizeof *s->data);
    if (!s->started || !s->frames || !s->channels || !s->height || !s->width || !s->data) {
        gv_vae_stream_free(s);
        return gv_fail("vae: out of memory for %d cache slots", n_slots);
    }
    return 0;
}

void gv_vae_stream_free(gv_vae_stream *s)
{
    for (int i = 0; s->data && i < s->n_slots; i++) free(s->data[i]);
    free(s->started);
    free(s->frames);
    free(s->channels);
    free(s->height);
    free(s->width);
    free(s->data);
    memset(s, 0, sizeof *s);
}

/* The slot's frames as a leaf [1, C, n, H, W], or NULL with *n = 0 when it holds none. Fails
 * (returning NULL, *n = -1) when x's channels or size differ from the cached frames. */
static gv_tensor *cached(gv_graph *g, const gv_vae_stream *s, int slot, const gv_tensor *x, int *n)
{
    *n = s ? s->frames[slot] : 0;
    if (*n == 0) return NULL;
    if (s->channels[slot] != x->shape[1] || s->height[slot] != x->shape[3] || s->width[slot] != x->shape[4]) {
        gv_fail("vae: a chunk of %d x %d x %d does not continue the stream's %d x %d x %d", x->shape[1], x->shape[3],
                x->shape[4], s->channels[slot], s->height[slot], s->width[slot]);
        *n = -1;
        return NULL;
    }
    int shape[5] = {1, s->channels[slot], *n, s->height[slot], s->width[slot]};
    gv_tensor *t = gv_tensor_from(g, 5, shape, s->data[slot]);
    if (!t) *n = -1;
    return t;
}

/* Keeps the last min(keep, n + T) frames of [the slot's n frames, x] (x [1, C, T, H, W]). */
static int keep_frames(gv_vae_stream *s, int slot, const gv_tensor *x, int keep)
{
    int n = s->frames[slot], T = x->shape[2], C = x->shape[1];
    int64_t hw = (int64_t)x->shape[3] * x->shape[4];
    int k = n + T < keep ? n + T : keep;
    float *next = malloc((size_t)((int64_t)C * k * hw) * sizeof *next + 1);
    if (!next) return gv_fail("vae: out of memory for a cache of %d frames", k);
    for (int j = 0; j < k; j++) {
        int frame = n + T - k + j; /* index in [cache, x] */
        for (int c = 0; c < C; c++) {
            const float *src = frame < n ? s->data[slot] + ((int64_t)c * n + frame) * hw
                                         : x->data + ((int64_t)c * T + frame - n) * hw;
            memcpy(next + ((int64_t)c * k + j) * hw, src, (size_t)hw * sizeof *next);
        }
    }
    free(s->data[slot]);
    s->data[slot] = next;
    s->frames[slot] = k;
    s->started[slot] = 1;
    s->channels[slot] = C;
    s->height[slot] = x->shape[3];
    s->width[slot] = x->shape[4];
    return 0;
}

gv_tensor *gv_vae_causal_conv(gv_graph *g, const gv_vae_conv *c, gv_tensor *x, int pad_hw, gv_vae_stream *s)
{
    if (!x) return NULL;
    int kt = c->weight->shape[2];
    gv_conv_geom geom = {{1, 1, 1}, {0, 0, pad_hw, pad_hw, pad_hw, pad_hw}};
    if (kt == 1) return gv_conv3d(g, x, c->weight, c->bias, &geom);
    int n;
    gv_tensor *cache = cached(g, s, c->slot, x, &n);
    if (n < 0) return NULL;
    geom.pad[0] = kt - 1 - n; /* zeros stand for the frames before the first */
    gv_tensor *in = x;
    if (cache) {
        gv_tensor *parts[2] = {cache, x};
        in = gv_concat(g, parts, 2, 2);
    }
    gv_tensor *y = gv_conv3d(g, in, c->weight, c->bias, &geom);
    if (y && s && keep_frames(s, c->slot, x, GV_VAE_CACHE_T)) return NULL;
    return y;
}

/* ---- ResidualBlock: x + (norm, SiLU, conv 3x3x3, norm, SiLU, dropout 0, conv 3x3x3) ------- */
static gv_tensor *residual(gv_graph *g, const gv_vae_layer *l, gv_tensor *x, gv_vae_stream *s)
{
    gv_tensor *h = gv_silu(g, gv_rms_norm_axis(g, x, l->gamma0, 1, GV_VAE_NORM_FLOOR));
    h = gv_vae_causal_conv(g, &l->conv2, h, 1, s);
    h = gv_silu(g, gv_rms_norm_axis(g, h, l->gamma3, 1, GV_VAE_NORM_FLOOR));
    h = gv_vae_causal_conv(g, &l->conv6, h, 1, s);
    gv_tensor *shortcut = l->shortcut.weight ? gv_vae_causal_conv(g, &l->shortcut, x, 0, NULL) : x;
    return gv_add(g, h, shortcut);
}

/* ---- AttentionBlock: per frame, one head over the H W positions ---------------------------
 * q, k, v are channels [0, C), [C, 2C), [2C, 3C) of to_qkv; scale 1 / sqrt(C). The 1x1
 * Conv2d layers are linear layers on the channel-last tokens. */
static gv_tensor *attention(gv_graph *g, const gv_vae_layer *l, gv_tensor *x)
{
    int B = x->shape[0], C = x->shape[1], T = x->shape[2], H = x->shape[3], W = x->shape[4];
    const int to_tokens[5] = {0, 2, 3, 4, 1}, to_video[5] = {0, 4, 1, 2, 3};
    const int tokens[3] = {B * T, H * W, C}, w_qkv[2] = {3 * C, C}, w_proj[2] = {C, C};
    const int frames[5] = {B, T, H, W, C};
    gv_tensor *h = gv_rms_norm_axis(g, x, l->norm_gamma, 1, GV_VAE_NORM_FLOOR);
    h = gv_reshape(g, gv_permute(g, h, to_tokens), 3, tokens);
    gv_tensor *qkv = gv_linear(g, h, gv_reshape(g, l->to_qkv.weight, 2, w_qkv), l->to_qkv.bias);
    gv_tensor *q = gv_slice(g, qkv, 2, 0, C), *k = gv_slice(g, qkv, 2, C, C), *v = gv_slice(g, qkv, 2, 2 * C, C);
    h = gv_attention(g, q, k, v, NULL, 1, (float)(1.0 / sqrt((double)C)));
    h = gv_linear(g, h, gv_reshape(g, l->proj.weight, 2, w_proj), l->proj.bias);
    h = gv_permute(g, gv_reshape(g, h, 5, frames), to_video);
    return gv_add(g, h, x);
}

/* ---- Resample -------------------------------------------------------------------------------- */
/* The per-frame 3x3 Conv2d as a Conv3d with k_t = 1: down is ZeroPad2d(0, 1, 0, 1) then
 * stride 2; up is nearest x2 then padding 1. */
static gv_tensor *spatial(gv_graph *g, const gv_vae_layer *l, gv_tensor *x, int up)
{
    const gv_tensor *w = l->resample.weight;
    const int shape[5] = {w->shape[0], w->shape[1], 1, w->shape[2], w->shape[3]};
    gv_tensor *w5 = gv_reshape(g, l->resample.weight, 5, shape);
    gv_conv_geom down = {{1, 2, 2}, {0, 0, 0, 1, 0, 1}}, same = {{1, 1, 1}, {0, 0, 1, 1, 1, 1}};
    if (up) return gv_conv3d(g, gv_upsample_nearest(g, x, 1, 2, 2), w5, l->resample.bias, &same);
    return gv_conv3d(g, x, w5, l->resample.bias, &down);
}

/* downsample3d's time_conv ((3,1,1), stride 2, no padding) after the spatial step. The first
 * frame of a clip passes alone (Wan skips the conv on the first chunk and keeps it); after
 * it, frames 2k-1, 2k go with the frame before them. */
static gv_tensor *down_time(gv_graph *g, const gv_vae_layer *l, gv_tensor *x, gv_vae_stream *s)
{
    if (!x) return NULL;
    const gv_conv_geom stride2 = {{2, 1, 1}, {0, 0, 0, 0, 0, 0}};
    int T = x->shape[2], started = s && s->started[l->slot];
    if (started ? T % 2 : !(T % 2)) {
        gv_fail("vae: downsample3d got %d frames (needs %s)", T, started ? "an even count" : "an odd count");
        return NULL;
    }
    gv_tensor *y;
    if (!started) {
        gv_tensor *first = gv_slice(g, x, 2, 0, 1);
        if (T == 1) y = first;
        else {
            gv_tensor *parts[2] = {first, gv_conv3d(g, x, l->time_conv.weight, l->time_conv.bias, &stride2)};
            y = gv_concat(g, parts, 2, 2);
        }
    } else {
        int n;
        gv_tensor *cache = cached(g, s, l->slot, x, &n);
        if (n != 1) {
            if (n >= 0) gv_fail("vae: downsample3d stream holds %d frames", n);
            return NULL;
        }
        gv_tensor *parts[2] = {cache, x};
        y = gv_conv3d(g, gv_concat(g, parts, 2, 2), l->time_conv.weight, l->time_conv.bias, &stride2);
    }
    if (y && s && keep_frames(s, l->slot, x, 1)) return NULL;
    return y;
}

/* [B, 2C, T, H, W] -> [B, C, 2T, H, W]: channels [0, C) become frame 2t, [C, 2C) frame 2t + 1
 * (Wan's reshape(b, 2, c, t, h, w) and stack on time). */
static gv_tensor *time_double(gv_graph *g, gv_tensor *y)
{
    if (!y) return NULL;
    int B = y->shape[0], C = y->shape[1] / 2, T = y->shape[2], H = y->shape[3], W = y->shape[4];
    const int split[5] = {B, 2, C, T, H * W}, perm[5] = {0, 2, 3, 1, 4}, video[5] = {B, C, 2 * T, H, W};
    return gv_reshape(g, gv_permute(g, gv_reshape(g, y, 5, split), perm), 5, video);
}

/* upsample3d's time_conv ((3,1,1) causal, C -> 2C, time doubling) before the spatial step.
 * The first frame of a clip passes alone; the frames after it start from zero history (Wan's
 * "Rep" state: the first frame is not their context). */
static gv_tensor *up_time(gv_graph *g, const gv_vae_layer *l, gv_tensor *x, gv_vae_stream *s)
{
    if (!x) return NULL;
    if (s && s->started[l->slot]) return time_double(g, gv_vae_causal_conv(g, &l->time_conv, x, 0, s));
    if (s) s->started[l->slot] = 1; /* "Rep": nothing cached yet */
    int T = x->shape[2];
    gv_tensor *first = gv_slice(g, x, 2, 0, 1);
    if (T == 1) return first;
    gv_tensor *rest = gv_vae_causal_conv(g, &l->time_conv, gv_slice(g, x, 2, 1, T - 1), 0, s);
    gv_tensor *parts[2] = {first, time_double(g, rest)};
    return gv_concat(g, parts, 2, 2);
}

gv_tensor *gv_vae_layer_forward(gv_graph *g, const gv_vae_layer *l, gv_tensor *x, gv_vae_stream *s)
{
    if (!x) return NULL;
    switch (l->kind) {
    case GV_VAE_RESIDUAL: return residual(g, l, x, s);
    case GV_VAE_ATTENTION: return attention(g, l, x);
    case GV_VAE_DOWN2D: return spatial(g, l, x, 0);
    case GV_VAE_DOWN3D: return down_time(g, l, spatial(g, l, x, 0), s);
    case GV_VAE_UP2D: return spatial(g, l, x, 1);
    case GV_VAE_UP3D: return spatial(g, l, up_time(g, l, x, s), 1);
    }
    gv_fail("vae: unknown layer kind %d", (int)l->kind);
    return NULL;
}

gv_tensor *gv_vae_head_forward(gv_graph *g, const gv_vae_coder *c, gv_tensor *x, gv_vae_stream *s)
{
    gv_tensor *h = gv_silu(g, gv_rms_norm_axis(g, x, c->head_gamma, 1, GV_VAE_NORM_FLOOR));
    return gv_vae_causal_conv(g, &c->head_conv, h, 1, s);
}
