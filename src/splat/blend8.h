/* Front-to-back alpha blending of one Gaussian at eight pixels of a tile row, as the
 * reference's renderCUDA tests each pixel (docs/reference/gaussian-splatting.md section 9),
 * shared by the image (rasterize.c), the depth pass (rasterize_depth.c) and its backward
 * (rasterize_depth_backward.c), which must blend exactly the same Gaussians: the alpha
 * threshold, the early stop before T (1 - alpha) < 1e-4, and the tile's pixel bookkeeping.
 * What a blended Gaussian adds (colour, depth) is the caller's. */
#ifndef GAUSSVID_SPLAT_BLEND8_H
#define GAUSSVID_SPLAT_BLEND8_H

#include <math.h>

#include "gaussvid/splat/splat.h"
#include "splat/simd8.h"

enum { TILE_PIXELS = GV_SPLAT_TILE * GV_SPLAT_TILE };

/* Pixel centre offsets of the eight lanes. */
static const f8 LANE_CENTRES = {0.5f, 1.5f, 2.5f, 3.5f, 4.5f, 5.5f, 6.5f, 7.5f};

/* power = -0.5 (A dx^2 + C dy^2) - B dx dy for eight pixels of a row, in the reference's
 * order of operations (cdd = C dy dy is the same for the row). */
static SIMD8_INLINE f8 gaussian_power(float A, float B, f8 dx, float dy, float cdd)
{
    return -0.5f * (A * dx * dx + cdd) - B * dx * dy;
}

/* alpha = min(0.99, o exp(power)); *G = exp(power) (f8_exp_neg, the backward's too). */
static SIMD8_INLINE f8 gaussian_alpha(float o, f8 power, f8 *G)
{
    *G = f8_exp_neg(f8_min(power, f8_splat(0.0f)));
    return f8_min(o * *G, f8_splat(GV_SPLAT_ALPHA_MAX));
}

/* A tile's first pixel and its width and height inside the image. */
typedef struct {
    int px0, py0, tw, th;
} tile_box;

static SIMD8_INLINE tile_box tile_box_of(const gv_splat_tiles *t, int tile, int width, int height)
{
    tile_box b;
    b.px0 = (tile % t->tiles_x) * GV_SPLAT_TILE, b.py0 = (tile / t->tiles_x) * GV_SPLAT_TILE;
    b.tw = width - b.px0 < GV_SPLAT_TILE ? width - b.px0 : GV_SPLAT_TILE;
    b.th = height - b.py0 < GV_SPLAT_TILE ? height - b.py0 : GV_SPLAT_TILE;
    return b;
}

/* The pixels of a tile as blending leaves them: transmittance, the lanes still blending (all
 * ones; none past the image's edge), the count of those per row. */
typedef struct {
    float T[TILE_PIXELS];
    int32_t live[TILE_PIXELS];
    int row_live[GV_SPLAT_TILE];
} tile_pixels;

/* Transmittance 1, every pixel of the image live; returns the tile's live pixels. */
static SIMD8_INLINE int tile_start(tile_pixels *px, tile_box b)
{
    for (int p = 0; p < TILE_PIXELS; p++) {
        px->T[p] = 1;
        px->live[p] = (p % GV_SPLAT_TILE) < b.tw && (p / GV_SPLAT_TILE) < b.th ? -1 : 0;
    }
    for (int y = 0; y < GV_SPLAT_TILE; y++) px->row_live[y] = y < b.th ? b.tw : 0;
    return b.tw * b.th;
}

/* One Gaussian as a tile sees it: mean, conic (A, B, C), opacity; power_min, below which
 * alpha < 1/255 for certain (-INFINITY: no such bound); its pixel box inside the tile,
 * inclusive, x0 a multiple of 8. */
typedef struct {
    float mx, my, A, B, C, o, power_min;
    int x0, x1, y0, y1;
} tile_splat;

static SIMD8_INLINE int clamp_to_int(float v, int lo, int hi)
{
    if (!(v > (float)lo)) return lo; /* also NaN */
    if (v >= (float)hi) return hi;
    return (int)v;
}

/* Loads Gaussian g of the per-Gaussian arrays and clips its alpha box to the tile, as the
 * image's forward (rasterize.c, pack_splats and load_splat) computes the box and the bound
 * power_min: every pixel the image blended is inside the box, and no group of pixels whose
 * powers are all below the bound holds one. Returns 0 when the Gaussian cannot blend in this
 * tile. For the passes that walk the image's tiles again: the depth forward and its
 * backward. */
static SIMD8_INLINE int tile_splat_load(tile_splat *s, int g, const float *means2d,
                                        const float *conics, const float *opacities, int px0,
                                        int py0, int tw, int th)
{
    float A = conics[3 * g], B = conics[3 * g + 1], C = conics[3 * g + 2], o = opacities[g];
    if (!(o >= GV_SPLAT_ALPHA_MIN)) return 0; /* o exp(power) <= o */
    float hx = INFINITY, hy = INFINITY, det = A * C - B * B, log_o = logf(255.0f * o);
    if (det > 0 && A > 0) {
        float level = 2.0f * (log_o + 0.1f);
        hx = sqrtf(level * C / det) + 0.01f;
        hy = sqrtf(level * A / det) + 0.01f;
    }
    s->mx = means2d[2 * g], s->my = means2d[2 * g + 1];
    /* pixel x of the tile has its centre at px0 + x + 0.5 */
    s->x0 = clamp_to_int(ceilf(s->mx - hx - 0.5f - (float)px0), 0, tw);
    s->x1 = clamp_to_int(floorf(s->mx + hx - 0.5f - (float)px0) + 1.0f, 0, tw) - 1;
    s->y0 = clamp_to_int(ceilf(s->my - hy - 0.5f - (float)py0), 0, th);
    s->y1 = clamp_to_int(floorf(s->my + hy - 0.5f - (float)py0) + 1.0f, 0, th) - 1;
    if (s->x0 > s->x1 || s->y0 > s->y1) return 0;
    s->x0 &= ~7;
    s->A = A, s->B = B, s->C = C, s->o = o;
    s->power_min = -log_o - 1e-3f; /* rasterize.c, pack_splats: alpha < 1/255 below it */
    return 1;
}

/* What a blended Gaussian adds to a pixel of weight w = alpha T: its colour to the image
 * (sum[c] += colour[c] alpha T, in the reference's order, and the 1-based index of the last
 * Gaussian blended), or its depth (sum[0] += w, sum[1] += w z). */
typedef enum { BLEND_COLOUR, BLEND_DEPTH } blend_kind;
typedef struct {
    float *sum[3];
    float value[3];      /* the colour, or the depth in value[0] */
    int32_t *last;       /* BLEND_COLOUR: the last contributor's index + 1 */
    int index;           /* ... this Gaussian's */
} blend_target;

/* Blends one Gaussian into the live pixels of its box, front to back as the reference's
 * renderCUDA: where it counts (power <= 0, alpha >= 1/255) a pixel takes it unless its
 * transmittance would fall below 1e-4, which stops the pixel instead. Returns the number of
 * pixels that stopped. kind is a constant at each call, so each caller gets its own loop. */
static SIMD8_INLINE int blend_box(tile_pixels *px, const tile_splat *s, int px0, int py0, blend_kind kind,
                                  const blend_target *to)
{
    int stopped = 0;
    i8 contributor = {to->index + 1, to->index + 1, to->index + 1, to->index + 1,
                      to->index + 1, to->index + 1, to->index + 1, to->index + 1};
    f8 centres = f8_splat((float)px0) + LANE_CENTRES; /* pixel centres of the lanes at x = 0 */
    for (int y = s->y0; y <= s->y1; y++) {
        if (px->row_live[y] == 0) continue;
        float dy = s->my - ((float)(py0 + y) + 0.5f), cdd = s->C * dy * dy;
        i8 stops = {0, 0, 0, 0, 0, 0, 0, 0};
        for (int x = s->x0; x <= s->x1; x += 8) {
            int p = y * GV_SPLAT_TILE + x;
            i8 live = i8_load(px->live + p);
            f8 dx = s->mx - (centres + (float)x), G; /* exact centres: one rounding */
            f8 power = gaussian_power(s->A, s->B, dx, dy, cdd);
            if (!i8_any(live & (power >= s->power_min))) continue; /* nothing to blend */
            f8 alpha = gaussian_alpha(s->o, power, &G);
            i8 ok = live & (power <= 0.0f) & (alpha >= GV_SPLAT_ALPHA_MIN);
            f8 T = f8_load(px->T + p), test_T = T * (1.0f - alpha);
            i8 stop = ok & (test_T < GV_SPLAT_T_MIN); /* this Gaussian is not blended */
            i8 blend = ok & ~stop;
            f8 w = f8_mask(blend, alpha);
            if (kind == BLEND_COLOUR) {
                for (int c = 0; c < 3; c++)
                    f8_store(to->sum[c] + p, f8_load(to->sum[c] + p) + to->value[c] * w * T);
                i8_store(to->last + p, i8_select(blend, contributor, i8_load(to->last + p)));
            } else {
                w = w * T;
                f8_store(to->sum[0] + p, f8_load(to->sum[0] + p) + w);
                f8_store(to->sum[1] + p, f8_load(to->sum[1] + p) + w * to->value[0]);
            }
            f8_store(px->T + p, f8_select(blend, test_T, T));
            i8_store(px->live + p, live & ~stop);
            stops += stop;
        }
        int n = i8_count(stops);
        px->row_live[y] -= n;
        stopped += n;
    }
    return stopped;
}

#endif
