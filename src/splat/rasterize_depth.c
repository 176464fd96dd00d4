/* Expected depth and accumulated opacity per pixel: a pass of its own over the tiles of the
 * last forward, blending the view-space depths of the Gaussians with the forward's weights.
 *
 * With w_i = alpha_i T_i the weight of Gaussian i in a pixel (the colour's weight in
 * section 9 of the reference doc), the depth is sum_i w_i z_i / sum_i w_i (0 where nothing
 * blends) and the opacity is 1 - T_final = sum_i w_i. Every pixel goes through the
 * forward's tests in the forward's order of operations (rasterize.c: the same power,
 * f8_exp_neg, alpha clamp and threshold, early stop before T (1 - alpha) < 1e-4), so it
 * blends exactly the Gaussians the image blended and its T_final is the forward's, bit for
 * bit. A Gaussian visits only the pixels of its alpha box (rasterize.c explains the box;
 * outside it alpha < 1/255). Kept apart from rasterize.c so that the training kernels do not
 * carry it: nothing here is differentiated. */
#include <math.h>
#include <stdlib.h>

#include "gaussvid/core.h"
#include "gaussvid/render.h"
#include "gaussvid/splat.h"
#include "splat/simd8.h"

enum { TILE_PIXELS = GV_SPLAT_TILE * GV_SPLAT_TILE };

/* One Gaussian of a tile list: its 2D data and view depth, and its pixel box inside the
 * tile (inclusive; x0 a multiple of 8). */
typedef struct {
    float mx, my, A, B, C, o, z;
    int x0, x1, y0, y1;
} depth_splat;

typedef struct {
    float T[TILE_PIXELS], w[TILE_PIXELS], wz[TILE_PIXELS];
    int32_t live[TILE_PIXELS];
    int row_live[GV_SPLAT_TILE];
} depth_state;

static int clamp_int(float v, int lo, int hi)
{
    if (!(v > (float)lo)) return lo; /* also NaN */
    if (v >= (float)hi) return hi;
    return (int)v;
}

/* Loads Gaussian g and clips its alpha box to the tile; 0 when it cannot blend here. */
static int load_depth_splat(depth_splat *s, int g, const float *means2d, const float *conics,
                            const float *opacities, const float *depths, int px0, int py0,
                            int tw, int th)
{
    float A = conics[3 * g], B = conics[3 * g + 1], C = conics[3 * g + 2], o = opacities[g];
    if (!(o >= GV_SPLAT_ALPHA_MIN)) return 0; /* o exp(power) <= o */
    float hx = INFINITY, hy = INFINITY, det = A * C - B * B;
    if (det > 0 && A > 0) {
        float level = 2.0f * (logf(255.0f * o) + 0.1f);
        hx = sqrtf(level * C / det) + 0.01f;
        hy = sqrtf(level * A / det) + 0.01f;
    }
    s->mx = means2d[2 * g], s->my = means2d[2 * g + 1];
    /* pixel x of the tile has its centre at px0 + x + 0.5 */
    s->x0 = clamp_int(ceilf(s->mx - hx - 0.5f - (float)px0), 0, tw);
    s->x1 = clamp_int(floorf(s->mx + hx - 0.5f - (float)px0) + 1.0f, 0, tw) - 1;
    s->y0 = clamp_int(ceilf(s->my - hy - 0.5f - (float)py0), 0, th);
    s->y1 = clamp_int(floorf(s->my + hy - 0.5f - (float)py0) + 1.0f, 0, th) - 1;
    if (s->x0 > s->x1 || s->y0 > s->y1) return 0;
    s->x0 &= ~7;
    s->A = A, s->B = B, s->C = C, s->o = o, s->z = depths[g];
    return 1;
}

/* Blends one Gaussian's depth into the live pixels of its box (rasterize.c blend_splat,
 * with the depth in place of the colour); returns the number of pixels that stopped. */
SIMD8_INLINE int blend_depth(depth_state *st, const depth_splat *s, int px0, int py0)
{
    static const f8 lane_centres = {0.5f, 1.5f, 2.5f, 3.5f, 4.5f, 5.5f, 6.5f, 7.5f};
    f8 centres = f8_splat((float)px0) + lane_centres;
    int stopped = 0;
    for (int y = s->y0; y <= s->y1; y++) {
        if (st->row_live[y] == 0) continue;
        float dy = s->my - ((float)(py0 + y) + 0.5f), cdd = s->C * dy * dy;
        i8 stops = {0, 0, 0, 0, 0, 0, 0, 0};
        for (int x = s->x0; x <= s->x1; x += 8) {
            int p = y * GV_SPLAT_TILE + x;
            i8 live = i8_load(st->live + p);
            f8 dx = s->mx - (centres + (float)x);
            f8 power = -0.5f * (s->A * dx * dx + cdd) - s->B * dx * dy;
            f8 G = f8_exp_neg(f8_min(power, f8_splat(0.0f)));
            f8 alpha = f8_min(s->o * G, f8_splat(GV_SPLAT_ALPHA_MAX));
            i8 ok = live & (power <= 0.0f) & (alpha >= GV_SPLAT_ALPHA_MIN);
            f8 T = f8_load(st->T + p), test_T = T * (1.0f - alpha);
            i8 stop = ok & (test_T < GV_SPLAT_T_MIN);
            i8 blend = ok & ~stop;
            f8 w = f8_mask(blend, alpha) * T;
            f8_store(st->w + p, f8_load(st->w + p) + w);
            f8_store(st->wz + p, f8_load(st->wz + p) + w * s->z);
            f8_store(st->T + p, f8_select(blend, test_T, T));
            i8_store(st->live + p, live & ~stop);
            stops += stop;
        }
        int n = i8_count(stops);
        st->row_live[y] -= n;
        stopped += n;
    }
    return stopped;
}

RASTER_CLONES static void depth_tile(const gv_splat_tiles *t, int tile, int width, int height,
                                    const float *means2d, const float *conics,
                                    const float *opacities, const float *depths, float *depth,
                                    float *opacity)
{
    int px0 = (tile % t->tiles_x) * GV_SPLAT_TILE, py0 = (tile / t->tiles_x) * GV_SPLAT_TILE;
    int tw = width - px0 < GV_SPLAT_TILE ? width - px0 : GV_SPLAT_TILE;
    int th = height - py0 < GV_SPLAT_TILE ? height - py0 : GV_SPLAT_TILE;
    depth_state st __attribute__((aligned(32)));
    for (int p = 0; p < TILE_PIXELS; p++) {
        st.T[p] = 1, st.w[p] = st.wz[p] = 0;
        st.live[p] = (p % GV_SPLAT_TILE) < tw && (p / GV_SPLAT_TILE) < th ? -1 : 0;
    }
    for (int y = 0; y < GV_SPLAT_TILE; y++) st.row_live[y] = y < th ? tw : 0;
    int n_live = tw * th;
    for (int e = t->tile_offsets[tile]; e < t->tile_offsets[tile + 1] && n_live > 0; e++) {
        depth_splat s;
        int g = t->depth_order[t->entries[e]];
        if (load_depth_splat(&s, g, means2d, conics, opacities, depths, px0, py0, tw, th))
            n_live -= blend_depth(&st, &s, px0, py0);
    }
    for (int y = 0; y < th; y++)
        for (int x = 0; x < tw; x++) {
            int p = y * GV_SPLAT_TILE + x;
            size_t pix = (size_t)(py0 + y) * width + (px0 + x);
            if (depth) depth[pix] = st.w[p] > 0 ? st.wz[p] / st.w[p] : 0.0f;
            if (opacity) opacity[pix] = 1.0f - st.T[p];
        }
}

void gv_splat_rasterize_depth(const gv_splat_tiles *t, int width, int height,
                              const float *means2d, const float *conics,
                              const float *opacities, const float *depths, float *depth,
                              float *opacity)
{
    int n_tiles = t->tiles_x * t->tiles_y;
#pragma omp parallel for schedule(dynamic, 1)
    for (int tile = 0; tile < n_tiles; tile++)
        depth_tile(t, tile, width, height, means2d, conics, opacities, depths, depth, opacity);
}

int gv_splat_render_depth(const gv_splat_renderer *r, float *depth, float *opacity)
{
    if (!r->tiles.tile_offsets || r->view.width <= 0)
        return gv_fail("render: depth asked before any forward");
    gv_splat_rasterize_depth(&r->tiles, r->view.width, r->view.height, r->means2d, r->conics,
                             r->opacities, r->depths, depth, opacity);
    return 0;
}
