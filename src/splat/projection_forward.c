/* The forward projection (docs/reference/gaussian-splatting.md sections 2, 4-6; [RAST] forward.cu
 * preprocessCUDA, computeCov2D, computeCov3D), eight Gaussians at a time (projection_lanes.h).
 *
 * Two passes over each chunk of Gaussians:
 *  1. a cheap bound on the radius settles most of the Gaussians that miss the image:
 *     lambda_1 = mid + sqrt(max(0.1, mid^2 - det)) <= a + c + 0.32, and a + c =
 *     trace(J W Sigma W^T J^T) + 0.6 <= |J|_F^2 max(s)^2 + 0.6 (W is a rotation), so
 *     radius <= 3 sqrt(|J|_F^2 max(s)^2 + 0.92), taken with a margin for rounding; when even
 *     that radius gives an empty tile rectangle, the Gaussian is culled;
 *  2. the others, gathered eight at a time, go through the whole projection. */
#include "splat/projection_lanes.h"

enum { CHUNK = 256 };

/* ceilf(x) for x >= 0, infinity or NaN: below 2^24 through the truncating conversion, above
 * it x is already an integer (and infinity and NaN are returned as they are). */
static SIMD8_INLINE f8 ceil_nonneg8(f8 x)
{
    i8 small = x < f8_splat(16777216.0f);
    f8 xs = f8_mask(small, x);
    f8 f = __builtin_convertvector(__builtin_convertvector(xs, i8), f8);
    return f8_select(small, f8_select(f < xs, f + 1.0f, f), x);
}

/* binning.c's tile_coord: truncation towards zero of a clamped float, then [0, grid]. */
static SIMD8_INLINE i8 tile_coord8(f8 v, int grid)
{
    v = f8_select(v > -1.0f, v, f8_splat(-1.0f)); /* NaN becomes -1 */
    v = f8_select(v < (float)grid + 1.0f, v, f8_splat((float)grid + 1.0f));
    i8 i = __builtin_convertvector(v, i8);
    i = i8_select(i < 0, (i8){0}, i);
    return i8_select(i > grid, (i8){0} + grid, i);
}

/* All ones where gv_splat_tile_rect(mx, my, radius) is empty. */
static SIMD8_INLINE i8 rect_empty8(f8 mx, f8 my, i8 radius, int tiles_x, int tiles_y)
{
    f8 px = mx - 0.5f, py = my - 0.5f, r = __builtin_convertvector(radius, f8);
    const float tile = (float)GV_SPLAT_TILE;
    i8 x0 = tile_coord8((px - r) / tile, tiles_x), y0 = tile_coord8((py - r) / tile, tiles_y);
    i8 x1 = tile_coord8((px + r + tile - 1.0f) / tile, tiles_x);
    i8 y1 = tile_coord8((py + r + tile - 1.0f) / tile, tiles_y);
    return (x1 - x0 == 0) | (y1 - y0 == 0);
}

/* The pixel position of the mean; finite where ok. */
static SIMD8_INLINE void pixel_mean(const gv_splat_view *v, const f8 t[3], f8 *mx, f8 *my)
{
    *mx = v->fx * t[0] / t[2] + v->cx;
    *my = v->fy * t[1] / t[2] + v->cy;
}

/* Pass 1: all ones where the radius bound already culls the Gaussian (an empty tile
 * rectangle). Lanes the bound does not settle (behind the near plane, non-finite, a huge
 * bound) are left to pass 2. */
static SIMD8_INLINE i8 surely_off_screen8(const gv_splat_view *v, const lanes_in *g, int tiles_x,
                                          int tiles_y)
{
    f8 t[3];
    camera_point(v, g, t);
    i8 decided = (t[2] > GV_SPLAT_NEAR) & finite8(t[2]);
    f8 u = min8(max8(t[0] / t[2], f8_splat(-v->lim_x_neg)), f8_splat(v->lim_x_pos));
    f8 w = min8(max8(t[1] / t[2], f8_splat(-v->lim_y_neg)), f8_splat(v->lim_y_pos));
    f8 jx = v->fx / t[2], jy = v->fy / t[2];
    f8 j2 = jx * jx * (1 + u * u) + jy * jy * (1 + w * w);
    f8 s = expf8(max8(max8(g->log_scale[0], g->log_scale[1]), g->log_scale[2]));
    f8 bound = 3.0f * sqrt8(j2 * s * s + 0.92f) * 1.01f + 2.0f;
    f8 mx, my;
    pixel_mean(v, t, &mx, &my);
    decided &= (bound < (float)GV_SPLAT_MAX_RADIUS) & finite8(mx) & finite8(my);
    i8 radius = __builtin_convertvector(f8_mask(decided, bound), i8) + 1;
    return decided & rect_empty8(mx, my, radius, tiles_x, tiles_y);
}

/* Pass 2: the whole projection of eight Gaussians; writes the outputs of the first `count`
 * lanes (radius 0 and zeros for the culled ones). */
static SIMD8_INLINE void project8(const gv_splat_view *v, const lanes_in *g, const int idx[LANES],
                                  int count, int tiles_x, int tiles_y, float *means2d, float *conics,
                                  float *depths, int *radii)
{
    lanes_state p;
    i8 ok = project_state8(v, g, &p);
    f8 a = p.a, b = p.b, c = p.c, tz = p.t[2];

    f8 det = a * c - b * b;
    ok &= (det > 0.0f) & finite8(det); /* the reference culls det == 0 */
    f8 inv = 1.0f / det;

    /* 3-sigma of the larger eigenvalue, with the reference's floor of 0.1. */
    f8 mid = 0.5f * (a + c);
    f8 root = sqrt8(max8(mid * mid - det, f8_splat(0.1f)));
    f8 rad = ceil_nonneg8(3.0f * sqrt8(max8(mid + root, mid - root)));
    ok &= finite8(rad);
    i8 huge = rad > (float)GV_SPLAT_MAX_RADIUS;
    i8 radius = i8_select(huge, (i8){0} + GV_SPLAT_MAX_RADIUS,
                          __builtin_convertvector(f8_mask(ok & ~huge, rad), i8));

    f8 mx, my;
    pixel_mean(v, p.t, &mx, &my);
    ok &= finite8(mx) & finite8(my);
    ok &= ~rect_empty8(mx, my, radius, tiles_x, tiles_y);

    f8 c0 = c * inv, c1 = -b * inv, c2 = a * inv;
    for (int l = 0; l < count; l++) {
        size_t i = (size_t)idx[l];
        int keep = ok[l] != 0;
        radii[i] = keep ? radius[l] : 0;
        means2d[2 * i] = keep ? mx[l] : 0, means2d[2 * i + 1] = keep ? my[l] : 0;
        conics[3 * i] = keep ? c0[l] : 0, conics[3 * i + 1] = keep ? c1[l] : 0;
        conics[3 * i + 2] = keep ? c2[l] : 0;
        depths[i] = keep ? tz[l] : 0;
    }
}

/* Writes the outputs of a culled Gaussian. */
static inline void cull(size_t i, float *means2d, float *conics, float *depths, int *radii)
{
    radii[i] = 0;
    means2d[2 * i] = means2d[2 * i + 1] = 0;
    conics[3 * i] = conics[3 * i + 1] = conics[3 * i + 2] = 0;
    depths[i] = 0;
}

/* Gaussians [lo, hi), hi - lo <= CHUNK. */
static RASTER_CLONES void project_chunk(int lo, int hi, const float *means, const float *scales,
                                        const float *rotations, const gv_splat_view *v,
                                        int tiles_x, int tiles_y, float *means2d, float *conics,
                                        float *depths, int *radii)
{
    int all[CHUNK], left[CHUNK], n_left = 0, idx[LANES];
    lanes_in g;
    for (int i = lo; i < hi; i++) all[i - lo] = i;
    for (int k = 0; k < hi - lo; k += LANES) {
        int count = hi - lo - k < LANES ? hi - lo - k : LANES;
        lane_indices(all + k, count, idx);
        gather_lanes(idx, means, scales, rotations, &g);
        i8 off = surely_off_screen8(v, &g, tiles_x, tiles_y);
        for (int l = 0; l < count; l++) {
            if (off[l])
                cull((size_t)idx[l], means2d, conics, depths, radii);
            else
                left[n_left++] = idx[l];
        }
    }
    for (int k = 0; k < n_left; k += LANES) {
        int count = n_left - k < LANES ? n_left - k : LANES;
        lane_indices(left + k, count, idx);
        gather_lanes(idx, means, scales, rotations, &g);
        project8(v, &g, idx, count, tiles_x, tiles_y, means2d, conics, depths, radii);
    }
}

void gv_splat_project_forward(int n, const float *means, const float *scales,
                              const float *rotations, const gv_splat_view *view,
                              float *means2d, float *conics, float *depths, int *radii)
{
    int tiles_x = (view->width + GV_SPLAT_TILE - 1) / GV_SPLAT_TILE;
    int tiles_y = (view->height + GV_SPLAT_TILE - 1) / GV_SPLAT_TILE;
    int n_chunks = (n + CHUNK - 1) / CHUNK;
#pragma omp parallel for schedule(static)
    for (int k = 0; k < n_chunks; k++) {
        int lo = k * CHUNK, hi = lo + CHUNK < n ? lo + CHUNK : n;
        project_chunk(lo, hi, means, scales, rotations, view, tiles_x, tiles_y, means2d, conics,
                      depths, radii);
    }
}
