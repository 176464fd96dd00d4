/* Adam for the Gaussians (src/splat/splat_adam.c): steps against a double-precision
 * computation of PyTorch's formula, the reference learning rates and position schedule,
 * dense vs listed rows, group masks and the active SH coefficients. */
#include "check.h"
#include "gaussvid/core/core.h"
#include "gaussvid/splat/splat_train.h"

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

static const int ALL[8] = {0, 1, 2, 3, 4, 5, 6, 7}; /* every row has a gradient */

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
        gv_splat_adam_step(&a, &p, &g, ALL, p.n, 1, 4, GV_ADAM_ALL_GROUPS);
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
    gv_splat_adam_step(&a, &p, &g, ALL, p.n, 1, 4, GV_ADAM_ALL_GROUPS);
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
    int rows[2] = {1, 3};
    unsigned groups = GV_ADAM_ALL_GROUPS & ~(1u << GV_ADAM_OPACITY);
    gv_splat_adam_step(&a, &p, &g, rows, 2, 0, 4, groups); /* degree 1 active: 4 coefficients */
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
     * decayed moments (docs/reference/gaussian-splatting.md 13.1). */
    float m = a.m.means[3], v = a.v.means[3], x = p.means[3];
    memset(g.means, 0, sizeof(float) * 12);
    gv_splat_adam_step(&a, &p, &g, ALL, 4, 1, 4, GV_ADAM_ALL_GROUPS);
    double m2 = 0.9 * m, v2 = 0.999 * v;
    double expect = x - (a.lr[GV_ADAM_MEANS] / (1 - 0.81)) * m2 / (sqrt(v2) / sqrt(1 - 0.999 * 0.999) + 1e-15);
    CHECK_NEAR(p.means[3], expect, 1e-6);
    CHECK(p.means[3] != x);
    gv_splat_adam_free(&a);
    gv_gaussians_free(&p), gv_gaussians_free(&p0), gv_gaussians_free(&g);
}

/* Copies the gradient of the listed rows of `from` into `to`, whose other rows are zero. */
static void listed_gradient(gv_gaussians *to, const gv_gaussians *from, const int *list, int n)
{
    size_t N = (size_t)to->n;
    memset(to->means, 0, sizeof(float) * 3 * N), memset(to->sh, 0, sizeof(float) * 48 * N);
    memset(to->opacities, 0, sizeof(float) * N), memset(to->scales, 0, sizeof(float) * 3 * N);
    memset(to->rotations, 0, sizeof(float) * 4 * N);
    for (int k = 0; k < n; k++) {
        int i = list[k];
        memcpy(to->means + 3 * i, from->means + 3 * i, sizeof(float) * 3);
        memcpy(to->sh + 48 * i, from->sh + 48 * i, sizeof(float) * 48);
        to->opacities[i] = from->opacities[i];
        memcpy(to->scales + 3 * i, from->scales + 3 * i, sizeof(float) * 3);
        memcpy(to->rotations + 4 * i, from->rotations + 4 * i, sizeof(float) * 4);
    }
}

static int all_zero(const gv_gaussians *g)
{
    size_t N = (size_t)g->n;
    int zero = 1;
    for (size_t i = 0; i < 48 * N; i++) zero &= g->sh[i] == 0;
    for (size_t i = 0; i < 4 * N; i++) zero &= g->rotations[i] == 0;
    for (size_t i = 0; i < 3 * N; i++) zero &= g->means[i] == 0 && g->scales[i] == 0;
    for (size_t i = 0; i < N; i++) zero &= g->opacities[i] == 0;
    return zero;
}

/* 600 rows (blocks of 256 and a partial one), degree 3, a scattered list of rows with a
 * gradient. Dense with the list: the same bytes as a dense step in which every row is
 * listed; sparse: the listed rows as in the dense step, the others untouched. Every step
 * leaves the gradient zero (consumed), also that of a masked group. */
static void test_listed_rows_many(void)
{
    enum { N = 600 };
    gv_gaussians p1, p2, p3, g, g1, g2, g3;
    gv_splat_adam a1, a2, a3;
    gv_splat_adam_config c;
    gv_splat_adam_defaults(&c);
    gv_gaussians *all_sets[7] = {&p1, &p2, &p3, &g, &g1, &g2, &g3};
    for (int k = 0; k < 7; k++) CHECK(gv_gaussians_alloc(all_sets[k], N, 3) == 0);
    fill(&p1, 21, 1.0), fill(&p2, 21, 1.0), fill(&p3, 21, 1.0);
    CHECK(gv_splat_adam_init(&a1, &c, &p1, 3.0) == 0 && gv_splat_adam_init(&a2, &c, &p2, 3.0) == 0 &&
          gv_splat_adam_init(&a3, &c, &p3, 3.0) == 0);
    static int list[N], all[N];
    int n_list = 0;
    for (int i = 0; i < N; i++) {
        all[i] = i;
        if (gv_uniform_at(22, (uint64_t)i) < 0.3 || i == 255 || i == 256 || i == N - 1)
            list[n_list++] = i;
    }
    int consumed = 1;
    for (int step = 1; step <= 3; step++) {
        fill(&g, 30 + step, 1e-3);
        listed_gradient(&g1, &g, list, n_list), listed_gradient(&g2, &g, list, n_list);
        listed_gradient(&g3, &g, list, n_list);
        gv_splat_adam_set_iteration(&a1, step), gv_splat_adam_set_iteration(&a2, step);
        gv_splat_adam_set_iteration(&a3, step);
        gv_splat_adam_step(&a1, &p1, &g1, list, n_list, 1, 16, GV_ADAM_ALL_GROUPS);
        gv_splat_adam_step(&a2, &p2, &g2, all, N, 1, 16, GV_ADAM_ALL_GROUPS);
        gv_splat_adam_step(&a3, &p3, &g3, list, n_list, 0, 16, GV_ADAM_ALL_GROUPS);
        consumed &= all_zero(&g1) && all_zero(&g2) && all_zero(&g3);
    }
    CHECK(consumed);
    CHECK(memcmp(p1.means, p2.means, sizeof(float) * 3 * N) == 0);
    CHECK(memcmp(p1.sh, p2.sh, sizeof(float) * 48 * N) == 0);
    CHECK(memcmp(p1.opacities, p2.opacities, sizeof(float) * N) == 0);
    CHECK(memcmp(p1.scales, p2.scales, sizeof(float) * 3 * N) == 0);
    CHECK(memcmp(p1.rotations, p2.rotations, sizeof(float) * 4 * N) == 0);
    CHECK(memcmp(a1.v.sh, a2.v.sh, sizeof(float) * 48 * N) == 0);
    int listed_same = 1, unlisted_kept = 1, unlisted_still = 1;
    fill(&g, 21, 1.0); /* the initial values */
    for (int i = 0, k = 0; i < N; i++) {
        int listed = k < n_list && list[k] == i;
        k += listed;
        if (listed) {
            listed_same &= memcmp(p3.sh + 48 * i, p1.sh + 48 * i, sizeof(float) * 48) == 0;
            listed_same &= p3.means[3 * i + 1] == p1.means[3 * i + 1];
        } else {
            unlisted_kept &= memcmp(p3.sh + 48 * i, g.sh + 48 * i, sizeof(float) * 48) == 0;
            unlisted_kept &= p3.rotations[4 * i + 3] == g.rotations[4 * i + 3];
            unlisted_kept &= a3.m.sh[48 * i] == 0 && a3.v.scales[3 * i] == 0;
            unlisted_still &= a1.m.sh[48 * i] == 0; /* never had a gradient: m = 0, no momentum */
            unlisted_still &= p1.sh[48 * i + 7] == g.sh[48 * i + 7];
        }
    }
    printf("Adam: %d of %d rows listed; dense == dense with zero gradients, sparse keeps the rest\n",
           n_list, N);
    CHECK(listed_same && unlisted_kept && unlisted_still);
    /* A masked group is not stepped, and its gradient is dropped with the others. */
    fill(&g, 40, 1e-3);
    listed_gradient(&g1, &g, list, n_list);
    float before = p1.opacities[list[3]];
    gv_splat_adam_step(&a1, &p1, &g1, list, n_list, 1, 16,
                       GV_ADAM_ALL_GROUPS & ~(1u << GV_ADAM_OPACITY));
    CHECK(all_zero(&g1) && p1.opacities[list[3]] == before && a1.step[GV_ADAM_OPACITY] == 3);
    gv_splat_adam_free(&a1), gv_splat_adam_free(&a2), gv_splat_adam_free(&a3);
    for (int k = 0; k < 7; k++) gv_gaussians_free(all_sets[k]);
}

int main(void)
{
    test_schedule();
    test_steps_against_reference();
    test_rows_groups_coefficients();
    test_listed_rows_many();
    return check_summary();
}
