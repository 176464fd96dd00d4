/* CoR-GS's co-pruning (src/splat/corgs.c) on a hand-built pair of fields: which rows each
 * field loses, the order of the rest, the Adam moments following their rows, an empty
 * field; and the pseudo-view cameras between two training views (src/splat/camera_path.c:
 * rotation by slerp, centre and intrinsics linearly) against hand-derived poses; the
 * pseudo-view term's gradient for both fields against central finite differences of its
 * loss. */
#include "gaussvid/splat/render.h"
#include "gaussvid/scene/scene.h"
#include "gaussvid/splat/splat_train.h"
#include "splat_fixtures.h"

static void make_field(gv_gaussians *g, gv_splat_adam *adam, int n, const float (*xyz)[3])
{
    CHECK(gv_gaussians_alloc(g, n, 0) == 0);
    for (int i = 0; i < n; i++) {
        for (int a = 0; a < 3; a++) g->means[3 * i + a] = xyz[i][a], g->scales[3 * i + a] = -3;
        g->rotations[4 * i] = 1, g->opacities[i] = (float)i;
    }
    gv_splat_adam_config c;
    gv_splat_adam_defaults(&c);
    CHECK(gv_splat_adam_init(adam, &c, g, 1.0) == 0);
    for (int i = 0; i < n; i++) adam->m.opacities[i] = adam->v.opacities[i] = (float)(10 + i);
}

/* The rows left are the listed ones of the original, in order, with their moments. */
static void check_rows(const gv_gaussians *g, const gv_splat_adam *adam, const float (*xyz)[3],
                       const int *kept, int n_kept)
{
    CHECK(g->n == n_kept && adam->m.n == n_kept && adam->v.n == n_kept);
    for (int r = 0; r < n_kept && r < g->n; r++) {
        int i = kept[r];
        for (int a = 0; a < 3; a++) CHECK(g->means[3 * r + a] == xyz[i][a]);
        CHECK(g->opacities[r] == (float)i);
        CHECK(adam->m.opacities[r] == (float)(10 + i) && adam->v.opacities[r] == (float)(10 + i));
    }
}

static void test_coprune(void)
{
    /* tau = 0.1. Field a: (7, 0, 0) has nothing of b near it; the others have a partner
     * within 0.02-0.09 (the isolated pair (5, 5, 5) - (5, 5, 5.05) keeps both). Field b:
     * (9, 9, 9) is 6.9 from a's nearest, (0, 2.3, 0) is 0.3 from (0, 2, 0); the rest within
     * 0.09. */
    const float xa[5][3] = {{0, 0, 0}, {1, 0, 0}, {5, 5, 5}, {0, 2, 0}, {7, 0, 0}};
    const float xb[7][3] = {{0.05f, 0, 0}, {1, 0.02f, 0}, {9, 9, 9}, {0, 0, 0.04f},
                            {0, 2.09f, 0}, {0, 2.3f, 0}, {5, 5, 5.05f}};
    gv_gaussians a, b;
    gv_splat_adam adam_a, adam_b;
    make_field(&a, &adam_a, 5, xa);
    make_field(&b, &adam_b, 7, xb);
    int pa = -1, pb = -1;
    CHECK(gv_splat_corgs_coprune(&a, &adam_a, &b, &adam_b, 0.1, &pa, &pb) == 0);
    CHECK(pa == 1 && pb == 2);
    const int kept_a[4] = {0, 1, 2, 3}, kept_b[5] = {0, 1, 3, 4, 6};
    check_rows(&a, &adam_a, xa, kept_a, 4);
    check_rows(&b, &adam_b, xb, kept_b, 5);
    /* Again: every Gaussian left has its partner, nothing more goes. */
    CHECK(gv_splat_corgs_coprune(&a, &adam_a, &b, &adam_b, 0.1, &pa, &pb) == 0);
    CHECK(pa == 0 && pb == 0 && a.n == 4 && b.n == 5);
    /* A smaller tau takes the pairs 0.05-0.09 apart: a keeps (1, 0, 0) (0.02) and (0, 0, 0)
     * (0.04 from b's (0, 0, 0.04)); b keeps (1, 0.02, 0) and (0, 0, 0.04). */
    CHECK(gv_splat_corgs_coprune(&a, &adam_a, &b, &adam_b, 0.045, &pa, &pb) == 0);
    const int kept_a2[2] = {0, 1}, kept_b2[2] = {1, 3};
    CHECK(pa == 2 && pb == 3);
    check_rows(&a, &adam_a, xa, kept_a2, 2);
    check_rows(&b, &adam_b, xb, kept_b2, 2);
    /* An empty field prunes nothing of the other. */
    b.n = adam_b.m.n = adam_b.v.n = 0;
    CHECK(gv_splat_corgs_coprune(&a, &adam_a, &b, &adam_b, 0.1, &pa, &pb) == 0);
    CHECK(pa == 0 && pb == 0 && a.n == 2);
    gv_gaussians_free(&a), gv_gaussians_free(&b);
    gv_splat_adam_free(&adam_a), gv_splat_adam_free(&adam_b);
}

/* A camera with world-to-camera rotation Rz(theta) and centre c. */
static void camera_at(gv_camera *cam, double theta, const double c[3], double f)
{
    memset(cam, 0, sizeof *cam);
    cam->width = 64, cam->height = 48, cam->fx = cam->fy = f, cam->cx = 32, cam->cy = 24;
    double R[9] = {cos(theta), -sin(theta), 0, sin(theta), cos(theta), 0, 0, 0, 1};
    memcpy(cam->R, R, sizeof R);
    for (int i = 0; i < 3; i++) cam->t[i] = -(R[3 * i] * c[0] + R[3 * i + 1] * c[1] + R[3 * i + 2] * c[2]);
}

static void test_pseudo_cameras(void)
{
    const double ca[3] = {0, 0, 0}, cb[3] = {2, 4, -2}, pi = acos(-1.0);
    gv_camera a, b, mid, expect;
    camera_at(&a, 0, ca, 100);
    camera_at(&b, pi / 2, cb, 200);
    const double s_list[4] = {0, 0.25, 0.5, 1};
    for (int k = 0; k < 4; k++) {
        double s = s_list[k], c[3], centre[3];
        for (int i = 0; i < 3; i++) c[i] = (1 - s) * ca[i] + s * cb[i];
        /* slerp between Rz(0) and Rz(90 degrees) at s is Rz(90 s degrees) */
        camera_at(&expect, s * pi / 2, c, 100 + 100 * s);
        gv_camera_interpolate(&a, &b, s, &mid);
        gv_camera_center(&mid, centre);
        for (int i = 0; i < 9; i++) CHECK_NEAR(mid.R[i], expect.R[i], 1e-12);
        for (int i = 0; i < 3; i++) CHECK_NEAR(mid.t[i], expect.t[i], 1e-12);
        for (int i = 0; i < 3; i++) CHECK_NEAR(centre[i], c[i], 1e-12);
        CHECK_NEAR(mid.fx, 100 + 100 * s, 1e-12);
        CHECK(mid.width == 64 && mid.height == 48);
    }
    /* Half-way between Rz(0) and Rz(90): Rz(45), centre (1, 2, -1), f = 150, written out. */
    gv_camera_interpolate(&a, &b, 0.5, &mid);
    double h = sqrt(0.5);
    CHECK_NEAR(mid.R[0], h, 1e-12);
    CHECK_NEAR(mid.R[1], -h, 1e-12);
    CHECK_NEAR(mid.R[3], h, 1e-12);
    CHECK_NEAR(mid.R[8], 1, 1e-12);
    CHECK_NEAR(mid.t[0], -(h * 1 - h * 2), 1e-12); /* -R c */
    CHECK_NEAR(mid.t[1], -(h * 1 + h * 2), 1e-12);
    CHECK_NEAR(mid.t[2], 1, 1e-12);
    CHECK_NEAR(mid.fx, 150, 1e-12);
}

/* The pair's loss from the double reference renderer (its signature of discrete decisions
 * lets the differences step around the 1/255 cut), on the float32 loss of the renders. */
enum { PN = 24, PW = 40, PH = 24 };
typedef struct {
    double means[2][3 * PN], sh[2][3 * PN], opacities[2][PN], scales[2][3 * PN], rotations[2][4 * PN];
    double image[PW * PH * 3];
    float render[2][PW * PH * 3];
    gv_splat_loss_work work;
    const gv_splat_view *view;
    double lambda;
} pair_fd;

static double pair_loss(void *ctx, uint64_t *signature)
{
    pair_fd *p = ctx;
    const double bg[3] = {0, 0, 0};
    *signature = 0;
    for (int k = 0; k < 2; k++) {
        uint64_t sig;
        gv_splat_reference_render(PN, 0, 0, p->means[k], p->sh[k], p->opacities[k], p->scales[k],
                                  p->rotations[k], p->view, bg, p->image, &sig);
        *signature = *signature * 1000003u + sig;
        for (int i = 0; i < PW * PH * 3; i++) p->render[k][i] = (float)p->image[i];
    }
    gv_splat_loss_value v;
    CHECK(gv_splat_loss(&p->work, p->render[0], p->render[1], PW, PH, p->lambda, NULL, &v) == 0);
    return 0.7 * v.loss;
}

static void to_doubles(const float *x, int n, double *out)
{
    for (int i = 0; i < n; i++) out[i] = x[i];
}

/* Field 1 is field 0 with every colour 0.3 brighter, so the L1 term has no kink near the
 * renders (they differ by at least 0.3/255 wherever either is drawn) and central
 * differences are exact up to rounding. The SSIM term's gradient is the training loss's
 * (tests/test_splat_loss.c checks it against a double SSIM; float32 moments are too coarse
 * for differences here); what this term adds is its use with each render as the other's
 * target, which needs the loss to be symmetric: test_loss_symmetry. */
static void test_pseudo_gradient(double lambda, double h, double tol)
{
    gv_splat_view view;
    fix_view(&view, PW, PH, 71);
    gv_gaussians g[2], grad[2];
    static pair_fd p;
    p.view = &view, p.lambda = lambda;
    for (int k = 0; k < 2; k++) {
        fix_gaussians(&g[k], PN, 0, &view, 72 + (uint64_t)(lambda > 0 ? k : 0));
        for (int i = 0; i < 3 * PN && lambda == 0 && k == 1; i++) g[k].sh[i] += (float)(0.3 / FIX_C0);
        CHECK(gv_gaussians_alloc(&grad[k], PN, 0) == 0);
        to_doubles(g[k].means, 3 * PN, p.means[k]), to_doubles(g[k].sh, 3 * PN, p.sh[k]);
        to_doubles(g[k].opacities, PN, p.opacities[k]), to_doubles(g[k].scales, 3 * PN, p.scales[k]);
        to_doubles(g[k].rotations, 4 * PN, p.rotations[k]);
    }
    gv_splat_corgs c;
    memset(&c, 0, sizeof c);
    double loss;
    CHECK(gv_splat_corgs_pseudo_grad(&c, &g[0], &g[1], &view, 0, lambda, 0.7, &grad[0], &grad[1], &loss) == 0);
    uint64_t s0;
    double reference = pair_loss(&p, &s0);
    printf("  lambda %g: pseudo-view loss %.6f, from the reference renders %.6f\n", lambda, loss, reference);
    CHECK_NEAR(loss, reference, 1e-5);
    static fix_compare cmp[3] = {{"pseudo: opacity logits", 0, 0, {0}, {0}},
                                 {"pseudo: SH DC", 0, 0, {0}, {0}},
                                 {"pseudo: means", 0, 0, {0}, {0}}};
    for (int k = 0; k < 2; k++)
        for (int m = 0; m < c.renderer[k].tiles.n_visible; m++) {
            int i = c.renderer[k].tiles.visible[m];
            double num;
            struct { double *param; const float *analytic; int count; int kind; } kinds[3] = {
                {p.opacities[k] + i, grad[k].opacities + i, 1, 0},
                {p.sh[k] + 3 * i, grad[k].sh + 3 * i, 3, 1},
                {p.means[k] + 3 * i, grad[k].means + 3 * i, 3, 2}};
            for (int q = 0; q < 3; q++)
                for (int j = 0; j < kinds[q].count; j++) {
                    if (fix_derivative(pair_loss, &p, s0, kinds[q].param + j, h, &num))
                        cmp[q].skipped++;
                    else
                        fix_add(&cmp[q], kinds[q].analytic[j], num);
                }
        }
    for (int q = 0; q < 3; q++) fix_report(&cmp[q], tol), cmp[q].count = cmp[q].skipped = 0;
    for (int k = 0; k < 2; k++) gv_gaussians_free(&g[k]), gv_gaussians_free(&grad[k]);
    gv_splat_corgs_free(&c);
    gv_splat_loss_free(&p.work);
}

/* L(a, b) = L(b, a) for the training loss's form at lambda 0.2. */
static void test_loss_symmetry(void)
{
    enum { W = 37, H = 23 };
    static float a[W * H * 3], b[W * H * 3];
    for (int i = 0; i < W * H * 3; i++) {
        a[i] = (float)gv_uniform_at(81, (uint64_t)i);
        b[i] = (float)(0.5 * a[i] + 0.5 * gv_uniform_at(82, (uint64_t)i));
    }
    gv_splat_loss_work w;
    memset(&w, 0, sizeof w);
    gv_splat_loss_value ab, ba;
    CHECK(gv_splat_loss(&w, a, b, W, H, 0.2, NULL, &ab) == 0);
    CHECK(gv_splat_loss(&w, b, a, W, H, 0.2, NULL, &ba) == 0);
    printf("  L(a, b) %.9f, L(b, a) %.9f\n", ab.loss, ba.loss);
    CHECK(ab.l1 == ba.l1);
    CHECK_NEAR(ab.ssim, ba.ssim, 1e-6);
    gv_splat_loss_free(&w);
}

int main(void)
{
    test_pseudo_gradient(0.0, 1e-4, 1e-2);
    test_loss_symmetry();
    test_coprune();
    test_pseudo_cameras();
    return check_summary();
}
