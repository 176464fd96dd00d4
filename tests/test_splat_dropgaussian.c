/* DropGaussian (src/splat/dropgaussian.c) and the opacity-scaled render it trains with
 * (src/splat/render.c):
 * - the --regularize list's parser and names;
 * - the rate schedule's exact values;
 * - the draw: only 0 and 1 / (1 - rate), the dropped share, the same for 1 and 2 threads;
 * - the expectation: on a hand-built scene of three overlapping low-opacity Gaussians, the
 *   average of the renders over all 2^3 drop patterns, weighted by their probabilities,
 *   equals the full render wherever no Gaussian's alpha lies in the band where only the
 *   compensated one passes the 1/255 cut; without compensation it does not; and the mean
 *   of many drawn renders is within Hoeffding's bound of that expectation;
 * - the gradients of the scaled render against central finite differences of the double
 *   reference renderer, and untouched gradient rows of dropped Gaussians. */
#include <omp.h>

#include "gaussvid/splat/render.h"
#include "gaussvid/splat/splat_train.h"
#include "splat_fixtures.h"

enum { IW = 40, IH = 24, NPIX = IW * IH * 3 };

static void test_rate(void)
{
    CHECK(gv_splat_drop_rate(0, 100, 0.2) == 0.0);
    CHECK(gv_splat_drop_rate(50, 100, 0.2) == 0.1);
    CHECK(gv_splat_drop_rate(100, 100, 0.2) == 0.2);
    CHECK(gv_splat_drop_rate(2000, 8000, 0.2) == 0.05);
    CHECK(gv_splat_drop_rate(8000, 8000, 0.2) == 0.2);
    CHECK(gv_splat_drop_rate(9000, 8000, 0.2) == 0.2); /* past the run: the last rate */
    CHECK(gv_splat_drop_rate(4000, 8000, 0.1) == 0.05);
    CHECK(gv_splat_drop_rate(8000, 8000, 0.1) == 0.1);
    CHECK(gv_splat_drop_rate(8000, 8000, 0) == 0);
    CHECK_NEAR(gv_splat_drop_rate(1, 8000, 0.2), 2.5e-5, 1e-19);
    for (int it = 1; it < 8000; it++) /* linear: equal steps */
        CHECK_NEAR(gv_splat_drop_rate(it + 1, 8000, 0.2) - gv_splat_drop_rate(it, 8000, 0.2), 2.5e-5, 1e-15);
}

/* The --regularize list: names, order-free, each once; the name round-trips. */
static void test_parse(void)
{
    char buf[64];
    CHECK(gv_splat_regularize_parse("none") == 0);
    CHECK(gv_splat_regularize_parse("dropgaussian") == GV_REGULARIZE_DROPGAUSSIAN);
    int all = GV_REGULARIZE_DROPGAUSSIAN | GV_REGULARIZE_FSGS | GV_REGULARIZE_CORGS;
    CHECK(gv_splat_regularize_parse("corgs,fsgs,dropgaussian") == all);
    gv_splat_regularize_name(all, buf, sizeof buf);
    CHECK(strcmp(buf, "dropgaussian,fsgs,corgs") == 0);
    CHECK(gv_splat_regularize_parse(buf) == all);
    gv_splat_regularize_name(0, buf, sizeof buf);
    CHECK(strcmp(buf, "none") == 0);
    gv_splat_regularize_name(GV_REGULARIZE_FSGS, buf, sizeof buf);
    CHECK(strcmp(buf, "fsgs") == 0);
    const char *bad[] = {"", ",", "fsgs,", ",fsgs", "fsgs,fsgs", "none,fsgs", "NONE", "drop", "fsgsx"};
    for (size_t i = 0; i < sizeof bad / sizeof bad[0]; i++) CHECK(gv_splat_regularize_parse(bad[i]) == -1);
}

static void test_draw(void)
{
    enum { N = 100000 };
    static float a[N], b[N];
    omp_set_num_threads(1);
    int dropped = gv_splat_drop_draw(N, 0.2, 7, a);
    omp_set_num_threads(2);
    int dropped2 = gv_splat_drop_draw(N, 0.2, 7, b);
    CHECK(dropped == dropped2 && memcmp(a, b, sizeof a) == 0);
    int zeros = 0;
    for (int i = 0; i < N; i++) {
        CHECK(a[i] == 0.0f || a[i] == 1.25f);
        zeros += a[i] == 0.0f;
    }
    CHECK(zeros == dropped);
    /* Binomial(N, 0.2): mean 20000, standard deviation sqrt(N 0.2 0.8) = 126.5. */
    printf("  %d of %d dropped at rate 0.2\n", dropped, N);
    CHECK(abs(dropped - 20000) < 5 * 127);
    CHECK(gv_splat_drop_draw(N, 0.2, 8, b) > 0 && memcmp(a, b, sizeof a) != 0);
    CHECK(gv_splat_drop_draw(N, 0.0, 7, b) == 0);
    for (int i = 0; i < N; i++) CHECK(b[i] == 1.0f);
}

/* Camera at the origin looking down +z: 40x24, fx = fy = 20, principal point (20, 12). */
static void identity_view(gv_splat_view *v)
{
    double R[9] = {1, 0, 0, 0, 1, 0, 0, 0, 1}, t[3] = {0, 0, 0};
    CHECK(gv_splat_view_init(v, IW, IH, 20, 20, 20, 12, R, t) == 0);
}

/* Three isotropic Gaussians at depths 4, 5, 6 whose discs overlap in the middle of the
 * image; opacities 0.3, 0.4, 0.35: with compensation 1 / 0.8 at most 0.5, far from the
 * 0.99 clamp, and the transmittance stays far above the 1e-4 stop. */
static void three_gaussians(gv_gaussians *g)
{
    CHECK(gv_gaussians_alloc(g, 3, 0) == 0);
    const float xy[3][2] = {{-0.3f, 0}, {0.2f, 0.2f}, {0.1f, -0.3f}}, depth[3] = {4, 5, 6};
    const double opacity[3] = {0.3, 0.4, 0.35};
    const float colour[3][3] = {{1, 0.2f, 0.1f}, {0.1f, 0.9f, 0.3f}, {0.2f, 0.3f, 1}};
    for (int i = 0; i < 3; i++) {
        g->means[3 * i] = xy[i][0] * depth[i], g->means[3 * i + 1] = xy[i][1] * depth[i];
        g->means[3 * i + 2] = depth[i];
        for (int a = 0; a < 3; a++) g->scales[3 * i + a] = logf(0.12f * depth[i]);
        g->rotations[4 * i] = 1;
        g->rotations[4 * i + 1] = g->rotations[4 * i + 2] = g->rotations[4 * i + 3] = 0;
        g->opacities[i] = (float)log(opacity[i] / (1 - opacity[i]));
        for (int c = 0; c < 3; c++) g->sh[3 * i + c] = (float)((colour[i][c] - 0.5) / FIX_C0);
    }
}

/* 1 where some Gaussian's alpha (from the full render's 2D Gaussians) is, within 3 %, in
 * [(1 - rate) / 255, 1 / 255]: there the compensated alpha passes the cut and the full one
 * does not, and the expectation differs by up to 1/255 of a colour. */
static void band_pixels(const gv_splat_renderer *r, double rate, unsigned char *band)
{
    for (int y = 0; y < IH; y++)
        for (int x = 0; x < IW; x++) {
            band[y * IW + x] = 0;
            for (int i = 0; i < r->n; i++) {
                double dx = r->means2d[2 * i] - (x + 0.5), dy = r->means2d[2 * i + 1] - (y + 0.5);
                const float *k = r->conics + 3 * i;
                double alpha = r->opacities[i] *
                               exp(-0.5 * (k[0] * dx * dx + k[2] * dy * dy) - k[1] * dx * dy);
                if (alpha >= 0.97 * (1 - rate) / 255 && alpha <= 1.03 / 255) band[y * IW + x] = 1;
            }
        }
}

/* The expected render over the 2^n drop patterns; compensate 0 keeps the opacities. */
static void expected_render(gv_splat_renderer *r, const gv_gaussians *g, const gv_splat_view *v,
                            const float bg[3], double rate, int compensate, double *out)
{
    static float image[NPIX];
    float scale[3];
    memset(out, 0, NPIX * sizeof(double));
    for (int mask = 0; mask < 1 << g->n; mask++) {
        double weight = 1;
        for (int i = 0; i < g->n; i++) {
            int kept = (mask >> i) & 1;
            weight *= kept ? 1 - rate : rate;
            scale[i] = kept ? (compensate ? (float)(1 / (1 - rate)) : 1.0f) : 0.0f;
        }
        CHECK(gv_splat_render_forward_scaled(r, g, v, 0, bg, scale, image) == 0);
        for (int p = 0; p < NPIX; p++) out[p] += weight * image[p];
    }
}

static void test_expectation(void)
{
    gv_splat_view v;
    identity_view(&v);
    gv_gaussians g;
    three_gaussians(&g);
    const float bg[3] = {0.1f, 0.2f, 0.05f};
    const double rate = 0.2;
    static float full[NPIX], image[NPIX];
    static double expected[NPIX], uncompensated[NPIX], mean[NPIX];
    static unsigned char band[IW * IH];
    gv_splat_renderer r = {0};
    CHECK(gv_splat_render_forward(&r, &g, &v, 0, bg, full) == 0);
    CHECK(r.tiles.n_visible == 3);
    band_pixels(&r, rate, band);
    expected_render(&r, &g, &v, bg, rate, 1, expected);
    expected_render(&r, &g, &v, bg, rate, 0, uncompensated);
    double worst = 0, worst_band = 0, darkest = 0;
    int checked = 0, covered = 0;
    for (int p = 0; p < NPIX; p++) {
        double d = fabs(expected[p] - full[p]);
        covered += fabs(full[p] - bg[p % 3]) > 1e-3;
        darkest = fmax(darkest, fabs(uncompensated[p] - full[p]));
        if (band[p / 3]) {
            worst_band = fmax(worst_band, d);
            continue;
        }
        checked += fabs(full[p] - bg[p % 3]) > 1e-3;
        worst = fmax(worst, d);
    }
    printf("  expectation over the 8 drop patterns: max |E - full| %.2e on %d of %d covered "
           "values, %.2e in the 1/255 band; without compensation %.3f\n", worst, checked,
           covered, worst_band, darkest);
    CHECK(checked > covered / 2);
    CHECK(worst < 2e-6);            /* float rounding of eight renders */
    CHECK(worst_band < 3.0 / 255); /* at most 1/255 of a colour per Gaussian */
    CHECK(darkest > 0.05);          /* the compensation is what makes it hold */

    /* Many drawn renders (the trainer's draw): each value lies in [0, 1], so by Hoeffding
     * |mean - E| <= sqrt(ln(2 / 1e-9) / (2 N)) = 0.0517 but for a 1e-9 chance per value. */
    enum { DRAWS = 4000 };
    float scale[3];
    memset(mean, 0, sizeof mean);
    for (int d = 0; d < DRAWS; d++) {
        gv_splat_drop_draw(3, rate, 1000 + (uint64_t)d, scale);
        CHECK(gv_splat_render_forward_scaled(&r, &g, &v, 0, bg, scale, image) == 0);
        for (int p = 0; p < NPIX; p++) mean[p] += image[p] / (double)DRAWS;
    }
    double worst_mean = 0, worst_full = 0;
    for (int p = 0; p < NPIX; p++) {
        worst_mean = fmax(worst_mean, fabs(mean[p] - expected[p]));
        if (!band[p / 3]) worst_full = fmax(worst_full, fabs(mean[p] - full[p]));
    }
    printf("  mean of %d drawn renders: max |mean - E| %.4f, |mean - full| %.4f off the band\n",
           DRAWS, worst_mean, worst_full);
    CHECK(worst_mean < 0.0517);
    CHECK(worst_full < 0.0517 + 2e-6);
    gv_gaussians_free(&g);
    gv_splat_renderer_free(&r);
}

/* The raw opacity logits and drop scales, mapped to the reference's logits: a kept
 * Gaussian of opacity s sigmoid(x) renders as one of logit log(s o / (1 - s o)), a dropped
 * one as transparent (logit -100: alpha 4e-44, skipped). */
typedef struct {
    int n;
    double *means, *sh, *opacities, *scales, *rotations, *raw, *w, bg[3], *image;
    const float *scale;
    const gv_splat_view *view;
} scaled_fd;

static double scaled_loss(void *ctx, uint64_t *signature)
{
    scaled_fd *c = ctx;
    for (int i = 0; i < c->n; i++) {
        double o = c->scale[i] / (1 + exp(-c->raw[i]));
        c->opacities[i] = c->scale[i] == 0 ? -100 : log(o / (1 - o));
    }
    gv_splat_reference_render(c->n, 0, 0, c->means, c->sh, c->opacities, c->scales,
                              c->rotations, c->view, c->bg, c->image, signature);
    double loss = 0;
    for (int p = 0; p < c->view->width * c->view->height * 3; p++) loss += c->w[p] * c->image[p];
    return loss;
}

static double *doubles(const float *x, int count)
{
    double *d = malloc((size_t)count * sizeof(double));
    for (int i = 0; i < count; i++) d[i] = x[i];
    return d;
}

static void test_gradients(void)
{
    enum { N = 40 };
    gv_splat_view v;
    fix_view(&v, IW, IH, 91);
    gv_gaussians g, grad;
    fix_gaussians(&g, N, 0, &v, 92);
    CHECK(gv_gaussians_alloc(&grad, N, 0) == 0);
    float scale[N];
    for (int i = 0; i < N; i++) {
        g.opacities[i] = fminf(g.opacities[i], 1.0f); /* 1.25 sigmoid(1) = 0.91 < 0.99 */
        scale[i] = i % 4 == 0 ? 0.0f : 1.25f;
    }
    for (int i = 0; i < N * 3; i++) grad.means[i] = 7; /* rows the backward must not touch */
    for (int i = 0; i < N; i++) grad.opacities[i] = 7;
    static float image[NPIX], w[NPIX];
    for (int p = 0; p < NPIX; p++) w[p] = (float)(2 * gv_uniform_at(93, (uint64_t)p) - 1);
    const float bg[3] = {0.25f, 0.5f, 0.75f};
    gv_splat_renderer r = {0};
    CHECK(gv_splat_render_forward_scaled(&r, &g, &v, 0, bg, scale, image) == 0);
    CHECK(gv_splat_render_backward(&r, &g, w, &grad, NULL) == 0);
    scaled_fd c = {.n = N, .scale = scale, .view = &v, .bg = {bg[0], bg[1], bg[2]}};
    c.means = doubles(g.means, 3 * N), c.sh = doubles(g.sh, 3 * N);
    c.scales = doubles(g.scales, 3 * N), c.rotations = doubles(g.rotations, 4 * N);
    c.raw = doubles(g.opacities, N), c.w = doubles(w, NPIX);
    c.opacities = malloc(N * sizeof(double)), c.image = malloc(NPIX * sizeof(double));
    uint64_t s0;
    scaled_loss(&c, &s0);
    double worst_image = 0;
    for (int p = 0; p < NPIX; p++) worst_image = fmax(worst_image, fabs(c.image[p] - image[p]));
    static fix_compare opacity = {"opacity logits", 0, 0, {0}, {0}};
    static fix_compare means = {"means", 0, 0, {0}, {0}};
    int visible_kept = 0;
    for (int i = 0; i < N; i++) {
        if (scale[i] == 0) { /* dropped: culled, its rows untouched */
            CHECK(r.radii[i] == 0 && grad.opacities[i] == 7 && grad.means[3 * i] == 7);
            continue;
        }
        if (r.radii[i] == 0) continue;
        visible_kept++;
        double num;
        if (fix_derivative(scaled_loss, &c, s0, c.raw + i, 1e-6, &num) == 0)
            fix_add(&opacity, grad.opacities[i], num);
        else
            opacity.skipped++;
        gv_splat_ref_projection p;
        gv_splat_reference_project(c.means + 3 * i, c.scales + 3 * i, c.rotations + 4 * i, &v, &p);
        for (int a = 0; a < 3 && !p.clamp_x && !p.clamp_y; a++) {
            if (fix_derivative(scaled_loss, &c, s0, c.means + 3 * i + a, 1e-6, &num) == 0)
                fix_add(&means, grad.means[3 * i + a], num);
            else
                means.skipped++;
        }
    }
    printf("  scaled render of %d Gaussians (%d kept and visible): max |render - reference| %.2e\n",
           N, visible_kept, worst_image);
    CHECK(worst_image < 2e-5);
    CHECK(visible_kept > N / 3);
    fix_report(&opacity, 2e-3);
    fix_report(&means, 2e-3);
    free(c.means), free(c.sh), free(c.scales), free(c.rotations), free(c.raw), free(c.w);
    free(c.opacities), free(c.image);
    gv_gaussians_free(&g), gv_gaussians_free(&grad);
    gv_splat_renderer_free(&r);
}

int main(void)
{
    test_parse();
    test_rate();
    test_draw();
    omp_set_num_threads(1); /* small renders: a thread team costs more than it saves */
    test_expectation();
    test_gradients();
    return check_summary();
}
