/* Density control as Markov chain Monte Carlo (Kheradmand et al., "3D Gaussian Splatting
 * as Markov Chain Monte Carlo", NeurIPS 2024; gsplat's MCMCStrategy is the known-good
 * implementation it is checked against in docs/SPLAT_TRAINING.md). Instead of cloning and
 * splitting by a screen-space gradient threshold, the model has a budget of Gaussians:
 * - relocation: Gaussians whose opacity fell to min_opacity or below are moved onto live
 *   ones drawn in proportion to their opacity;
 * - growth: every refinement a further 5 % of the count is drawn the same way, until the
 *   budget is reached;
 * - a drawn Gaussian and its N - 1 copies share its contribution: their opacity and scale
 *   are set so that N of them render like the one did (paper eq. 9);
 * - noise on the positions of nearly transparent Gaussians, shaped by their covariance, so
 *   that they explore (paper eq. 10);
 * - L1 regularisers on opacity and scale, so that Gaussians that do not pay for themselves
 *   fade and get relocated.
 * The Adam moments of every row that a relocation or growth touches start from zero. */
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "gaussvid/core/core.h"
#include "gaussvid/splat/splat_train.h"

#define MAX_SHARE 51          /* gsplat's n_max: a Gaussian is drawn at most 50 times */
#define NOISE_SHARPNESS 100.0 /* op_sigmoid k */
#define NOISE_SKIP 1e-3       /* below this gate the noise is < 1e-3 of a dead Gaussian's */

void gv_splat_mcmc_defaults(gv_splat_mcmc_params *p)
{
    *p = (gv_splat_mcmc_params){.cap = 0, .growth = 0.05, .min_opacity = 0.005,
                                .noise_lr = 5e5, .opacity_reg = 0.01, .scale_reg = 0.01};
}

static float sigmoid(float x)
{
    return 1.0f / (1.0f + expf(-x));
}

void gv_splat_mcmc_share(double opacity, int n, double *new_opacity, double *scale_factor)
{
    if (n < 1) n = 1;
    if (n > MAX_SHARE) n = MAX_SHARE;
    double o = 1.0 - pow(1.0 - opacity, 1.0 / n);
    o = fmin(fmax(o, 0.0), 1.0 - 1.1920929e-07); /* gsplat clamps below 1 - float eps */
    /* Denominator of eq. 9: sum_{i=1}^{n} sum_{k=0}^{i-1} C(i-1, k) (-1)^k o^(k+1)/sqrt(k+1). */
    double denominator = 0;
    for (int i = 1; i <= n; i++) {
        double binomial = 1; /* C(i-1, 0) */
        for (int k = 0; k < i; k++) {
            double term = binomial * pow(o, k + 1) / sqrt(k + 1.0);
            denominator += k % 2 ? -term : term;
            binomial = binomial * (i - 1 - k) / (k + 1);
        }
    }
    *new_opacity = o;
    *scale_factor = denominator > 0 ? opacity / denominator : 1.0;
}

/* Draws n indices with replacement, each in proportion to its weight (the cumulative sums
 * cdf[0 .. n_items) ascending, cdf[n_items - 1] > 0). */
static void draw(const double *cdf, const int *items, int n_items, int n, gv_rng *rng,
                 int *out)
{
    double total = cdf[n_items - 1];
    for (int j = 0; j < n; j++) {
        double u = gv_rng_uniform(rng) * total;
        int lo = 0, hi = n_items - 1;
        while (lo < hi) { /* first cdf[k] > u */
            int mid = lo + (hi - lo) / 2;
            if (cdf[mid] > u) hi = mid;
            else lo = mid + 1;
        }
        out[j] = items[lo];
    }
}

/* Gives each drawn source its share (count[s] copies besides itself), then copies the
 * sources into the destination rows; every touched row's moments start from zero. */
static void share_and_copy(gv_gaussians *g, gv_splat_adam *adam, const int *sources,
                           const int *destinations, int n, int *count)
{
    for (int j = 0; j < n; j++) count[sources[j]]++;
    for (int j = 0; j < n; j++) {
        int s = sources[j];
        if (count[s] == 0) continue; /* already shared */
        double o, factor;
        gv_splat_mcmc_share(sigmoid(g->opacities[s]), count[s] + 1, &o, &factor);
        o = fmax(o, 1e-7);
        g->opacities[s] = (float)log(o / (1.0 - o));
        for (int a = 0; a < 3; a++) g->scales[3 * (size_t)s + a] += (float)log(factor);
        gv_gaussians_zero_rows(&adam->m, s, s + 1), gv_gaussians_zero_rows(&adam->v, s, s + 1);
        count[s] = 0;
    }
    for (int j = 0; j < n; j++) {
        int d = destinations[j];
        gv_gaussians_copy_row(g, d, sources[j]);
        gv_gaussians_zero_rows(&adam->m, d, d + 1), gv_gaussians_zero_rows(&adam->v, d, d + 1);
    }
}

/* Cumulative opacity of the rows with keep(opacity) true: items and cdf; returns the count. */
static int opacity_cdf(const gv_gaussians *g, float dead_logit, int alive, int *items,
                       double *cdf)
{
    int n = 0;
    double sum = 0;
    for (int i = 0; i < g->n; i++) {
        int is_alive = g->opacities[i] > dead_logit;
        if (alive && !is_alive) continue;
        sum += sigmoid(g->opacities[i]);
        items[n] = i, cdf[n] = sum, n++;
    }
    return n;
}

int gv_splat_mcmc_relocate(gv_gaussians *g, gv_splat_adam *adam, const gv_splat_mcmc_params *p,
                           gv_rng *rng, int *relocated)
{
    *relocated = 0;
    int n = g->n;
    float dead_logit = (float)log(p->min_opacity / (1.0 - p->min_opacity));
    int *items = malloc((size_t)(n + 1) * sizeof(int)), *dead = malloc((size_t)(n + 1) * sizeof(int));
    int *sources = malloc((size_t)(n + 1) * sizeof(int)), *count = calloc((size_t)n + 1, sizeof(int));
    double *cdf = malloc((size_t)(n + 1) * sizeof(double));
    int ok = items && dead && sources && count && cdf ? 0 : -1;
    if (ok == 0) {
        int n_dead = 0;
        for (int i = 0; i < n; i++)
            if (!(g->opacities[i] > dead_logit)) dead[n_dead++] = i; /* NaN counts as dead */
        int n_alive = opacity_cdf(g, dead_logit, 1, items, cdf);
        if (n_dead > 0 && n_alive > 0 && cdf[n_alive - 1] > 0) {
            draw(cdf, items, n_alive, n_dead, rng, sources);
            share_and_copy(g, adam, sources, dead, n_dead, count);
            *relocated = n_dead;
        }
    }
    free(items), free(dead), free(sources), free(count), free(cdf);
    return ok == 0 ? 0 : gv_fail("mcmc: out of memory for %d Gaussians", n);
}

int gv_splat_mcmc_grow(gv_gaussians *g, gv_splat_adam *adam, const gv_splat_mcmc_params *p,
                       gv_rng *rng, int *added)
{
    *added = 0;
    int n = g->n;
    long target = (long)floor((1.0 + p->growth) * n);
    if (p->cap > 0 && target > p->cap) target = p->cap;
    int n_new = target > n ? (int)(target - n) : 0;
    if (n_new == 0 || n == 0) return 0;
    int cap = n + n_new;
    if (gv_gaussians_reserve(g, cap) || gv_gaussians_reserve(&adam->m, cap) ||
        gv_gaussians_reserve(&adam->v, cap))
        return gv_fail_context("mcmc");
    int *items = malloc((size_t)n * sizeof(int)), *sources = malloc((size_t)n_new * sizeof(int));
    int *rows = malloc((size_t)n_new * sizeof(int)), *count = calloc((size_t)n, sizeof(int));
    double *cdf = malloc((size_t)n * sizeof(double));
    int ok = items && sources && rows && count && cdf ? 0 : -1;
    if (ok == 0) {
        int n_items = opacity_cdf(g, -INFINITY, 0, items, cdf);
        if (cdf[n_items - 1] > 0) {
            draw(cdf, items, n_items, n_new, rng, sources);
            for (int j = 0; j < n_new; j++) rows[j] = n + j;
            g->n = adam->m.n = adam->v.n = cap;
            share_and_copy(g, adam, sources, rows, n_new, count);
            *added = n_new;
        }
    }
    free(items), free(sources), free(rows), free(count), free(cdf);
    return ok == 0 ? 0 : gv_fail("mcmc: out of memory for %d Gaussians", cap);
}

/* Covariance R diag(s^2) R^T of one Gaussian (raw quaternion, log-scales), row-major. */
static void covariance(const float *q_raw, const float *log_scale, double S[9])
{
    double n = sqrt((double)q_raw[0] * q_raw[0] + (double)q_raw[1] * q_raw[1] +
                    (double)q_raw[2] * q_raw[2] + (double)q_raw[3] * q_raw[3]);
    if (n < 1e-12) n = 1e-12;
    double w = q_raw[0] / n, x = q_raw[1] / n, y = q_raw[2] / n, z = q_raw[3] / n;
    double R[9] = {1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y),
                   2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x),
                   2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)};
    double s2[3];
    for (int a = 0; a < 3; a++) s2[a] = exp(2.0 * log_scale[a]);
    for (int i = 0; i < 3; i++)
        for (int j = 0; j < 3; j++)
            S[3 * i + j] = R[3 * i] * s2[0] * R[3 * j] + R[3 * i + 1] * s2[1] * R[3 * j + 1] +
                           R[3 * i + 2] * s2[2] * R[3 * j + 2];
}

void gv_splat_mcmc_noise(gv_gaussians *g, const gv_splat_mcmc_params *p, double means_lr,
                         uint64_t seed)
{
    double scaler = p->noise_lr * means_lr;
    double threshold = 1.0 - p->min_opacity;
#pragma omp parallel for schedule(static)
    for (int i = 0; i < g->n; i++) {
        /* op_sigmoid(1 - opacity): about 1 for dead Gaussians, 0 for opaque ones. */
        double o = sigmoid(g->opacities[i]);
        double gate = 1.0 / (1.0 + exp(-NOISE_SHARPNESS * ((1.0 - o) - threshold)));
        if (!(gate >= NOISE_SKIP)) continue;
        double eps[3], S[9];
        for (int a = 0; a < 3; a++) eps[a] = gv_normal_at(seed, 3 * (uint64_t)i + a);
        covariance(g->rotations + 4 * (size_t)i, g->scales + 3 * (size_t)i, S);
        for (int a = 0; a < 3; a++) {
            double d = S[3 * a] * eps[0] + S[3 * a + 1] * eps[1] + S[3 * a + 2] * eps[2];
            g->means[3 * (size_t)i + a] += (float)(d * gate * scaler);
        }
    }
}

void gv_splat_mcmc_regularize(const gv_gaussians *g, const gv_splat_mcmc_params *p,
                              gv_gaussians *grad)
{
    if (g->n == 0) return;
    float d_opacity = (float)(p->opacity_reg / g->n), d_scale = (float)(p->scale_reg / (3.0 * g->n));
#pragma omp parallel for schedule(static)
    for (int i = 0; i < g->n; i++) {
        float o = sigmoid(g->opacities[i]);
        grad->opacities[i] += d_opacity * o * (1.0f - o);
        for (int a = 0; a < 3; a++)
            grad->scales[3 * (size_t)i + a] += d_scale * expf(g->scales[3 * (size_t)i + a]);
    }
}
