/* MCMC density control (src/splat/mcmc.c) on hand-built sets: the share of a drawn
 * Gaussian (paper eq. 9, hand-derived values), which rows relocation and growth touch and
 * what they hold afterwards, the budget, the Adam moments, the noise (exact against an
 * independent computation; the same for 1 and 2 threads) and the regularisers' gradients
 * against finite differences. */
#include <omp.h>

#include "check.h"
#include "gaussvid/core/core.h"
#include "gaussvid/splat/splat_train.h"

enum { W = 12 }; /* SH floats per Gaussian at degree 1 */

static float logit(double o)
{
    return (float)log(o / (1.0 - o));
}

static double sigmoid(double x)
{
    return 1.0 / (1.0 + exp(-x));
}

static void set_gaussian(gv_gaussians *g, int i, float x, float scale, double opacity)
{
    g->means[3 * i] = x, g->means[3 * i + 1] = 0.5f * x, g->means[3 * i + 2] = 2;
    for (int a = 0; a < 3; a++) g->scales[3 * i + a] = logf(scale * (1 + 0.1f * a));
    g->opacities[i] = logit(opacity);
    g->rotations[4 * i] = 1, g->rotations[4 * i + 1] = 0.2f * i;
    g->rotations[4 * i + 2] = g->rotations[4 * i + 3] = 0;
    for (int j = 0; j < W; j++) g->sh[W * i + j] = (float)(i + 0.01 * j);
}

static void test_share(void)
{
    double o, f;
    gv_splat_mcmc_share(0.3, 1, &o, &f); /* one copy: unchanged */
    CHECK_NEAR(o, 0.3, 1e-12);
    CHECK_NEAR(f, 1.0, 1e-12);
    /* n = 2, opacity 0.75: o' = 1 - sqrt(0.25) = 0.5; denominator = o' + (o' - o'^2/sqrt 2)
     * = 0.5 + 0.5 - 0.25/sqrt(2) = 0.823223305; factor = 0.75 / 0.823223305. */
    gv_splat_mcmc_share(0.75, 2, &o, &f);
    CHECK_NEAR(o, 0.5, 1e-12);
    CHECK_NEAR(f, 0.75 / (1.0 - 0.25 / sqrt(2.0)), 1e-12);
    /* n = 3, opacity 0.875: o' = 0.5; denominator = 3 o' - (1 + 2) o'^2/sqrt 2 + o'^3/sqrt 3. */
    gv_splat_mcmc_share(0.875, 3, &o, &f);
    CHECK_NEAR(o, 0.5, 1e-12);
    CHECK_NEAR(f, 0.875 / (1.5 - 0.75 / sqrt(2.0) + 0.125 / sqrt(3.0)), 1e-12);
    /* The n copies together are as opaque as the one: 1 - (1 - o')^n = o. */
    for (int n = 2; n <= 51; n += 7) {
        gv_splat_mcmc_share(0.6, n, &o, &f);
        CHECK_NEAR(1.0 - pow(1.0 - o, n), 0.6, 1e-9);
        CHECK(f > 0 && f <= 1.0 + 1e-12);
    }
}

/* Rows 0..5: opacities 0.9, 0.001 (dead), 0.5, 0.004 (dead), 0.3, 0.005 (dead: at the
 * threshold). */
static void make_set(gv_gaussians *g, gv_splat_adam *adam)
{
    gv_splat_adam_config c;
    gv_splat_adam_defaults(&c);
    if (gv_gaussians_alloc(g, 6, 1) != 0) exit(1);
    const double opacity[6] = {0.9, 0.001, 0.5, 0.004, 0.3, 0.005};
    for (int i = 0; i < 6; i++) set_gaussian(g, i, (float)i, 0.1f, opacity[i]);
    if (gv_splat_adam_init(adam, &c, g, 1.0) != 0) exit(1);
    for (int i = 0; i < 6; i++) { /* non-zero moments, to see which rows are reset */
        adam->m.opacities[i] = adam->v.opacities[i] = 1;
        adam->m.means[3 * i] = adam->v.sh[W * i] = 1;
    }
}

static int same_row_except_share(const gv_gaussians *g, int a, int b)
{
    return memcmp(g->means + 3 * a, g->means + 3 * b, 3 * sizeof(float)) == 0 &&
           memcmp(g->sh + W * a, g->sh + W * b, W * sizeof(float)) == 0 &&
           memcmp(g->rotations + 4 * a, g->rotations + 4 * b, 4 * sizeof(float)) == 0 &&
           memcmp(g->scales + 3 * a, g->scales + 3 * b, 3 * sizeof(float)) == 0 &&
           g->opacities[a] == g->opacities[b];
}

static void test_relocate(void)
{
    gv_gaussians g, before;
    gv_splat_adam adam;
    make_set(&g, &adam);
    if (gv_gaussians_alloc(&before, 6, 1) != 0) exit(1);
    memcpy(before.means, g.means, sizeof(float) * 18), memcpy(before.opacities, g.opacities, 24);
    memcpy(before.scales, g.scales, sizeof(float) * 18);
    gv_splat_mcmc_params p;
    gv_splat_mcmc_defaults(&p);
    gv_rng rng;
    gv_rng_init(&rng, 7);
    int moved = -1;
    CHECK(gv_splat_mcmc_relocate(&g, &adam, &p, &rng, &moved) == 0);
    CHECK(moved == 3);
    CHECK(g.n == 6);
    const int dead[3] = {1, 3, 5}, alive[3] = {0, 2, 4};
    int copies[6] = {0};
    for (int d = 0; d < 3; d++) {
        int r = dead[d], source = -1;
        for (int a = 0; a < 3; a++)
            if (same_row_except_share(&g, r, alive[a])) source = alive[a];
        CHECK(source >= 0); /* every dead row now is a copy of a live row */
        if (source >= 0) copies[source]++;
        CHECK(adam.m.opacities[r] == 0 && adam.v.opacities[r] == 0 && adam.m.means[3 * r] == 0);
    }
    for (int a = 0; a < 3; a++) {
        int s = alive[a];
        double o0 = sigmoid(before.opacities[s]), o1 = sigmoid(g.opacities[s]);
        if (copies[s] == 0) { /* not drawn: untouched, moments kept */
            CHECK(g.opacities[s] == before.opacities[s] && adam.m.opacities[s] == 1);
            continue;
        }
        double o, f;
        gv_splat_mcmc_share(o0, copies[s] + 1, &o, &f);
        CHECK_NEAR(o1, o, 1e-6);
        CHECK_NEAR(1.0 - pow(1.0 - o1, copies[s] + 1), o0, 1e-5);
        CHECK_NEAR(expf(g.scales[3 * s]) / expf(before.scales[3 * s]), f, 1e-5);
        CHECK(memcmp(g.means + 3 * s, before.means + 3 * s, 12) == 0); /* the source stays */
        CHECK(adam.m.opacities[s] == 0 && adam.v.sh[W * s] == 0);
    }
    /* Nothing dead: nothing moves. */
    CHECK(gv_splat_mcmc_relocate(&g, &adam, &p, &rng, &moved) == 0 && moved == 0);
    gv_gaussians_free(&before), gv_gaussians_free(&g), gv_splat_adam_free(&adam);
}

static void test_grow_and_budget(void)
{
    gv_gaussians g;
    gv_splat_adam adam;
    gv_splat_adam_config c;
    gv_splat_adam_defaults(&c);
    CHECK(gv_gaussians_alloc(&g, 40, 1) == 0);
    for (int i = 0; i < 40; i++) set_gaussian(&g, i, (float)i, 0.1f, i == 7 ? 0.99 : 1e-4);
    CHECK(gv_splat_adam_init(&adam, &c, &g, 1.0) == 0);
    gv_splat_mcmc_params p;
    gv_splat_mcmc_defaults(&p);
    p.cap = 45;
    gv_rng rng;
    gv_rng_init(&rng, 3);
    int added = -1;
    CHECK(gv_splat_mcmc_grow(&g, &adam, &p, &rng, &added) == 0);
    CHECK(added == 2 && g.n == 42); /* floor(1.05 x 40) */
    CHECK(adam.m.n == 42 && adam.v.n == 42);
    /* Row 7 holds 0.99 of ~0.994 total weight: the draws take it (the rest is 1e-4 each). */
    for (int r = 40; r < 42; r++) CHECK(same_row_except_share(&g, r, 7));
    for (int k = 0; k < 10; k++) CHECK(gv_splat_mcmc_grow(&g, &adam, &p, &rng, &added) == 0);
    CHECK(g.n == 45); /* the budget */
    CHECK(gv_splat_mcmc_grow(&g, &adam, &p, &rng, &added) == 0 && added == 0 && g.n == 45);
    gv_gaussians_free(&g), gv_splat_adam_free(&adam);
}

static void test_noise(void)
{
    gv_gaussians g, h;
    CHECK(gv_gaussians_alloc(&g, 300, 1) == 0 && gv_gaussians_alloc(&h, 300, 1) == 0);
    for (int i = 0; i < 300; i++) {
        double o = i % 3 == 0 ? 0.9 : i % 3 == 1 ? 0.002 : 0.03;
        set_gaussian(&g, i, (float)i, 0.05f, o);
        set_gaussian(&h, i, (float)i, 0.05f, o);
    }
    gv_splat_mcmc_params p;
    gv_splat_mcmc_defaults(&p);
    omp_set_num_threads(1);
    gv_splat_mcmc_noise(&g, &p, 1e-4, 99);
    omp_set_num_threads(2);
    gv_splat_mcmc_noise(&h, &p, 1e-4, 99);
    CHECK(memcmp(g.means, h.means, sizeof(float) * 900) == 0); /* thread count: same bytes */
    int exact = 1;
    for (int i = 0; i < 300; i++) {
        double o = sigmoid(h.opacities[i]);
        double gate = 1.0 / (1.0 + exp(-100.0 * ((1.0 - o) - 0.995)));
        /* Independent: Sigma = R diag(s^2) R^T with R from the quaternion (1, 0.2 i, 0, 0),
         * a rotation about x by 2 atan(0.2 i). */
        double angle = 2 * atan(0.2 * i), c = cos(angle), sn = sin(angle);
        double s2[3];
        for (int a = 0; a < 3; a++) s2[a] = pow(0.05 * (1 + 0.1 * a), 2);
        double e[3];
        for (int a = 0; a < 3; a++) e[a] = gv_normal_at(99, 3 * (uint64_t)i + a);
        double d[3] = {s2[0] * e[0],
                       (c * c * s2[1] + sn * sn * s2[2]) * e[1] + c * sn * (s2[1] - s2[2]) * e[2],
                       c * sn * (s2[1] - s2[2]) * e[1] + (sn * sn * s2[1] + c * c * s2[2]) * e[2]};
        double base[3] = {i, 0.5 * i, 2};
        for (int a = 0; a < 3; a++) {
            double want = gate < 1e-3 ? base[a] : base[a] + d[a] * gate * 5e5 * 1e-4;
            if (gate < 1e-3 && h.means[3 * i + a] != (float)base[a]) exact = 0;
            if (fabs(h.means[3 * i + a] - want) > 1e-5 * (1 + fabs(want))) exact = 0;
        }
    }
    CHECK(exact);
    CHECK(g.means[3 * 0] == 0.0f); /* opacity 0.9: the gate is ~e^-89, not moved */
    CHECK(g.means[3 * 1 + 1] != 0.5f); /* 0.002: moved */
    gv_gaussians_free(&g), gv_gaussians_free(&h);
}

/* The regularisers' loss: opacity_reg mean(sigmoid(o)) + scale_reg mean(exp(s)). */
static double reg_loss(const gv_gaussians *g, const gv_splat_mcmc_params *p)
{
    double so = 0, ss = 0;
    for (int i = 0; i < g->n; i++) {
        so += sigmoid(g->opacities[i]);
        for (int a = 0; a < 3; a++) ss += exp(g->scales[3 * i + a]);
    }
    return p->opacity_reg * so / g->n + p->scale_reg * ss / (3.0 * g->n);
}

static void test_regularize_gradient(void)
{
    gv_gaussians g, grad;
    CHECK(gv_gaussians_alloc(&g, 5, 1) == 0 && gv_gaussians_alloc(&grad, 5, 1) == 0);
    for (int i = 0; i < 5; i++) set_gaussian(&g, i, (float)i, 0.2f + 0.3f * i, 0.1 + 0.15 * i);
    gv_splat_mcmc_params p;
    gv_splat_mcmc_defaults(&p);
    grad.opacities[2] = 1; /* ADDS to what is there */
    gv_splat_mcmc_regularize(&g, &p, &grad);
    grad.opacities[2] -= 1;
    const float h = 1e-2f;
    for (int i = 0; i < 5; i++) {
        float keep = g.opacities[i];
        g.opacities[i] = keep + h;
        double up = reg_loss(&g, &p);
        g.opacities[i] = keep - h;
        double down = reg_loss(&g, &p);
        g.opacities[i] = keep;
        CHECK_NEAR(grad.opacities[i], (up - down) / (2 * h), 1e-6);
        for (int a = 0; a < 3; a++) {
            keep = g.scales[3 * i + a];
            g.scales[3 * i + a] = keep + h;
            up = reg_loss(&g, &p);
            g.scales[3 * i + a] = keep - h;
            down = reg_loss(&g, &p);
            g.scales[3 * i + a] = keep;
            CHECK_NEAR(grad.scales[3 * i + a], (up - down) / (2 * h), 1e-6);
        }
    }
    gv_gaussians_free(&g), gv_gaussians_free(&grad);
}

int main(void)
{
    test_share();
    test_relocate();
    test_grow_and_budget();
    test_noise();
    test_regularize_gradient();
    return check_summary();
}
