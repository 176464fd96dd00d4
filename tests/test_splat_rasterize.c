/* Tile rasteriser on 2D Gaussians: hand-computed pixels (early stop, alpha threshold,
 * alpha clamp, tile rectangle), agreement with the plain reference rasteriser, gradients
 * with respect to means2d, conics, colours and opacities against central finite
 * differences of the reference, and identical results for any thread count. */
#include <omp.h>

#include "splat_fixtures.h"

enum { MAXN = 200, MAXW = 70, MAXH = 50 };

/* A 2D scene in both precisions. */
typedef struct {
    int n, width, height;
    float m2[2 * MAXN], conic[3 * MAXN], color[3 * MAXN], opacity[MAXN], depth[MAXN];
    int radii[MAXN];
    float bg[3];
} scene2d;

/* Adds a Gaussian with 2D covariance [[a, b], [b, c]]; radius by the 3DGS formula unless
 * given. */
static void add_gaussian(scene2d *s, float mx, float my, double a, double b, double c,
                         float o, float r, float g, float bl, float depth, int radius)
{
    int i = s->n++;
    double det = a * c - b * b, mid = 0.5 * (a + c);
    s->m2[2 * i] = mx, s->m2[2 * i + 1] = my;
    s->conic[3 * i] = (float)(c / det), s->conic[3 * i + 1] = (float)(-b / det);
    s->conic[3 * i + 2] = (float)(a / det);
    s->color[3 * i] = r, s->color[3 * i + 1] = g, s->color[3 * i + 2] = bl;
    s->opacity[i] = o, s->depth[i] = depth;
    s->radii[i] = radius > 0 ? radius : (int)ceil(3 * sqrt(mid + sqrt(fmax(0.1, mid * mid - det))));
}

typedef struct {
    gv_splat_tiles tiles;
    float image[MAXW * MAXH * 3], final_T[MAXW * MAXH];
    int n_contrib[MAXW * MAXH];
    float d_m2[2 * MAXN], d_conic[3 * MAXN], d_color[3 * MAXN], d_opacity[MAXN];
} raster_out;

static void render(const scene2d *s, raster_out *o)
{
    CHECK(gv_splat_tiles_build(&o->tiles, s->n, s->width, s->height, s->m2, s->radii,
                               s->depth) == 0);
    gv_splat_rasterize_forward(&o->tiles, s->width, s->height, s->m2, s->conic, s->color,
                               s->opacity, s->bg, o->image, o->final_T, o->n_contrib);
}

static void backward(const scene2d *s, raster_out *o, const float *d_image)
{
    gv_splat_rasterize_backward(&o->tiles, s->width, s->height, s->bg, o->final_T,
                                o->n_contrib, d_image, o->d_m2, o->d_conic, o->d_color,
                                o->d_opacity);
}

static double *reference_image(const scene2d *s, uint64_t *signature)
{
    static double img[MAXW * MAXH * 3];
    double m2[2 * MAXN], con[3 * MAXN], col[3 * MAXN], op[MAXN], dep[MAXN], bg[3];
    for (int i = 0; i < 2 * s->n; i++) m2[i] = s->m2[i];
    for (int i = 0; i < 3 * s->n; i++) con[i] = s->conic[i], col[i] = s->color[i];
    for (int i = 0; i < s->n; i++) op[i] = s->opacity[i], dep[i] = s->depth[i];
    for (int c = 0; c < 3; c++) bg[c] = s->bg[c];
    CHECK(gv_splat_reference_rasterize(s->n, s->width, s->height, m2, con, col, op, dep,
                                       s->radii, bg, img, signature) == 0);
    return img;
}

static raster_out out; /* large: keep it off the stack */

static void test_early_stop_by_hand(void)
{
    /* Five Gaussians centred on pixel (20, 12) (centre 20.5, 12.5), each of opacity 0.95,
     * depths 1..5. At that pixel G = 1, alpha = 0.95: T goes 1 -> 0.05 -> 0.0025 ->
     * 1.25e-4; the fourth would leave 6.25e-6 < 1e-4, so the pixel stops there: three
     * blended, n_contrib = 3, colour = 0.95 c1 + 0.05*0.95 c2 + 0.0025*0.95 c3 +
     * 1.25e-4 bg. */
    scene2d s = {0};
    s.width = 40, s.height = 24;
    s.bg[0] = 0.2f, s.bg[1] = 0.4f, s.bg[2] = 0.6f;
    float cols[5][3] = {{1, 0, 0}, {0, 1, 0}, {0, 0, 1}, {1, 1, 0}, {0, 1, 1}};
    for (int i = 0; i < 5; i++) /* listed back to front: the sort must reorder them */
        add_gaussian(&s, 20.5f, 12.5f, 4, 0, 4, 0.95f, cols[4 - i][0], cols[4 - i][1],
                     cols[4 - i][2], (float)(5 - i), 0);
    render(&s, &out);
    size_t p = 12 * 40 + 20;
    double T[4] = {1, 0.05, 0.0025, 0.000125};
    for (int c = 0; c < 3; c++) {
        double want = T[3] * s.bg[c];
        for (int k = 0; k < 3; k++) want += 0.95 * T[k] * cols[k][c];
        CHECK_NEAR(out.image[p * 3 + c], want, 1e-6);
    }
    CHECK(out.n_contrib[p] == 3);
    CHECK_NEAR(out.final_T[p], 1.25e-4, 1e-9);
    uint64_t sig;
    double *ref = reference_image(&s, &sig);
    for (int c = 0; c < 3; c++) CHECK_NEAR(ref[p * 3 + c], out.image[p * 3 + c], 1e-6);
    gv_splat_tiles_free(&out.tiles);
}

static void test_alpha_threshold_and_clamp(void)
{
    /* Isotropic sigma^2 = 1, o = 0.5, centred on pixel (20, 12): alpha = 0.5 exp(-d^2/2) >=
     * 1/255 iff d^2 <= 2 ln(127.5) = 9.70. Pixel (23, 12): d^2 = 9, alpha = 0.5 e^-4.5 =
     * 0.00555, blended; (23, 13): d^2 = 10, 0.00337, skipped; (24, 12): d^2 = 16, skipped.
     * (The 0.3 dilation is part of the covariance given, so a = c = 1 here.) */
    scene2d s = {0};
    s.width = 40, s.height = 24;
    s.bg[0] = 0.1f, s.bg[1] = 0.1f, s.bg[2] = 0.1f;
    add_gaussian(&s, 20.5f, 12.5f, 1, 0, 1, 0.5f, 1, 1, 1, 1, 10);
    render(&s, &out);
    double a = 0.5 * exp(-4.5);
    CHECK_NEAR(out.image[(12 * 40 + 23) * 3], a + (1 - a) * 0.1, 1e-7);
    CHECK(out.n_contrib[12 * 40 + 23] == 1);
    CHECK(out.image[(13 * 40 + 23) * 3] == 0.1f && out.n_contrib[13 * 40 + 23] == 0);
    CHECK(out.image[(12 * 40 + 24) * 3] == 0.1f && out.n_contrib[12 * 40 + 24] == 0);
    CHECK(out.final_T[13 * 40 + 23] == 1);
    gv_splat_tiles_free(&out.tiles);

    /* Opacity 0.003 < 1/255: nothing anywhere. Opacity 1: alpha clamped to 0.99 at the
     * centre, so the pixel is 0.99 c + 0.01 bg and T = 0.01. */
    scene2d t = {0};
    t.width = 40, t.height = 24;
    add_gaussian(&t, 10.5f, 5.5f, 4, 0, 4, 0.003f, 1, 1, 1, 1, 0);
    add_gaussian(&t, 30.5f, 15.5f, 4, 1, 4, 1.0f, 0.5f, 0.25f, 1, 2, 0);
    render(&t, &out);
    CHECK(out.n_contrib[5 * 40 + 10] == 0 && out.image[(5 * 40 + 10) * 3] == 0);
    CHECK_NEAR(out.image[(15 * 40 + 30) * 3], 0.99 * 0.5, 1e-7);
    CHECK_NEAR(out.final_T[15 * 40 + 30], 0.01, 1e-7);
    gv_splat_tiles_free(&out.tiles);
}

static void test_tile_rectangle_limits(void)
{
    /* sigma = 5 px but a given radius of 1 at (15.5, 8.5): getRect gives tile column 0
     * only (trunc((15 + 1 + 15)/16) = 1), so pixel (16, 8), one pixel right of the centre in
     * tile column 1, stays background while pixel (15, 8) is blended. */
    scene2d s = {0};
    s.width = 40, s.height = 24;
    add_gaussian(&s, 15.5f, 8.5f, 25, 0, 25, 0.8f, 1, 1, 1, 1, 1);
    render(&s, &out);
    CHECK_NEAR(out.image[(8 * 40 + 15) * 3], 0.8, 1e-6);
    CHECK(out.image[(8 * 40 + 16) * 3] == 0);
    uint64_t sig;
    double *ref = reference_image(&s, &sig);
    CHECK(ref[(8 * 40 + 16) * 3] == 0);
    gv_splat_tiles_free(&out.tiles);
}

/* Random 2D Gaussians: sizes 0.5-8 px (needles of 0.1 x 2-60 px when `needles`), any
 * orientation, spread beyond the image. */
static void random_scene_shaped(scene2d *s, int n, int width, int height, double o_lo,
                                double o_hi, uint64_t seed, int needles)
{
    gv_rng r;
    gv_rng_init(&r, seed);
    memset(s, 0, sizeof *s);
    s->width = width, s->height = height;
    s->bg[0] = 0.2f, s->bg[1] = 0.5f, s->bg[2] = 0.8f;
    for (int i = 0; i < n; i++) {
        double s1 = 0.5 + 7.5 * gv_rng_uniform(&r), s2 = 0.5 + 4 * gv_rng_uniform(&r);
        if (needles) s1 = 2 + 58 * gv_rng_uniform(&r), s2 = 0.1;
        double th = 3.14159 * gv_rng_uniform(&r), cs = cos(th), sn = sin(th);
        double a = cs * cs * s1 * s1 + sn * sn * s2 * s2 + 0.3;
        double b = cs * sn * (s1 * s1 - s2 * s2);
        double c = sn * sn * s1 * s1 + cs * cs * s2 * s2 + 0.3;
        float depth = gv_rng_uniform(&r) < 0.2 ? 3.0f : (float)(1 + 5 * gv_rng_uniform(&r));
        add_gaussian(s, (float)(-8 + (width + 16) * gv_rng_uniform(&r)),
                     (float)(-8 + (height + 16) * gv_rng_uniform(&r)), a, b, c,
                     (float)(o_lo + (o_hi - o_lo) * gv_rng_uniform(&r)),
                     (float)gv_rng_uniform(&r), (float)gv_rng_uniform(&r),
                     (float)gv_rng_uniform(&r), depth, 0);
    }
}

static void random_scene(scene2d *s, int n, int width, int height, double o_lo, double o_hi,
                         uint64_t seed)
{
    random_scene_shaped(s, n, width, height, o_lo, o_hi, seed, 0);
}

static void test_reference_agreement(void)
{
    /* The last two: thin needles (sigma 0.1 x up to 60 px before the 0.3 dilation). Their
     * conic is nearly singular: A dx^2 + C dy^2 + 2 B dx dy cancels from ~1e4 down to ~10,
     * so float rounding moves power by ~1e-3 and alpha by ~1e-4 relative, against the
     * double reference; a pixel dropped or added at the 1/255 threshold would show as an
     * error of ~4e-3 instead. */
    int sizes[5][3] = {{40, 24, 60}, {70, 50, 200}, {33, 17, 120}, {70, 50, 150}, {40, 24, 100}};
    for (int k = 0; k < 5; k++) {
        static scene2d s;
        int needles = k >= 3;
        random_scene_shaped(&s, sizes[k][2], sizes[k][0], sizes[k][1], 0.02, 1.0, 50 + k, needles);
        render(&s, &out);
        uint64_t sig;
        double *ref = reference_image(&s, &sig);
        double worst = 0;
        int stopped = 0, total = s.width * s.height;
        for (int i = 0; i < total * 3; i++) worst = fmax(worst, fabs(ref[i] - out.image[i]));
        for (int i = 0; i < total; i++) stopped += out.final_T[i] < 1e-3f;
        printf("  %dx%d, %d Gaussians: max |tiled - reference| %.2e (%d pixels nearly opaque)\n",
               s.width, s.height, s.n, worst, stopped);
        CHECK(worst < (needles ? 3e-4 : 1e-5));
        gv_splat_tiles_free(&out.tiles);
    }
}

/* Which pixels each Gaussian is blended into must be exactly the reference's: the kernel
 * skips groups of eight pixels by a bound on the power and pixels outside an alpha box, so
 * this compares, pixel by pixel, the index of the last blended entry of the tile list
 * (n_contrib) and the transmittance left (final_T) with an independent double-precision
 * walk of the reference's rule. Pixels where some alpha or T test is within 1e-5 of its
 * threshold (float and double may then decide differently) are left out and counted. Low
 * opacities put the 1/255 threshold inside the boxes, where the group skip acts. */
static void test_blended_pixels_exact(void)
{
    double o_range[3][2] = {{0.004, 0.03}, {0.02, 1.0}, {0.3, 0.99}};
    for (int k = 0; k < 4; k++) {
        static scene2d s;
        random_scene_shaped(&s, 200, 70, 50, o_range[k % 3][0], o_range[k % 3][1], 90 + k, k == 3);
        render(&s, &out);
        int tx = (s.width + 15) / 16, ty = (s.height + 15) / 16, compared = 0, ambiguous = 0;
        int mismatched = 0, blended_pixels = 0;
        double worst_T = 0;
        for (int py = 0; py < s.height; py++)
            for (int px = 0; px < s.width; px++) {
                /* the tile's list: rectangle holds the tile, sorted by (depth, index) */
                int list[MAXN], m = 0;
                for (int g = 0; g < s.n; g++) {
                    int r[4];
                    if (s.radii[g] <= 0) continue;
                    gv_splat_tile_rect(s.m2[2 * g], s.m2[2 * g + 1], s.radii[g], tx, ty, r);
                    if (px / 16 < r[0] || px / 16 >= r[2] || py / 16 < r[1] || py / 16 >= r[3])
                        continue;
                    int at = m++;
                    while (at > 0 && (s.depth[list[at - 1]] > s.depth[g])) {
                        list[at] = list[at - 1];
                        at--;
                    }
                    list[at] = g;
                }
                double T = 1;
                int last = 0, unsure = 0;
                for (int j = 0; j < m; j++) {
                    int g = list[j];
                    double dx = s.m2[2 * g] - (px + 0.5), dy = s.m2[2 * g + 1] - (py + 0.5);
                    const float *q = s.conic + 3 * g;
                    double power = -0.5 * (q[0] * dx * dx + q[2] * dy * dy) - q[1] * dx * dy;
                    if (power > 0) continue;
                    double a = fmin(s.opacity[g] * exp(power), GV_SPLAT_ALPHA_MAX);
                    if (fabs(a - GV_SPLAT_ALPHA_MIN) < 1e-5 * GV_SPLAT_ALPHA_MIN) unsure = 1;
                    if (a < GV_SPLAT_ALPHA_MIN) continue;
                    if (fabs(T * (1 - a) - GV_SPLAT_T_MIN) < 1e-5 * GV_SPLAT_T_MIN) unsure = 1;
                    if (T * (1 - a) < GV_SPLAT_T_MIN) break;
                    T *= 1 - a;
                    last = j + 1;
                }
                size_t p = (size_t)py * s.width + px;
                if (unsure) {
                    ambiguous++;
                    continue;
                }
                compared++;
                blended_pixels += last > 0;
                mismatched += out.n_contrib[p] != last;
                worst_T = fmax(worst_T, fabs(out.final_T[p] - T));
            }
        printf("  blended pixels, scene %d: %d pixels compared (%d with a blended Gaussian), "
               "%d near a threshold left out; n_contrib differs at %d, max |final_T diff| "
               "%.2e\n", k, compared, blended_pixels, ambiguous, mismatched, worst_T);
        CHECK(mismatched == 0);
        CHECK(worst_T < 1e-5);
        CHECK(blended_pixels > compared / 2 && ambiguous < compared / 100);
        gv_splat_tiles_free(&out.tiles);
    }
}

/* L = sum w . image through the reference, as a function of the scene's parameters. */
typedef struct {
    scene2d *s;
    const double *w;
    double m2[2 * MAXN], conic[3 * MAXN], color[3 * MAXN], opacity[MAXN], depth[MAXN], bg[3];
} raster_fd;

static double raster_loss(void *ctx, uint64_t *signature)
{
    raster_fd *c = ctx;
    static double img[MAXW * MAXH * 3];
    gv_splat_reference_rasterize(c->s->n, c->s->width, c->s->height, c->m2, c->conic, c->color,
                                 c->opacity, c->depth, c->s->radii, c->bg, img, signature);
    double loss = 0;
    for (int i = 0; i < c->s->width * c->s->height * 3; i++) loss += c->w[i] * img[i];
    return loss;
}

static fix_compare cmp_m2 = {"means2d", 0, 0, {0}, {0}};
static fix_compare cmp_conic = {"conics", 0, 0, {0}, {0}};
static fix_compare cmp_color = {"colours", 0, 0, {0}, {0}};
static fix_compare cmp_opacity = {"opacities", 0, 0, {0}, {0}};

/* Opacities stay <= 0.9 so the 0.99 clamp (ignored by the 3DGS gradient) never acts. With
 * `stack`, six Gaussians of opacity 0.88 are piled in front at (20.3, 11.7): at their centre
 * T falls 0.12, 0.0144, 1.7e-3, 2.1e-4, and the fifth would leave 2.5e-5 < 1e-4, so those
 * pixels stop early. */
static void test_gradients(int n, double o_lo, uint64_t seed, int stride, int stack)
{
    static scene2d s;
    random_scene(&s, n, 40, 24, o_lo, 0.9, seed);
    for (int k = 0; stack && k < 6; k++)
        add_gaussian(&s, 20.3f + 0.2f * k, 11.7f - 0.1f * k, 9, 1, 8, 0.88f, 0.1f * k, 0.5f,
                     1 - 0.1f * k, 0.5f + 0.05f * k, 0);
    static raster_fd c;
    static double w[MAXW * MAXH * 3];
    static float wf[MAXW * MAXH * 3];
    gv_rng r;
    gv_rng_init(&r, 62);
    for (int i = 0; i < 40 * 24 * 3; i++) wf[i] = (float)(w[i] = 2 * gv_rng_uniform(&r) - 1);
    c.s = &s, c.w = w;
    for (int i = 0; i < 2 * s.n; i++) c.m2[i] = s.m2[i];
    for (int i = 0; i < 3 * s.n; i++) c.conic[i] = s.conic[i], c.color[i] = s.color[i];
    for (int i = 0; i < s.n; i++) c.opacity[i] = s.opacity[i], c.depth[i] = s.depth[i];
    for (int k = 0; k < 3; k++) c.bg[k] = s.bg[k];
    render(&s, &out);
    backward(&s, &out, wf);
    int stopped = 0;
    for (int i = 0; i < 40 * 24; i++) stopped += out.final_T[i] < 1e-3f;
    printf("  rasteriser gradients, %d Gaussians, %d pixels nearly opaque:\n", s.n, stopped);
    if (stack) CHECK(out.n_contrib[11 * 40 + 20] > 0 && out.final_T[11 * 40 + 20] < 1e-3f);
    uint64_t s0;
    raster_loss(&c, &s0);
    for (int i = 0; i < s.n; i++) {
        if (i % stride && i < n) continue; /* every stacked one is checked */
        if (s.radii[i] == 0) continue;
        fix_add_params(&cmp_m2, raster_loss, &c, s0, c.m2 + 2 * i, out.d_m2 + 2 * i, 2, 1e-6);
        fix_add_params(&cmp_conic, raster_loss, &c, s0, c.conic + 3 * i, out.d_conic + 3 * i, 3, 1e-6);
        fix_add_params(&cmp_color, raster_loss, &c, s0, c.color + 3 * i, out.d_color + 3 * i, 3, 1e-6);
        fix_add_params(&cmp_opacity, raster_loss, &c, s0, c.opacity + i, out.d_opacity + i, 1, 1e-6);
    }
    fix_report(&cmp_m2, 2e-3);
    fix_report(&cmp_conic, 2e-3);
    fix_report(&cmp_color, 2e-3);
    fix_report(&cmp_opacity, 2e-3);
    gv_splat_tiles_free(&out.tiles);
}

static void test_thread_independence(void)
{
    static scene2d s;
    random_scene(&s, 200, 70, 50, 0.02, 1.0, 71);
    static float w[MAXW * MAXH * 3];
    for (int i = 0; i < 70 * 50 * 3; i++) w[i] = (float)gv_uniform_at(72, (uint64_t)i) - 0.5f;
    static raster_out one, two;
    omp_set_num_threads(1);
    render(&s, &one);
    backward(&s, &one, w);
    omp_set_num_threads(3);
    render(&s, &two);
    backward(&s, &two, w);
    omp_set_num_threads(2);
    CHECK(memcmp(one.image, two.image, sizeof one.image) == 0);
    CHECK(memcmp(one.d_m2, two.d_m2, sizeof(float) * 2 * s.n) == 0);
    CHECK(memcmp(one.d_conic, two.d_conic, sizeof(float) * 3 * s.n) == 0);
    CHECK(memcmp(one.d_color, two.d_color, sizeof(float) * 3 * s.n) == 0);
    CHECK(memcmp(one.d_opacity, two.d_opacity, sizeof(float) * s.n) == 0);
    gv_splat_tiles_free(&one.tiles);
    gv_splat_tiles_free(&two.tiles);
}

int main(void)
{
    test_early_stop_by_hand();
    test_alpha_threshold_and_clamp();
    test_tile_rectangle_limits();
    test_reference_agreement();
    test_blended_pixels_exact();
    test_gradients(40, 0.2, 61, 1, 0);
    test_gradients(100, 0.5, 63, 7, 1); /* dense, pixels stop early; every 7th Gaussian */
    test_thread_independence();
    return check_summary();
}
