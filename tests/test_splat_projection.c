/* Projection of 3D Gaussians: hand-computed cases, culling, the Jacobian clamp, agreement
 * with the double-precision reference, and gradients with respect to means, log-scales
 * and quaternions against central finite differences of the reference. */
#include <omp.h>
#include <string.h>

#include "splat_fixtures.h"

/* Camera at the origin looking down +z: 40x24, fx = fy = 20, principal point (20, 12). */
static void identity_view(gv_splat_view *v)
{
    double R[9] = {1, 0, 0, 0, 1, 0, 0, 0, 1}, t[3] = {0, 0, 0};
    CHECK(gv_splat_view_init(v, 40, 24, 20, 20, 20, 12, R, t) == 0);
}

/* Projects one Gaussian with the float kernel. */
static int project1(const gv_splat_view *v, const float mean[3], const float log_scale[3],
                    const float quat[4], float m2[2], float conic[3], float *depth)
{
    int radius;
    gv_splat_project_forward(1, mean, log_scale, quat, v, m2, conic, depth, &radius);
    return radius;
}

/* The 3DGS radius: ceil(3 sqrt(lambda_max)) with lambda = mid + sqrt(max(0.1, mid^2 - det)). */
static int hand_radius(double a, double b, double c)
{
    double mid = 0.5 * (a + c), det = a * c - b * b;
    return (int)ceil(3 * sqrt(mid + sqrt(fmax(0.1, mid * mid - det))));
}

static void test_hand_isotropic(void)
{
    gv_splat_view v;
    identity_view(&v);
    /* Sigma = 0.5^2 I at z = 5; J = diag(fx/z, fy/z) = diag(4, 4) (the third column is
     * -f x/z^2 = 0 on the axis), so Sigma2D = 16 * 0.25 I + 0.3 I = 4.3 I; conic = I / 4.3;
     * mean2d = (cx, cy); mid = 4.3, mid^2 - det = 0 -> 0.1: radius = ceil(3 sqrt(4.3 +
     * sqrt(0.1))) = ceil(6.4455) = 7. The quaternion (2, 0, 0, 0) normalises to identity. */
    float mean[3] = {0, 0, 5}, ls[3], q[4] = {2, 0, 0, 0}, m2[2], conic[3], depth;
    for (int j = 0; j < 3; j++) ls[j] = logf(0.5f);
    int r = project1(&v, mean, ls, q, m2, conic, &depth);
    CHECK(r == 7);
    CHECK(hand_radius(4.3, 0, 4.3) == 7);
    CHECK_NEAR(m2[0], 20, 1e-5);
    CHECK_NEAR(m2[1], 12, 1e-5);
    CHECK_NEAR(conic[0], 1 / 4.3, 1e-6);
    CHECK_NEAR(conic[1], 0, 1e-7);
    CHECK_NEAR(conic[2], 1 / 4.3, 1e-6);
    CHECK_NEAR(depth, 5, 1e-6);
}

static void test_hand_rotated(void)
{
    gv_splat_view v;
    identity_view(&v);
    /* q = (cos 45, 0, 0, sin 45): 90 degrees about z, R = [[0,-1,0],[1,0,0],[0,0,1]], so
     * Sigma = R diag(0.2^2, 0.1^2, 0.3^2) R^T = diag(0.01, 0.04, 0.09). Mean (1, -0.5, 4):
     * x/z = 0.25, y/z = -0.125 (inside the clamp), J = [[5, 0, -20*1/16], [0, 5,
     * -20*(-0.5)/16]] = [[5, 0, -1.25], [0, 5, 0.625]].
     * a = 25*0.01 + 1.25^2*0.09 + 0.3, b = -1.25*0.625*0.09, c = 25*0.04 + 0.625^2*0.09 + 0.3;
     * mean2d = (20*0.25 + 20, 20*(-0.125) + 12) = (25, 9.5). */
    float h = (float)sqrt(0.5);
    float mean[3] = {1, -0.5f, 4}, ls[3] = {logf(0.2f), logf(0.1f), logf(0.3f)};
    float q[4] = {h, 0, 0, h}, m2[2], conic[3], depth;
    int r = project1(&v, mean, ls, q, m2, conic, &depth);
    double a = 25 * 0.01 + 1.25 * 1.25 * 0.09 + 0.3, b = -1.25 * 0.625 * 0.09;
    double c = 25 * 0.04 + 0.625 * 0.625 * 0.09 + 0.3, det = a * c - b * b;
    CHECK(r == hand_radius(a, b, c));
    CHECK(r == 4); /* mid = 1.013, sqrt(mid^2 - det) = 0.332: ceil(3 sqrt(1.345)) */
    CHECK_NEAR(m2[0], 25, 1e-5);
    CHECK_NEAR(m2[1], 9.5, 1e-5);
    CHECK_NEAR(conic[0], c / det, 1e-5);
    CHECK_NEAR(conic[1], -b / det, 1e-5);
    CHECK_NEAR(conic[2], a / det, 1e-5);
}

static void test_culling(void)
{
    gv_splat_view v;
    identity_view(&v);
    float ls[3], q[4] = {1, 0, 0, 0}, m2[2] = {7, 7}, conic[3] = {7, 7, 7}, depth = 7;
    for (int j = 0; j < 3; j++) ls[j] = logf(0.01f);
    struct { float mean[3]; int visible; const char *what; } cases[] = {
        {{0, 0, -5}, 0, "behind the camera"},
        {{0, 0, 0.15f}, 0, "in front but nearer than 0.2"},
        {{0, 0, 0.199f}, 0, "just inside the near limit"},
        {{0, 0, 0.25f}, 1, "just beyond the near limit"},
        {{100, 0, 5}, 0, "far right of the image"},
        {{0, -50, 5}, 0, "far above the image"},
        /* mean2d x = 20 * (-2.2) + 20 = -24, radius 3: tiles end before x = 0 */
        {{-2.2f, 0, 1}, 0, "left of the image by 24 px"},
        /* mean2d x = -3 (pixel-index -3.5), radius 3: getRect's max is trunc((-3.5 + 3 + 15)
         * / 16) = 0, an empty rectangle, although the 3-sigma disc touches pixel 0 */
        {{-1.15f, 0, 1}, 0, "left of the image by 3 px"},
        /* mean2d x = -1 (pixel-index -1.5): trunc((-1.5 + 3 + 15) / 16) = 1, tile 0 */
        {{-1.05f, 0, 1}, 1, "left of the image by 1 px"},
        {{NAN, 0, 5}, 0, "not finite"},
    };
    for (size_t k = 0; k < sizeof cases / sizeof cases[0]; k++) {
        int r = project1(&v, cases[k].mean, ls, q, m2, conic, &depth);
        if ((r > 0) != cases[k].visible)
            fprintf(stderr, "culling case '%s': radius %d\n", cases[k].what, r);
        CHECK((r > 0) == cases[k].visible);
        if (r == 0) CHECK(m2[0] == 0 && m2[1] == 0 && conic[0] == 0 && depth == 0);
    }
}

static void test_jacobian_clamp(void)
{
    gv_splat_view v;
    identity_view(&v);
    /* Mean (10, 0, 5): x/z = 2 beyond lim_x_pos = (40 - 20)/20 + 0.3 * 40/(2*20) = 1.3, so
     * J uses x = 1.3 z: J = [[4, 0, -4 * 1.3], [0, 4, 0]]. With Sigma = 9 I:
     * a = 9 * 16 * (1 + 1.3^2) + 0.3, b = 0, c = 9 * 16 + 0.3. mean2d x = 20*2 + 20 = 60, far
     * right of the 40-pixel image, but the radius (60) reaches back into it. */
    CHECK_NEAR(v.lim_x_pos, 1.3, 1e-6);
    CHECK_NEAR(v.lim_x_neg, 1.3, 1e-6);
    CHECK_NEAR(v.lim_y_pos, 12.0 / 20 + 0.3 * 24 / 40, 1e-6);
    float mean[3] = {10, 0, 5}, ls[3], q[4] = {1, 0, 0, 0}, m2[2], conic[3], depth;
    for (int j = 0; j < 3; j++) ls[j] = logf(3.0f);
    int r = project1(&v, mean, ls, q, m2, conic, &depth);
    double a = 9 * 16 * (1 + 1.3 * 1.3) + 0.3, c = 9 * 16 + 0.3;
    CHECK(r == hand_radius(a, 0, c) && r > 0);
    CHECK_NEAR(m2[0], 60, 1e-4);
    CHECK_NEAR(conic[0], 1 / a, 1e-7);
    CHECK_NEAR(conic[2], 1 / c, 1e-7);

    /* Clamped, J no longer depends on the camera x of the mean: the 3DGS zeroing of that
     * gradient is then exact, and the conic's x-derivative matches finite differences. */
    double dm[3] = {10, 0, 5}, dls[3], dq[4] = {1, 0, 0, 0};
    for (int j = 0; j < 3; j++) dls[j] = log(3.0);
    double num = 0, hstep = 1e-4;
    gv_splat_ref_projection p;
    dm[0] = 10 + hstep;
    gv_splat_reference_project(dm, dls, dq, &v, &p);
    num += p.conic[0] + p.conic[2];
    dm[0] = 10 - hstep;
    gv_splat_reference_project(dm, dls, dq, &v, &p);
    num -= p.conic[0] + p.conic[2];
    num /= 2 * hstep;
    float dmean2d[2] = {0, 0}, dconic[3] = {1, 0, 1}, gmean[3], gscale[3], grot[4];
    int list[1] = {0};
    gv_splat_project_backward(1, list, mean, ls, q, &v, dmean2d, dconic, gmean, gscale, grot);
    CHECK(p.clamp_x == 1);
    CHECK_NEAR(gmean[0], num, 1e-9);
    CHECK(gmean[0] == 0);
}

static void test_reference_agreement(void)
{
    gv_splat_view v;
    fix_view(&v, 40, 24, 11);
    gv_gaussians g;
    enum { N = 300 };
    fix_gaussians(&g, N, 0, &v, 12);
    float m2[2 * N], conic[3 * N], depth[N];
    int radii[N];
    gv_splat_project_forward(N, g.means, g.scales, g.rotations, &v, m2, conic, depth, radii);
    int visible = 0, same_radius = 0;
    double worst_mean = 0, worst_conic = 0;
    for (int i = 0; i < N; i++) {
        double dm[3], dls[3], dq[4];
        for (int j = 0; j < 3; j++) dm[j] = g.means[3 * i + j], dls[j] = g.scales[3 * i + j];
        for (int j = 0; j < 4; j++) dq[j] = g.rotations[4 * i + j];
        gv_splat_ref_projection p;
        int vis = gv_splat_reference_project(dm, dls, dq, &v, &p);
        same_radius += (vis ? p.radius : 0) == radii[i];
        if (!vis || !radii[i]) continue;
        visible++;
        for (int j = 0; j < 2; j++)
            worst_mean = fmax(worst_mean, fabs(p.mean2d[j] - m2[2 * i + j]));
        for (int j = 0; j < 3; j++)
            worst_conic = fmax(worst_conic, fabs(p.conic[j] - conic[3 * i + j]) /
                                                (fabs(p.conic[0]) + fabs(p.conic[2])));
    }
    printf("  projection vs reference: %d/%d radii equal, %d visible, max |mean2d diff| %.2e px, "
           "max conic rel diff %.2e\n", same_radius, N, visible, worst_mean, worst_conic);
    CHECK(same_radius == N);
    CHECK(visible > N / 2);
    CHECK(worst_mean < 1e-4);
    CHECK(worst_conic < 1e-5);
    gv_gaussians_free(&g);
}

/* Gaussians all around the view, most of them outside, of 0.5 to 60 pixels: culling (and
 * the early off-screen test in front of it) agrees with the reference Gaussian by
 * Gaussian. */
/* n Gaussians around view v (seeds `seed` and seed + 1), most of them off-screen and every
 * seventh behind the camera, of 0.5 to 60 pixels. */
static void gaussians_around_view(gv_gaussians *g, int n, const gv_splat_view *v, uint64_t seed)
{
    fix_gaussians(g, n, 0, v, seed);
    gv_rng r;
    gv_rng_init(&r, seed + 1);
    for (int i = 0; i < n; i++) {
        double u = -120 + 280 * gv_rng_uniform(&r), w = -70 + 170 * gv_rng_uniform(&r);
        double z = (i % 7 == 0 ? -2 : 0.3) + 8 * gv_rng_uniform(&r);
        fix_unproject(v, u, w, z, g->means + 3 * i);
        double sigma_px = 0.5 * exp(log(120.0) * gv_rng_uniform(&r));
        for (int j = 0; j < 3; j++)
            g->scales[3 * i + j] =
                (float)log(sigma_px * fabs(z) / v->fx * (0.3 + gv_rng_uniform(&r)));
    }
}

static void test_culling_agrees_with_reference(void)
{
    gv_splat_view v;
    fix_view(&v, 40, 24, 13);
    enum { N = 4000 };
    gv_gaussians g;
    gaussians_around_view(&g, N, &v, 14);
    static float m2[2 * N], conic[3 * N], depth[N];
    static int radii[N];
    gv_splat_project_forward(N, g.means, g.scales, g.rotations, &v, m2, conic, depth, radii);
    int visible = 0, agree = 0;
    for (int i = 0; i < N; i++) {
        double dm[3], dls[3], dq[4];
        for (int j = 0; j < 3; j++) dm[j] = g.means[3 * i + j], dls[j] = g.scales[3 * i + j];
        for (int j = 0; j < 4; j++) dq[j] = g.rotations[4 * i + j];
        gv_splat_ref_projection p;
        int vis = gv_splat_reference_project(dm, dls, dq, &v, &p);
        visible += vis;
        agree += vis == (radii[i] > 0) && (!vis || p.radius == radii[i]);
    }
    printf("  culling of %d Gaussians around the view: %d visible, %d agree with the reference\n",
           N, visible, agree);
    CHECK(visible > N / 10 && visible < N / 2);
    CHECK(agree == N);
    gv_gaussians_free(&g);
}

/* The forward runs eight Gaussians at a time in chunks of 256, repeating the last Gaussian
 * of a short group to fill the lanes: each Gaussian's outputs must be the same bits whatever
 * its neighbours, the slice it is projected in and the thread count. Mixed on- and
 * off-screen Gaussians, some behind the camera, some with non-finite parameters. */
static void test_lanes_independent(void)
{
    gv_splat_view v;
    fix_view(&v, 40, 24, 31);
    enum { N = 1037 };
    gv_gaussians g;
    gaussians_around_view(&g, N, &v, 32);
    g.means[3 * 7 + 2] = NAN, g.scales[3 * 100] = INFINITY, g.rotations[4 * 300] = NAN;
    for (int j = 0; j < 3; j++) g.scales[3 * 501 + j] = 12; /* 10^6 pixels: the radius cap */
    static float m2[2 * N], conic[3 * N], depth[N], m2_b[2 * N], conic_b[3 * N], depth_b[N];
    static int radii[N], radii_b[N];
    gv_splat_project_forward(N, g.means, g.scales, g.rotations, &v, m2, conic, depth, radii);
    /* one at a time, then in slices of 13 (never a whole group of eight at the end) */
    for (int step = 1; step <= 13; step += 12)
        for (int lo = 0; lo < N; lo += step) {
            int n = lo + step <= N ? step : N - lo;
            gv_splat_project_forward(n, g.means + 3 * lo, g.scales + 3 * lo,
                                     g.rotations + 4 * lo, &v, m2_b + 2 * lo, conic_b + 3 * lo,
                                     depth_b + lo, radii_b + lo);
            CHECK(memcmp(m2_b + 2 * lo, m2 + 2 * lo, sizeof(float) * 2 * n) == 0);
            CHECK(memcmp(conic_b + 3 * lo, conic + 3 * lo, sizeof(float) * 3 * n) == 0);
            CHECK(memcmp(depth_b + lo, depth + lo, sizeof(float) * n) == 0);
            CHECK(memcmp(radii_b + lo, radii + lo, sizeof(int) * n) == 0);
        }
    int threads = omp_get_max_threads();
    omp_set_num_threads(3);
    gv_splat_project_forward(N, g.means, g.scales, g.rotations, &v, m2_b, conic_b, depth_b,
                             radii_b);
    omp_set_num_threads(threads);
    CHECK(memcmp(radii_b, radii, sizeof radii) == 0 && memcmp(conic_b, conic, sizeof conic) == 0);
    int visible = 0;
    for (int i = 0; i < N; i++) visible += radii[i] > 0;
    printf("  %d Gaussians alone, in slices of 13 and on 3 threads: the same bits (%d visible)\n",
           N, visible);
    CHECK(visible > N / 10 && visible < N / 2);
    CHECK(radii[7] == 0 && radii[100] == 0 && radii[300] == 0);
    CHECK(radii[501] == GV_SPLAT_MAX_RADIUS);
    gv_gaussians_free(&g);
}

/* L = w_mean . mean2d + w_conic . conic of one Gaussian through the reference. */
typedef struct {
    const gv_splat_view *view;
    double mean[3], scale[3], quat[4], w[5];
} projection_fd;

static double projection_loss(void *ctx, uint64_t *signature)
{
    projection_fd *c = ctx;
    gv_splat_ref_projection p;
    int vis = gv_splat_reference_project(c->mean, c->scale, c->quat, c->view, &p);
    *signature = (uint64_t)vis | (uint64_t)p.radius << 1 | (uint64_t)p.clamp_x << 40 |
                 (uint64_t)p.clamp_y << 41;
    return c->w[0] * p.mean2d[0] + c->w[1] * p.mean2d[1] + c->w[2] * p.conic[0] +
           c->w[3] * p.conic[1] + c->w[4] * p.conic[2];
}

static fix_compare cmp_mean = {"means", 0, 0, {0}, {0}};
static fix_compare cmp_scale = {"log-scales", 0, 0, {0}, {0}};
static fix_compare cmp_quat = {"quaternions", 0, 0, {0}, {0}};

static void test_gradients(void)
{
    gv_splat_view v;
    fix_view(&v, 40, 24, 21);
    enum { N = 60 };
    gv_gaussians g;
    fix_gaussians(&g, N, 0, &v, 22);
    float m2[2 * N], conic[3 * N], depth[N], dm2[2 * N], dconic[3 * N];
    float gmean[3 * N], gscale[3 * N], grot[4 * N];
    int radii[N], list[N], n_list = 0;
    gv_splat_project_forward(N, g.means, g.scales, g.rotations, &v, m2, conic, depth, radii);
    gv_rng r;
    gv_rng_init(&r, 23);
    for (int i = 0; i < N; i++) {
        for (int j = 0; j < 2; j++) dm2[2 * i + j] = (float)(2 * gv_rng_uniform(&r) - 1);
        /* conic entries are ~1/sigma^2: weigh them up so both paths matter */
        for (int j = 0; j < 3; j++) dconic[3 * i + j] = (float)(20 * (2 * gv_rng_uniform(&r) - 1));
        if (radii[i] > 0) list[n_list++] = i;
    }
    gv_splat_project_backward(n_list, list, g.means, g.scales, g.rotations, &v, dm2, dconic,
                              gmean, gscale, grot);
    int clamped = 0;
    for (int k = 0; k < n_list; k++) {
        int i = list[k];
        projection_fd c = {&v, {0}, {0}, {0}, {0}};
        for (int j = 0; j < 3; j++)
            c.mean[j] = g.means[3 * i + j], c.scale[j] = g.scales[3 * i + j];
        for (int j = 0; j < 4; j++) c.quat[j] = g.rotations[4 * i + j];
        for (int j = 0; j < 2; j++) c.w[j] = dm2[2 * i + j];
        for (int j = 0; j < 3; j++) c.w[2 + j] = dconic[3 * i + j];
        gv_splat_ref_projection p;
        gv_splat_reference_project(c.mean, c.scale, c.quat, &v, &p);
        if (p.clamp_x || p.clamp_y) { /* 3DGS's clamped gradient is not the derivative */
            clamped++;
            continue;
        }
        uint64_t s0;
        projection_loss(&c, &s0);
        fix_add_params(&cmp_mean, projection_loss, &c, s0, c.mean, gmean + 3 * i, 3, 1e-6);
        fix_add_params(&cmp_scale, projection_loss, &c, s0, c.scale, gscale + 3 * i, 3, 1e-6);
        fix_add_params(&cmp_quat, projection_loss, &c, s0, c.quat, grot + 4 * i, 4, 1e-6);
    }
    printf("  projection gradients: %d visible Gaussians (%d with a clamped Jacobian left out)\n",
           n_list, clamped);
    fix_report(&cmp_mean, 2e-3);
    fix_report(&cmp_scale, 2e-3);
    fix_report(&cmp_quat, 2e-3);
    gv_gaussians_free(&g);
}

int main(void)
{
    test_hand_isotropic();
    test_hand_rotated();
    test_culling();
    test_jacobian_clamp();
    test_reference_agreement();
    test_culling_agrees_with_reference();
    test_lanes_independent();
    test_gradients();
    return check_summary();
}
