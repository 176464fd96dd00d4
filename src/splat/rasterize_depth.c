/* Expected depth and accumulated opacity per pixel: a pass of its own over the tiles of the
 * last forward, blending the view-space depths of the Gaussians with the forward's weights.
 *
 * With w_i = alpha_i T_i the weight of Gaussian i in a pixel (the colour's weight in
 * docs/reference/gaussian-splatting.md section 9), the depth is sum_i w_i z_i / sum_i w_i (0 where
 * nothing blends) and the opacity is 1 - T_final = sum_i w_i. Every pixel goes through the
 * forward's tests in the forward's order of operations (rasterize.c: the same power,
 * f8_exp_neg, alpha clamp and threshold, early stop before T (1 - alpha) < 1e-4), so it
 * blends exactly the Gaussians the image blended and its T_final is the forward's, bit for
 * bit. A Gaussian visits only the pixels of its alpha box (rasterize.c explains the box;
 * outside it alpha < 1/255). Kept apart from rasterize.c so that the training kernels do not
 * carry it: nothing here is differentiated. */
#include <math.h>
#include <stdlib.h>

#include "gaussvid/core/core.h"
#include "gaussvid/splat/render.h"
#include "gaussvid/splat/splat.h"
#include "splat/blend8.h"
#include "splat/simd8.h"

/* One Gaussian of a tile list as the tile sees it (blend8.h) and its view depth. */
typedef struct {
    tile_splat g;
    float z;
} depth_splat;

typedef struct {
    tile_pixels px;
    float w[TILE_PIXELS], wz[TILE_PIXELS];
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
    s->g.mx = means2d[2 * g], s->g.my = means2d[2 * g + 1];
    /* pixel x of the tile has its centre at px0 + x + 0.5 */
    s->g.x0 = clamp_int(ceilf(s->g.mx - hx - 0.5f - (float)px0), 0, tw);
    s->g.x1 = clamp_int(floorf(s->g.mx + hx - 0.5f - (float)px0) + 1.0f, 0, tw) - 1;
    s->g.y0 = clamp_int(ceilf(s->g.my - hy - 0.5f - (float)py0), 0, th);
    s->g.y1 = clamp_int(floorf(s->g.my + hy - 0.5f - (float)py0) + 1.0f, 0, th) - 1;
    if (s->g.x0 > s->g.x1 || s->g.y0 > s->g.y1) return 0;
    s->g.x0 &= ~7;
    s->g.A = A, s->g.B = B, s->g.C = C, s->g.o = o, s->z = depths[g];
    s->g.power_min = -INFINITY; /* every pixel of the box is tested */
    return 1;
}

static RASTER_CLONES void depth_tile(const gv_splat_tiles *t, int tile, int width, int height,
                                    const float *means2d, const float *conics,
                                    const float *opacities, const float *depths, float *depth,
                                    float *opacity)
{
    tile_box b = tile_box_of(t, tile, width, height);
    int px0 = b.px0, py0 = b.py0, tw = b.tw, th = b.th;
    depth_state st __attribute__((aligned(32)));
    int n_live = tile_start(&st.px, b);
    for (int p = 0; p < TILE_PIXELS; p++) st.w[p] = st.wz[p] = 0;
    blend_target to = {{st.w, st.wz, NULL}, {0, 0, 0}, NULL, 0};
    for (int e = t->tile_offsets[tile]; e < t->tile_offsets[tile + 1] && n_live > 0; e++) {
        depth_splat s;
        int g = t->depth_order[t->entries[e]];
        if (load_depth_splat(&s, g, means2d, conics, opacities, depths, px0, py0, tw, th)) {
            to.value[0] = s.z; /* the image's blend, with the depth in place of the colour */
            n_live -= blend_box(&st.px, &s.g, px0, py0, BLEND_DEPTH, &to);
        }
    }
    for (int y = 0; y < th; y++)
        for (int x = 0; x < tw; x++) {
            int p = y * GV_SPLAT_TILE + x;
            size_t pix = (size_t)(py0 + y) * width + (px0 + x);
            if (depth) depth[pix] = st.w[p] > 0 ? st.wz[p] / st.w[p] : 0.0f;
            if (opacity) opacity[pix] = 1.0f - st.px.T[p];
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
