/* Adam for the Gaussians, one parameter group per attribute, with the reference learning
 * rates and the log-linear position schedule (reference doc sections 13.1-13.2; 3DGS
 * gaussian_model.py training_setup, general_utils.py get_expon_lr_func).
 *
 * The update is PyTorch's (torch.optim.Adam, no weight decay, not amsgrad):
 *   m <- b1 m + (1 - b1) g,  v <- b2 v + (1 - b2) g^2,
 *   p <- p - (lr / (1 - b1^t)) m / (sqrt(v) / sqrt(1 - b2^t) + eps),
 * with t the group's own step count. The moments are two gv_gaussians parallel to the
 * model, so densification moves them with the parameters row by row (densify.c).
 *
 * Rows: the reference's dense Adam steps every row, also those not visible in the view
 * (zero gradient: the moments decay and the parameter keeps moving by its momentum).
 * Given a row list, only those rows are stepped and the others keep their moments as they
 * are, as the 2024 3DGS "sparse_adam" does (docs/SPLAT_TRAINING.md measures both). */
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "gaussvid/core.h"
#include "gaussvid/splat_train.h"

void gv_splat_adam_defaults(gv_splat_adam_config *c)
{
    c->means_lr_init = 0.00016;     /* position_lr_init, x spatial_lr_scale */
    c->means_lr_final = 0.0000016;  /* position_lr_final */
    c->means_lr_steps = 30000;      /* position_lr_max_steps */
    c->sh_dc_lr = 0.0025;           /* feature_lr */
    c->sh_rest_lr = 0.0025 / 20.0;  /* feature_lr / 20 */
    c->opacity_lr = 0.05;           /* 2023 release (0.025 in the 2024 update) */
    c->scales_lr = 0.005;
    c->rotations_lr = 0.001;
    c->beta1 = 0.9, c->beta2 = 0.999; /* torch defaults */
    c->eps = 1e-15;                   /* training_setup */
}

double gv_splat_expon_lr(long step, double lr_init, double lr_final, long max_steps)
{
    if (step < 0 || (lr_init == 0.0 && lr_final == 0.0)) return 0.0;
    double t = max_steps > 0 ? (double)step / (double)max_steps : 1.0;
    if (t > 1.0) t = 1.0;
    return exp((1.0 - t) * log(lr_init) + t * log(lr_final));
}

int gv_splat_adam_init(gv_splat_adam *a, const gv_splat_adam_config *c,
                       const gv_gaussians *params, double spatial_lr_scale)
{
    memset(a, 0, sizeof *a);
    a->config = *c;
    a->spatial_lr_scale = spatial_lr_scale;
    if (gv_gaussians_alloc(&a->m, params->n, params->sh_degree) != 0 ||
        gv_gaussians_alloc(&a->v, params->n, params->sh_degree) != 0 ||
        gv_gaussians_reserve(&a->m, params->capacity) != 0 ||
        gv_gaussians_reserve(&a->v, params->capacity) != 0) {
        gv_splat_adam_free(a);
        return gv_fail_context("Adam state");
    }
    a->lr[GV_ADAM_SH_DC] = c->sh_dc_lr;
    a->lr[GV_ADAM_SH_REST] = c->sh_rest_lr;
    a->lr[GV_ADAM_OPACITY] = c->opacity_lr;
    a->lr[GV_ADAM_SCALES] = c->scales_lr;
    a->lr[GV_ADAM_ROTATIONS] = c->rotations_lr;
    gv_splat_adam_set_iteration(a, 0);
    return 0;
}

void gv_splat_adam_set_iteration(gv_splat_adam *a, long iteration)
{
    const gv_splat_adam_config *c = &a->config;
    a->lr[GV_ADAM_MEANS] = gv_splat_expon_lr(iteration, c->means_lr_init * a->spatial_lr_scale,
                                             c->means_lr_final * a->spatial_lr_scale,
                                             c->means_lr_steps);
}

/* The constants of one group's step. */
typedef struct {
    float b1, b2, step_size, bc2_sqrt, eps;
} adam_coeffs;

/* v >= 0, so sqrtf never sets errno: this file is compiled with -fno-math-errno
 * (CMakeLists.txt) so that the loop vectorises (sqrtps) instead of checking errno. */
static void update(float *restrict p, float *restrict m, float *restrict v,
                   const float *restrict g, int count, const adam_coeffs *k)
{
    const float b1 = k->b1, b2 = k->b2, step = k->step_size, bc2 = k->bc2_sqrt, eps = k->eps;
#pragma omp simd
    for (int j = 0; j < count; j++) {
        float mj = b1 * m[j] + (1.0f - b1) * g[j];
        float vj = b2 * v[j] + (1.0f - b2) * g[j] * g[j];
        m[j] = mj, v[j] = vj;
        p[j] -= step * mj / (sqrtf(vj) / bc2 + eps);
    }
}

/* One SH row, columns [c0, c1): the DC (columns 0..2) and the higher coefficients have their
 * own learning rates and step counts, given per column (step[j], bc2[j]), so the whole row
 * is one vector loop. */
static void update_sh_row(float *restrict p, float *restrict m, float *restrict v,
                          const float *restrict g, int c0, int c1, const float *restrict step,
                          const float *restrict bc2, const adam_coeffs *k)
{
    const float b1 = k->b1, b2 = k->b2, eps = k->eps;
#pragma omp simd
    for (int j = c0; j < c1; j++) {
        float mj = b1 * m[j] + (1.0f - b1) * g[j];
        float vj = b2 * v[j] + (1.0f - b2) * g[j] * g[j];
        m[j] = mj, v[j] = vj;
        p[j] -= step[j] * mj / (sqrtf(vj) / bc2[j] + eps);
    }
}

/* The listed rows [lo, hi) of an array of `width` floats per row, columns [offset, offset +
 * count), count <= 4: gathered into contiguous scratch so that the vector loop runs over
 * many rows at once, then written back. Much faster than a short loop per row. */
enum { GATHER_ROWS = 256, GATHER_MAX = 4 };
static void update_gathered(float *p, float *m, float *v, const float *g, size_t width,
                            int offset, int count, const int *rows, int lo, int hi,
                            const adam_coeffs *k)
{
    float tp[GATHER_ROWS * GATHER_MAX], tm[GATHER_ROWS * GATHER_MAX];
    float tv[GATHER_ROWS * GATHER_MAX], tg[GATHER_ROWS * GATHER_MAX];
    for (int r0 = lo; r0 < hi; r0 += GATHER_ROWS) {
        int r1 = r0 + GATHER_ROWS < hi ? r0 + GATHER_ROWS : hi, n = 0;
        for (int r = r0; r < r1; r++) {
            size_t at = (size_t)rows[r] * width + (size_t)offset;
            for (int j = 0; j < count; j++, n++)
                tp[n] = p[at + j], tm[n] = m[at + j], tv[n] = v[at + j], tg[n] = g[at + j];
        }
        update(tp, tm, tv, tg, n, k);
        n = 0;
        for (int r = r0; r < r1; r++) {
            size_t at = (size_t)rows[r] * width + (size_t)offset;
            for (int j = 0; j < count; j++, n++) p[at + j] = tp[n], m[at + j] = tm[n], v[at + j] = tv[n];
        }
    }
}

/* The rows [lo, hi) of the list (rows NULL: the rows themselves) of every active group.
 * Unlisted rows are updated as contiguous runs so that the loops vectorise. */
static void step_block(gv_splat_adam *a, gv_gaussians *p, const gv_gaussians *g,
                       const adam_coeffs *k, const int *active, const int *rows, int lo, int hi,
                       int n_coeffs)
{
    gv_gaussians *m = &a->m, *v = &a->v;
    size_t w = (size_t)3 * gv_sh_coefficient_count(p->sh_degree);
    if (!rows) {
        size_t at = (size_t)lo, n = (size_t)(hi - lo);
        if (active[GV_ADAM_MEANS])
            update(p->means + 3 * at, m->means + 3 * at, v->means + 3 * at, g->means + 3 * at,
                   (int)(3 * n), &k[GV_ADAM_MEANS]);
        if (active[GV_ADAM_OPACITY])
            update(p->opacities + at, m->opacities + at, v->opacities + at, g->opacities + at,
                   (int)n, &k[GV_ADAM_OPACITY]);
        if (active[GV_ADAM_SCALES])
            update(p->scales + 3 * at, m->scales + 3 * at, v->scales + 3 * at, g->scales + 3 * at,
                   (int)(3 * n), &k[GV_ADAM_SCALES]);
        if (active[GV_ADAM_ROTATIONS])
            update(p->rotations + 4 * at, m->rotations + 4 * at, v->rotations + 4 * at,
                   g->rotations + 4 * at, (int)(4 * n), &k[GV_ADAM_ROTATIONS]);
    }
    if (rows) {
        if (active[GV_ADAM_MEANS])
            update_gathered(p->means, m->means, v->means, g->means, 3, 0, 3, rows, lo, hi,
                            &k[GV_ADAM_MEANS]);
        if (active[GV_ADAM_OPACITY])
            update_gathered(p->opacities, m->opacities, v->opacities, g->opacities, 1, 0, 1, rows,
                            lo, hi, &k[GV_ADAM_OPACITY]);
        if (active[GV_ADAM_SCALES])
            update_gathered(p->scales, m->scales, v->scales, g->scales, 3, 0, 3, rows, lo, hi,
                            &k[GV_ADAM_SCALES]);
        if (active[GV_ADAM_ROTATIONS])
            update_gathered(p->rotations, m->rotations, v->rotations, g->rotations, 4, 0, 4, rows,
                            lo, hi, &k[GV_ADAM_ROTATIONS]);
    }
    /* SH rows: DC and higher coefficients in one loop per row with per-column constants. */
    int c0 = active[GV_ADAM_SH_DC] ? 0 : 3;
    int c1 = active[GV_ADAM_SH_REST] ? 3 * n_coeffs : 3;
    if (c0 >= c1) return;
    float step[48], bc2[48];
    for (int j = c0; j < c1; j++) {
        const adam_coeffs *kj = &k[j < 3 ? GV_ADAM_SH_DC : GV_ADAM_SH_REST];
        step[j] = kj->step_size, bc2[j] = kj->bc2_sqrt;
    }
    const adam_coeffs *kb = &k[c0 == 0 ? GV_ADAM_SH_DC : GV_ADAM_SH_REST];
    for (int r = lo; r < hi; r++) {
        size_t s = w * (size_t)(rows ? rows[r] : r);
        update_sh_row(p->sh + s, m->sh + s, v->sh + s, g->sh + s, c0, c1, step, bc2, kb);
    }
}

void gv_splat_adam_step(gv_splat_adam *a, gv_gaussians *params, const gv_gaussians *grad,
                        const int *rows, int n_rows, int n_coeffs, unsigned group_mask)
{
    int max_coeffs = gv_sh_coefficient_count(params->sh_degree);
    if (n_coeffs > max_coeffs) n_coeffs = max_coeffs;
    adam_coeffs k[GV_ADAM_GROUPS];
    int active[GV_ADAM_GROUPS];
    for (int group = 0; group < GV_ADAM_GROUPS; group++) {
        active[group] = (group_mask >> group) & 1u;
        if (!active[group]) continue;
        long t = ++a->step[group];
        k[group] = (adam_coeffs){(float)a->config.beta1, (float)a->config.beta2,
                                 (float)(a->lr[group] / (1.0 - pow(a->config.beta1, (double)t))),
                                 (float)sqrt(1.0 - pow(a->config.beta2, (double)t)),
                                 (float)a->config.eps};
    }
    /* One parallel loop over blocks of rows for all groups. */
    enum { BLOCK = 1024 };
    int n_blocks = (n_rows + BLOCK - 1) / BLOCK;
#pragma omp parallel for schedule(static)
    for (int b = 0; b < n_blocks; b++) {
        int lo = b * BLOCK, hi = lo + BLOCK < n_rows ? lo + BLOCK : n_rows;
        step_block(a, params, grad, k, active, rows, lo, hi, n_coeffs);
    }
}

void gv_splat_adam_free(gv_splat_adam *a)
{
    gv_gaussians_free(&a->m);
    gv_gaussians_free(&a->v);
}
