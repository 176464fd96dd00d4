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
 * outside it alpha < 1/255). The un-normalised sum sum_i w_i z_i is also given: it is the
 * depth Binocular3DGS's consistency loss differentiates (rasterize_depth_backward.c). Kept
 * apart from rasterize.c so that the training kernels do not carry it. */
#include <math.h>
#include <stdlib.h>

#include "gaussvid/core/core.h"
#include "gaussvid/splat/render.h"
#include "gaussvid/splat/splat.h"
#include "splat/blend8.h"
#include "splat/simd8.h"

typedef struct {
    tile_pixels px;
    float w[TILE_PIXELS], wz[TILE_PIXELS];
} depth_state;

static RASTER_CLONES void depth_tile(const gv_splat_tiles *t, int tile, int width, int height,
                                    const float *means2d, const float *conics,
                                    const float *opacities, const float *depths, float *depth,
                                    float *opacity, float *depth_sum)
{
    tile_box b = tile_box_of(t, tile, width, height);
    int px0 = b.px0, py0 = b.py0, tw = b.tw, th = b.th;
    depth_state st __attribute__((aligned(32)));
    int n_live = tile_start(&st.px, b);
    for (int p = 0; p < TILE_PIXELS; p++) st.w[p] = st.wz[p] = 0;
    blend_target to = {{st.w, st.wz, NULL}, {0, 0, 0}, NULL, 0};
    for (int e = t->tile_offsets[tile]; e < t->tile_offsets[tile + 1] && n_live > 0; e++) {
        tile_splat s;
        int g = t->depth_order[t->entries[e]];
        if (tile_splat_load(&s, g, means2d, conics, opacities, px0, py0, tw, th)) {
            to.value[0] = depths[g]; /* the image's blend, with the depth in place of the colour */
            n_live -= blend_box(&st.px, &s, px0, py0, BLEND_DEPTH, &to);
        }
    }
    for (int y = 0; y < th; y++)
        for (int x = 0; x < tw; x++) {
            int p = y * GV_SPLAT_TILE + x;
            size_t pix = (size_t)(py0 + y) * width + (px0 + x);
            if (depth) depth[pix] = st.w[p] > 0 ? st.wz[p] / st.w[p] : 0.0f;
            if (opacity) opacity[pix] = 1.0f - st.px.T[p];
            if (depth_sum) depth_sum[pix] = st.wz[p];
        }
}

void gv_splat_rasterize_depth(const gv_splat_tiles *t, int width, int height,
                              const float *means2d, const float *conics,
                              const float *opacities, const float *depths, float *depth,
                              float *opacity, float *depth_sum)
{
    int n_tiles = t->tiles_x * t->tiles_y;
#pragma omp parallel for schedule(dynamic, 1)
    for (int tile = 0; tile < n_tiles; tile++)
        depth_tile(t, tile, width, height, means2d, conics, opacities, depths, depth, opacity,
                   depth_sum);
}

int gv_splat_render_depth(const gv_splat_renderer *r, float *depth, float *opacity)
{
    if (!r->tiles.tile_offsets || r->view.width <= 0)
        return gv_fail("render: depth asked before any forward");
    gv_splat_rasterize_depth(&r->tiles, r->view.width, r->view.height, r->means2d, r->conics,
                             r->opacities, r->depths, depth, opacity, NULL);
    return 0;
}

int gv_splat_render_depth_sum(const gv_splat_renderer *r, float *depth_sum)
{
    if (!r->tiles.tile_offsets || r->view.width <= 0)
        return gv_fail("render: depth asked before any forward");
    gv_splat_rasterize_depth(&r->tiles, r->view.width, r->view.height, r->means2d, r->conics,
                             r->opacities, r->depths, NULL, NULL, depth_sum);
    return 0;
}
