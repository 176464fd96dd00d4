/* CoR-GS's co-pruning (src/splat/corgs.c) on a hand-built pair of fields: which rows each
 * field loses, the order of the rest, the Adam moments following their rows, an empty
 * field; and the pseudo-view cameras between two training views (src/splat/camera_path.c:
 * rotation by slerp, centre and intrinsics linearly) against hand-derived poses. */
#include "check.h"
#include "gaussvid/core.h"
#include "gaussvid/scene.h"
#include "gaussvid/splat_train.h"

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

int main(void)
{
    test_coprune();
    test_pseudo_cameras();
    return check_summary();
}
