/* Binocular3DGS's consistency loss (src/splat/binocular.c): the `binocular` name in the
 * --regularize parser (and in no default); the row warp on hand values (interpolation weights, the columns that
 * fall outside); the warp's gradient with respect to the image and the disparity, the
 * edge-aware smoothness's, and the whole term's with respect to the shifted render and the
 * accumulated depth, against central differences of an independent double-precision
 * version written here; the shifted camera; and the term's gradient through both renders
 * (the training view's depth, the shifted view's image) to the Gaussians' 3D parameters,
 * against central differences of the double reference renderer. */
#include "gaussvid/splat/splat_train.h"
#include "splat_fixtures.h"

enum { W = 40, H = 24, NPIX = W * H };

static void test_parse(void)
{
    int set = gv_splat_regularize_parse("decay,binocular");
    CHECK(set == (GV_REGULARIZE_DECAY | GV_REGULARIZE_BINOCULAR));
    CHECK(gv_splat_regularize_parse("binocular") == GV_REGULARIZE_BINOCULAR);
    CHECK(gv_splat_regularize_parse("binocular,binocular") == -1);
    CHECK(gv_splat_regularize_parse("binoculars") == -1);
    char name[64];
    gv_splat_regularize_name(set, name, sizeof name);
    CHECK(strcmp(name, "decay,binocular") == 0);
    CHECK(gv_splat_regularize_parse(name) == set);
    /* opt-in only: in no density control's default */
    gv_splat_densify_mode modes[] = {GV_DENSIFY_LEAN, GV_DENSIFY_REFERENCE, GV_DENSIFY_MCMC};
    for (int m = 0; m < 3; m++) CHECK(!(gv_splat_regularize_default(modes[m]) & GV_REGULARIZE_BINOCULAR));
}

/* A 6 x 2 image whose channel c at column x, row y is 10 y + x + c / 10. */
static void test_warp_by_hand(void)
{
    enum { w = 6, h = 2 };
    float image[w * h * 3], warped[w * h * 3], valid[w * h], disp[w * h];
    for (int y = 0; y < h; y++)
        for (int x = 0; x < w; x++)
            for (int c = 0; c < 3; c++) image[3 * (y * w + x) + c] = 10.0f * y + x + c / 10.0f;
    /* row 0: 1.25 everywhere; row 1: -0.5, 0.5, -2, 0 (integer: weight 1 on x0, x0 + 1 must
     * still be inside), 0, 0.75 */
    for (int x = 0; x < w; x++) disp[x] = 1.25f;
    float row1[w] = {-0.5f, 0.5f, -2, 0, 0, 0.75f};
    for (int x = 0; x < w; x++) disp[w + x] = row1[x];
    gv_splat_warp_rows(image, w, h, disp, warped, valid);
    /* row 0: x + 1.25 for x = 0..3 (x0 + 1 = x + 2 <= 5), outside from x = 4 */
    for (int x = 0; x < 4; x++) {
        CHECK(valid[x] == 1);
        CHECK_NEAR(warped[3 * x + 1], x + 1.25 + 0.1, 1e-5);
    }
    CHECK(valid[4] == 0 && valid[5] == 0 && warped[3 * 4] == 0 && warped[3 * 5 + 2] == 0);
    /* row 1 */
    CHECK(valid[w] == 0);                                   /* -0.5: x0 = -1 */
    CHECK(valid[w + 1] == 1);
    CHECK_NEAR(warped[3 * (w + 1)], 11.5, 1e-5);            /* halfway from column 1 to 2 */
    CHECK(valid[w + 2] == 1 && warped[3 * (w + 2)] == 10);  /* -2: exactly column 0 */
    CHECK(valid[w + 3] == 1 && warped[3 * (w + 3)] == 13);  /* 0: itself */
    CHECK(valid[w + 5] == 0);                               /* 5.75: x0 + 1 = 6 */
    /* NaN and huge disparities (a transparent pixel: D = 0) are outside */
    disp[0] = NAN, disp[1] = 1e30f, disp[2] = -1e30f;
    gv_splat_warp_rows(image, w, h, disp, warped, valid);
    CHECK(valid[0] == 0 && valid[1] == 0 && valid[2] == 0);
}

/* ---- an independent double version of the term, for the finite differences -------------- */

static uint64_t mix(uint64_t h, int64_t v)
{
    return (h ^ (uint64_t)v) * 0x100000001B3ull;
}

static int sgn(double v)
{
    return v > 0 ? 1 : v < 0 ? -1 : 0;
}

/* The release's term in double: L1 of the masked warp + 0.05 smoothness of the masked
 * disparity. The signature hashes every piecewise choice (floor, validity, the signs of the
 * absolute values). */
static double term_double(const double *target, const double *D, const double *shifted, int w,
                          int h, double fx, double b, uint64_t *sig)
{
    static double disp[NPIX], m[NPIX];
    uint64_t s = 14695981039346656037ull;
    double l1 = 0;
    for (int y = 0; y < h; y++)
        for (int x = 0; x < w; x++) {
            int p = y * w + x;
            disp[p] = fx * -b / (D[p] + 1e-5);
            double x0 = floor(disp[p]);
            int c0 = x + (int)fmax(fmin(x0, 1e6), -1e6), ok = c0 >= 0 && c0 + 1 <= w - 1;
            m[p] = ok ? disp[p] : 0;
            s = mix(s, ok ? c0 : -7);
            for (int c = 0; c < 3 && ok; c++) {
                double v = (x0 + 1 - disp[p]) * shifted[3 * (y * w + c0) + c] +
                           (disp[p] - x0) * shifted[3 * (y * w + c0 + 1) + c];
                l1 += fabs(v - target[3 * p + c]);
                s = mix(s, sgn(v - target[3 * p + c]));
            }
        }
    l1 /= 3.0 * w * h;
    double smooth = 0;
    for (int y = 1; y < h - 1; y++)
        for (int x = 1; x < w - 1; x++) {
            int p = y * w + x;
            double gx = 0, gy = 0;
            for (int c = 0; c < 3; c++) {
                gx += 0.5 * (target[3 * (p + 1) + c] - target[3 * (p - 1) + c]);
                gy += 0.5 * (target[3 * (p + w) + c] - target[3 * (p - w) + c]);
            }
            double tx = exp(-0.33 * fabs(gx)) * 0.5 * (m[p + 1] - m[p - 1]);
            double ty = exp(-0.33 * fabs(gy)) * 0.5 * (m[p + w] - m[p - w]);
            smooth += fabs(tx) + fabs(ty);
            s = mix(mix(s, sgn(tx)), sgn(ty));
        }
    smooth /= (double)(w - 2) * (h - 2);
    *sig = s;
    return l1 + 0.05 * smooth;
}

typedef struct {
    double target[NPIX * 3], D[NPIX], shifted[NPIX * 3], fx, b;
} term_fd;

static double term_loss(void *ctx, uint64_t *sig)
{
    term_fd *c = ctx;
    return term_double(c->target, c->D, c->shifted, W, H, c->fx, c->b, sig);
}

/* A textured target and shifted render, and a depth whose disparities are 0.3-3 px, with a
 * band of transparent pixels (D = 0: outside after the warp) and a band of a hundred times
 * nearer ones (beyond the image edge). The term's value against the double version, its
 * gradients against central differences of it. */
static void test_term_gradients(void)
{
    static term_fd c;
    static float target[NPIX * 3], D[NPIX], shifted[NPIX * 3], d_shifted[NPIX * 3], d_D[NPIX];
    c.fx = 32, c.b = -0.09;
    for (int p = 0; p < NPIX; p++) {
        int x = p % W, y = p / W;
        for (int k = 0; k < 3; k++) {
            target[3 * p + k] = (float)(0.5 + 0.3 * sin(0.7 * x + 1.3 * k) * cos(0.4 * y) +
                                        0.1 * gv_uniform_at(1, 3 * (uint64_t)p + k));
            shifted[3 * p + k] = (float)(0.5 + 0.3 * sin(0.7 * x + 0.2 + 1.3 * k) * cos(0.4 * y) +
                                         0.1 * gv_uniform_at(2, 3 * (uint64_t)p + k));
        }
        D[p] = (float)(1 + 8 * gv_uniform_at(3, (uint64_t)p));
        if (y == 5) D[p] = 0;
        if (y == 9) D[p] *= 0.01f;
    }
    for (int i = 0; i < NPIX * 3; i++) c.target[i] = target[i], c.shifted[i] = shifted[i];
    for (int p = 0; p < NPIX; p++) c.D[p] = D[p];
    gv_splat_binocular_work work = {0};
    gv_splat_binocular_value value;
    REQUIRE(gv_splat_binocular_loss(&work, target, D, shifted, W, H, c.fx, c.b, 1.0, d_shifted,
                                    d_D, &value) == 0);
    uint64_t s0;
    double want = term_loss(&c, &s0);
    printf("  term: L1 %.5f, smoothness %.4f, %d of %d pixels inside; loss %.7f, double %.7f\n",
           value.l1, value.smoothness, value.valid_pixels, NPIX, value.loss, want);
    CHECK(fabs(value.loss - want) < 1e-6 * want);
    CHECK(value.valid_pixels > NPIX / 2 && value.valid_pixels < NPIX - W); /* both bands out */
    static fix_compare cs = {"shifted render", 0, 0, {0}, {0}}, cd = {"accumulated depth", 0, 0, {0}, {0}};
    for (int p = 0; p < NPIX; p += 3) {
        fix_add_params(&cs, term_loss, &c, s0, c.shifted + 3 * p, d_shifted + 3 * p, 3, 1e-6);
        fix_add_params(&cd, term_loss, &c, s0, c.D + p, d_D + p, 1, 1e-6 * fmax(c.D[p], 1e-3));
    }
    fix_report(&cs, 1e-3);
    fix_report(&cd, 1e-3);
    /* the weight scales the loss and both gradients */
    static float d_shifted2[NPIX * 3], d_D2[NPIX];
    gv_splat_binocular_value v2;
    REQUIRE(gv_splat_binocular_loss(&work, target, D, shifted, W, H, c.fx, c.b, 0.25, d_shifted2,
                                    d_D2, &v2) == 0);
    CHECK(fabs(v2.loss - 0.25 * value.loss) < 1e-12);
    double worst = 0;
    for (int p = 0; p < NPIX; p++) worst = fmax(worst, fabs(d_D2[p] - 0.25 * d_D[p]) / fmax(1e-9, fabs(d_D[p])));
    CHECK(worst < 1e-5);
    gv_splat_binocular_work_free(&work);
}

/* The warp's and the smoothness's own gradients (the term's test sees them only through
 * it): L = sum a . warped and L = smoothness(d, image), against central differences. */
typedef struct {
    double image[NPIX * 3], disp[NPIX], a[NPIX * 3];
} warp_fd;

static double warp_loss(void *ctx, uint64_t *sig)
{
    warp_fd *c = ctx;
    double loss = 0;
    uint64_t s = 1;
    for (int y = 0; y < H; y++)
        for (int x = 0; x < W; x++) {
            int p = y * W + x;
            double x0 = floor(c->disp[p]);
            int c0 = x + (int)x0, ok = c0 >= 0 && c0 + 1 <= W - 1;
            s = mix(s, ok ? c0 : -7);
            for (int k = 0; k < 3 && ok; k++)
                loss += c->a[3 * p + k] * ((x0 + 1 - c->disp[p]) * c->image[3 * (y * W + c0) + k] +
                                           (c->disp[p] - x0) * c->image[3 * (y * W + c0 + 1) + k]);
        }
    *sig = s;
    return loss;
}

static double smooth_loss(void *ctx, uint64_t *sig)
{
    warp_fd *c = ctx;
    double s = 0;
    uint64_t h = 1;
    for (int y = 1; y < H - 1; y++)
        for (int x = 1; x < W - 1; x++) {
            int p = y * W + x;
            double gx = 0, gy = 0;
            for (int k = 0; k < 3; k++) {
                gx += 0.5 * (c->image[3 * (p + 1) + k] - c->image[3 * (p - 1) + k]);
                gy += 0.5 * (c->image[3 * (p + W) + k] - c->image[3 * (p - W) + k]);
            }
            double tx = exp(-0.33 * fabs(gx)) * 0.5 * (c->disp[p + 1] - c->disp[p - 1]);
            double ty = exp(-0.33 * fabs(gy)) * 0.5 * (c->disp[p + W] - c->disp[p - W]);
            s += fabs(tx) + fabs(ty);
            h = mix(mix(h, sgn(tx)), sgn(ty));
        }
    *sig = h;
    return s / ((double)(W - 2) * (H - 2));
}

static void test_warp_and_smoothness_gradients(void)
{
    static warp_fd c;
    static float image[NPIX * 3], disp[NPIX], a[NPIX * 3], warped[NPIX * 3], valid[NPIX];
    static float d_image[NPIX * 3], d_disp[NPIX], d_smooth[NPIX];
    for (int i = 0; i < NPIX * 3; i++) {
        image[i] = (float)gv_uniform_at(11, (uint64_t)i);
        a[i] = (float)(2 * gv_uniform_at(12, (uint64_t)i) - 1);
        c.image[i] = image[i], c.a[i] = a[i], d_image[i] = 0;
    }
    for (int p = 0; p < NPIX; p++) {
        /* away from integers, where x0 jumps; some past either edge */
        double k = floor(9 * gv_uniform_at(13, (uint64_t)p)) - 4, f = 0.1 + 0.8 * gv_uniform_at(14, (uint64_t)p);
        c.disp[p] = disp[p] = (float)(k + f);
        d_smooth[p] = 0;
    }
    gv_splat_warp_rows(image, W, H, disp, warped, valid);
    gv_splat_warp_rows_backward(image, W, H, disp, a, d_image, d_disp);
    double smooth = gv_splat_edge_smoothness(disp, image, W, H, d_smooth);
    uint64_t s0, s1;
    warp_loss(&c, &s0);
    CHECK(fabs(smooth_loss(&c, &s1) - smooth) < 1e-6);
    static fix_compare ci = {"warp: image", 0, 0, {0}, {0}}, cdisp = {"warp: disparity", 0, 0, {0}, {0}};
    static fix_compare csm = {"smoothness: disparity", 0, 0, {0}, {0}};
    for (int p = 0; p < NPIX; p++) {
        if (p % 2 == 0) fix_add_params(&ci, warp_loss, &c, s0, c.image + 3 * p, d_image + 3 * p, 3, 1e-6);
        fix_add_params(&cdisp, warp_loss, &c, s0, c.disp + p, d_disp + p, 1, 1e-6);
        fix_add_params(&csm, smooth_loss, &c, s1, c.disp + p, d_smooth + p, 1, 1e-6);
    }
    fix_report(&ci, 1e-4);
    fix_report(&cdisp, 1e-4);
    fix_report(&csm, 1e-3); /* float sums of +- terms that cancel: 1e-10 absolute */
}

/* The shifted camera: centre moved by b along the camera's x axis, rotation and intrinsics
 * kept; a point at view depth z moves by -fx b / z pixels. */
static void test_shifted_view(void)
{
    gv_splat_view v, s;
    fix_view(&v, W, H, 21);
    gv_splat_view_shifted(&v, 0.3, &s);
    double right[3] = {v.R[0], v.R[1], v.R[2]};
    for (int a = 0; a < 3; a++) CHECK_NEAR(s.campos[a] - v.campos[a], 0.3 * right[a], 1e-6);
    CHECK(memcmp(s.R, v.R, sizeof v.R) == 0 && s.fx == v.fx && s.cx == v.cx && s.width == v.width);
    float X[3];
    fix_unproject(&v, 17.3, 9.1, 4.0, X); /* pixel (17.3, 9.1) at depth 4 */
    double c[3];
    for (int a = 0; a < 3; a++) c[a] = s.R[3 * a] * X[0] + s.R[3 * a + 1] * X[1] + s.R[3 * a + 2] * X[2] + s.t[a];
    CHECK_NEAR(c[2], 4.0, 1e-5);
    CHECK_NEAR(s.fx * c[0] / c[2] + s.cx, 17.3 - v.fx * 0.3 / 4.0, 1e-4);
    CHECK_NEAR(s.fy * c[1] / c[2] + s.cy, 9.1, 1e-4);
}

/* ---- through the renders --------------------------------------------------------------- */

enum { N3 = 60 };

typedef struct {
    const gv_splat_view *view, *moved;
    const double *target;
    double fx, b;
    double means[3 * N3], sh[3 * N3], opacities[N3], scales[3 * N3], rotations[4 * N3];
} render_fd;

/* The term from the double reference: D of the training view (the rasteriser blending
 * (z, 0, 0)), the shifted view's render, then term_double. */
static double render_loss(void *ctx, uint64_t *signature)
{
    render_fd *c = ctx;
    static double D[NPIX], shifted[NPIX * 3];
    double bg[3] = {0.1, 0.2, 0.3};
    uint64_t s1, s2, s3;
    fix_reference_depth_sum(N3, c->means, c->scales, c->rotations, c->opacities, c->view, D, &s1);
    gv_splat_reference_render(N3, 0, 0, c->means, c->sh, c->opacities, c->scales, c->rotations,
                              c->moved, bg, shifted, &s2);
    double loss = term_double(c->target, D, shifted, W, H, c->fx, c->b, &s3);
    *signature = mix(mix(s1, (int64_t)s2), (int64_t)s3);
    return loss;
}

static void test_through_renders(void)
{
    gv_splat_view v, moved;
    fix_view(&v, W, H, 31);
    const double b = 0.12;
    gv_splat_view_shifted(&v, b, &moved);
    gv_gaussians g, grad, grad_moved;
    fix_gaussians(&g, N3, 0, &v, 32);
    for (int i = 0; i < N3; i++) g.opacities[i] = fminf(g.opacities[i] + 1.0f, 2.0f); /* <= 0.88 */
    CHECK(gv_gaussians_alloc(&grad, N3, 0) == 0 && gv_gaussians_alloc(&grad_moved, N3, 0) == 0);
    static float image[NPIX * 3], shifted[NPIX * 3], target[NPIX * 3], D[NPIX];
    static float d_shifted[NPIX * 3], d_D[NPIX], zero_image[NPIX * 3];
    static double target_d[NPIX * 3];
    for (int i = 0; i < NPIX * 3; i++) target[i] = (float)(target_d[i] = gv_uniform_at(33, (uint64_t)i));
    const float bg[3] = {0.1f, 0.2f, 0.3f};
    gv_splat_renderer r = {0}, rm = {0};
    gv_splat_binocular_work work = {0};
    gv_splat_binocular_value value;
    REQUIRE(gv_splat_render_forward(&r, &g, &v, 0, bg, image) == 0);
    REQUIRE(gv_splat_render_depth_sum(&r, D) == 0);
    REQUIRE(gv_splat_render_forward(&rm, &g, &moved, 0, bg, shifted) == 0);
    REQUIRE(gv_splat_binocular_loss(&work, target, D, shifted, W, H, v.fx, b, 1.0, d_shifted, d_D,
                                    &value) == 0);
    REQUIRE(gv_splat_render_backward(&rm, &g, d_shifted, &grad_moved, NULL) == 0);
    REQUIRE(gv_splat_render_backward_depth(&r, &g, zero_image, d_D, &grad, NULL) == 0);
    /* the two renders' gradients, summed where each saw the Gaussian */
    for (int i = 0; i < N3; i++) {
        int in_view = r.radii[i] > 0, in_moved = rm.radii[i] > 0;
        for (int a = 0; a < 3; a++)
            grad.means[3 * i + a] = (in_view ? grad.means[3 * i + a] : 0) + (in_moved ? grad_moved.means[3 * i + a] : 0);
        grad.opacities[i] = (in_view ? grad.opacities[i] : 0) + (in_moved ? grad_moved.opacities[i] : 0);
        for (int a = 0; a < 3; a++)
            grad.scales[3 * i + a] = (in_view ? grad.scales[3 * i + a] : 0) + (in_moved ? grad_moved.scales[3 * i + a] : 0);
        grad.sh[3 * i] = in_moved ? grad_moved.sh[3 * i] : 0; /* the depth has no colour */
    }
    static render_fd c;
    c.view = &v, c.moved = &moved, c.target = target_d, c.fx = v.fx, c.b = b;
    for (int i = 0; i < 3 * N3; i++) c.means[i] = g.means[i], c.scales[i] = g.scales[i], c.sh[i] = g.sh[i];
    for (int i = 0; i < 4 * N3; i++) c.rotations[i] = g.rotations[i];
    for (int i = 0; i < N3; i++) c.opacities[i] = g.opacities[i];
    uint64_t s0;
    double want = render_loss(&c, &s0);
    printf("  through the renders (baseline %.2f, %d of %d pixels inside): loss %.6f, double "
           "reference %.6f\n", b, value.valid_pixels, NPIX, value.loss, want);
    CHECK(fabs(value.loss - want) < 1e-4 * want);
    CHECK(value.valid_pixels > NPIX / 3);
    static fix_compare cm = {"means (both renders)", 0, 0, {0}, {0}};
    static fix_compare co = {"opacity logits", 0, 0, {0}, {0}}, cs = {"log-scales", 0, 0, {0}, {0}};
    static fix_compare csh = {"SH DC (shifted render)", 0, 0, {0}, {0}};
    for (int i = 0; i < N3; i++) {
        gv_splat_ref_projection p1, p2;
        int v1 = gv_splat_reference_project(c.means + 3 * i, c.scales + 3 * i, c.rotations + 4 * i, &v, &p1);
        int v2 = gv_splat_reference_project(c.means + 3 * i, c.scales + 3 * i, c.rotations + 4 * i, &moved, &p2);
        if ((!v1 && !v2) || (v1 && (p1.clamp_x || p1.clamp_y)) || (v2 && (p2.clamp_x || p2.clamp_y)))
            continue; /* the clamped Jacobian's gradient is 3DGS's, not exact */
        fix_add_params(&cm, render_loss, &c, s0, c.means + 3 * i, grad.means + 3 * i, 3, 1e-6);
        fix_add_params(&co, render_loss, &c, s0, c.opacities + i, grad.opacities + i, 1, 1e-6);
        fix_add_params(&cs, render_loss, &c, s0, c.scales + 3 * i, grad.scales + 3 * i, 3, 1e-6);
        fix_add_params(&csh, render_loss, &c, s0, c.sh + 3 * i, grad.sh + 3 * i, 1, 1e-6);
    }
    fix_report(&cm, 5e-3);
    fix_report(&co, 5e-3);
    fix_report(&cs, 5e-3);
    fix_report(&csh, 5e-3);
    gv_splat_binocular_work_free(&work);
    gv_splat_renderer_free(&r), gv_splat_renderer_free(&rm);
    gv_gaussians_free(&g), gv_gaussians_free(&grad), gv_gaussians_free(&grad_moved);
}

/* The baseline's scale: the median depth of the centres inside the views. */
static void test_median_depth(void)
{
    gv_splat_view v;
    double R[9] = {1, 0, 0, 0, 1, 0, 0, 0, 1}, t[3] = {0, 0, 0};
    CHECK(gv_splat_view_init(&v, W, H, 20, 20, 20, 12, R, t) == 0);
    gv_gaussians g;
    CHECK(gv_gaussians_alloc(&g, 5, 0) == 0);
    /* on the axis at 2, 3, 7; one behind the camera; one outside the image (x / z = 2) */
    float means[15] = {0, 0, 2, 0, 0, 7, 0, 0, 3, 0, 0, -4, 10, 0, 5};
    memcpy(g.means, means, sizeof means);
    CHECK_NEAR(gv_splat_median_view_depth(&g, 1, &v), 3, 1e-6);
    gv_splat_view two[2] = {v, v};
    two[1].t[2] = 1; /* the second sees them 1 further: 2, 3, 3, 4, 7, 8 -> 3.5 */
    CHECK_NEAR(gv_splat_median_view_depth(&g, 2, two), 3.5, 1e-6);
    g.n = 0;
    CHECK(gv_splat_median_view_depth(&g, 1, &v) == 0);
    gv_gaussians_free(&g);
}

int main(void)
{
    test_parse();
    test_warp_by_hand();
    test_warp_and_smoothness_gradients();
    test_term_gradients();
    test_shifted_view();
    test_median_depth();
    test_through_renders();
    return check_summary();
}
