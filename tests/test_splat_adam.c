/* Adam for the Gaussians (src/splat/splat_adam.c): steps against a double-precision
 * computation of PyTorch's formula, the reference learning rates and position schedule,
 * dense vs listed rows, group masks and the active SH coefficients. */
#include "check.h"
#include "gaussvid/core.h"
#include "gaussvid/splat_train.h"

/* PyTorch Adam on one value, in double: returns the new parameter. */
typedef struct { double p, m, v; } ref_state;
static void ref_step(ref_state *s, double g, double lr, long t)
{
    const double b1 = 0.9, b2 = 0.999, eps = 1e-15;
    s->m = b1 * s->m + (1 - b1) * g;
    s->v = b2 * s->v + (1 - b2) * g * g;
    double step_size = lr / (1 - pow(b1, (double)t));
    double denom = sqrt(s->v) / sqrt(1 - pow(b2, (double)t)) + eps;
    s->p -= step_size * s->m / denom;
}

static void test_schedule(void)
{
    /* get_expon_lr_func(1.6e-4 E, 1.6e-6 E, max_steps 30000): log-linear, 1/100 at the end. */
    double E = 4.4;
    CHECK_NEAR(gv_splat_expon_lr(0, 1.6e-4 * E, 1.6e-6 * E, 30000), 1.6e-4 * E, 1e-15);
    CHECK_NEAR(gv_splat_expon_lr(15000, 1.6e-4 * E, 1.6e-6 * E, 30000), 1.6e-5 * E, 1e-15);
    CHECK_NEAR(gv_splat_expon_lr(7500, 1.6e-4, 1.6e-6, 30000), 1.6e-4 * pow(0.01, 0.25), 1e-15);
    CHECK_NEAR(gv_splat_expon_lr(30000, 1.6e-4, 1.6e-6, 30000), 1.6e-6, 1e-17);
    CHECK_NEAR(gv_splat_expon_lr(90000, 1.6e-4, 1.6e-6, 30000), 1.6e-6, 1e-17);
    CHECK(gv_splat_expon_lr(100, 0, 0, 30000) == 0);

    gv_splat_adam_config c;
    gv_splat_adam_defaults(&c);
    CHECK(c.means_lr_init == 0.00016 && c.means_lr_final == 0.0000016 && c.means_lr_steps == 30000);
    CHECK(c.sh_dc_lr == 0.0025 && c.sh_rest_lr == 0.0025 / 20 && c.opacity_lr == 0.05);
    CHECK(c.scales_lr == 0.005 && c.rotations_lr == 0.001 && c.eps == 1e-15);
    gv_gaussians p;
    gv_splat_adam a;
    CHECK(gv_gaussians_alloc(&p, 2, 0) == 0);
    CHECK(gv_splat_adam_init(&a, &c, &p, E) == 0);
    CHECK_NEAR(a.lr[GV_ADAM_MEANS], 1.6e-4 * E, 1e-15);
    gv_splat_adam_set_iteration(&a, 3000);
    CHECK_NEAR(a.lr[GV_ADAM_MEANS], 1.6e-4 * E * pow(0.01, 0.1), 1e-15);
    CHECK(a.lr[GV_ADAM_OPACITY] == 0.05 && a.lr[GV_ADAM_SCALES] == 0.005);
    gv_splat_adam_free(&a), gv_gaussians_free(&p);
}

/* Fills every parameter and gradient of g with values from a stream. */
static void fill(gv_gaussians *g, uint64_t seed, double scale)
{
    long k = 3L * gv_sh_coefficient_count(g->sh_degree);
    for (long i = 0; i < g->n; i++) {
        float *rows[5] = {g->means + 3 * i, g->sh + k * i, g->opacities + i, g->scales + 3 * i,
                          g->rotations + 4 * i};
        int widths[5] = {3, (int)k, 1, 3, 4};
        for (int f = 0; f < 5; f++)
            for (int j = 0; j < widths[f]; j++)
                rows[f][j] = (float)(scale * gv_normal_at(seed, (uint64_t)(i * 100 + f * 20 + j)));
    }
}

static void test_steps_against_reference(void)
{
    gv_gaussians p, g;
    gv_splat_adam a;
    gv_splat_adam_config c;
    gv_splat_adam_defaults(&c);
    CHECK(gv_gaussians_alloc(&p, 5, 1) == 0 && gv_gaussians_alloc(&g, 5, 1) == 0);
    fill(&p, 1, 0.05); /* small values: float rounding of p stays far below one step */
    CHECK(gv_splat_adam_init(&a, &c, &p, 2.0) == 0);
    /* Track one value per group in double: means[1][2], sh dc[3][1], sh rest[2][k=2,c=0],
     * opacity[4], scale[0][1], rotation[2][3]. */
    ref_state r[6] = {{p.means[5], 0, 0}, {p.sh[12 * 3 + 1], 0, 0}, {p.sh[12 * 2 + 6], 0, 0},
                      {p.opacities[4], 0, 0}, {p.scales[1], 0, 0}, {p.rotations[11], 0, 0}};
    float *val[6] = {&p.means[5], &p.sh[12 * 3 + 1], &p.sh[12 * 2 + 6], &p.opacities[4],
                     &p.scales[1], &p.rotations[11]};
    float *grd[6] = {&g.means[5], &g.sh[12 * 3 + 1], &g.sh[12 * 2 + 6], &g.opacities[4],
                     &g.scales[1], &g.rotations[11]};
    double worst = 0;
    for (int it = 1; it <= 20; it++) {
        fill(&g, 100 + it, it == 7 ? 0.0 : 1e-3); /* one all-zero gradient on the way */
        gv_splat_adam_set_iteration(&a, it);
        double lrs[6] = {a.lr[GV_ADAM_MEANS], 0.0025, 0.000125, 0.05, 0.005, 0.001};
        for (int j = 0; j < 6; j++) ref_step(&r[j], *grd[j], lrs[j], it);
        gv_splat_adam_step(&a, &p, &g, NULL, p.n, 4, GV_ADAM_ALL_GROUPS);
        for (int j = 0; j < 6; j++) {
            double d = fabs(*val[j] - r[j].p) / lrs[j]; /* error in units of one step */
            if (d > worst) worst = d;
        }
    }
    printf("Adam: worst difference to the double computation %.2e learning rates\n", worst);
    CHECK(worst < 1e-3);
    for (int k = 0; k < GV_ADAM_GROUPS; k++) CHECK(a.step[k] == 20);
    /* The first step of Adam moves every value with a non-zero gradient by exactly lr. */
    gv_splat_adam_free(&a);
    fill(&p, 1, 1.0);
    CHECK(gv_splat_adam_init(&a, &c, &p, 2.0) == 0);
    fill(&g, 5, 0.3);
    float before = p.scales[7], gs = g.scales[7];
    gv_splat_adam_step(&a, &p, &g, NULL, p.n, 4, GV_ADAM_ALL_GROUPS);
    CHECK_NEAR(p.scales[7], before - 0.005 * (gs > 0 ? 1 : -1), 1e-7);
    gv_splat_adam_free(&a), gv_gaussians_free(&p), gv_gaussians_free(&g);
}

/* Listed rows only; group mask; SH coefficients above the active count untouched. */
static void test_rows_groups_coefficients(void)
{
    gv_gaussians p, p0, g;
    gv_splat_adam a;
    gv_splat_adam_config c;
    gv_splat_adam_defaults(&c);
    CHECK(gv_gaussians_alloc(&p, 4, 2) == 0 && gv_gaussians_alloc(&p0, 4, 2) == 0 &&
          gv_gaussians_alloc(&g, 4, 2) == 0);
    fill(&p, 7, 1.0), fill(&p0, 7, 1.0), fill(&g, 8, 0.01);
    CHECK(gv_splat_adam_init(&a, &c, &p, 1.0) == 0);
    int rows[2] = {3, 1};
    unsigned groups = GV_ADAM_ALL_GROUPS & ~(1u << GV_ADAM_OPACITY);
    gv_splat_adam_step(&a, &p, &g, rows, 2, 4, groups); /* degree 1 active: 4 coefficients */
    CHECK(a.step[GV_ADAM_OPACITY] == 0 && a.step[GV_ADAM_MEANS] == 1);
    int K = 27; /* 9 coefficients x 3 */
    for (int i = 0; i < 4; i++) {
        int listed = i == 1 || i == 3;
        CHECK((p.means[3 * i] != p0.means[3 * i]) == listed);
        CHECK((a.m.means[3 * i] != 0) == listed);
        CHECK((p.rotations[4 * i + 2] != p0.rotations[4 * i + 2]) == listed);
        CHECK(p.opacities[i] == p0.opacities[i] && a.m.opacities[i] == 0);
        CHECK((p.sh[K * i + 11] != p0.sh[K * i + 11]) == listed); /* coefficient 3 */
        CHECK(p.sh[K * i + 12] == p0.sh[K * i + 12]);             /* coefficient 4: not active */
        CHECK(a.v.sh[K * i + 12] == 0);
    }
    /* Dense rows: a row with zero gradient keeps moving by its momentum, m / sqrt(v) of the
     * decayed moments (reference doc 13.1). */
    float m = a.m.means[3], v = a.v.means[3], x = p.means[3];
    memset(g.means, 0, sizeof(float) * 12);
    gv_splat_adam_step(&a, &p, &g, NULL, 4, 4, GV_ADAM_ALL_GROUPS);
    double m2 = 0.9 * m, v2 = 0.999 * v;
    double expect = x - (a.lr[GV_ADAM_MEANS] / (1 - 0.81)) * m2 / (sqrt(v2) / sqrt(1 - 0.999 * 0.999) + 1e-15);
    CHECK_NEAR(p.means[3], expect, 1e-6);
    CHECK(p.means[3] != x);
    gv_splat_adam_free(&a);
    gv_gaussians_free(&p), gv_gaussians_free(&p0), gv_gaussians_free(&g);
}

int main(void)
{
    test_schedule();
    test_steps_against_reference();
    test_rows_groups_coefficients();
    return check_summary();
}
