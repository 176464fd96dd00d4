/* Shared pieces of the splatting tests: small random cameras and scenes, central finite
 * differences that detect discontinuities, and gradient comparison reports. */
#ifndef GAUSSVID_TESTS_SPLAT_FIXTURES_H
#define GAUSSVID_TESTS_SPLAT_FIXTURES_H

#include <math.h>
#include <stdint.h>

#include "check.h"
#include "gaussvid/core/core.h"
#include "gaussvid/io/gaussians.h"
#include "gaussvid/splat/splat.h"

static const double FIX_C0 = 0.28209479177387814;

/* Rotation (row-major) of the unit quaternion (w, x, y, z), in double. */
static inline void fix_quat_to_rotmat(const double q[4], double R[9])
{
    double w = q[0], x = q[1], y = q[2], z = q[3];
    R[0] = 1 - 2 * (y * y + z * z), R[1] = 2 * (x * y - w * z), R[2] = 2 * (x * z + w * y);
    R[3] = 2 * (x * y + w * z), R[4] = 1 - 2 * (x * x + z * z), R[5] = 2 * (y * z - w * x);
    R[6] = 2 * (x * z - w * y), R[7] = 2 * (y * z + w * x), R[8] = 1 - 2 * (x * x + y * y);
}

/* A 40x24 camera with an off-centre principal point, slightly rotated and translated. */
static inline void fix_view(gv_splat_view *v, int width, int height, uint64_t seed)
{
    gv_rng r;
    gv_rng_init(&r, seed);
    double q[4] = {1, 0.1 * gv_rng_normal(&r), 0.1 * gv_rng_normal(&r), 0.1 * gv_rng_normal(&r)};
    double n = sqrt(q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3]);
    for (int i = 0; i < 4; i++) q[i] /= n;
    double R[9], t[3] = {0.3 * gv_rng_normal(&r), 0.3 * gv_rng_normal(&r), 0.5};
    fix_quat_to_rotmat(q, R);
    double f = 0.8 * width;
    if (gv_splat_view_init(v, width, height, f, f * 1.05, 0.5 * width - 0.7, 0.5 * height + 0.4,
                           R, t)) {
        fprintf(stderr, "fixture view: %s\n", gv_last_error());
        exit(1);
    }
}

/* World point that projects to pixel position (u, v) at camera depth z. */
static inline void fix_unproject(const gv_splat_view *v, double u, double w, double z, float out[3])
{
    double c[3] = {(u - v->cx) / v->fx * z, (w - v->cy) / v->fy * z, z};
    for (int j = 0; j < 3; j++)
        out[j] = (float)(v->R[j] * (c[0] - v->t[0]) + v->R[3 + j] * (c[1] - v->t[1]) +
                         v->R[6 + j] * (c[2] - v->t[2]));
}

/* n random Gaussians in front of the camera, 2D sizes of about 1-5 pixels, centres spread
 * over the image and a few pixels beyond it (so many straddle tile borders and edges),
 * opacities 0.18-0.85, colours mostly inside (0, 1). */
static inline void fix_gaussians(gv_gaussians *g, int n, int sh_degree, const gv_splat_view *v,
                          uint64_t seed)
{
    if (gv_gaussians_alloc(g, n, sh_degree)) {
        fprintf(stderr, "fixture: %s\n", gv_last_error());
        exit(1);
    }
    gv_rng r;
    gv_rng_init(&r, seed);
    int K = gv_sh_coefficient_count(sh_degree);
    for (int i = 0; i < n; i++) {
        double u = -3 + (v->width + 6) * gv_rng_uniform(&r);
        double w = -3 + (v->height + 6) * gv_rng_uniform(&r);
        double z = 2 + 4 * gv_rng_uniform(&r);
        fix_unproject(v, u, w, z, g->means + 3 * i);
        for (int j = 0; j < 3; j++) {
            double sigma_px = 0.8 + 3.5 * gv_rng_uniform(&r);
            g->scales[3 * i + j] = (float)log(sigma_px * z / v->fx);
        }
        double qn = 0;
        for (int j = 0; j < 4; j++) {
            g->rotations[4 * i + j] = (float)gv_rng_normal(&r);
            qn += g->rotations[4 * i + j] * g->rotations[4 * i + j];
        }
        double norm = (0.5 + gv_rng_uniform(&r)) / sqrt(qn); /* deliberately not unit */
        for (int j = 0; j < 4; j++) g->rotations[4 * i + j] *= (float)norm;
        g->opacities[i] = (float)(-1.5 + 3.2 * gv_rng_uniform(&r));
        for (int c = 0; c < 3; c++) {
            double rgb = 0.15 + 0.7 * gv_rng_uniform(&r);
            g->sh[(size_t)i * K * 3 + c] = (float)((rgb - 0.5) / FIX_C0);
            for (int k = 1; k < K; k++)
                g->sh[(size_t)i * K * 3 + k * 3 + c] = (float)(0.12 * gv_rng_normal(&r));
        }
    }
}

/* The double reference's accumulated depth sum_i w_i z_i of n raw Gaussians (opacities as
 * logits) in view v, what the depth backward differentiates: each projected
 * (gv_splat_reference_project), then blended with colour (z, 0, 0) over black; W x H values
 * into depth_sum, the rasteriser's signature into *signature. */
static inline void fix_reference_depth_sum(int n, const double *means, const double *scales,
                                           const double *rotations, const double *opacity_logits,
                                           const gv_splat_view *v, double *depth_sum,
                                           uint64_t *signature)
{
    size_t pixels = (size_t)v->width * v->height, m = n > 0 ? (size_t)n : 1;
    double *m2 = malloc((10 * m + 3 * pixels) * sizeof(double));
    int *radii = malloc(m * sizeof(int));
    if (!m2 || !radii) {
        fprintf(stderr, "fixture: out of memory for the reference depth\n");
        exit(1);
    }
    double *con = m2 + 2 * m, *col = con + 3 * m, *op = col + 3 * m, *z = op + m, *image = z + m;
    double zero[3] = {0, 0, 0};
    for (int i = 0; i < n; i++) {
        gv_splat_ref_projection p;
        radii[i] = gv_splat_reference_project(means + 3 * i, scales + 3 * i, rotations + 4 * i, v, &p)
                       ? p.radius : 0;
        m2[2 * i] = p.mean2d[0], m2[2 * i + 1] = p.mean2d[1];
        for (int k = 0; k < 3; k++) con[3 * i + k] = p.conic[k];
        z[i] = p.depth, op[i] = 1 / (1 + exp(-opacity_logits[i]));
        col[3 * i] = p.depth, col[3 * i + 1] = col[3 * i + 2] = 0;
    }
    gv_splat_reference_rasterize(n, v->width, v->height, m2, con, col, op, z, radii, zero, image,
                                 signature);
    for (size_t p = 0; p < pixels; p++) depth_sum[p] = image[3 * p];
    free(m2), free(radii);
}

/* ---- finite differences ------------------------------------------------------------- */
typedef double (*fix_eval_fn)(void *ctx, uint64_t *signature);

/* Central difference of f with respect to *param. The signature of the discrete decisions
 * must be the same at x - h and x + h as at x (s0, from f at x); otherwise the step shrinks
 * (three times, by 10). Returns 0, or -1 when every step crossed a discontinuity. */
static inline int fix_derivative(fix_eval_fn f, void *ctx, uint64_t s0, double *param,
                                 double h, double *out)
{
    uint64_t sp, sm;
    double x = *param;
    for (int attempt = 0; attempt < 4; attempt++, h *= 0.1) {
        *param = x + h;
        double fp = f(ctx, &sp);
        *param = x - h;
        double fm = f(ctx, &sm);
        *param = x;
        if (sp == s0 && sm == s0) {
            *out = (fp - fm) / (2 * h);
            return 0;
        }
    }
    return -1;
}

/* Pairs (analytic, numeric) of one parameter kind; the relative error of each is
 * |a - n| / max(|a|, |n|, 1e-3 max|n|), so gradients far below the kind's scale are judged
 * against that scale. */
enum { FIX_MAX_PAIRS = 8192 };
typedef struct {
    const char *name;
    int count, skipped;
    double a[FIX_MAX_PAIRS], n[FIX_MAX_PAIRS];
} fix_compare;

static inline void fix_add(fix_compare *c, double analytic, double numeric)
{
    if (c->count < FIX_MAX_PAIRS) c->a[c->count] = analytic, c->n[c->count] = numeric, c->count++;
}

/* Adds to c the pairs (analytic[j], central difference of f in params[j]) for j < count, step
 * h; a value whose every step crosses a discontinuity is counted as skipped. */
static inline void fix_add_params(fix_compare *c, fix_eval_fn f, void *ctx, uint64_t s0,
                                  double *params, const float *analytic, int count, double h)
{
    for (int j = 0; j < count; j++) {
        double num;
        if (fix_derivative(f, ctx, s0, params + j, h, &num)) c->skipped++;
        else fix_add(c, analytic[j], num);
    }
}

/* Prints the maximum relative error and checks it against tol. */
static inline double fix_report(const fix_compare *c, double tol)
{
    double scale = 0, worst = 0;
    for (int i = 0; i < c->count; i++) scale = fmax(scale, fabs(c->n[i]));
    for (int i = 0; i < c->count; i++) {
        double den = fmax(fmax(fabs(c->a[i]), fabs(c->n[i])), 1e-3 * scale);
        double e = den > 0 ? fabs(c->a[i] - c->n[i]) / den : 0;
        if (e > worst) worst = e;
    }
    printf("  d/d %-22s %5d values (%d skipped at discontinuities), max |grad| %.3g, "
           "max relative error %.2e\n", c->name, c->count, c->skipped, scale, worst);
    CHECK(c->count > 0);
    CHECK(scale > 0);
    CHECK(worst < tol);
    return worst;
}

#endif
