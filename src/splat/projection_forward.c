/* The forward projection, eight Gaussians at a time (simd8.h lanes); the per-Gaussian
 * arithmetic is that of projection.c's project_state, which the backward recomputes, in the
 * same order of operations, so every output is the same float as one Gaussian at a time
 * would give (this file is compiled without fused multiply-adds, CMakeLists.txt).
 *
 * Two passes over each chunk of Gaussians:
 *  1. a cheap bound on the radius settles most of the Gaussians that miss the image:
 *     lambda_1 = mid + sqrt(max(0.1, mid^2 - det)) <= a + c + 0.32, and a + c =
 *     trace(J W Sigma W^T J^T) + 0.6 <= |J|_F^2 max(s)^2 + 0.6 (W is a rotation), so
 *     radius <= 3 sqrt(|J|_F^2 max(s)^2 + 0.92), taken with a margin for rounding; when even
 *     that radius gives an empty tile rectangle, the Gaussian is culled;
 *  2. the others, gathered eight at a time, go through the whole projection.
 * The exponentials of the log-scales stay libm's expf, lane by lane: a vector exponential
 * would round differently. */
#include <math.h>

#include "gaussvid/splat.h"
#include "splat/simd8.h"

enum { LANES = 8, CHUNK = 256 };

/* a > b ? a : b and a < b ? a : b, lane by lane (NaN gives the second operand). */
SIMD8_INLINE f8 max8(f8 a, f8 b)
{
    return f8_select(a > b, a, b);
}

SIMD8_INLINE f8 min8(f8 a, f8 b)
{
    return f8_select(a < b, a, b);
}

/* All ones where x is finite: x - x is 0 there and NaN for infinities and NaN. */
SIMD8_INLINE i8 finite8(f8 x)
{
    return (x - x) == f8_splat(0.0f);
}

SIMD8_INLINE f8 sqrt8(f8 x)
{
    f8 r;
    for (int l = 0; l < LANES; l++) r[l] = __builtin_sqrtf(x[l]);
    return r;
}

/* ceilf(x) for x >= 0, infinity or NaN: below 2^24 through the truncating conversion, above
 * it x is already an integer (and infinity and NaN are returned as they are). */
SIMD8_INLINE f8 ceil_nonneg8(f8 x)
{
    i8 small = x < f8_splat(16777216.0f);
    f8 xs = f8_mask(small, x);
    f8 f = __builtin_convertvector(__builtin_convertvector(xs, i8), f8);
    return f8_select(small, f8_select(f < xs, f + 1.0f, f), x);
}

/* binning.c's tile_coord: truncation towards zero of a clamped float, then [0, grid]. */
SIMD8_INLINE i8 tile_coord8(f8 v, int grid)
{
    v = f8_select(v > -1.0f, v, f8_splat(-1.0f)); /* NaN becomes -1 */
    v = f8_select(v < (float)grid + 1.0f, v, f8_splat((float)grid + 1.0f));
    i8 i = __builtin_convertvector(v, i8);
    i = i8_select(i < 0, (i8){0}, i);
    return i8_select(i > grid, (i8){0} + grid, i);
}

/* All ones where gv_splat_tile_rect(mx, my, radius) is empty. */
SIMD8_INLINE i8 rect_empty8(f8 mx, f8 my, i8 radius, int tiles_x, int tiles_y)
{
    f8 px = mx - 0.5f, py = my - 0.5f, r = __builtin_convertvector(radius, f8);
    const float tile = (float)GV_SPLAT_TILE;
    i8 x0 = tile_coord8((px - r) / tile, tiles_x), y0 = tile_coord8((py - r) / tile, tiles_y);
    i8 x1 = tile_coord8((px + r + tile - 1.0f) / tile, tiles_x);
    i8 y1 = tile_coord8((py + r + tile - 1.0f) / tile, tiles_y);
    return (x1 - x0 == 0) | (y1 - y0 == 0);
}

/* Eight Gaussians' rows, lane by lane (rows of the model arrays). */
typedef struct {
    f8 mean[3], log_scale[3], rot[4];
} lanes_in;

SIMD8_INLINE void gather(const int idx[LANES], const float *means, const float *scales,
                         const float *rotations, lanes_in *g)
{
    for (int l = 0; l < LANES; l++) {
        size_t i = (size_t)idx[l];
        for (int j = 0; j < 3; j++)
            g->mean[j][l] = means[3 * i + j], g->log_scale[j][l] = scales[3 * i + j];
        for (int j = 0; j < 4; j++) g->rot[j][l] = rotations[4 * i + j];
    }
}

/* Camera-space mean t = W mean + t_view. */
SIMD8_INLINE void camera_point(const gv_splat_view *v, const lanes_in *g, f8 t[3])
{
    const float *W = v->R;
    for (int i = 0; i < 3; i++)
        t[i] = W[i * 3] * g->mean[0] + W[i * 3 + 1] * g->mean[1] + W[i * 3 + 2] * g->mean[2] +
               v->t[i];
}

/* The pixel position of the mean; finite where ok. */
SIMD8_INLINE void pixel_mean(const gv_splat_view *v, const f8 t[3], f8 *mx, f8 *my)
{
    *mx = v->fx * t[0] / t[2] + v->cx;
    *my = v->fy * t[1] / t[2] + v->cy;
}

/* Pass 1: all ones where the radius bound already culls the Gaussian (an empty tile
 * rectangle). Lanes the bound does not settle (behind the near plane, non-finite, a huge
 * bound) are left to pass 2. */
SIMD8_INLINE i8 surely_off_screen8(const gv_splat_view *v, const lanes_in *g, int tiles_x,
                                   int tiles_y)
{
    f8 t[3];
    camera_point(v, g, t);
    i8 decided = (t[2] > GV_SPLAT_NEAR) & finite8(t[2]);
    f8 u = min8(max8(t[0] / t[2], f8_splat(-v->lim_x_neg)), f8_splat(v->lim_x_pos));
    f8 w = min8(max8(t[1] / t[2], f8_splat(-v->lim_y_neg)), f8_splat(v->lim_y_pos));
    f8 jx = v->fx / t[2], jy = v->fy / t[2];
    f8 j2 = jx * jx * (1 + u * u) + jy * jy * (1 + w * w);
    f8 s;
    for (int l = 0; l < LANES; l++) {
        float a = g->log_scale[0][l], b = g->log_scale[1][l], c = g->log_scale[2][l];
        float m = a > b ? a : b;
        s[l] = expf(m > c ? m : c);
    }
    f8 bound = 3.0f * sqrt8(j2 * s * s + 0.92f) * 1.01f + 2.0f;
    f8 mx, my;
    pixel_mean(v, t, &mx, &my);
    decided &= (bound < (float)GV_SPLAT_MAX_RADIUS) & finite8(mx) & finite8(my);
    i8 radius = __builtin_convertvector(f8_mask(decided, bound), i8) + 1;
    return decided & rect_empty8(mx, my, radius, tiles_x, tiles_y);
}

/* Pass 2: the whole projection of eight Gaussians; writes the outputs of the first `count`
 * lanes (radius 0 and zeros for the culled ones). */
SIMD8_INLINE void project8(const gv_splat_view *v, const lanes_in *g, const int idx[LANES],
                           int count, int tiles_x, int tiles_y, float *means2d, float *conics,
                           float *depths, int *radii)
{
    const float *W = v->R;
    f8 t[3];
    camera_point(v, g, t);
    f8 tz = t[2];
    i8 ok = (tz > GV_SPLAT_NEAR) & finite8(tz);

    /* Jacobian of the perspective map at the clamped point. */
    f8 tx_c = min8(max8(t[0] / tz, f8_splat(-v->lim_x_neg)), f8_splat(v->lim_x_pos)) * tz;
    f8 ty_c = min8(max8(t[1] / tz, f8_splat(-v->lim_y_neg)), f8_splat(v->lim_y_pos)) * tz;
    f8 J00 = v->fx / tz, J02 = -v->fx * tx_c / (tz * tz);
    f8 J11 = v->fy / tz, J12 = -v->fy * ty_c / (tz * tz);
    f8 Am[6];
    for (int j = 0; j < 3; j++) {
        Am[j] = J00 * W[j] + J02 * W[6 + j];
        Am[3 + j] = J11 * W[3 + j] + J12 * W[6 + j];
    }

    /* M = R(q) diag(s), Sigma = M M^T. */
    f8 s[3];
    for (int j = 0; j < 3; j++)
        for (int l = 0; l < LANES; l++) s[j][l] = expf(g->log_scale[j][l]);
    const f8 *r = g->rot;
    f8 norm = max8(sqrt8(r[0] * r[0] + r[1] * r[1] + r[2] * r[2] + r[3] * r[3]),
                   f8_splat(1e-12f));
    f8 qw = r[0] / norm, x = r[1] / norm, y = r[2] / norm, z = r[3] / norm;
    f8 R[9];
    R[0] = 1 - 2 * (y * y + z * z), R[1] = 2 * (x * y - qw * z), R[2] = 2 * (x * z + qw * y);
    R[3] = 2 * (x * y + qw * z), R[4] = 1 - 2 * (x * x + z * z), R[5] = 2 * (y * z - qw * x);
    R[6] = 2 * (x * z - qw * y), R[7] = 2 * (y * z + qw * x), R[8] = 1 - 2 * (x * x + y * y);
    f8 M[9];
    for (int i = 0; i < 3; i++)
        for (int j = 0; j < 3; j++) M[i * 3 + j] = R[i * 3 + j] * s[j];

    /* Sigma2D = (Am M)(Am M)^T plus the dilation. */
    f8 U[6];
    for (int k = 0; k < 2; k++)
        for (int j = 0; j < 3; j++)
            U[k * 3 + j] = Am[k * 3] * M[j] + Am[k * 3 + 1] * M[3 + j] + Am[k * 3 + 2] * M[6 + j];
    f8 a = U[0] * U[0] + U[1] * U[1] + U[2] * U[2] + GV_SPLAT_DILATION;
    f8 b = U[0] * U[3] + U[1] * U[4] + U[2] * U[5];
    f8 c = U[3] * U[3] + U[4] * U[4] + U[5] * U[5] + GV_SPLAT_DILATION;

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
    pixel_mean(v, t, &mx, &my);
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

/* Indices first .. first + count - 1 into lanes; the last is repeated to fill eight. */
static inline void lane_indices(const int *list, int count, int idx[LANES])
{
    for (int l = 0; l < LANES; l++) idx[l] = list[l < count ? l : count - 1];
}

/* Gaussians [lo, hi), hi - lo <= CHUNK. */
RASTER_CLONES static void project_chunk(int lo, int hi, const float *means, const float *scales,
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
        gather(idx, means, scales, rotations, &g);
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
        gather(idx, means, scales, rotations, &g);
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
