/* Expected depth and accumulated opacity (src/splat/rasterize_depth.c): hand-built scenes of
 * one, two and six stacked Gaussians computed from the formulas, agreement with the double
 * reference rasteriser (blending (z, 1, 0) as a colour gives sum w z and sum w), exactly
 * the forward's T_final, thread independence, and empty pixels. */
#include <omp.h>

#include "gaussvid/splat/render.h"
#include "splat_fixtures.h"

enum { W = 40, H = 24 };

/* Camera at the origin looking down +z: 40x24, fx = fy = 20, principal point (20, 12). */
static void identity_view(gv_splat_view *v)
{
    double R[9] = {1, 0, 0, 0, 1, 0, 0, 0, 1}, t[3] = {0, 0, 0};
    CHECK(gv_splat_view_init(v, W, H, 20, 20, 20, 12, R, t) == 0);
}

/* An isotropic Gaussian of world scale s on the optical axis at depth z: its 2D variance
 * is (20 s / z)^2 + 0.3 in x and y (J = diag(20 / z) there), its mean2d (20, 12). */
static void set_on_axis(gv_gaussians *g, int i, float z, float scale, float opacity_logit)
{
    g->means[3 * i] = 0, g->means[3 * i + 1] = 0, g->means[3 * i + 2] = z;
    for (int j = 0; j < 3; j++) g->scales[3 * i + j] = logf(scale);
    g->rotations[4 * i] = 1;
    g->rotations[4 * i + 1] = g->rotations[4 * i + 2] = g->rotations[4 * i + 3] = 0;
    g->opacities[i] = opacity_logit;
}

/* The reference's alpha of a Gaussian at mean2d (20, 12) with isotropic variance var at
 * pixel (i, j): o exp(-d^2 / (2 var)), clamped at 0.99, 0 below 1/255. */
static double hand_alpha(double o, int i, int j, double var)
{
    double dx = 20 - (i + 0.5), dy = 12 - (j + 0.5);
    double a = fmin(o * exp(-0.5 * (dx * dx + dy * dy) / var), 0.99);
    return a < 1.0 / 255 ? 0 : a;
}

static double sigmoid(double x)
{
    return 1 / (1 + exp(-x));
}

/* Hand blending of stacked on-axis Gaussians (front to back, with the early stop) at every
 * pixel, compared with the renderer's depth and opacity. Radii stay inside the first two
 * tile columns (pixels x < 32), where the hand formula holds; beyond, nothing blends. */
static void check_stack(gv_splat_renderer *r, int n, const double *z, const double *o,
                        const double *var, const char *what)
{
    static float depth[W * H], opacity[W * H];
    CHECK(gv_splat_render_depth(r, depth, opacity) == 0);
    double worst_d = 0, worst_o = 0;
    int blended_max = 0;
    for (int j = 0; j < H; j++)
        for (int i = 0; i < W; i++) {
            double T = 1, sw = 0, swz = 0;
            int blended = 0;
            for (int k = 0; k < n && i < 32; k++) {
                double a = hand_alpha(o[k], i, j, var[k]);
                if (a == 0) continue;
                if (T * (1 - a) < 1e-4) break;
                sw += a * T, swz += a * T * z[k], T *= 1 - a, blended++;
            }
            if (blended > blended_max) blended_max = blended;
            double want_d = sw > 0 ? swz / sw : 0;
            worst_d = fmax(worst_d, fabs(depth[j * W + i] - want_d) / fmax(want_d, 1));
            worst_o = fmax(worst_o, fabs(opacity[j * W + i] - (1 - T)));
            if (sw == 0) CHECK(depth[j * W + i] == 0 && opacity[j * W + i] == 0);
        }
    printf("  %s: at most %d blended per pixel, max relative |depth - hand| %.2e, "
           "max |opacity - hand| %.2e\n", what, blended_max, worst_d, worst_o);
    CHECK(worst_d < 1e-6);
    CHECK(worst_o < 1e-6);
}

static void test_hand_scenes(void)
{
    gv_splat_view v;
    identity_view(&v);
    float bg[3] = {0, 0, 0};
    static float image[W * H * 3], depth[W * H], opacity[W * H];
    gv_splat_renderer r = {0};
    gv_gaussians g;
    CHECK(gv_gaussians_alloc(&g, 6, 0) == 0);

    /* One Gaussian at depth 5, scale 0.5: variance 2^2 + 0.3; opacity sigmoid(0) = 0.5.
     * Wherever it blends the depth is 5 and the opacity its alpha. */
    set_on_axis(&g, 0, 5, 0.5f, 0);
    g.n = 1;
    CHECK(gv_splat_render_forward(&r, &g, &v, 0, bg, image) == 0);
    double z1[1] = {5}, o1[1] = {0.5}, v1[1] = {4.3};
    check_stack(&r, 1, z1, o1, v1, "one Gaussian at depth 5");
    CHECK(gv_splat_render_depth(&r, depth, opacity) == 0);
    /* the four pixels around (20, 12) have d^2 = 0.5 */
    CHECK_NEAR(depth[11 * W + 19], 5, 1e-6);
    CHECK_NEAR(opacity[11 * W + 19], 0.5 * exp(-0.5 / 8.6), 1e-7);
    CHECK(depth[0] == 0 && opacity[0] == 0); /* corner: alpha below 1/255 */

    /* Two: in front at depth 4 (scale 0.4, opacity sigmoid(1)), behind at depth 8 (scale
     * 0.8, opacity sigmoid(2)), both of variance 4.3: depth = (4 a1 + 8 (1 - a1) a2) /
     * (a1 + (1 - a1) a2), opacity a1 + (1 - a1) a2. */
    set_on_axis(&g, 0, 8, 0.8f, 2);  /* index order is not depth order */
    set_on_axis(&g, 1, 4, 0.4f, 1);
    g.n = 2;
    CHECK(gv_splat_render_forward(&r, &g, &v, 0, bg, image) == 0);
    double z2[2] = {4, 8}, o2[2] = {sigmoid(1), sigmoid(2)}, v2[2] = {4.3, 4.3};
    check_stack(&r, 2, z2, o2, v2, "two Gaussians at depths 4 and 8");
    CHECK(gv_splat_render_depth(&r, depth, opacity) == 0);
    double a1 = o2[0] * exp(-0.5 / 8.6), a2 = o2[1] * exp(-0.5 / 8.6);
    double want = (4 * a1 + 8 * (1 - a1) * a2) / (a1 + (1 - a1) * a2);
    printf("  centre pixel: depth %.7f (hand %.7f), opacity %.7f (hand %.7f)\n",
           depth[11 * W + 19], want, opacity[11 * W + 19], a1 + (1 - a1) * a2);
    CHECK_NEAR(depth[11 * W + 19], want, 2e-6);
    CHECK_NEAR(opacity[11 * W + 19], a1 + (1 - a1) * a2, 1e-7);

    /* Six stacked at depths 2..7, each opacity sigmoid(3) = 0.953 and variance 4.3: at the
     * centre pixels alpha = 0.896 each, T after k of them 0.104^k; the fifth would leave
     * T = 1.2e-5 < 1e-4, so four blend and the two farthest never count. */
    for (int k = 0; k < 6; k++) set_on_axis(&g, k, 2.0f + k, 0.1f * (2.0f + k), 3);
    g.n = 6;
    CHECK(gv_splat_render_forward(&r, &g, &v, 0, bg, image) == 0);
    double z6[6] = {2, 3, 4, 5, 6, 7}, o6[6], v6[6];
    for (int k = 0; k < 6; k++) o6[k] = sigmoid(3), v6[k] = 4.3;
    check_stack(&r, 6, z6, o6, v6, "six stacked, early stop");
    CHECK(r.n_contrib[11 * W + 19] == 4);
    gv_gaussians_free(&g);
    gv_splat_renderer_free(&r);
}

static double *to_double(const float *x, size_t count)
{
    double *d = malloc((count > 0 ? count : 1) * sizeof(double));
    for (size_t i = 0; i < count; i++) d[i] = x[i];
    return d;
}

/* Random scenes against the double reference: project every Gaussian with
 * gv_splat_reference_project, then rasterise with colour (z, 1, 0) over a black background,
 * which gives sum w z and sum w per pixel. Also: 1 - opacity is the forward's final_T bit
 * for bit, and 1 and 2 threads give the same bytes. */
static void test_reference_agreement(int width, int height, int n, uint64_t seed)
{
    gv_splat_view v;
    fix_view(&v, width, height, seed);
    gv_gaussians g;
    fix_gaussians(&g, n, 0, &v, seed + 1);
    size_t pixels = (size_t)width * height;
    float *image = malloc(pixels * 3 * sizeof(float)), *depth = malloc(pixels * sizeof(float));
    float *opacity = malloc(pixels * sizeof(float)), *depth2 = malloc(pixels * sizeof(float));
    float *opacity2 = malloc(pixels * sizeof(float));
    float bg[3] = {0.2f, 0.4f, 0.6f};
    gv_splat_renderer r = {0};
    CHECK(gv_splat_render_forward(&r, &g, &v, 0, bg, image) == 0);
    omp_set_num_threads(1);
    CHECK(gv_splat_render_depth(&r, depth, opacity) == 0);
    omp_set_num_threads(2);
    CHECK(gv_splat_render_depth(&r, depth2, opacity2) == 0);
    CHECK(memcmp(depth, depth2, pixels * sizeof(float)) == 0);
    CHECK(memcmp(opacity, opacity2, pixels * sizeof(float)) == 0);
    int exact = 1;
    for (size_t p = 0; p < pixels; p++) exact &= opacity[p] == 1.0f - r.final_T[p];
    CHECK(exact);
    CHECK(gv_splat_render_depth(&r, NULL, opacity2) == 0); /* either output may be NULL */
    CHECK(memcmp(opacity, opacity2, pixels * sizeof(float)) == 0);

    double *m2 = malloc((size_t)n * 2 * sizeof(double)), *con = malloc((size_t)n * 3 * sizeof(double));
    double *col = calloc((size_t)n * 3, sizeof(double)), *op = malloc((size_t)n * sizeof(double));
    double *dep = malloc((size_t)n * sizeof(double)), *ref = malloc(pixels * 3 * sizeof(double));
    int *radii = malloc((size_t)n * sizeof(int));
    double *means = to_double(g.means, 3 * (size_t)n), *scales = to_double(g.scales, 3 * (size_t)n);
    double *rots = to_double(g.rotations, 4 * (size_t)n);
    for (int i = 0; i < n; i++) {
        gv_splat_ref_projection p;
        int vis = gv_splat_reference_project(means + 3 * i, scales + 3 * i, rots + 4 * i, &v, &p);
        radii[i] = vis ? p.radius : 0;
        m2[2 * i] = p.mean2d[0], m2[2 * i + 1] = p.mean2d[1];
        for (int k = 0; k < 3; k++) con[3 * i + k] = p.conic[k];
        dep[i] = p.depth, op[i] = sigmoid(g.opacities[i]);
        col[3 * i] = p.depth, col[3 * i + 1] = 1;
    }
    double zero[3] = {0, 0, 0};
    uint64_t sig;
    CHECK(gv_splat_reference_rasterize(n, width, height, m2, con, col, op, dep, radii, zero, ref,
                                       &sig) == 0);
    double worst_d = 0, worst_o = 0, zmin = 1e30, zmax = 0;
    int covered = 0;
    for (size_t p = 0; p < pixels; p++) {
        double sw = ref[3 * p + 1], want = sw > 0 ? ref[3 * p] / sw : 0;
        if (sw > 0.01) { /* where the ratio is well conditioned */
            worst_d = fmax(worst_d, fabs(depth[p] - want) / want);
            zmin = fmin(zmin, want), zmax = fmax(zmax, want);
            covered++;
        }
        worst_o = fmax(worst_o, fabs(opacity[p] - sw));
        if (sw == 0) CHECK(depth[p] == 0);
    }
    printf("  %dx%d, %d Gaussians (%d visible): depths %.2f-%.2f on %d pixels, max relative "
           "|depth - reference| %.2e, max |opacity - reference| %.2e\n", width, height, n,
           r.tiles.n_visible, zmin, zmax, covered, worst_d, worst_o);
    CHECK(covered > (int)pixels / 2);
    CHECK(worst_d < 1e-5);
    CHECK(worst_o < 1e-5);
    free(m2), free(con), free(col), free(op), free(dep), free(ref), free(radii);
    free(means), free(scales), free(rots);
    free(image), free(depth), free(opacity), free(depth2), free(opacity2);
    gv_gaussians_free(&g);
    gv_splat_renderer_free(&r);
}

static void test_bad_calls(void)
{
    gv_splat_renderer r = {0};
    float d[4];
    CHECK_FAILS_WITH(gv_splat_render_depth(&r, d, NULL), "before any forward");
    /* an empty set renders: nothing blends anywhere */
    gv_splat_view v;
    identity_view(&v);
    gv_gaussians g;
    CHECK(gv_gaussians_alloc(&g, 1, 0) == 0);
    g.n = 0;
    static float image[W * H * 3], depth[W * H], opacity[W * H];
    float bg[3] = {0, 0, 0};
    CHECK(gv_splat_render_forward(&r, &g, &v, 0, bg, image) == 0);
    CHECK(gv_splat_render_depth(&r, depth, opacity) == 0);
    int zero = 1;
    for (int p = 0; p < W * H; p++) zero &= depth[p] == 0 && opacity[p] == 0;
    CHECK(zero);
    gv_gaussians_free(&g);
    gv_splat_renderer_free(&r);
}

int main(void)
{
    test_hand_scenes();
    test_reference_agreement(64, 48, 300, 31);
    test_reference_agreement(53, 37, 800, 41); /* partial tiles, dense: early stops */
    test_bad_calls();
    return check_summary();
}
