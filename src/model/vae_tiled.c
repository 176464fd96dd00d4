/* The VAE in tiles as the GaussVid release runs it (include/gaussvid/model/vae.h, gv_vae_tiling;
 * docs/GAUSSVID_RELEASE.md): overlapping tiles coded whole, blended with linear ramps. */
#include <stdlib.h>
#include <string.h>

#include "gaussvid/core/core.h"
#include "gaussvid/io/safetensors.h"
#include "gaussvid/model/vae.h"
#include "model/vae_internal.h"

enum { MAX_TILES = 256 };

const gv_vae_tiling GV_VAE_TILING_RELEASE = {30, 52, 15, 26, 1};

int gv_vae_tile_origins(int size, int tile, int stride, int *origins, int max)
{
    int n = 0;
    for (int o = 0; o < size && n < max; o += stride)
        if (!(o - stride >= 0 && o - stride + tile >= size)) origins[n++] = o; /* the tile before reaches the end */
    return n;
}

/* The 1-D weights of a tile of n cells: (k + 1) / border over the first and last `border`
 * cells, on the sides that are not the image's border; 1 elsewhere. */
static void ramp(float *x, int n, int first, int last, int border)
{
    for (int k = 0; k < n; k++) x[k] = 1.0f;
    for (int k = 0; !first && k < border && k < n; k++) x[k] = (float)(k + 1) / (float)border;
    for (int k = 0; !last && k < border && k < n; k++) x[n - 1 - k] = (float)(k + 1) / (float)border;
}

static float bf16(float x)
{
    return gv_bf16_to_f32(gv_f32_to_bf16(x));
}

/* The blend of one coded tile [C, T, th, tw] into sums [C, T, H, W] at (y0, x0), with ramps of
 * by x bx cells on inner sides. */
static int accumulate(const float *tile, int C, int T, int th, int tw, int H, int W, int y0, int x0, int by, int bx,
                      int bf16_acc, float *values, float *weight)
{
    float *ry = malloc((size_t)th * sizeof *ry), *rx = malloc((size_t)tw * sizeof *rx);
    if (!ry || !rx) {
        free(ry), free(rx);
        return gv_fail("vae tiles: out of memory");
    }
    ramp(ry, th, y0 == 0, y0 + th >= H, by);
    ramp(rx, tw, x0 == 0, x0 + tw >= W, bx);
    const int64_t plane = (int64_t)H * W;
    for (int y = 0; y < th; y++)
        for (int x = 0; x < tw; x++) {
            float m = ry[y] < rx[x] ? ry[y] : rx[x];
            int64_t at = (int64_t)(y0 + y) * W + x0 + x;
            weight[at] = bf16_acc ? bf16(weight[at] + m) : weight[at] + m;
            for (int ct = 0; ct < C * T; ct++) {
                float *v = &values[ct * plane + at];
                float add = tile[((int64_t)ct * th + y) * tw + x] * m;
                *v = bf16_acc ? bf16(*v + add) : *v + add;
            }
        }
    free(ry), free(rx);
    return 0;
}

/* sums / weights into out [C, T, H, W], clamped to [lo, hi]. */
static void finish(const float *values, const float *weight, int CT, int64_t plane, float lo, float hi, float *out)
{
    for (int ct = 0; ct < CT; ct++)
        for (int64_t p = 0; p < plane; p++) {
            float x = values[ct * plane + p] / weight[p];
            out[ct * plane + p] = x < lo ? lo : x > hi ? hi : x;
        }
}

/* Crops [C, T, H, W] to rows [y0, y0 + h) and columns [x0, x0 + w). */
static void crop(const float *src, int CT, int H, int W, int y0, int x0, int h, int w, float *dst)
{
    for (int ct = 0; ct < CT; ct++)
        for (int y = 0; y < h; y++)
            memcpy(dst + ((int64_t)ct * h + y) * w, src + ((int64_t)ct * H + y0 + y) * W + x0, (size_t)w * sizeof *dst);
}

/* The tiled pass shared by encoding and decoding: input [Ci, Ti, Hi, Wi] cut into tiles of
 * tile cells x `in_cell` input pixels, each coded into [Co, To, .. x out_cell], blended. */
typedef struct {
    gv_vae *v;
    const gv_vae_tiling *t;
    int encode, flag, chunk;     /* normalize / normalized; chunk_frames / chunked */
    int Ci, Ti, Co, To;
    int in_cell, out_cell;       /* pixels of one tiling cell in the input and the output */
    int cells_h, cells_w;        /* the image in tiling cells */
    float lo, hi;                /* the output's clamp */
} tiled_job;

static int run_tiles(const tiled_job *j, const float *in, float *out)
{
    int oy[MAX_TILES], ox[MAX_TILES];
    int ny = gv_vae_tile_origins(j->cells_h, j->t->tile_h, j->t->stride_h, oy, MAX_TILES);
    int nx = gv_vae_tile_origins(j->cells_w, j->t->tile_w, j->t->stride_w, ox, MAX_TILES);
    const int Hi = j->cells_h * j->in_cell, Wi = j->cells_w * j->in_cell, Ho = j->cells_h * j->out_cell,
              Wo = j->cells_w * j->out_cell;
    const int by = (j->t->tile_h - j->t->stride_h) * j->out_cell, bx = (j->t->tile_w - j->t->stride_w) * j->out_cell;
    const int64_t tile_in = (int64_t)j->Ci * j->Ti * j->t->tile_h * j->in_cell * j->t->tile_w * j->in_cell;
    const int64_t tile_out = (int64_t)j->Co * j->To * j->t->tile_h * j->out_cell * j->t->tile_w * j->out_cell;
    float *a = malloc((size_t)tile_in * sizeof *a), *b = malloc((size_t)tile_out * sizeof *b);
    float *values = calloc((size_t)j->Co * j->To * Ho * Wo, sizeof *values), *weight = calloc((size_t)Ho * Wo, sizeof *weight);
    int rc = a && b && values && weight ? 0 : gv_fail("vae tiles: out of memory");
    for (int iy = 0; rc == 0 && iy < ny; iy++)
        for (int ix = 0; rc == 0 && ix < nx; ix++) {
            int ch = j->cells_h - oy[iy] < j->t->tile_h ? j->cells_h - oy[iy] : j->t->tile_h;
            int cw = j->cells_w - ox[ix] < j->t->tile_w ? j->cells_w - ox[ix] : j->t->tile_w;
            crop(in, j->Ci * j->Ti, Hi, Wi, oy[iy] * j->in_cell, ox[ix] * j->in_cell, ch * j->in_cell, cw * j->in_cell, a);
            rc = j->encode ? gv_vae_encode_whole(j->v, a, j->Ti, ch * j->in_cell, cw * j->in_cell, j->flag, j->chunk, b)
                           : gv_vae_decode_whole(j->v, a, j->Ti, ch, cw, j->flag, j->chunk, b);
            if (rc == 0)
                rc = accumulate(b, j->Co, j->To, ch * j->out_cell, cw * j->out_cell, Ho, Wo, oy[iy] * j->out_cell,
                                ox[ix] * j->out_cell, by, bx, j->t->bf16_accumulate, values, weight);
        }
    if (rc == 0) finish(values, weight, j->Co * j->To, (int64_t)Ho * Wo, j->lo, j->hi, out);
    free(a), free(b), free(values), free(weight);
    return rc;
}

static int check_tiling(const gv_vae_tiling *t)
{
    if (t->tile_h < 1 || t->tile_w < 1 || t->stride_h < 1 || t->stride_w < 1 || t->stride_h > t->tile_h ||
        t->stride_w > t->tile_w)
        return gv_fail("vae tiles: tiles %dx%d with strides %dx%d", t->tile_h, t->tile_w, t->stride_h, t->stride_w);
    return 0;
}

int gv_vae_encode_tiled(gv_vae *v, const gv_vae_tiling *t, const float *video, int frames, int height, int width,
                        int normalize, int chunk_frames, float *latent)
{
    const gv_vae_config *c = &v->cfg;
    int tl = 0, s = c->spatial_factor;
    if (check_tiling(t) || gv_vae_check_clip(c, frames, height, width) || gv_vae_latent_frames(c, frames, &tl)) return -1;
    tiled_job j = {v, t, 1, normalize, chunk_frames, 3, frames, c->z_dim, tl, s, 1, height / s, width / s, -3.4e38f, 3.4e38f};
    return run_tiles(&j, video, latent);
}

int gv_vae_decode_tiled(gv_vae *v, const gv_vae_tiling *t, const float *latent, int latent_frames, int lh, int lw,
                        int normalized, int chunked, float *video)
{
    const gv_vae_config *c = &v->cfg;
    if (check_tiling(t)) return -1;
    if (latent_frames < 1 || lh < 1 || lw < 1)
        return gv_fail("vae decode: bad latent size %d x %d x %d", latent_frames, lh, lw);
    int frames = 1 + c->temporal_factor * (latent_frames - 1), s = c->spatial_factor;
    tiled_job j = {v, t, 0, normalized, chunked, c->z_dim, latent_frames, 3, frames, 1, s, lh, lw, -1.0f, 1.0f};
    return run_tiles(&j, latent, video);
}
