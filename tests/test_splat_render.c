/* The whole renderer (projection, binning, SH, rasterisation) from raw parameters:
 * hand-built scenes of one and two Gaussians computed from the formulas, agreement with the
 * double reference, gradients with respect to every raw parameter against central finite
 * differences, the densification statistic, untouched rows of culled Gaussians, thread
 * independence, reuse of the renderer, and bad calls. */
#include <omp.h>

#include "gaussvid/splat/render.h"
#include "splat_fixtures.h"

/* Camera at the origin looking down +z: 40x24, fx = fy = 20, principal point (20, 12). */
static void identity_view(gv_splat_view *v)
{
    double R[9] = {1, 0, 0, 0, 1, 0, 0, 0, 1}, t[3] = {0, 0, 0};
    CHECK(gv_splat_view_init(v, 40, 24, 20, 20, 20, 12, R, t) == 0);
}

static void set_gaussian(gv_gaussians *g, int i, float x, float y, float z, float scale,
                         float opacity_logit, const float sh0[3])
{
    int K = gv_sh_coefficient_count(g->sh_degree);
    g->means[3 * i] = x, g->means[3 * i + 1] = y, g->means[3 * i + 2] = z;
    for (int j = 0; j < 3; j++) g->scales[3 * i + j] = logf(scale);
    g->rotations[4 * i] = 1;
    g->rotations[4 * i + 1] = g->rotations[4 * i + 2] = g->rotations[4 * i + 3] = 0;
    g->opacities[i] = opacity_logit;
    for (int c = 0; c < 3; c++) g->sh[(size_t)i * K * 3 + c] = sh0[c];
}

/* alpha of the reference at squared pixel distance d2 from a Gaussian with isotropic 2D
 * variance var (after dilation): o exp(-d2 / (2 var)), clamped at 0.99, 0 below 1/255. */
static double hand_alpha(double o, double dx, double dy, double var_x, double var_y)
{
    double a = o * exp(-0.5 * (dx * dx / var_x + dy * dy / var_y));
    a = fmin(a, 0.99);
    return a < 1.0 / 255 ? 0 : a;
}

static void test_hand_scenes(void)
{
    gv_splat_view v;
    identity_view(&v);
    float bg[3] = {0.1f, 0.2f, 0.3f};
    static float image[40 * 24 * 3];
    gv_splat_renderer r = {0};
    gv_gaussians g;
    CHECK(gv_gaussians_alloc(&g, 2, 1) == 0);

    /* One Gaussian at (0, 0, 5), scale 0.5, opacity sigmoid(0) = 0.5, degree 0 colour
     * C0 sh0 + 0.5. On the axis J = diag(20/5) so Sigma2D = 16 * 0.25 + 0.3 = 4.3 in x and y;
     * mean2d = (20, 12). Pixel (i, j) has centre (i + 0.5, j + 0.5): dx = 20 - i - 0.5,
     * dy = 12 - j - 0.5, alpha = 0.5 exp(-(dx^2 + dy^2) / 8.6) (skipped below 1/255) and
     * pixel = alpha c + (1 - alpha) bg. Radius 7: tile columns 0-1, i.e. pixels x < 32 (the
     * Gaussian is negligible there anyway). */
    float sh0[3] = {1, 0, -0.5f};
    set_gaussian(&g, 0, 0, 0, 5, 0.5f, 0, sh0);
    g.n = 1;
    CHECK(gv_splat_render_forward(&r, &g, &v, 0, bg, image) == 0);
    CHECK(r.radii[0] == 7 && r.tiles.n_visible == 1);
    double worst = 0;
    for (int j = 0; j < 24; j++)
        for (int i = 0; i < 40; i++) {
            double a = i < 32 ? hand_alpha(0.5, 20 - i - 0.5, 12 - j - 0.5, 4.3, 4.3) : 0;
            for (int c = 0; c < 3; c++) {
                double col = fmax(FIX_C0 * sh0[c] + 0.5, 0);
                double want = a * col + (1 - a) * bg[c];
                worst = fmax(worst, fabs(image[(j * 40 + i) * 3 + c] - want));
            }
        }
    printf("  one Gaussian: max |render - hand| %.2e\n", worst);
    CHECK(worst < 2e-7);
    /* the brightest pixels are the four around (20, 12): d^2 = 0.5 */
    double a4 = 0.5 * exp(-0.5 / 8.6);
    CHECK_NEAR(image[(11 * 40 + 19) * 3], a4 * (FIX_C0 + 0.5) + (1 - a4) * 0.1, 1e-6);

    /* Two: a second Gaussian behind, at (0.4, 0, 8), scale 1, opacity sigmoid(1). Its
     * mean2d = (20 * 0.4/8 + 20, 12) = (21, 12); J = [[2.5, 0, -20 * 0.4/64], [0, 2.5, 0]],
     * Sigma = I: Sigma2D = (2.5^2 + 0.125^2 + 0.3, 0, 2.5^2 + 0.3). The front one blends
     * first: pixel = a1 c1 + (1 - a1) a2 c2 + (1 - a1)(1 - a2) bg. */
    float sh1[3] = {-1, 1, 0.5f};
    set_gaussian(&g, 1, 0.4f, 0, 8, 1, 1, sh1);
    g.n = 2;
    CHECK(gv_splat_render_forward(&r, &g, &v, 0, bg, image) == 0);
    double o2 = 1 / (1 + exp(-1.0)), var_x = 6.25 + 0.015625 + 0.3, var_y = 6.55;
    CHECK_NEAR(r.conics[3], 1 / var_x, 1e-6);
    CHECK_NEAR(r.conics[5], 1 / var_y, 1e-6);
    double half_gap2 = 0.25 * (var_x - var_y) * (var_x - var_y); /* mid^2 - det */
    int rad2 = (int)ceil(3 * sqrt(0.5 * (var_x + var_y) + sqrt(fmax(0.1, half_gap2))));
    CHECK(r.radii[1] == rad2);
    worst = 0;
    for (int j = 0; j < 24; j++)
        for (int i = 0; i < 40; i++) {
            double a1 = i < 32 ? hand_alpha(0.5, 20 - i - 0.5, 12 - j - 0.5, 4.3, 4.3) : 0;
            /* radius 8 from x = 21: tile columns 0-1 as well (trunc((20.5 + 8 + 15)/16) = 2) */
            double a2 = i < 32 ? hand_alpha(o2, 21 - i - 0.5, 12 - j - 0.5, var_x, var_y) : 0;
            for (int c = 0; c < 3; c++) {
                double c1 = fmax(FIX_C0 * sh0[c] + 0.5, 0), c2 = fmax(FIX_C0 * sh1[c] + 0.5, 0);
                double want = a1 * c1 + (1 - a1) * a2 * c2 + (1 - a1) * (1 - a2) * bg[c];
                worst = fmax(worst, fabs(image[(j * 40 + i) * 3 + c] - want));
            }
        }
    printf("  two Gaussians: max |render - hand| %.2e\n", worst);
    CHECK(rad2 == 8);
    CHECK(worst < 2e-7);
    gv_gaussians_free(&g);
    gv_splat_renderer_free(&r);
}

static double *to_double(const float *x, size_t count)
{
    double *d = malloc((count > 0 ? count : 1) * sizeof(double));
    for (size_t i = 0; i < count; i++) d[i] = x[i];
    return d;
}

/* The raw parameters in double, for the reference. */
typedef struct {
    int n, degree, active;
    double *means, *sh, *opacities, *scales, *rotations, *w, bg[3];
    const gv_splat_view *view;
    double *image;
} render_fd;

static void fd_init(render_fd *c, const gv_gaussians *g, int active, const gv_splat_view *v,
                    const float bg[3], const float *w)
{
    int K = gv_sh_coefficient_count(g->sh_degree);
    c->n = g->n, c->degree = g->sh_degree, c->active = active, c->view = v;
    c->means = to_double(g->means, 3 * (size_t)g->n);
    c->sh = to_double(g->sh, (size_t)g->n * K * 3);
    c->opacities = to_double(g->opacities, (size_t)g->n);
    c->scales = to_double(g->scales, 3 * (size_t)g->n);
    c->rotations = to_double(g->rotations, 4 * (size_t)g->n);
    c->w = w ? to_double(w, (size_t)v->width * v->height * 3) : NULL;
    c->image = malloc((size_t)v->width * v->height * 3 * sizeof(double));
    for (int k = 0; k < 3; k++) c->bg[k] = bg[k];
}

static void fd_free(render_fd *c)
{
    free(c->means), free(c->sh), free(c->opacities), free(c->scales), free(c->rotations);
    free(c->w), free(c->image);
}

static double render_loss(void *ctx, uint64_t *signature)
{
    render_fd *c = ctx;
    gv_splat_reference_render(c->n, c->degree, c->active, c->means, c->sh, c->opacities,
                              c->scales, c->rotations, c->view, c->bg, c->image, signature);
    double loss = 0;
    for (int i = 0; i < c->view->width * c->view->height * 3; i++) loss += c->w[i] * c->image[i];
    return loss;
}

static void test_reference_agreement(void)
{
    gv_splat_view v;
    fix_view(&v, 64, 48, 81);
    gv_gaussians g;
    fix_gaussians(&g, 250, 3, &v, 82);
    float bg[3] = {0.3f, 0.6f, 0.1f};
    static float image[64 * 48 * 3];
    gv_splat_renderer r = {0};
    for (int active = 0; active <= 3; active += 3) {
        CHECK(gv_splat_render_forward(&r, &g, &v, active, bg, image) == 0);
        render_fd c;
        fd_init(&c, &g, active, &v, bg, NULL);
        uint64_t sig;
        CHECK(gv_splat_reference_render(c.n, c.degree, active, c.means, c.sh, c.opacities, c.scales,
                                        c.rotations, &v, c.bg, c.image, &sig) == 0);
        double worst = 0;
        for (int i = 0; i < 64 * 48 * 3; i++) worst = fmax(worst, fabs(c.image[i] - image[i]));
        printf("  64x48, 250 Gaussians, SH degree %d: %d visible, max |render - reference| %.2e\n",
               active, r.tiles.n_visible, worst);
        CHECK(worst < 2e-5);
        fd_free(&c);
    }
    gv_gaussians_free(&g);
    gv_splat_renderer_free(&r);
}

static fix_compare cmp[5] = {{"means", 0, 0, {0}, {0}},
                             {"SH coefficients", 0, 0, {0}, {0}},
                             {"opacity logits", 0, 0, {0}, {0}},
                             {"log-scales", 0, 0, {0}, {0}},
                             {"raw quaternions", 0, 0, {0}, {0}}};

static void test_gradients(int n, int active, uint64_t seed)
{
    gv_splat_view v;
    fix_view(&v, 40, 24, seed);
    gv_gaussians g, grad;
    fix_gaussians(&g, n, 3, &v, seed + 1);
    CHECK(gv_gaussians_alloc(&grad, n, 3) == 0);
    float bg[3] = {0.25f, 0.5f, 0.75f};
    static float image[40 * 24 * 3], w[40 * 24 * 3];
    for (int i = 0; i < 40 * 24 * 3; i++)
        w[i] = (float)(2 * gv_uniform_at(seed + 2, (uint64_t)i) - 1);
    gv_splat_renderer r = {0};
    CHECK(gv_splat_render_forward(&r, &g, &v, active, bg, image) == 0);
    CHECK(gv_splat_render_backward(&r, &g, w, &grad, NULL) == 0);

    render_fd c;
    fd_init(&c, &g, active, &v, bg, w);
    uint64_t s0;
    render_loss(&c, &s0);
    int K = 16, clamped = 0;
    for (int k = 0; k < r.tiles.n_visible; k++) {
        int i = r.tiles.visible[k];
        gv_splat_ref_projection p;
        gv_splat_reference_project(c.means + 3 * i, c.scales + 3 * i, c.rotations + 4 * i, &v, &p);
        int skip_geometry = p.clamp_x || p.clamp_y; /* 3DGS's clamped gradient is approximate */
        clamped += skip_geometry;
        struct { double *param; const float *analytic; int count; } kinds[5] = {
            {c.means + 3 * i, grad.means + 3 * i, 3},
            {c.sh + (size_t)i * K * 3, grad.sh + (size_t)i * K * 3, K * 3},
            {c.opacities + i, grad.opacities + i, 1},
            {c.scales + 3 * i, grad.scales + 3 * i, 3},
            {c.rotations + 4 * i, grad.rotations + 4 * i, 4},
        };
        for (int kind = 0; kind < 5; kind++) {
            if (skip_geometry && kind != 1 && kind != 2) continue;
            for (int j = 0; j < kinds[kind].count; j++) {
                double num;
                if (kind == 1 && j >= (active + 1) * (active + 1) * 3) {
                    CHECK(kinds[kind].analytic[j] == 0); /* above the active degree */
                    continue;
                }
                if (fix_derivative(render_loss, &c, s0, kinds[kind].param + j, 1e-6, &num))
                    cmp[kind].skipped++;
                else
                    fix_add(&cmp[kind], kinds[kind].analytic[j], num);
            }
        }
    }
    int straddling = 0;
    for (int k = 0; k < r.tiles.n_visible; k++)
        straddling += r.tiles.gauss_offsets[k + 1] - r.tiles.gauss_offsets[k] > 1;
    printf("  %d Gaussians, SH degree %d: %d visible, %d across tile borders (%d with a clamped "
           "Jacobian: SH and opacity only)\n", n, active, r.tiles.n_visible, straddling, clamped);
    CHECK(r.tiles.n_visible > n / 2);
    CHECK(straddling > 0);
    fd_free(&c);
    gv_gaussians_free(&g);
    gv_gaussians_free(&grad);
    gv_splat_renderer_free(&r);
}

/* The statistic against finite differences of the reference rasteriser in means2d. */
static void test_densification_statistic(void)
{
    gv_splat_view v;
    fix_view(&v, 40, 24, 91);
    enum { N = 30 };
    gv_gaussians g, grad;
    fix_gaussians(&g, N, 1, &v, 92);
    CHECK(gv_gaussians_alloc(&grad, N, 1) == 0);
    float bg[3] = {0, 0, 0}, densify[N];
    static float image[40 * 24 * 3], w[40 * 24 * 3];
    static double ref[40 * 24 * 3];
    for (int i = 0; i < 40 * 24 * 3; i++) w[i] = (float)(2 * gv_uniform_at(93, (uint64_t)i) - 1);
    gv_splat_renderer r = {0};
    CHECK(gv_splat_render_forward(&r, &g, &v, 1, bg, image) == 0);
    CHECK(gv_splat_render_backward(&r, &g, w, &grad, densify) == 0);

    double m2[2 * N], con[3 * N], col[3 * N], op[N], dep[N], dbg[3] = {0, 0, 0};
    int radii[N];
    double campos[3] = {v.campos[0], v.campos[1], v.campos[2]};
    for (int i = 0; i < N; i++) {
        double mean[3], ls[3], q[4], sh[12];
        for (int j = 0; j < 3; j++) mean[j] = g.means[3 * i + j], ls[j] = g.scales[3 * i + j];
        for (int j = 0; j < 4; j++) q[j] = g.rotations[4 * i + j];
        for (int j = 0; j < 12; j++) sh[j] = g.sh[12 * i + j];
        gv_splat_ref_projection p;
        radii[i] = gv_splat_reference_project(mean, ls, q, &v, &p) ? p.radius : 0;
        m2[2 * i] = p.mean2d[0], m2[2 * i + 1] = p.mean2d[1], dep[i] = p.depth;
        for (int j = 0; j < 3; j++) con[3 * i + j] = p.conic[j];
        op[i] = 1 / (1 + exp(-(double)g.opacities[i]));
        if (radii[i]) gv_splat_reference_sh(1, 1, sh, mean, campos, col + 3 * i);
    }
    double worst = 0;
    int checked = 0;
    for (int i = 0; i < N; i++) {
        if (!radii[i]) continue;
        double gpix[2];
        for (int a = 0; a < 2; a++) {
            double x = m2[2 * i + a], h = 1e-5, lp = 0, lm = 0;
            m2[2 * i + a] = x + h;
            gv_splat_reference_rasterize(N, 40, 24, m2, con, col, op, dep, radii, dbg, ref, NULL);
            for (int k = 0; k < 40 * 24 * 3; k++) lp += w[k] * ref[k];
            m2[2 * i + a] = x - h;
            gv_splat_reference_rasterize(N, 40, 24, m2, con, col, op, dep, radii, dbg, ref, NULL);
            for (int k = 0; k < 40 * 24 * 3; k++) lm += w[k] * ref[k];
            m2[2 * i + a] = x;
            gpix[a] = (lp - lm) / (2 * h);
        }
        /* 3DGS: the norm of the NDC gradient = pixel gradient x (W/2, H/2) */
        double want = hypot(gpix[0] * 20, gpix[1] * 12);
        worst = fmax(worst, fabs(densify[i] - want) / fmax(want, 1e-3));
        checked++;
    }
    printf("  densification statistic: %d Gaussians, max relative error %.2e\n", checked, worst);
    CHECK(checked > N / 2);
    CHECK(worst < 1e-3);
    gv_gaussians_free(&g);
    gv_gaussians_free(&grad);
    gv_splat_renderer_free(&r);
}

/* Rows of culled Gaussians keep whatever the caller had there; results do not depend on the
 * thread count; a renderer reused for other sizes gives the same images. */
static void test_culled_rows_threads_and_reuse(void)
{
    gv_splat_view v;
    fix_view(&v, 50, 30, 101);
    enum { N = 120 };
    gv_gaussians g, grad1, grad2;
    fix_gaussians(&g, N, 2, &v, 102);
    /* a few behind the camera and a few far outside */
    for (int i = 0; i < N; i += 10) {
        float *m = g.means + 3 * i;
        fix_unproject(&v, i % 20 ? 400 : 25, 15, i % 20 ? 3 : -3, m);
    }
    CHECK(gv_gaussians_alloc(&grad1, N, 2) == 0 && gv_gaussians_alloc(&grad2, N, 2) == 0);
    for (int i = 0; i < N * 27; i++) grad1.sh[i] = grad2.sh[i] = 7;
    for (int i = 0; i < N * 3; i++) grad1.means[i] = grad2.means[i] = 7;
    for (int i = 0; i < N; i++) grad1.opacities[i] = grad2.opacities[i] = 7;
    float bg[3] = {1, 1, 1};
    static float img1[50 * 30 * 3], img2[50 * 30 * 3], img3[50 * 30 * 3], w[50 * 30 * 3];
    for (int i = 0; i < 50 * 30 * 3; i++) w[i] = (float)gv_uniform_at(103, (uint64_t)i) - 0.5f;
    gv_splat_renderer r = {0};
    omp_set_num_threads(1);
    CHECK(gv_splat_render_forward(&r, &g, &v, 2, bg, img1) == 0);
    CHECK(gv_splat_render_backward(&r, &g, w, &grad1, NULL) == 0);
    int culled_ok = 1, n_culled = 0;
    for (int i = 0; i < N; i++) {
        if (r.radii[i] > 0) continue;
        n_culled++;
        culled_ok &= grad1.means[3 * i] == 7 && grad1.opacities[i] == 7;
        culled_ok &= grad1.sh[27 * i + 5] == 7;
    }
    CHECK(n_culled >= N / 10);
    CHECK(culled_ok);

    omp_set_num_threads(2);
    /* reuse: a smaller image and fewer Gaussians in between */
    gv_splat_view small;
    fix_view(&small, 20, 10, 104);
    g.n = 30;
    CHECK(gv_splat_render_forward(&r, &g, &small, 1, bg, img3) == 0);
    g.n = N;
    CHECK(gv_splat_render_forward(&r, &g, &v, 2, bg, img2) == 0);
    CHECK(gv_splat_render_backward(&r, &g, w, &grad2, NULL) == 0);
    CHECK(memcmp(img1, img2, sizeof img1) == 0);
    CHECK(memcmp(grad1.means, grad2.means, N * 3 * sizeof(float)) == 0);
    CHECK(memcmp(grad1.sh, grad2.sh, N * 27 * sizeof(float)) == 0);
    CHECK(memcmp(grad1.opacities, grad2.opacities, N * sizeof(float)) == 0);
    CHECK(memcmp(grad1.scales, grad2.scales, N * 3 * sizeof(float)) == 0);
    CHECK(memcmp(grad1.rotations, grad2.rotations, N * 4 * sizeof(float)) == 0);

    /* no Gaussians: the background */
    g.n = 0;
    CHECK(gv_splat_render_forward(&r, &g, &v, 0, bg, img3) == 0);
    int all_bg = 1;
    for (int i = 0; i < 50 * 30 * 3; i++) all_bg &= img3[i] == 1;
    CHECK(all_bg);
    CHECK(gv_splat_render_backward(&r, &g, w, &grad2, NULL) == 0);
    g.n = N;
    gv_gaussians_free(&g);
    gv_gaussians_free(&grad1);
    gv_gaussians_free(&grad2);
    gv_splat_renderer_free(&r);
}

static void test_bad_calls(void)
{
    gv_splat_view v;
    identity_view(&v);
    gv_gaussians g, grad;
    CHECK(gv_gaussians_alloc(&g, 3, 1) == 0 && gv_gaussians_alloc(&grad, 3, 2) == 0);
    static float image[40 * 24 * 3], w[40 * 24 * 3];
    float bg[3] = {0, 0, 0};
    gv_splat_renderer r = {0};
    CHECK_FAILS_WITH(gv_splat_render_forward(&r, &g, &v, 2, bg, image), "active SH degree 2");
    CHECK_FAILS_WITH(gv_splat_render_forward(&r, &g, &v, -1, bg, image), "active SH degree");
    CHECK(gv_splat_render_forward(&r, &g, &v, 1, bg, image) == 0);
    CHECK_FAILS_WITH(gv_splat_render_backward(&r, &g, w, &grad, NULL), "gradient holds");
    g.n = 2;
    CHECK_FAILS_WITH(gv_splat_render_backward(&r, &g, w, &grad, NULL), "backward of 2");
    double R[9] = {1, 0, 0, 0, 1, 0, 0, 0, 1}, t[3] = {0, 0, 0};
    gv_splat_view bad;
    CHECK_FAILS_WITH(gv_splat_view_init(&bad, 0, 24, 20, 20, 20, 12, R, t), "bad image size");
    CHECK_FAILS_WITH(gv_splat_view_init(&bad, 40, 24, -20, 20, 20, 12, R, t), "bad intrinsics");
    t[1] = NAN;
    CHECK_FAILS_WITH(gv_splat_view_init(&bad, 40, 24, 20, 20, 20, 12, R, t), "non-finite");
    gv_gaussians_free(&g);
    gv_gaussians_free(&grad);
    gv_splat_renderer_free(&r);
}

int main(void)
{
    test_hand_scenes();
    test_reference_agreement();
    test_gradients(16, 3, 111);
    test_gradients(12, 1, 121);
    for (int k = 0; k < 5; k++) fix_report(&cmp[k], 2e-3);
    test_densification_statistic();
    test_culled_rows_threads_and_reuse();
    test_bad_calls();
    return check_summary();
}
