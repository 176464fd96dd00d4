/* A plain double-precision renderer with the reference formulas
 * (docs/reference/gaussian-splatting.md sections 2-9), written without the tiles, the per-Gaussian
 * state or the pixel boxes of the fast kernels. The tests compare the kernels with it and take
 * finite differences of it. */
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "gaussvid/core/core.h"
#include "gaussvid/splat/splat.h"

/* FNV-1a over 64-bit values: the signature of the discrete decisions. */
static void mix(uint64_t *h, uint64_t v)
{
    for (int i = 0; i < 8; i++) {
        *h ^= (v >> (8 * i)) & 255;
        *h *= 1099511628211ull;
    }
}

static void mat3_mul(const double *a, const double *b, double *out)
{
    for (int i = 0; i < 3; i++)
        for (int j = 0; j < 3; j++)
            out[i * 3 + j] = a[i * 3] * b[j] + a[i * 3 + 1] * b[3 + j] + a[i * 3 + 2] * b[6 + j];
}

static void mat3_transpose(const double *a, double *out)
{
    for (int i = 0; i < 3; i++)
        for (int j = 0; j < 3; j++) out[j * 3 + i] = a[i * 3 + j];
}

/* Reference getRect on the pixel-index position (centre - 0.5). */
static void reference_rect(double mx, double my, int radius, int tiles_x, int tiles_y,
                           int rect[4])
{
    double lo[2] = {(mx - 0.5 - radius) / 16.0, (my - 0.5 - radius) / 16.0};
    double hi[2] = {(mx - 0.5 + radius + 15) / 16.0, (my - 0.5 + radius + 15) / 16.0};
    int grid[2] = {tiles_x, tiles_y};
    for (int a = 0; a < 2; a++) {
        double l = trunc(fmax(-1.0, fmin(lo[a], grid[a] + 1.0)));
        double h = trunc(fmax(-1.0, fmin(hi[a], grid[a] + 1.0)));
        rect[a] = (int)fmin(fmax(l, 0.0), grid[a]);
        rect[2 + a] = (int)fmin(fmax(h, 0.0), grid[a]);
    }
}

int gv_splat_reference_project(const double mean[3], const double log_scale[3],
                               const double quat[4], const gv_splat_view *view,
                               gv_splat_ref_projection *out)
{
    memset(out, 0, sizeof *out);
    double W[9], Wt[9];
    for (int i = 0; i < 9; i++) W[i] = view->R[i];
    mat3_transpose(W, Wt);
    double p[3];
    for (int i = 0; i < 3; i++)
        p[i] = W[i * 3] * mean[0] + W[i * 3 + 1] * mean[1] + W[i * 3 + 2] * mean[2] + view->t[i];
    if (!(p[2] > (double)GV_SPLAT_NEAR)) return 0;

    /* Sigma = (R S)(R S)^T with the normalised quaternion. */
    double qn = sqrt(quat[0] * quat[0] + quat[1] * quat[1] + quat[2] * quat[2] + quat[3] * quat[3]);
    qn = fmax(qn, 1e-12);
    double w = quat[0] / qn, x = quat[1] / qn, y = quat[2] / qn, z = quat[3] / qn;
    double R[9] = {1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y),
                   2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x),
                   2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)};
    double S[9] = {exp(log_scale[0]), 0, 0, 0, exp(log_scale[1]), 0, 0, 0, exp(log_scale[2])};
    double L[9], Lt[9], Sigma[9];
    mat3_mul(R, S, L);
    mat3_transpose(L, Lt);
    mat3_mul(L, Lt, Sigma);

    /* Camera-space covariance, then the clamped Jacobian. */
    double tmp[9], Sc[9];
    mat3_mul(W, Sigma, tmp);
    mat3_mul(tmp, Wt, Sc);
    double u = p[0] / p[2], v = p[1] / p[2];
    out->clamp_x = u < -view->lim_x_neg || u > view->lim_x_pos;
    out->clamp_y = v < -view->lim_y_neg || v > view->lim_y_pos;
    u = fmin(fmax(u, -(double)view->lim_x_neg), view->lim_x_pos);
    v = fmin(fmax(v, -(double)view->lim_y_neg), view->lim_y_pos);
    double J[6] = {view->fx / p[2], 0, -view->fx * u / p[2],
                   0, view->fy / p[2], -view->fy * v / p[2]};
    double cov[4] = {0, 0, 0, 0};
    for (int r = 0; r < 2; r++)
        for (int c = 0; c < 2; c++)
            for (int i = 0; i < 3; i++)
                for (int j = 0; j < 3; j++)
                    cov[r * 2 + c] += J[r * 3 + i] * Sc[i * 3 + j] * J[c * 3 + j];
    cov[0] += GV_SPLAT_DILATION;
    cov[3] += GV_SPLAT_DILATION;
    double det = cov[0] * cov[3] - cov[1] * cov[2];
    if (!(det > 0)) return 0;

    double mid = 0.5 * (cov[0] + cov[3]);
    double lambda = mid + sqrt(fmax(0.1, mid * mid - det));
    double radius = ceil(3.0 * sqrt(lambda));
    double mx = view->fx * p[0] / p[2] + view->cx, my = view->fy * p[1] / p[2] + view->cy;
    if (!isfinite(radius) || !isfinite(mx) || !isfinite(my)) return 0;
    int rect[4], tiles_x = (view->width + 15) / 16, tiles_y = (view->height + 15) / 16;
    out->radius = (int)fmin(radius, GV_SPLAT_MAX_RADIUS);
    reference_rect(mx, my, out->radius, tiles_x, tiles_y, rect);
    if (rect[2] <= rect[0] || rect[3] <= rect[1]) {
        out->radius = 0;
        return 0;
    }
    out->mean2d[0] = mx, out->mean2d[1] = my;
    out->conic[0] = cov[3] / det, out->conic[1] = -cov[1] / det, out->conic[2] = cov[0] / det;
    out->depth = p[2];
    return 1;
}

int gv_splat_reference_sh(int sh_degree, int active_degree, const double *sh,
                          const double mean[3], const double campos[3], double rgb[3])
{
    double d[3] = {mean[0] - campos[0], mean[1] - campos[1], mean[2] - campos[2]};
    double len = sqrt(d[0] * d[0] + d[1] * d[1] + d[2] * d[2]);
    double x = d[0] / len, y = d[1] / len, z = d[2] / len;
    double Y[16] = {
        0.28209479177387814,
        -0.4886025119029199 * y, 0.4886025119029199 * z, -0.4886025119029199 * x,
        1.0925484305920792 * x * y, -1.0925484305920792 * y * z,
        0.31539156525252005 * (2 * z * z - x * x - y * y), -1.0925484305920792 * x * z,
        0.5462742152960396 * (x * x - y * y),
        -0.5900435899266435 * y * (3 * x * x - y * y), 2.890611442640554 * x * y * z,
        -0.4570457994644658 * y * (4 * z * z - x * x - y * y),
        0.3731763325901154 * z * (2 * z * z - 3 * x * x - 3 * y * y),
        -0.4570457994644658 * x * (4 * z * z - x * x - y * y),
        1.445305721320277 * z * (x * x - y * y), -0.5900435899266435 * x * (x * x - 3 * y * y)};
    int used = (active_degree + 1) * (active_degree + 1);
    int bits = 0;
    for (int c = 0; c < 3; c++) {
        double sum = 0.5;
        for (int k = 0; k < used; k++) sum += Y[k] * sh[k * 3 + c];
        if (sum < 0) bits |= 1 << c;
        rgb[c] = fmax(sum, 0.0);
    }
    return bits;
}

typedef struct {
    double depth;
    int index;
} depth_key;

static int compare_depth(const void *a, const void *b)
{
    const depth_key *x = a, *y = b;
    if (x->depth != y->depth) return x->depth < y->depth ? -1 : 1;
    return (x->index > y->index) - (x->index < y->index);
}

int gv_splat_reference_rasterize(int n, int width, int height, const double *means2d,
                                 const double *conics, const double *colors,
                                 const double *opacities, const double *depths,
                                 const int *radii, const double bg[3], double *image,
                                 uint64_t *signature)
{
    depth_key *order = malloc((size_t)(n > 0 ? n : 1) * sizeof *order);
    int *rects = malloc((size_t)(n > 0 ? n : 1) * 4 * sizeof *rects);
    if (!order || !rects) {
        free(order);
        free(rects);
        return gv_fail("splat reference: out of memory for %d Gaussians", n);
    }
    int m = 0, tiles_x = (width + 15) / 16, tiles_y = (height + 15) / 16;
    for (int i = 0; i < n; i++) {
        if (radii[i] <= 0) continue;
        order[m].depth = depths[i], order[m].index = i, m++;
        reference_rect(means2d[2 * i], means2d[2 * i + 1], radii[i], tiles_x, tiles_y,
                       rects + 4 * i);
    }
    qsort(order, (size_t)m, sizeof *order, compare_depth);
    uint64_t h = 14695981039346656037ull;
    for (int py = 0; py < height; py++)
        for (int px = 0; px < width; px++) {
            int tx = px / 16, ty = py / 16;
            double T = 1, C[3] = {0, 0, 0};
            for (int k = 0; k < m; k++) {
                int g = order[k].index;
                const int *r = rects + 4 * g;
                if (tx < r[0] || tx >= r[2] || ty < r[1] || ty >= r[3]) continue;
                double dx = means2d[2 * g] - (px + 0.5), dy = means2d[2 * g + 1] - (py + 0.5);
                const double *q = conics + 3 * g;
                double power = -0.5 * (q[0] * dx * dx + q[2] * dy * dy) - q[1] * dx * dy;
                if (power > 0) continue;
                double a = opacities[g] * exp(power);
                if (a > GV_SPLAT_ALPHA_MAX) mix(&h, 0xA1F4A000u + (uint64_t)g);
                a = fmin(a, GV_SPLAT_ALPHA_MAX);
                if (a < GV_SPLAT_ALPHA_MIN) continue;
                if (T * (1 - a) < GV_SPLAT_T_MIN) break;
                for (int c = 0; c < 3; c++) C[c] += colors[3 * g + c] * a * T;
                T *= 1 - a;
                mix(&h, ((uint64_t)(py * width + px) << 32) | (uint32_t)g);
            }
            for (int c = 0; c < 3; c++) image[((size_t)py * width + px) * 3 + c] = C[c] + T * bg[c];
        }
    free(order);
    free(rects);
    if (signature) *signature = h;
    return 0;
}

int gv_splat_reference_render(int n, int sh_degree, int active_degree, const double *means,
                              const double *sh, const double *opacities,
                              const double *scales, const double *rotations,
                              const gv_splat_view *view, const double bg[3], double *image,
                              uint64_t *signature)
{
    size_t rows = (size_t)(n > 0 ? n : 1);
    double *m2 = malloc(rows * 2 * sizeof(double)), *con = malloc(rows * 3 * sizeof(double));
    double *col = malloc(rows * 3 * sizeof(double)), *op = malloc(rows * sizeof(double));
    double *dep = malloc(rows * sizeof(double));
    int *rad = malloc(rows * sizeof(int));
    int rc = -1;
    if (!m2 || !con || !col || !op || !dep || !rad) {
        gv_fail("splat reference: out of memory for %d Gaussians", n);
        goto done;
    }
    int K = (sh_degree + 1) * (sh_degree + 1);
    double campos[3] = {view->campos[0], view->campos[1], view->campos[2]};
    uint64_t h = 1469598103934665603ull;
    for (int i = 0; i < n; i++) {
        gv_splat_ref_projection pr;
        int visible = gv_splat_reference_project(means + 3 * i, scales + 3 * i, rotations + 4 * i,
                                                 view, &pr);
        rad[i] = visible ? pr.radius : 0;
        m2[2 * i] = pr.mean2d[0], m2[2 * i + 1] = pr.mean2d[1];
        for (int c = 0; c < 3; c++) con[3 * i + c] = pr.conic[c];
        dep[i] = pr.depth;
        op[i] = 1.0 / (1.0 + exp(-opacities[i]));
        int bits = 0;
        if (visible) bits = gv_splat_reference_sh(sh_degree, active_degree, sh + (size_t)i * K * 3,
                                                  means + 3 * i, campos, col + 3 * i);
        mix(&h, ((uint64_t)rad[i] << 8) | (uint64_t)(bits << 2 | pr.clamp_x << 1 | pr.clamp_y));
    }
    uint64_t raster = 0;
    rc = gv_splat_reference_rasterize(n, view->width, view->height, m2, con, col, op, dep, rad, bg,
                                      image, &raster);
    mix(&h, raster);
    if (signature) *signature = h;
done:
    free(m2), free(con), free(col), free(op), free(dep), free(rad);
    return rc;
}
