/* Adaptive density control (src/splat/densify.c) on hand-built sets: which Gaussians are
 * cloned, split and pruned, where the children go, their scales, the order of the rows,
 * the Adam moments that follow each row, and the opacity reset
 * (docs/reference/gaussian-splatting.md 14.2-14.3). */
#include "check.h"
#include "gaussvid/core/core.h"
#include "gaussvid/splat/splat_train.h"

enum { W = 12 }; /* SH floats per Gaussian at degree 1 */

static void set_gaussian(gv_gaussians *g, int i, float x, const float log_scale[3],
                         float opacity_logit, const float q[4])
{
    g->means[3 * i] = x, g->means[3 * i + 1] = 1, g->means[3 * i + 2] = -2;
    for (int a = 0; a < 3; a++) g->scales[3 * i + a] = log_scale[a];
    g->opacities[i] = opacity_logit;
    for (int a = 0; a < 4; a++) g->rotations[4 * i + a] = q[a];
    for (int j = 0; j < W; j++) g->sh[W * i + j] = (float)(i + 0.01 * j);
}

static void test_accumulate(void)
{
    gv_splat_densify_stats s = {0};
    CHECK(gv_splat_densify_stats_reserve(&s, 4) == 0);
    int visible[2] = {1, 3}, radii[4] = {0, 7, 0, 2};
    float grad[4] = {9, 0.5f, 9, 0.25f};
    gv_splat_densify_accumulate(&s, 2, visible, grad, radii);
    radii[1] = 5, radii[3] = 4, grad[1] = 1.5f;
    gv_splat_densify_accumulate(&s, 2, visible, grad, radii);
    CHECK(s.grad_accum[0] == 0 && s.denom[0] == 0 && s.max_radii[0] == 0);
    CHECK(s.grad_accum[1] == 2.0f && s.denom[1] == 2 && s.max_radii[1] == 7);
    CHECK(s.grad_accum[3] == 0.5f && s.denom[3] == 2 && s.max_radii[3] == 4);
    CHECK(s.grad_accum[2] == 0);
    gv_splat_densify_stats_clear(&s, 4);
    CHECK(s.grad_accum[1] == 0 && s.denom[1] == 0 && s.max_radii[1] == 0);
    gv_splat_densify_stats_free(&s);
}

/* Seven Gaussians, their statistics and Adam moments (the comments say what the reference's
 * threshold 0.0002 does with each). */
static const float opaque = 0.5f;
static const float id[4] = {1, 0, 0, 0};

static void hand_built_set(gv_gaussians *out, gv_splat_adam *adam_out, gv_splat_densify_stats *s)
{
    gv_gaussians g;
    gv_splat_adam adam;
    gv_splat_adam_config c;
    gv_splat_adam_defaults(&c);
    CHECK(gv_gaussians_alloc(&g, 7, 1) == 0);
    const float small[3] = {logf(0.05f), logf(0.05f), logf(0.05f)};
    const float large[3] = {logf(0.5f), logf(0.2f), logf(0.3f)};
    const float huge[3] = {logf(2.0f), logf(0.1f), logf(0.1f)};
    const float zrot[4] = {2, 0, 0, 2}; /* 90 deg about z, unnormalised */
    float faint = logf(0.001f / 0.999f);
    set_gaussian(&g, 0, 0, small, opaque, id);   /* grad 0.0003, small: clone */
    set_gaussian(&g, 1, 1, large, opaque, zrot); /* grad 0.0005, large: split */
    set_gaussian(&g, 2, 2, small, opaque, id);   /* grad 0.0001: kept as is */
    set_gaussian(&g, 3, 3, small, faint, id);    /* opacity 0.001 < 0.005: pruned */
    set_gaussian(&g, 4, 4, huge, opaque, id);    /* 2.0 > 0.1 x extent: pruned (prune_big) */
    set_gaussian(&g, 5, 5, small, opaque, id);   /* never visible: kept */
    set_gaussian(&g, 6, 6, small, opaque, id);   /* grad exactly 0.0002 (>=): clone */
    CHECK(gv_splat_adam_init(&adam, &c, &g, 10.0) == 0);
    CHECK(gv_splat_densify_stats_reserve(s, g.capacity) == 0);
    float accum[7] = {0.0006f, 0.0015f, 0.0001f, 0, 0.0001f, 0, 0.0004f};
    int denom[7] = {2, 3, 1, 1, 1, 0, 2};
    for (int i = 0; i < 7; i++) {
        s->grad_accum[i] = accum[i], s->denom[i] = denom[i], s->max_radii[i] = 100;
        adam.m.means[3 * i] = (float)(i + 1), adam.v.scales[3 * i + 2] = (float)(i + 1);
        adam.m.sh[W * i + 5] = (float)(i + 1);
    }
    adam.step[GV_ADAM_MEANS] = 41;
    *out = g, *adam_out = adam;
}

static void test_clone_split_prune(void)
{
    gv_gaussians g;
    gv_splat_adam adam;
    gv_splat_densify_stats s = {0};
    const float huge[3] = {logf(2.0f), logf(0.1f), logf(0.1f)};
    hand_built_set(&g, &adam, &s);
    gv_splat_densify_params p = {.grad_threshold = 0.0002, .percent_dense = 0.01,
                                 .min_opacity = 0.005, .extent = 10.0, .prune_big = 1};
    gv_rng rng, expect_rng;
    gv_rng_init(&rng, 99), gv_rng_init(&expect_rng, 99);
    gv_splat_densify_counts counts;
    CHECK(gv_splat_densify_and_prune(&g, &adam, &s, &p, &rng, &counts) == 0);
    CHECK(counts.cloned == 2 && counts.split == 1 && counts.pruned == 2);
    /* Rows: kept originals 0 2 5 6, clones of 0 and 6, the two children of 1. */
    CHECK(g.n == 8 && adam.m.n == 8 && adam.v.n == 8);
    const float x_expected[6] = {0, 2, 5, 6, 0, 6};
    for (int i = 0; i < 6; i++) CHECK(g.means[3 * i] == x_expected[i]);
    for (int i = 0; i < 6; i++) CHECK(g.sh[W * i] == x_expected[i]); /* SH followed the row */
    const float m_expected[6] = {1, 3, 6, 7, 0, 0};
    for (int i = 0; i < 6; i++) {
        CHECK(adam.m.means[3 * i] == m_expected[i]);
        CHECK(adam.v.scales[3 * i + 2] == m_expected[i]);
        CHECK(adam.m.sh[W * i + 5] == m_expected[i]);
    }
    CHECK(adam.step[GV_ADAM_MEANS] == 41);
    /* Children: mean + R eps, R = 90 deg about z maps (e0, e1, e2) to (-e1, e0, e2);
     * eps ~ N(0, s^2) drawn child by child, axis by axis; log-scale log(s / 1.6). */
    double s1[3] = {0.5, 0.2, 0.3};
    for (int k = 6; k < 8; k++) {
        double e[3];
        for (int a = 0; a < 3; a++) e[a] = gv_rng_normal(&expect_rng) * s1[a];
        CHECK_NEAR(g.means[3 * k], 1 - e[1], 1e-6);
        CHECK_NEAR(g.means[3 * k + 1], 1 + e[0], 1e-6);
        CHECK_NEAR(g.means[3 * k + 2], -2 + e[2], 1e-6);
        for (int a = 0; a < 3; a++) CHECK_NEAR(g.scales[3 * k + a], log(s1[a] / 1.6), 1e-6);
        CHECK(g.rotations[4 * k] == 2 && g.rotations[4 * k + 3] == 2);
        CHECK(g.opacities[k] == opaque && g.sh[W * k] == 1);
        CHECK(adam.m.means[3 * k] == 0 && adam.v.scales[3 * k + 2] == 0 && adam.m.sh[W * k + 5] == 0);
    }
    CHECK(g.means[3 * 6] != g.means[3 * 7]); /* two different samples */
    for (int i = 0; i < 8; i++) CHECK(s.grad_accum[i] == 0 && s.denom[i] == 0 && s.max_radii[i] == 0);

    /* Without prune_big the huge Gaussian stays; with a screen-size limit it goes. */
    gv_splat_densify_params q = p;
    q.prune_big = 0;
    set_gaussian(&g, 1, 4, huge, opaque, id);
    CHECK(gv_splat_densify_and_prune(&g, &adam, &s, &q, &rng, &counts) == 0);
    CHECK(g.n == 8 && counts.pruned == 0 && counts.cloned == 0 && counts.split == 0);
    s.max_radii[1] = 30;
    q.max_screen_size = 20;
    CHECK(gv_splat_densify_and_prune(&g, &adam, &s, &q, &rng, &counts) == 0);
    CHECK(g.n == 7 && counts.pruned == 1 && g.means[3] == 5); /* the next row moved up */
    gv_splat_adam_free(&adam), gv_splat_densify_stats_free(&s), gv_gaussians_free(&g);
}

/* lean on the same set: its threshold 0.0004 leaves Gaussian 0 (mean statistic 0.0003) and 6
 * (0.0002) alone, which the reference clones; 1 (0.0005) still splits and the prunes are the
 * same. */
static void test_lean_threshold(void)
{
    gv_gaussians g;
    gv_splat_adam adam;
    gv_splat_densify_stats s = {0};
    hand_built_set(&g, &adam, &s);
    gv_splat_train_options o;
    gv_splat_train_defaults(&o);
    o.densify_mode = GV_DENSIFY_LEAN;
    gv_splat_densify_params p = o.densify;
    p.grad_threshold = gv_splat_densify_threshold(&o), p.extent = 10.0, p.prune_big = 1;
    CHECK(p.grad_threshold == 0.0004);
    gv_rng rng;
    gv_rng_init(&rng, 99);
    gv_splat_densify_counts counts;
    CHECK(gv_splat_densify_and_prune(&g, &adam, &s, &p, &rng, &counts) == 0);
    CHECK(counts.cloned == 0 && counts.split == 1 && counts.pruned == 2);
    /* Rows: kept originals 0 2 5 6, then the two children of 1. */
    CHECK(g.n == 6);
    const float x_expected[4] = {0, 2, 5, 6};
    for (int i = 0; i < 4; i++) CHECK(g.means[3 * i] == x_expected[i]);
    gv_splat_adam_free(&adam), gv_splat_densify_stats_free(&s), gv_gaussians_free(&g);
}

/* Many parents split: the children's offsets have the covariance R diag(s^2) R^T. */
static void test_split_distribution(void)
{
    enum { N = 4000 };
    gv_gaussians g;
    gv_splat_adam adam;
    gv_splat_adam_config c;
    gv_splat_densify_stats s = {0};
    gv_splat_adam_defaults(&c);
    CHECK(gv_gaussians_alloc(&g, N, 0) == 0);
    double h = sqrt(0.5);
    const float q[4] = {(float)h, (float)h, 0, 0}; /* 90 deg about x: (e0, e1, e2) -> (e0, -e2, e1) */
    for (int i = 0; i < N; i++) {
        g.scales[3 * i] = logf(0.4f), g.scales[3 * i + 1] = logf(0.1f), g.scales[3 * i + 2] = logf(0.2f);
        for (int a = 0; a < 4; a++) g.rotations[4 * i + a] = q[a];
        g.opacities[i] = 0;
    }
    CHECK(gv_splat_adam_init(&adam, &c, &g, 1.0) == 0);
    CHECK(gv_splat_densify_stats_reserve(&s, N) == 0);
    for (int i = 0; i < N; i++) s.grad_accum[i] = 1, s.denom[i] = 1;
    gv_splat_densify_params p = {.grad_threshold = 0.0002, .percent_dense = 0.01,
                                 .min_opacity = 0.005, .extent = 1.0};
    gv_rng rng;
    gv_rng_init(&rng, 5);
    CHECK(gv_splat_densify_and_prune(&g, &adam, &s, &p, &rng, NULL) == 0);
    CHECK(g.n == 2 * N);
    double cov[3][3] = {{0}};
    for (int i = 0; i < g.n; i++)
        for (int a = 0; a < 3; a++)
            for (int b = 0; b < 3; b++) cov[a][b] += (double)g.means[3 * i + a] * g.means[3 * i + b] / g.n;
    printf("split offsets: variances %.4f %.4f %.4f (expected 0.16 0.04 0.01), cov xy %.4f\n",
           cov[0][0], cov[1][1], cov[2][2], cov[0][1]);
    CHECK_NEAR(cov[0][0], 0.16, 0.16 * 0.08);
    CHECK_NEAR(cov[1][1], 0.04, 0.04 * 0.08);
    CHECK_NEAR(cov[2][2], 0.01, 0.01 * 0.08);
    CHECK(fabs(cov[0][1]) < 0.01 && fabs(cov[1][2]) < 0.005);
    gv_splat_adam_free(&adam), gv_splat_densify_stats_free(&s), gv_gaussians_free(&g);
}

static void test_reset_opacity(void)
{
    gv_gaussians g;
    gv_splat_adam adam;
    gv_splat_adam_config c;
    gv_splat_adam_defaults(&c);
    CHECK(gv_gaussians_alloc(&g, 3, 0) == 0);
    g.opacities[0] = 2.0f, g.opacities[1] = -6.0f, g.opacities[2] = -4.0f;
    CHECK(gv_splat_adam_init(&adam, &c, &g, 1.0) == 0);
    for (int i = 0; i < 3; i++) adam.m.opacities[i] = 1, adam.v.opacities[i] = 1, adam.m.scales[i] = 1;
    gv_splat_reset_opacity(&g, &adam);
    CHECK_NEAR(g.opacities[0], log(0.01 / 0.99), 1e-5);
    CHECK_NEAR(g.opacities[1], -6.0, 1e-4); /* sigmoid(-6) = 0.0025 < 0.01: unchanged */
    CHECK_NEAR(g.opacities[2], log(0.01 / 0.99), 1e-5); /* sigmoid(-4) = 0.018 */
    for (int i = 0; i < 3; i++) CHECK(adam.m.opacities[i] == 0 && adam.v.opacities[i] == 0);
    CHECK(adam.m.scales[0] == 1);
    gv_splat_adam_free(&adam), gv_gaussians_free(&g);
}

/* Decay multiplies each opacity (after the sigmoid) by the factor and keeps Adam's moments:
 * logit(sigmoid(x) f). */
static void test_decay_opacity(void)
{
    gv_gaussians g;
    CHECK(gv_gaussians_alloc(&g, 3, 0) == 0);
    g.opacities[0] = 0.0f, g.opacities[1] = 2.0f, g.opacities[2] = -6.0f;
    gv_splat_decay_opacity(&g, 0.995);
    CHECK_NEAR(g.opacities[0], log(0.4975 / 0.5025), 1e-6);          /* 0.5 -> 0.4975 */
    double p = 0.995 / (1 + exp(-2.0));                                 /* 0.880797 -> 0.876393 */
    CHECK_NEAR(g.opacities[1], log(p / (1 - p)), 1e-6);
    p = 0.995 / (1 + exp(6.0));
    CHECK_NEAR(g.opacities[2], log(p / (1 - p)), 1e-6);
    for (int k = 0; k < 999; k++) gv_splat_decay_opacity(&g, 0.995); /* 1000 in all: 0.5 x 0.995^1000 */
    CHECK_NEAR(1 / (1 + exp(-(double)g.opacities[0])), 0.5 * pow(0.995, 1000), 1e-6);
    gv_gaussians_free(&g);
}

int main(void)
{
    test_accumulate();
    test_clone_split_prune();
    test_lean_threshold();
    test_split_distribution();
    test_reset_opacity();
    test_decay_opacity();
    return check_summary();
}
