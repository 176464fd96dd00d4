/* The backward of the accumulated depth D = sum_i w_i z_i (w_i = alpha_i T_i, the colour's
 * weights; rasterize_depth.c): from dL/dD per pixel, the gradients with respect to each
 * visible Gaussian's means2d, conic, opacity (activated) and view depth z.
 *
 * Binocular3DGS's consistency loss (src/splat/binocular.c) differentiates this un-normalised
 * sum, not the expected depth D / sum_i w_i: its release renders depth with ashawkey's
 * diff-gaussian-rasterization (pinned at 8829d14), whose forward accumulates
 * D += z alpha T and whose backward passes dL/dD to the opacities, the 2D means and conics
 * (through alpha) and to each Gaussian's z (through w_i), which reaches the 3D mean through
 * the view matrix's third row. The same here.
 *
 * Per pixel, back to front as the colour's backward (rasterize.c; docs/reference/
 * gaussian-splatting.md section 10.1) with one channel whose colour is z and whose background
 * is 0: dD/dz_i = alpha_i T_i, and dD/dalpha_i = T_i (z_i - S_i) with S_i = sum_{j > i} z_j
 * alpha_j prod_{i < k < j} (1 - alpha_k), the depth behind i, accumulated as
 * S_i = alpha_{i+1} z_{i+1} + (1 - alpha_{i+1}) S_{i+1}. alpha = o G: dL/do = G dL/dalpha, and
 * G's derivatives give the 2D mean and conic (the 0.99 clamp is ignored, as in 3DGS).
 *
 * It must follow the image's forward on the same tiles (it reads its final_T and n_contrib:
 * the pixels of the depth pass blend the same Gaussians, rasterize_depth.c). Kept in a file
 * of its own, as the depth forward is, so that the colour kernels that every training
 * iteration runs do not carry it; only a training run with the binocular loss calls it. Rows
 * per (tile, entry) are summed per Gaussian in a fixed order: no atomics, the same result for
 * any number of threads. */
#include <math.h>
#include <string.h>

#include "gaussvid/splat/splat.h"
#include "splat/blend8.h"
#include "splat/simd8.h"

/* d means2d (2), d conic (3), d opacity, d z: one row per (tile, entry) in t->entry_grads,
 * which binning sizes for the colour's 9 floats per entry. */
enum { DEPTH_GRAD_WIDTH = 7 };

/* Per-pixel state of the backward walk: transmittance, the depth behind (S), the last
 * blended Gaussian's depth and alpha, dL/dD, and the forward's count of entries blended. */
typedef struct {
    float T[TILE_PIXELS], behind[TILE_PIXELS], last_z[TILE_PIXELS], last_alpha[TILE_PIXELS];
    float g[TILE_PIXELS];
    int32_t n_contrib[TILE_PIXELS];
    int row_contrib[GV_SPLAT_TILE]; /* largest n_contrib of each row */
} depth_grad_state;

/* The gradient row of entry j (a Gaussian at depth z) from every pixel of the tile that
 * blended it: with q = dL/dG G o and d = mean - pixel, sums of q dx, q dy, q dx^2, q dx dy,
 * q dy^2 give the mean and conic parts (rasterize.c, entry_backward, the same algebra). */
static SIMD8_INLINE void entry_depth_backward(depth_grad_state *st, const tile_splat *s, float z,
                                              int j, int px0, int py0,
                                              float row[DEPTH_GRAD_WIDTH])
{
    f8 zero = f8_splat(0.0f);
    f8 e_qx = zero, e_qy = zero, e_qxx = zero, e_qxy = zero, e_qyy = zero, e_o = zero, e_z = zero;
    i8 jv = {j, j, j, j, j, j, j, j};
    f8 centres = f8_splat((float)px0) + LANE_CENTRES;
    for (int y = s->y0; y <= s->y1; y++) {
        if (j >= st->row_contrib[y]) continue;
        float dy = s->my - ((float)(py0 + y) + 0.5f), cdd = s->C * dy * dy;
        f8 r_q = zero, r_qx = zero, r_qxx = zero;
        for (int x = s->x0; x <= s->x1; x += 8) {
            int p = y * GV_SPLAT_TILE + x;
            i8 m = jv < i8_load(st->n_contrib + p); /* this pixel blended entry j ... */
            if (!i8_any(m)) continue;
            f8 dx = s->mx - (centres + (float)x), G;
            f8 power = gaussian_power(s->A, s->B, dx, dy, cdd);
            if (!i8_any(m & (power >= s->power_min))) continue; /* alpha < 1/255 at all */
            f8 alpha = gaussian_alpha(s->o, power, &G);
            m &= (power <= 0.0f) & (alpha >= GV_SPLAT_ALPHA_MIN); /* ... if it counted here */
            if (!i8_any(m)) continue;
            f8 inv = 1.0f / (1.0f - alpha), T_after = f8_load(st->T + p), T = T_after * inv;
            f8_store(st->T + p, f8_select(m, T, T_after));
            f8 last_alpha = f8_load(st->last_alpha + p), behind_old = f8_load(st->behind + p);
            f8 behind = last_alpha * f8_load(st->last_z + p) + (1.0f - last_alpha) * behind_old;
            f8_store(st->behind + p, f8_select(m, behind, behind_old));
            f8_store(st->last_z + p, f8_select(m, f8_splat(z), f8_load(st->last_z + p)));
            f8_store(st->last_alpha + p, f8_select(m, alpha, last_alpha));
            f8 g = f8_load(st->g + p);
            f8 dL_dalpha = f8_mask(m, g * (z - behind) * T);
            e_z += f8_mask(m, alpha * T) * g;
            e_o += G * dL_dalpha;
            f8 q = (s->o * G) * dL_dalpha, qx = q * dx;
            r_q += q, r_qx += qx, r_qxx += qx * dx;
        }
        e_qx += r_qx, e_qxx += r_qxx;
        e_qy += dy * r_q, e_qxy += dy * r_qx, e_qyy += (dy * dy) * r_q;
    }
    float qx = f8_sum(e_qx), qy = f8_sum(e_qy);
    row[0] = -s->A * qx - s->B * qy;
    row[1] = -s->C * qy - s->B * qx;
    row[2] = -0.5f * f8_sum(e_qxx);
    row[3] = -f8_sum(e_qxy); /* B appears twice in d^T K d */
    row[4] = -0.5f * f8_sum(e_qyy);
    row[5] = f8_sum(e_o);
    row[6] = f8_sum(e_z);
}

static RASTER_CLONES void depth_backward_tile(gv_splat_tiles *t, int tile, int width,
                                              int height, const float *means2d,
                                              const float *conics, const float *opacities,
                                              const float *depths, const float *final_T,
                                              const int *n_contrib, const float *d_depth_sum)
{
    tile_box b = tile_box_of(t, tile, width, height);
    depth_grad_state st __attribute__((aligned(64)));
    memset(&st, 0, sizeof st);
    int max_contrib = 0;
    for (int y = 0; y < b.th; y++)
        for (int x = 0; x < b.tw; x++) {
            int p = y * GV_SPLAT_TILE + x;
            size_t pix = (size_t)(b.py0 + y) * width + (b.px0 + x);
            st.T[p] = final_T[pix];
            st.n_contrib[p] = n_contrib[pix];
            st.g[p] = d_depth_sum[pix];
            if (st.n_contrib[p] > st.row_contrib[y]) st.row_contrib[y] = st.n_contrib[p];
            if (st.n_contrib[p] > max_contrib) max_contrib = st.n_contrib[p];
        }
    int start = t->tile_offsets[tile], count = t->tile_offsets[tile + 1] - start;
    float *rows = t->entry_grads + (size_t)start * DEPTH_GRAD_WIDTH;
    memset(rows + (size_t)max_contrib * DEPTH_GRAD_WIDTH, 0,
           (size_t)(count - max_contrib) * DEPTH_GRAD_WIDTH * sizeof(float));
    const int *entries = t->entries + start;
    for (int j = max_contrib - 1; j >= 0; j--) {
        float *row = rows + (size_t)j * DEPTH_GRAD_WIDTH;
        int g = t->depth_order[entries[j]];
        tile_splat s;
        if (tile_splat_load(&s, g, means2d, conics, opacities, b.px0, b.py0, b.tw, b.th))
            entry_depth_backward(&st, &s, depths[g], j, b.px0, b.py0, row);
        else
            memset(row, 0, DEPTH_GRAD_WIDTH * sizeof(float));
    }
}

void gv_splat_rasterize_depth_backward(gv_splat_tiles *t, int width, int height,
                                       const float *means2d, const float *conics,
                                       const float *opacities, const float *depths,
                                       const float *final_T, const int *n_contrib,
                                       const float *d_depth_sum, float *d_means2d,
                                       float *d_conics, float *d_opacities, float *d_depths)
{
    int n_tiles = t->tiles_x * t->tiles_y;
#pragma omp parallel for schedule(dynamic, 1)
    for (int tile = 0; tile < n_tiles; tile++)
        depth_backward_tile(t, tile, width, height, means2d, conics, opacities, depths, final_T,
                            n_contrib, d_depth_sum);

    /* Sum each Gaussian's entry rows, always in the same order. */
#pragma omp parallel for schedule(static)
    for (int k = 0; k < t->n_visible; k++) {
        size_t g = (size_t)t->depth_order[k];
        float sum[DEPTH_GRAD_WIDTH] = {0};
        for (int e = t->gauss_offsets[k]; e < t->gauss_offsets[k + 1]; e++) {
            const float *row = t->entry_grads + (size_t)t->entry_of[e] * DEPTH_GRAD_WIDTH;
            for (int i = 0; i < DEPTH_GRAD_WIDTH; i++) sum[i] += row[i];
        }
        d_means2d[2 * g] = sum[0], d_means2d[2 * g + 1] = sum[1];
        for (int i = 0; i < 3; i++) d_conics[3 * g + i] = sum[2 + i];
        d_opacities[g] = sum[5];
        d_depths[g] = sum[6];
    }
}
