/* Plücker ray fields (paper 3.3.1, docs/ARCHITECTURE.md 6.4): hand-computed rays of hand-built cameras,
 * invariance of the encoder's input under a global rigid motion and a global scale of all
 * cameras, the temporal packing, and bad cameras. */
#include "check.h"
#include "gaussvid/core/core.h"
#include "gaussvid/model/plucker.h"

static gv_camera camera(double fx, double cx, const double R[9], const double t[3])
{
    gv_camera c;
    memset(&c, 0, sizeof c);
    c.width = c.height = 2;
    c.fx = c.fy = fx;
    c.cx = c.cy = cx;
    memcpy(c.R, R, sizeof c.R);
    memcpy(c.t, t, sizeof c.t);
    return c;
}

static const double I3[9] = {1, 0, 0, 0, 1, 0, 0, 0, 1};

static void test_hand_values(void)
{
    const double zero[3] = {0, 0, 0}, shifted[3] = {-1, 0, 0};
    gv_camera ref = camera(2, 1, I3, zero), side = camera(2, 1, I3, shifted);
    float r[6 * 4];
    /* pixel (0, 0): centre (0.5, 0.5), camera direction (-0.25, -0.25, 1) / sqrt(1.125) */
    CHECK(gv_plucker_rays(&ref, &ref, 1.0, 2, 2, r) == 0);
    double n = sqrt(1.125);
    CHECK_NEAR(r[3 * 4], -0.25 / n, 1e-7);
    CHECK_NEAR(r[4 * 4], -0.25 / n, 1e-7);
    CHECK_NEAR(r[5 * 4], 1.0 / n, 1e-7);
    CHECK(r[0] == 0 && r[4] == 0 && r[8] == 0); /* centre at the origin: no moment */
    /* pixel (1, 0) (x = 1, y = 0): direction (0.25, -0.25, 1) / n */
    CHECK_NEAR(r[3 * 4 + 1], 0.25 / n, 1e-7);
    /* camera centre C = -R^T t = (1, 0, 0): m = C x d = (0, -d_z, d_y) */
    CHECK(gv_plucker_rays(&side, &ref, 1.0, 2, 2, r) == 0);
    CHECK_NEAR(r[0 * 4], 0.0, 1e-7);
    CHECK_NEAR(r[1 * 4], -1.0 / n, 1e-7);
    CHECK_NEAR(r[2 * 4], -0.25 / n, 1e-7);
    /* translation scale 2 halves the moments */
    CHECK(gv_plucker_rays(&side, &ref, 2.0, 2, 2, r) == 0);
    CHECK_NEAR(r[1 * 4], -0.5 / n, 1e-7);
    /* a camera turned 90 degrees about y: its optical axis is R^T e_z = (1, 0, 0) in the
     * reference frame; pixel (0, 0) lies on the axis when cx = cy = 0.5 */
    const double turn[9] = {0, 0, -1, 0, 1, 0, 1, 0, 0};
    gv_camera turned = camera(2, 0.5, turn, zero);
    CHECK(gv_plucker_rays(&turned, &ref, 1.0, 2, 2, r) == 0);
    CHECK_NEAR(r[3 * 4], 1.0, 1e-7);
    CHECK_NEAR(r[4 * 4], 0.0, 1e-7);
    CHECK_NEAR(r[5 * 4], 0.0, 1e-7);
    /* ... and in its own frame the same ray is (0, 0, 1) */
    CHECK(gv_plucker_rays(&turned, &turned, 1.0, 2, 2, r) == 0);
    CHECK_NEAR(r[3 * 4], 0.0, 1e-7);
    CHECK_NEAR(r[5 * 4], 1.0, 1e-7);
}

/* A path of 5 cameras looking at a scene, moving and turning. */
static void path(gv_camera *cams, int n)
{
    for (int f = 0; f < n; f++) {
        double a = 0.1 * f - 0.2, b = 0.05 * f;
        double ca = cos(a), sa = sin(a), cb = cos(b), sb = sin(b);
        /* R = Rx(b) Ry(a) */
        double Ry[9] = {ca, 0, sa, 0, 1, 0, -sa, 0, ca}, Rx[9] = {1, 0, 0, 0, cb, -sb, 0, sb, cb}, R[9];
        for (int i = 0; i < 3; i++)
            for (int j = 0; j < 3; j++) R[i * 3 + j] = Rx[i * 3] * Ry[j] + Rx[i * 3 + 1] * Ry[3 + j] + Rx[i * 3 + 2] * Ry[6 + j];
        double t[3] = {0.4 * f - 1.0, 0.1 * f, 3.0 - 0.2 * f};
        cams[f] = camera(20, 8.2, R, t);
        cams[f].fy = 21, cams[f].cy = 7.7;
    }
}

/* World' = s Q X + p: w2c' = [R Q^T | s t - R Q^T p]. */
static void move_all(gv_camera *cams, int n, const double Q[9], const double p[3], double s)
{
    for (int f = 0; f < n; f++) {
        double R2[9], t2[3];
        for (int i = 0; i < 3; i++)
            for (int j = 0; j < 3; j++)
                R2[i * 3 + j] = cams[f].R[i * 3] * Q[j * 3] + cams[f].R[i * 3 + 1] * Q[j * 3 + 1] + cams[f].R[i * 3 + 2] * Q[j * 3 + 2];
        for (int i = 0; i < 3; i++) t2[i] = s * cams[f].t[i] - (R2[i * 3] * p[0] + R2[i * 3 + 1] * p[1] + R2[i * 3 + 2] * p[2]);
        memcpy(cams[f].R, R2, sizeof R2);
        memcpy(cams[f].t, t2, sizeof t2);
    }
}

static void test_invariance(void)
{
    enum { T = 5, H = 16, W = 16, P = T + 3 };
    gv_camera cams[T];
    path(cams, T);
    static float a[6 * P * H * W], b[6 * P * H * W];
    double scale_a, scale_b;
    CHECK(gv_plucker_field(cams, T, H, W, 4, a, &scale_a) == 0);
    double c = cos(0.7), s = sin(0.7); /* rotation about (1, 1, 1) / sqrt 3 by 0.7 rad */
    double k = 1 / sqrt(3.0), Q[9];
    double K[9] = {0, -k, k, k, 0, -k, -k, k, 0};
    for (int i = 0; i < 9; i++) {
        double K2 = 0;
        for (int j = 0; j < 3; j++) K2 += K[(i / 3) * 3 + j] * K[j * 3 + i % 3];
        Q[i] = (i % 4 == 0) + s * K[i] + (1 - c) * K2;
    }
    const double p[3] = {5, -2, 7};
    move_all(cams, T, Q, p, 3.5);
    CHECK(gv_plucker_field(cams, T, H, W, 4, b, &scale_b) == 0);
    CHECK_NEAR(scale_b, 3.5 * scale_a, 1e-9);
    double worst = 0, big = 0;
    for (int i = 0; i < 6 * P * H * W; i++) {
        if (fabs(a[i] - b[i]) > worst) worst = fabs(a[i] - b[i]);
        if (fabs(a[i]) > big) big = fabs(a[i]);
    }
    printf("rigid motion + scale 3.5: max |field change| %.2e (field max %.2f)\n", worst, big);
    CHECK(worst < 1e-5 && big > 0.1);
}

static void test_packing(void)
{
    enum { T = 5, H = 4, W = 6 };
    gv_camera cams[T];
    path(cams, T);
    CHECK(gv_plucker_packed_frames(5, 4) == 8 && gv_plucker_packed_frames(9, 4) == 12 && gv_plucker_packed_frames(1, 4) == 4);
    CHECK(gv_plucker_packed_frames(5, 1) == 5 && gv_plucker_packed_frames(4, 4) == -1 && gv_plucker_packed_frames(0, 1) == -1);
    static float field[6 * 8 * H * W], one[6 * H * W];
    double scale;
    CHECK(gv_plucker_field(cams, T, H, W, 4, field, &scale) == 0);
    /* packed slots 0..3 hold frame 0 (docs/reference/wan-vace-gaussvid.md 1.4: frame 0 repeated),
     * slot 4 + f - 1 frame f */
    const int source[8] = {0, 0, 0, 0, 1, 2, 3, 4};
    int ok = 1;
    for (int slot = 0; slot < 8; slot++) {
        CHECK(gv_plucker_rays(&cams[source[slot]], &cams[0], scale, H, W, one) == 0);
        for (int c = 0; c < 6; c++)
            ok &= !memcmp(field + ((size_t)c * 8 + slot) * H * W, one + (size_t)c * H * W, sizeof(float) * H * W);
    }
    CHECK(ok);
    static float flat[6 * 5 * H * W];
    CHECK(gv_plucker_field(cams, T, H, W, 1, flat, NULL) == 0);
    CHECK(!memcmp(flat + 2 * H * W, field + 5 * H * W, sizeof(float) * H * W)); /* frame 2, slot 5 */
    CHECK_FAILS_WITH(gv_plucker_field(cams, 4, H, W, 4, flat, NULL), "do not pack");
    /* every centre in one place: scale 1, zero moments */
    gv_camera same[2] = {cams[0], cams[0]};
    CHECK(gv_plucker_scale(same, 2) == 1.0);
}

static void test_bad_cameras(void)
{
    const double zero[3] = {0, 0, 0};
    gv_camera ref = camera(2, 1, I3, zero), bad = ref;
    float r[6 * 4];
    bad.R[0] = 1.5;
    CHECK_FAILS_WITH(gv_plucker_rays(&bad, &ref, 1.0, 2, 2, r), "R is not a rotation");
    bad = ref, bad.fx = 0;
    CHECK_FAILS_WITH(gv_plucker_rays(&bad, &ref, 1.0, 2, 2, r), "focal");
    bad = ref, bad.t[1] = NAN;
    CHECK_FAILS_WITH(gv_plucker_rays(&bad, &ref, 1.0, 2, 2, r), "translation");
    CHECK_FAILS_WITH(gv_plucker_rays(&ref, &ref, 0.0, 2, 2, r), "scale");
    CHECK_FAILS_WITH(gv_plucker_rays(&ref, &ref, 1.0, 0, 2, r), "image size");
    gv_camera clip[5] = {ref, ref, ref, bad, ref};
    clip[3].fy = -1;
    static float field[6 * 8 * 4];
    CHECK_FAILS_WITH(gv_plucker_field(clip, 5, 2, 2, 4, field, NULL), "frame 3");
}

int main(void)
{
    test_hand_values();
    test_invariance();
    test_packing();
    test_bad_cameras();
    return check_summary();
}
