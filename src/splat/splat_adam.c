/* Adam for the Gaussians, one parameter group per attribute, with the reference learning
 * rates and the log-linear position schedule (docs/reference/gaussian-splatting.md sections
 * 13.1-13.2; 3DGS gaussian_model.py training_setup, general_utils.py get_expon_lr_func).
 *
 * The update is PyTorch's (torch.optim.Adam, no weight decay, not amsgrad):
 *   m <- b1 m + (1 - b1) g,  v <- b2 v + (1 - b2) g^2,
 *   p <- p - (lr / (1 - b1^t)) m / (sqrt(v) / sqrt(1 - b2^t) + eps),
 * with t the group's own step count. The moments are two gv_gaussians parallel to the
 * model, so densification moves them with the parameters row by row (densify.c).
 *
 * Rows: only the rows of a list (the Gaussians visible in the view) have a gradient, and
 * the step consumes it: those rows of the gradient are zero afterwards, and every other row
 * must be zero already (the trainer's invariant). The reference's dense Adam steps every
 * row, also those not visible (zero gradient: the moments decay and the parameter keeps
 * moving by its momentum); it reads the whole gradient as a stream, which measured faster
 * than picking out the listed rows. The visible-only step of the 2024 3DGS "sparse_adam"
 * leaves the other rows and their moments as they are (docs/SPLAT_TRAINING.md measures
 * both). */
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "gaussvid/core/core.h"
#include "gaussvid/splat/splat_train.h"

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

/* The small groups (means, opacity, scales, rotations: width <= 4 floats per row) of the
 * rows [lo, hi) of every row (dense) in one vector loop; the gradient is read as a stream
 * (unlisted rows hold zeros), which is faster than picking out the listed rows, and the
 * listed rows' gradients are zeroed after use. */
enum { BLOCK = 256, MAX_WIDTH = 4 };
static void update_dense_block(float *p, float *m, float *v, float *g, int width, int lo,
                               int hi, const int *list, int k0, int k1, const adam_coeffs *k)
{
    size_t at = (size_t)lo * width;
    update(p + at, m + at, v + at, g + at, width * (hi - lo), k);
    for (int j = k0; j < k1; j++) /* a plain loop: width is at most 4 */
        for (int c = 0; c < width; c++) g[(size_t)list[j] * width + c] = 0;
}

/* The same groups of the listed rows list[k0 .. k1) only (sparse): gathered into contiguous
 * scratch so that the vector loop runs over many rows at once, then written back; the
 * gradients are zeroed after use. */
static void update_listed_block(float *p, float *m, float *v, float *g, int width,
                                const int *list, int k0, int k1, const adam_coeffs *k)
{
    float tp[BLOCK * MAX_WIDTH], tm[BLOCK * MAX_WIDTH], tv[BLOCK * MAX_WIDTH];
    float tg[BLOCK * MAX_WIDTH];
    if (k1 <= k0) return;
    int n = 0;
    for (int j = k0; j < k1; j++) {
        size_t at = (size_t)list[j] * width;
        for (int c = 0; c < width; c++, n++)
            tp[n] = p[at + c], tm[n] = m[at + c], tv[n] = v[at + c], tg[n] = g[at + c];
    }
    update(tp, tm, tv, tg, n, k);
    n = 0;
    for (int j = k0; j < k1; j++) {
        size_t at = (size_t)list[j] * width;
        for (int c = 0; c < width; c++, n++)
            p[at + c] = tp[n], m[at + c] = tm[n], v[at + c] = tv[n], g[at + c] = 0;
    }
}

/* The per-group pointers and constants of one step. */
typedef struct {
    gv_splat_adam *a;
    gv_gaussians *p, *g;
    adam_coeffs k[GV_ADAM_GROUPS];
    int active[GV_ADAM_GROUPS];
    int c0, c1;                       /* SH columns stepped */
    float step[48], bc2[48];          /* per SH column: DC and higher coefficients differ */
} step_plan;

/* One block: rows [lo, hi) of every row (dense; list[k0 .. k1) are the listed rows among
 * them), or the listed rows list[k0 .. k1) alone (lo < 0). */
static void step_block(const step_plan *s, const int *list, int k0, int k1, int lo, int hi)
{
    gv_splat_adam *a = s->a;
    gv_gaussians *p = s->p, *m = &a->m, *v = &a->v, *g = s->g;
    struct { int group, width; float *p, *m, *v, *g; } small[4] = {
        {GV_ADAM_MEANS, 3, p->means, m->means, v->means, g->means},
        {GV_ADAM_OPACITY, 1, p->opacities, m->opacities, v->opacities, g->opacities},
        {GV_ADAM_SCALES, 3, p->scales, m->scales, v->scales, g->scales},
        {GV_ADAM_ROTATIONS, 4, p->rotations, m->rotations, v->rotations, g->rotations}};
    for (int f = 0; f < 4; f++) {
        if (!s->active[small[f].group]) { /* not stepped: the gradient is dropped */
            for (int j = k0; j < k1; j++)
                for (int c = 0; c < small[f].width; c++)
                    small[f].g[(size_t)list[j] * small[f].width + c] = 0;
            continue;
        }
        const adam_coeffs *k = &s->k[small[f].group];
        if (lo >= 0)
            update_dense_block(small[f].p, small[f].m, small[f].v, small[f].g, small[f].width, lo,
                               hi, list, k0, k1, k);
        else
            update_listed_block(small[f].p, small[f].m, small[f].v, small[f].g, small[f].width,
                                list, k0, k1, k);
    }
    size_t w = (size_t)3 * gv_sh_coefficient_count(p->sh_degree);
    if (s->c0 >= s->c1) {
        for (int j = k0; j < k1; j++) memset(g->sh + (size_t)list[j] * w, 0, sizeof(float) * w);
        return;
    }
    const adam_coeffs *kb = &s->k[s->c0 == 0 ? GV_ADAM_SH_DC : GV_ADAM_SH_REST];
    int n_rows = lo >= 0 ? hi - lo : k1 - k0;
    for (int i = 0, j = k0; i < n_rows; i++) {
        size_t r = (size_t)(lo >= 0 ? lo + i : list[k0 + i]) * w;
        update_sh_row(p->sh + r, m->sh + r, v->sh + r, g->sh + r, s->c0, s->c1, s->step, s->bc2,
                      kb);
        if (lo < 0 || (j < k1 && list[j] == lo + i)) { /* consumed: zero it (still in cache) */
            memset(g->sh + r, 0, sizeof(float) * w);
            j++;
        }
    }
}

/* First position of the ascending list at or after row r. */
static int lower_bound(const int *list, int n, int r)
{
    int lo = 0, hi = n;
    while (lo < hi) {
        int mid = lo + (hi - lo) / 2;
        if (list[mid] < r) lo = mid + 1;
        else hi = mid;
    }
    return lo;
}

void gv_splat_adam_step(gv_splat_adam *a, gv_gaussians *params, gv_gaussians *grad,
                        const int *rows, int n_rows, int all_rows, int n_coeffs,
                        unsigned group_mask)
{
    step_plan s = {.a = a, .p = params, .g = grad};
    int max_coeffs = gv_sh_coefficient_count(params->sh_degree);
    if (n_coeffs > max_coeffs) n_coeffs = max_coeffs;
    for (int group = 0; group < GV_ADAM_GROUPS; group++) {
        s.active[group] = (group_mask >> group) & 1u;
        if (!s.active[group]) continue;
        long t = ++a->step[group];
        s.k[group] = (adam_coeffs){(float)a->config.beta1, (float)a->config.beta2,
                                   (float)(a->lr[group] / (1.0 - pow(a->config.beta1, (double)t))),
                                   (float)sqrt(1.0 - pow(a->config.beta2, (double)t)),
                                   (float)a->config.eps};
    }
    /* SH: DC and higher coefficients in one loop per row with per-column constants. */
    s.c0 = s.active[GV_ADAM_SH_DC] ? 0 : 3;
    s.c1 = s.active[GV_ADAM_SH_REST] ? 3 * n_coeffs : 3;
    for (int j = s.c0; j < s.c1; j++) {
        const adam_coeffs *kj = &s.k[j < 3 ? GV_ADAM_SH_DC : GV_ADAM_SH_REST];
        s.step[j] = kj->step_size, s.bc2[j] = kj->bc2_sqrt;
    }
    int n = all_rows ? params->n : n_rows, n_blocks = (n + BLOCK - 1) / BLOCK;
#pragma omp parallel for schedule(static)
    for (int b = 0; b < n_blocks; b++) {
        int lo = b * BLOCK, hi = lo + BLOCK < n ? lo + BLOCK : n;
        if (all_rows)
            step_block(&s, rows, lower_bound(rows, n_rows, lo), lower_bound(rows, n_rows, hi),
                       lo, hi);
        else
            step_block(&s, rows, lo, hi, -1, -1);
    }
}

void gv_splat_adam_free(gv_splat_adam *a)
{
    gv_gaussians_free(&a->m);
    gv_gaussians_free(&a->v);
}
