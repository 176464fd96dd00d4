/* Adaptive density control of 3DGS (docs/reference/gaussian-splatting.md sections 14.1-14.3;
 * gaussian_model.py add_densification_stats, densify_and_clone, densify_and_split,
 * densify_and_prune, reset_opacity). The rows of the Adam moments move with the rows of the model:
 * copies and children start with zero moments (cat_tensors_to_optimizer), removed rows take theirs
 * away (_prune_optimizer), and the step counts are kept. */
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "gaussvid/core/core.h"
#include "gaussvid/splat/splat_train.h"

#define SPLIT_CHILDREN 2         /* densify_and_split N = 2 */
#define SPLIT_SCALE_DIVISOR 1.6  /* scaling / (0.8 * N) */
#define PRUNE_BIG_FACTOR 0.1     /* big_points_ws: max scale > 0.1 x extent */
#define RESET_OPACITY 0.01       /* reset_opacity: min(opacity, 0.01) */

int gv_splat_densify_stats_reserve(gv_splat_densify_stats *s, int capacity)
{
    if (capacity <= s->capacity) return 0;
    float *ga = realloc(s->grad_accum, (size_t)capacity * sizeof(float));
    if (ga) s->grad_accum = ga;
    int *de = realloc(s->denom, (size_t)capacity * sizeof(int));
    if (de) s->denom = de;
    int *mr = realloc(s->max_radii, (size_t)capacity * sizeof(int));
    if (mr) s->max_radii = mr;
    if (!ga || !de || !mr) return gv_fail("densify: out of memory for %d Gaussians", capacity);
    int old = s->capacity;
    memset(ga + old, 0, (size_t)(capacity - old) * sizeof(float));
    memset(de + old, 0, (size_t)(capacity - old) * sizeof(int));
    memset(mr + old, 0, (size_t)(capacity - old) * sizeof(int));
    s->capacity = capacity;
    return 0;
}

void gv_splat_densify_stats_clear(gv_splat_densify_stats *s, int n)
{
    if (n <= 0) return;
    memset(s->grad_accum, 0, (size_t)n * sizeof(float));
    memset(s->denom, 0, (size_t)n * sizeof(int));
    memset(s->max_radii, 0, (size_t)n * sizeof(int));
}

void gv_splat_densify_stats_free(gv_splat_densify_stats *s)
{
    free(s->grad_accum), free(s->denom), free(s->max_radii);
    memset(s, 0, sizeof *s);
}

void gv_splat_densify_accumulate_scaled(gv_splat_densify_stats *s, int n_visible,
                                        const int *visible, const float *densify_grad,
                                        const int *radii, int radius_scale)
{
#pragma omp parallel for schedule(static)
    for (int k = 0; k < n_visible; k++) {
        int i = visible[k];
        s->grad_accum[i] += densify_grad[i];
        s->denom[i] += 1;
        int radius = radii[i] * radius_scale;
        if (radius > s->max_radii[i]) s->max_radii[i] = radius;
    }
}

void gv_splat_densify_accumulate(gv_splat_densify_stats *s, int n_visible, const int *visible,
                                 const float *densify_grad, const int *radii)
{
    gv_splat_densify_accumulate_scaled(s, n_visible, visible, densify_grad, radii, 1);
}

/* ---- rows of a set of Gaussians ------------------------------------------------------- */

/* Keeps the rows with keep[i] != 0, in order; returns the new count. */
static int compact(gv_gaussians *g, const unsigned char *keep)
{
    int n = 0;
    for (int i = 0; i < g->n; i++)
        if (keep[i]) {
            if (n != i) gv_gaussians_copy_row(g, n, i);
            n++;
        }
    g->n = n;
    return n;
}

static int reserve_all(gv_gaussians *g, gv_splat_adam *adam, int rows)
{
    if (rows <= g->capacity && rows <= adam->m.capacity && rows <= adam->v.capacity) return 0;
    int cap = rows + rows / 2;
    if (gv_gaussians_reserve(g, cap) || gv_gaussians_reserve(&adam->m, cap) ||
        gv_gaussians_reserve(&adam->v, cap))
        return gv_fail_context("densify");
    return 0;
}

static float max_scale(const gv_gaussians *g, int i)
{
    const float *s = g->scales + 3 * (size_t)i;
    return expf(fmaxf(s[0], fmaxf(s[1], s[2]))); /* exp is monotone */
}

/* Rotation matrix (row-major) of the normalised quaternion (w, x, y, z), build_rotation. */
static void rotation_of(const float *q_raw, double R[9])
{
    double n = sqrt((double)q_raw[0] * q_raw[0] + (double)q_raw[1] * q_raw[1] +
                    (double)q_raw[2] * q_raw[2] + (double)q_raw[3] * q_raw[3]);
    if (n < 1e-12) n = 1e-12; /* torch normalize eps */
    double w = q_raw[0] / n, x = q_raw[1] / n, y = q_raw[2] / n, z = q_raw[3] / n;
    R[0] = 1 - 2 * (y * y + z * z), R[1] = 2 * (x * y - w * z), R[2] = 2 * (x * z + w * y);
    R[3] = 2 * (x * y + w * z), R[4] = 1 - 2 * (x * x + z * z), R[5] = 2 * (y * z - w * x);
    R[6] = 2 * (x * z - w * y), R[7] = 2 * (y * z + w * x), R[8] = 1 - 2 * (x * x + y * y);
}

/* Child row `dst` of parent `src`: mean + R(q) eps with eps ~ N(0, diag(s^2)), log-scale
 * log(s / 1.6), everything else copied. */
static void make_child(gv_gaussians *g, int dst, int src, gv_rng *rng)
{
    double eps[3], R[9];
    for (int a = 0; a < 3; a++)
        eps[a] = gv_rng_normal(rng) * exp((double)g->scales[3 * (size_t)src + a]);
    gv_gaussians_copy_row(g, dst, src);
    rotation_of(g->rotations + 4 * (size_t)src, R);
    for (int a = 0; a < 3; a++) {
        double d = R[3 * a] * eps[0] + R[3 * a + 1] * eps[1] + R[3 * a + 2] * eps[2];
        g->means[3 * (size_t)dst + a] = (float)(g->means[3 * (size_t)src + a] + d);
        g->scales[3 * (size_t)dst + a] =
            (float)log(exp((double)g->scales[3 * (size_t)src + a]) / SPLIT_SCALE_DIVISOR);
    }
}

/* ---- densify_and_prune ---------------------------------------------------------------- */

int gv_splat_densify_and_prune(gv_gaussians *g, gv_splat_adam *adam,
                               gv_splat_densify_stats *s, const gv_splat_densify_params *p,
                               gv_rng *rng, gv_splat_densify_counts *counts)
{
    int n0 = g->n;
    double dense_limit = p->percent_dense * p->extent;
    unsigned char *clone = calloc((size_t)n0 + 1, 1), *split = calloc((size_t)n0 + 1, 1);
    if (!clone || !split) {
        free(clone), free(split);
        return gv_fail("densify: out of memory for %d Gaussians", n0);
    }
    /* grads = accum / denom (NaN -> 0 when never visible); >= threshold as the reference. */
    int n_clone = 0, n_split = 0;
    for (int i = 0; i < n0; i++) {
        float grad = s->denom[i] > 0 ? s->grad_accum[i] / (float)s->denom[i] : 0.0f;
        if (!(grad >= (float)p->grad_threshold)) continue;
        if (max_scale(g, i) <= (float)dense_limit) clone[i] = 1, n_clone++;
        else split[i] = 1, n_split++;
    }
    /* Clones (rows n0 ..), then children (rows n1 ..): first children of every parent, then
     * the second ones, as torch's repeat(N, 1) orders them. */
    int n1 = n0 + n_clone, n2 = n1 + SPLIT_CHILDREN * n_split;
    int ok = reserve_all(g, adam, n2 > 0 ? n2 : 1);
    unsigned char *keep = ok == 0 ? malloc((size_t)n2 + 1) : NULL;
    if (!keep) {
        free(clone), free(split);
        return ok == 0 ? gv_fail("densify: out of memory for %d Gaussians", n2) : -1;
    }
    int row = n0;
    for (int i = 0; i < n0; i++)
        if (clone[i]) gv_gaussians_copy_row(g, row++, i);
    for (int c = 0; c < SPLIT_CHILDREN; c++)
        for (int i = 0; i < n0; i++)
            if (split[i]) make_child(g, row++, i, rng);
    g->n = n2;
    gv_gaussians_zero_rows(&adam->m, n0, n2), gv_gaussians_zero_rows(&adam->v, n0, n2);
    adam->m.n = adam->v.n = n2;

    /* Prune: split parents, transparent Gaussians, and (after the first opacity reset)
     * Gaussians larger than 0.1 x extent. */
    int n_pruned = 0;
    float min_logit = logf((float)p->min_opacity / (1.0f - (float)p->min_opacity));
    for (int i = 0; i < n2; i++) {
        int remove = i < n0 && split[i];
        int prune = g->opacities[i] < min_logit; /* sigmoid(x) < min  <=>  x < logit(min) */
        if (p->prune_big && max_scale(g, i) > (float)(PRUNE_BIG_FACTOR * p->extent)) prune = 1;
        if (p->max_screen_size > 0 && i < n0 && s->max_radii[i] > p->max_screen_size) prune = 1;
        keep[i] = !(remove || prune);
        n_pruned += !remove && prune;
    }
    compact(g, keep), compact(&adam->m, keep), compact(&adam->v, keep);
    free(clone), free(split), free(keep);
    if (gv_splat_densify_stats_reserve(s, g->capacity) != 0) return -1;
    gv_splat_densify_stats_clear(s, n2);
    if (counts) counts->cloned = n_clone, counts->split = n_split, counts->pruned = n_pruned;
    return 0;
}

void gv_splat_reset_opacity(gv_gaussians *g, gv_splat_adam *adam)
{
    for (int i = 0; i < g->n; i++) {
        float o = 1.0f / (1.0f + expf(-g->opacities[i]));
        o = fminf(o, (float)RESET_OPACITY);
        g->opacities[i] = logf(o / (1.0f - o)); /* inverse_sigmoid */
    }
    memset(adam->m.opacities, 0, (size_t)g->n * sizeof(float));
    memset(adam->v.opacities, 0, (size_t)g->n * sizeof(float));
}

void gv_splat_decay_opacity(gv_gaussians *g, double factor)
{
    for (int i = 0; i < g->n; i++) {
        double o = factor / (1.0 + exp(-(double)g->opacities[i]));
        g->opacities[i] = (float)log(o / (1.0 - o));
    }
}
