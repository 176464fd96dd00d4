/* Tile rasteriser: front-to-back alpha blending and its backward
 * (docs/reference/gaussian-splatting.md sections 9 and 10.1; [RAST] forward.cu / backward.cu
 * renderCUDA).
 *
 * Each tile is rendered by one thread, Gaussian by Gaussian in the tile's depth order, eight
 * pixels of a row at a time (simd8.h); the reference runs one GPU thread per pixel over the
 * same list. Every pixel goes through the reference's sequence of operations, so the
 * result is the reference's; the order only lets a Gaussian skip the pixels where its alpha
 * cannot reach 1/255: with power = -d^T K d / 2 and alpha = o exp(power), alpha >= 1/255
 * needs d^T K d <= 2 ln(255 o), an ellipse whose bounding box is |dx| <= sqrt(2 ln(255 o)
 * Sigma_xx) (and the same in y), Sigma = K^-1. The box is widened (ln + 0.1, + 0.01 px) so
 * that float rounding never drops a pixel the reference would blend; pixels of the box's
 * 8-pixel groups outside it are evaluated too, which is harmless (alpha < 1/255 there).
 * exp is f8_exp_neg, the same function in the forward and the backward, so both take the
 * same decisions.
 *
 * The backward walks each tile's list back to front with the per-pixel state of the
 * reference (T, accumulated colour behind, last alpha and colour) and writes one gradient
 * row per (tile, Gaussian) entry; the rows are then summed per Gaussian in a fixed order.
 * No atomics, and the result does not depend on the number of threads. */
#include <math.h>
#include <string.h>

#include "gaussvid/splat/splat.h"
#include "splat/blend8.h"
#include "splat/simd8.h"

enum { GRAD_WIDTH = 9, SPLAT_WIDTH = 12 };
enum { PREFETCH = 8 }; /* how far ahead scattered rows are fetched */

/* Packs the 2D data of each visible Gaussian by depth rank (the order in which the tiles
 * read them): mean, conic, opacity, colour and the half extents of its alpha box. */
static void pack_splats(const gv_splat_tiles *t, const float *means2d, const float *conics,
                        const float *colors, const float *opacities)
{
#pragma omp parallel for schedule(static)
    for (int k = 0; k < t->n_visible; k++) {
        int g = t->depth_order[k];
        if (k + PREFETCH < t->n_visible) { /* depth order is random in memory */
            int h = t->depth_order[k + PREFETCH];
            __builtin_prefetch(means2d + 2 * h), __builtin_prefetch(conics + 3 * h);
            __builtin_prefetch(colors + 3 * h), __builtin_prefetch(opacities + h);
        }
        float *s = t->splats + (size_t)k * SPLAT_WIDTH;
        float A = conics[3 * g], B = conics[3 * g + 1], C = conics[3 * g + 2], o = opacities[g];
        s[0] = means2d[2 * g], s[1] = means2d[2 * g + 1];
        s[2] = A, s[3] = B, s[4] = C, s[5] = o;
        s[6] = colors[3 * g], s[7] = colors[3 * g + 1], s[8] = colors[3 * g + 2];
        float det = A * C - B * B;
        /* alpha = o exp(power) >= 1/255 needs power >= -ln(255 o); with a margin far above
         * the rounding of the exponential and of this logf, a group of pixels whose powers
         * are all below s[11] has no pixel the exact test would blend, so it is skipped. */
        float log_o = o >= GV_SPLAT_ALPHA_MIN ? logf(255.0f * o) : 0;
        s[11] = -log_o - 1e-3f;
        if (!(o >= GV_SPLAT_ALPHA_MIN)) {
            /* o exp(power) <= o: below 1/255 it is skipped everywhere (exactly, in float) */
            s[9] = s[10] = -1;
        } else if (!(det > 0) || !(A > 0)) {
            s[9] = s[10] = INFINITY; /* degenerate in float: the whole rectangle */
        } else {
            float level = 2.0f * (log_o + 0.1f);
            s[9] = sqrtf(level * C / det) + 0.01f;
            s[10] = sqrtf(level * A / det) + 0.01f;
        }
    }
}

/* One Gaussian as a tile sees it (blend8.h) and its colour. */
typedef struct {
    tile_splat g;
    float col[3];
} splat2d;

/* floor(v) and ceil(v) as ints, clamped to [-1, limit] first (no libm calls: this runs for
 * every entry of every tile). */
static inline int floor_bound(float v, int limit)
{
    v = v > -1.0f ? v : -1.0f; /* also maps NaN to -1 */
    v = v < (float)limit ? v : (float)limit;
    int i = (int)v;
    return (float)i > v ? i - 1 : i;
}

static inline int ceil_bound(float v, int limit)
{
    v = v > -1.0f ? v : -1.0f;
    v = v < (float)limit ? v : (float)limit;
    int i = (int)v;
    return (float)i < v ? i + 1 : i;
}

/* Returns 0 when the Gaussian's alpha box misses the tile. */
static SIMD8_INLINE int load_splat(splat2d *s, const float *p, int px0, int py0, int tw, int th)
{
    if (p[9] < 0) return 0;
    /* Pixel x has its centre at px0 + x + 0.5. */
    int x0 = ceil_bound(p[0] - p[9] - 0.5f - (float)px0, tw);
    int x1 = floor_bound(p[0] + p[9] - 0.5f - (float)px0, tw);
    int y0 = ceil_bound(p[1] - p[10] - 0.5f - (float)py0, th);
    int y1 = floor_bound(p[1] + p[10] - 0.5f - (float)py0, th);
    s->g.x0 = x0 < 0 ? 0 : x0;
    s->g.y0 = y0 < 0 ? 0 : y0;
    s->g.x1 = x1 > tw - 1 ? tw - 1 : x1;
    s->g.y1 = y1 > th - 1 ? th - 1 : y1;
    if (s->g.x0 > s->g.x1 || s->g.y0 > s->g.y1) return 0;
    s->g.x0 &= ~7; /* whole groups of eight pixels */
    s->g.mx = p[0], s->g.my = p[1], s->g.A = p[2], s->g.B = p[3], s->g.C = p[4], s->g.o = p[5];
    s->col[0] = p[6], s->col[1] = p[7], s->col[2] = p[8];
    s->g.power_min = p[11];
    return 1;
}

/* The Gaussian's power and alpha at eight pixels of a row (blend8.h). */
static SIMD8_INLINE f8 splat_power(const splat2d *s, f8 dx, float dy, float cdd)
{
    return gaussian_power(s->g.A, s->g.B, dx, dy, cdd);
}

static SIMD8_INLINE f8 splat_alpha(const splat2d *s, f8 power, f8 *G)
{
    return gaussian_alpha(s->g.o, power, G);
}

/* Per-pixel state of the forward blend. */
typedef struct {
    tile_pixels px;
    float C[3][TILE_PIXELS];
    int32_t last[TILE_PIXELS];
} blend_state;

static RASTER_CLONES void render_tile(const gv_splat_tiles *t, int tile, int width, int height,
                        const float bg[3], float *image, float *final_T, int *n_contrib)
{
    tile_box b = tile_box_of(t, tile, width, height);
    int px0 = b.px0, py0 = b.py0, tw = b.tw, th = b.th;
    blend_state st __attribute__((aligned(32)));
    int n_live = tile_start(&st.px, b);
    for (int p = 0; p < TILE_PIXELS; p++) st.C[0][p] = st.C[1][p] = st.C[2][p] = 0, st.last[p] = 0;
    blend_target to = {{st.C[0], st.C[1], st.C[2]}, {0, 0, 0}, st.last, 0};
    int start = t->tile_offsets[tile], count = t->tile_offsets[tile + 1] - start;
    const int *entries = t->entries + start;
    for (int j = 0; j < count && n_live > 0; j++) {
        splat2d s;
        if (j + 8 < count) __builtin_prefetch(t->splats + (size_t)entries[j + 8] * SPLAT_WIDTH);
        if (load_splat(&s, t->splats + (size_t)entries[j] * SPLAT_WIDTH, px0, py0, tw, th)) {
            to.value[0] = s.col[0], to.value[1] = s.col[1], to.value[2] = s.col[2], to.index = j;
            n_live -= blend_box(&st.px, &s.g, px0, py0, BLEND_COLOUR, &to);
        }
    }
    for (int y = 0; y < th; y++)
        for (int x = 0; x < tw; x++) {
            int p = y * GV_SPLAT_TILE + x;
            size_t pix = (size_t)(py0 + y) * width + (px0 + x);
            for (int c = 0; c < 3; c++) image[pix * 3 + c] = st.C[c][p] + st.px.T[p] * bg[c];
            final_T[pix] = st.px.T[p];
            n_contrib[pix] = st.last[p];
        }
}

void gv_splat_rasterize_forward(const gv_splat_tiles *t, int width, int height,
                                const float *means2d, const float *conics,
                                const float *colors, const float *opacities,
                                const float bg[3], float *image, float *final_T,
                                int *n_contrib)
{
    int n_tiles = t->tiles_x * t->tiles_y;
    pack_splats(t, means2d, conics, colors, opacities);
#pragma omp parallel for schedule(dynamic, 1)
    for (int tile = 0; tile < n_tiles; tile++)
        render_tile(t, tile, width, height, bg, image, final_T, n_contrib);
}

/* Per-pixel state of the backward walk (reference renderCUDA backward). The colour sums
 * of the reference enter only through their dot product with dL/dpixel, so they are kept as
 * that scalar: acc = g . (colour behind, normalised), last_gc = g . (last colour). */
typedef struct {
    float T[TILE_PIXELS], T_final[TILE_PIXELS], acc[TILE_PIXELS], last_gc[TILE_PIXELS];
    float last_alpha[TILE_PIXELS], dpix[3][TILE_PIXELS], bg_dot[TILE_PIXELS];
    int32_t n_contrib[TILE_PIXELS];
    int row_contrib[GV_SPLAT_TILE]; /* largest n_contrib of each row */
} tile_state;

/* Gradient row of one entry (position j of the tile list) from all the tile's pixels it
 * was blended into: d means2d (2), d conic (3), d colour (3), d opacity. With q = dL/dG G
 * per pixel and d = mean - pixel, dG/dmean = -G K d and dG/dK = -G d d^T / 2, so the sums
 * needed are of q dx, q dy, q dx^2, q dx dy, q dy^2; dy is constant along a row, so a row
 * sums q, q dx, q dx^2 and folds them in. */
static SIMD8_INLINE void entry_backward(tile_state *st, const splat2d *s, int j, int px0, int py0,
                                        float row[GRAD_WIDTH])
{
    f8 zero = f8_splat(0.0f);
    f8 e_qx = zero, e_qy = zero, e_qxx = zero, e_qxy = zero, e_qyy = zero;
    f8 e_o = zero, e_c0 = zero, e_c1 = zero, e_c2 = zero;
    i8 jv = {j, j, j, j, j, j, j, j};
    f8 centres = f8_splat((float)px0) + LANE_CENTRES; /* pixel centres of the lanes at x = 0 */
    for (int y = s->g.y0; y <= s->g.y1; y++) {
        if (j >= st->row_contrib[y]) continue;
        float dy = s->g.my - ((float)(py0 + y) + 0.5f), cdd = s->g.C * dy * dy;
        f8 r_q = zero, r_qx = zero, r_qxx = zero;
        for (int x = s->g.x0; x <= s->g.x1; x += 8) {
            int p = y * GV_SPLAT_TILE + x;
            i8 m = jv < i8_load(st->n_contrib + p); /* this pixel blended entry j */
            f8 dx = s->g.mx - (centres + (float)x), G; /* exact centres: one rounding */
            f8 power = splat_power(s, dx, dy, cdd);
            if (!i8_any(m & (power >= s->g.power_min))) continue; /* not blended here */
            f8 alpha = splat_alpha(s, power, &G);
            m &= (power <= 0.0f) & (alpha >= GV_SPLAT_ALPHA_MIN);
            if (!i8_any(m)) continue;
            /* transmittance before this Gaussian */
            f8 inv = 1.0f / (1.0f - alpha), T_after = f8_load(st->T + p), T = T_after * inv;
            f8_store(st->T + p, f8_select(m, T, T_after));
            f8 g0 = f8_load(st->dpix[0] + p), g1 = f8_load(st->dpix[1] + p);
            f8 g2 = f8_load(st->dpix[2] + p);
            f8 gc = g0 * s->col[0] + g1 * s->col[1] + g2 * s->col[2];
            f8 last_alpha = f8_load(st->last_alpha + p), acc_old = f8_load(st->acc + p);
            f8 acc = last_alpha * f8_load(st->last_gc + p) + (1.0f - last_alpha) * acc_old;
            f8_store(st->acc + p, f8_select(m, acc, acc_old));
            f8_store(st->last_gc + p, f8_select(m, gc, f8_load(st->last_gc + p)));
            f8_store(st->last_alpha + p, f8_select(m, alpha, last_alpha));
            f8 dL_dalpha = (gc - acc) * T +
                           (-f8_load(st->T_final + p) * inv) * f8_load(st->bg_dot + p);
            dL_dalpha = f8_mask(m, dL_dalpha);
            f8 w = f8_mask(m, alpha * T); /* d pixel / d colour */
            e_c0 += w * g0, e_c1 += w * g1, e_c2 += w * g2;
            /* alpha = o G (the 0.99 clamp is ignored, as in 3DGS) */
            e_o += G * dL_dalpha;
            f8 q = (s->g.o * G) * dL_dalpha, qx = q * dx;
            r_q += q, r_qx += qx, r_qxx += qx * dx;
        }
        e_qx += r_qx, e_qxx += r_qxx;
        e_qy += dy * r_q, e_qxy += dy * r_qx, e_qyy += (dy * dy) * r_q;
    }
    float qx = f8_sum(e_qx), qy = f8_sum(e_qy);
    row[0] = -s->g.A * qx - s->g.B * qy;
    row[1] = -s->g.C * qy - s->g.B * qx;
    row[2] = -0.5f * f8_sum(e_qxx);
    row[3] = -f8_sum(e_qxy); /* B appears twice in d^T K d */
    row[4] = -0.5f * f8_sum(e_qyy);
    row[5] = f8_sum(e_c0), row[6] = f8_sum(e_c1), row[7] = f8_sum(e_c2);
    row[8] = f8_sum(e_o);
}

static RASTER_CLONES void backward_tile(gv_splat_tiles *t, int tile, int width, int height,
                                       const float bg[3], const float *final_T,
                                       const int *n_contrib, const float *d_image)
{
    int px0 = (tile % t->tiles_x) * GV_SPLAT_TILE, py0 = (tile / t->tiles_x) * GV_SPLAT_TILE;
    int tw = width - px0 < GV_SPLAT_TILE ? width - px0 : GV_SPLAT_TILE;
    int th = height - py0 < GV_SPLAT_TILE ? height - py0 : GV_SPLAT_TILE;
    tile_state st __attribute__((aligned(64)));
    memset(&st, 0, sizeof st);
    int max_contrib = 0;
    for (int y = 0; y < th; y++)
        for (int x = 0; x < tw; x++) {
            int p = y * GV_SPLAT_TILE + x;
            size_t pix = (size_t)(py0 + y) * width + (px0 + x);
            st.T[p] = st.T_final[p] = final_T[pix];
            st.n_contrib[p] = n_contrib[pix];
            for (int c = 0; c < 3; c++) st.dpix[c][p] = d_image[pix * 3 + c];
            st.bg_dot[p] = bg[0] * st.dpix[0][p] + bg[1] * st.dpix[1][p] + bg[2] * st.dpix[2][p];
            if (st.n_contrib[p] > st.row_contrib[y]) st.row_contrib[y] = st.n_contrib[p];
            if (st.n_contrib[p] > max_contrib) max_contrib = st.n_contrib[p];
        }
    int start = t->tile_offsets[tile], count = t->tile_offsets[tile + 1] - start;
    float *rows = t->entry_grads + (size_t)start * GRAD_WIDTH;
    memset(rows + (size_t)max_contrib * GRAD_WIDTH, 0,
           (size_t)(count - max_contrib) * GRAD_WIDTH * sizeof(float));
    const int *entries = t->entries + start;
    for (int j = max_contrib - 1; j >= 0; j--) {
        splat2d s;
        float *row = rows + (size_t)j * GRAD_WIDTH;
        if (j >= 8) __builtin_prefetch(t->splats + (size_t)entries[j - 8] * SPLAT_WIDTH);
        if (load_splat(&s, t->splats + (size_t)entries[j] * SPLAT_WIDTH, px0, py0, tw, th))
            entry_backward(&st, &s, j, px0, py0, row);
        else
            memset(row, 0, GRAD_WIDTH * sizeof(float));
    }
}

void gv_splat_rasterize_backward(gv_splat_tiles *t, int width, int height, const float bg[3],
                                 const float *final_T, const int *n_contrib,
                                 const float *d_image, float *d_means2d, float *d_conics,
                                 float *d_colors, float *d_opacities)
{
    int n_tiles = t->tiles_x * t->tiles_y;
#pragma omp parallel for schedule(dynamic, 1)
    for (int tile = 0; tile < n_tiles; tile++)
        backward_tile(t, tile, width, height, bg, final_T, n_contrib, d_image);

    /* Sum each Gaussian's entry rows, always in the same order. */
#pragma omp parallel for schedule(static)
    for (int k = 0; k < t->n_visible; k++) {
        size_t g = (size_t)t->depth_order[k];
        float sum[GRAD_WIDTH] = {0};
        int ahead = t->gauss_offsets[k] + PREFETCH; /* the rows are scattered over the tiles */
        if (ahead < t->n_entries) {
            const float *row = t->entry_grads + (size_t)t->entry_of[ahead] * GRAD_WIDTH;
            __builtin_prefetch(row), __builtin_prefetch(row + GRAD_WIDTH - 1);
        }
        for (int e = t->gauss_offsets[k]; e < t->gauss_offsets[k + 1]; e++) {
            const float *row = t->entry_grads + (size_t)t->entry_of[e] * GRAD_WIDTH;
            for (int i = 0; i < GRAD_WIDTH; i++) sum[i] += row[i];
        }
        d_means2d[2 * g] = sum[0], d_means2d[2 * g + 1] = sum[1];
        for (int i = 0; i < 3; i++) d_conics[3 * g + i] = sum[2 + i];
        for (int i = 0; i < 3; i++) d_colors[3 * g + i] = sum[5 + i];
        d_opacities[g] = sum[8];
    }
}
