/* Reprojection by depth and the anchor warp with its occlusion test (src/scene/reproject.c):
 * the plane z = 5 seen by a target camera at the origin lands on hand-derived pixels of
 * anchors that are translated sideways, rotated 180 degrees about the axis, or closer and of
 * another size; pixels hidden behind a nearer surface in the anchor, or without depth, are
 * not covered; a depth edge keeps the far side's colour out of the interpolation. */
#include <stdint.h>

#include "check.h"
#include "gaussvid/core/core.h"
#include "gaussvid/scene/reproject.h"

enum { W = 40, H = 24 };

/* A camera of size w x h with focal f and principal point (cx, cy), world-to-camera R and
 * centre C (t = -R C). */
static gv_camera camera(int w, int h, double f, double cx, double cy, const double R[9],
                        const double C[3])
{
    gv_camera c = {.width = w, .height = h, .fx = f, .fy = f, .cx = cx, .cy = cy};
    for (int k = 0; k < 9; k++) c.R[k] = R[k];
    for (int k = 0; k < 3; k++) c.t[k] = -(R[3 * k] * C[0] + R[3 * k + 1] * C[1] + R[3 * k + 2] * C[2]);
    snprintf(c.name, sizeof c.name, "cam");
    return c;
}

static const double IDENTITY[9] = {1, 0, 0, 0, 1, 0, 0, 0, 1};

/* The target: 40x24, f = 20, principal point (20, 12), at the origin looking down +z. */
static gv_camera target_camera(void)
{
    double C[3] = {0, 0, 0};
    return camera(W, H, 20, 20, 12, IDENTITY, C);
}

/* Anchor colour of pixel (x, y): distinct per pixel and channel. */
static float anchor_colour(int x, int y, int c)
{
    return (float)(x + 100 * y + 1000 * c) / 4096.0f;
}

static void fill(float *depth, float *rgb, int w, int h, float z)
{
    for (int y = 0; y < h; y++)
        for (int x = 0; x < w; x++) {
            depth[y * w + x] = z;
            for (int c = 0; c < 3; c++) rgb[(y * w + x) * 3 + c] = anchor_colour(x, y, c);
        }
}

/* Checks the warp against a hand map: target pixel (i, j) must be covered exactly when
 * map(i, j) gives an anchor pixel (x, y) inside the anchor, and then carry its colour. */
typedef int (*hand_map)(int i, int j, int *x, int *y);

static void check_warp(const char *what, const gv_camera *anchor, const float *t_depth,
                       const float *a_depth, const float *a_rgb, hand_map map)
{
    static float warped[W * H * 3];
    static uint8_t covered[W * H];
    gv_camera target = target_camera();
    CHECK(gv_reproject_anchor(&target, t_depth, anchor, a_depth, a_rgb, 0.05, warped, covered) == 0);
    int wrong_mask = 0, n_covered = 0;
    double worst = 0;
    for (int j = 0; j < H; j++)
        for (int i = 0; i < W; i++) {
            int x, y, want = map(i, j, &x, &y) && x >= 0 && y >= 0 && x < anchor->width &&
                             y < anchor->height;
            if (want != covered[j * W + i]) wrong_mask++;
            n_covered += covered[j * W + i];
            for (int c = 0; c < 3; c++) {
                double v = want ? anchor_colour(x, y, c) : 0;
                worst = fmax(worst, fabs(warped[(j * W + i) * 3 + c] - v));
            }
        }
    printf("  %s: %d pixels covered, %d mask errors, max |colour - hand| %.2e\n", what,
           n_covered, wrong_mask, worst);
    CHECK(wrong_mask == 0);
    CHECK(worst < 1e-6);
}

/* Sideways by 0.5: the plane at depth 5 shifts by f b / z = 2 pixels. */
static int map_shift2(int i, int j, int *x, int *y)
{
    *x = i - 2, *y = j;
    return 1;
}

/* Rotated 180 degrees about the optical axis: u -> 2 cx - u, v -> 2 cy - v. */
static int map_mirror(int i, int j, int *x, int *y)
{
    *x = W - 1 - i, *y = H - 1 - j;
    return 1;
}

/* 2.5 closer, 20x12 with f = 10 and principal point (10, 6): u_a = 10 ((u - 20) 5/20) / 2.5
 * + 10 = u - 10, v_a = v - 6. */
static int map_closer(int i, int j, int *x, int *y)
{
    *x = i - 10, *y = j - 6;
    return 1;
}

static void test_plane(void)
{
    static float t_depth[W * H], a_depth[W * H], a_rgb[W * H * 3];
    gv_camera target = target_camera();
    fill(t_depth, a_rgb, W, H, 5);
    fill(a_depth, a_rgb, W, H, 5);

    double C1[3] = {0.5, 0, 0};
    gv_camera side = camera(W, H, 20, 20, 12, IDENTITY, C1);
    double u, v, z, worst = 0;
    for (int j = 0; j < H; j++)
        for (int i = 0; i < W; i++) {
            CHECK(gv_reproject_point(&target, i + 0.5, j + 0.5, 5, &side, &u, &v, &z) == 1);
            worst = fmax(worst, fabs(u - (i - 1.5)) + fabs(v - (j + 0.5)) + fabs(z - 5));
        }
    printf("  sideways 0.5: max |position - hand| %.2e\n", worst);
    CHECK(worst < 1e-12);
    check_warp("sideways 0.5", &side, t_depth, a_depth, a_rgb, map_shift2);

    double Rz[9] = {-1, 0, 0, 0, -1, 0, 0, 0, 1}, C0[3] = {0, 0, 0};
    gv_camera turned = camera(W, H, 20, 20, 12, Rz, C0);
    CHECK(gv_reproject_point(&target, 3.5, 2.5, 5, &turned, &u, &v, &z) == 1);
    CHECK_NEAR(u, 36.5, 1e-12);
    CHECK_NEAR(v, 21.5, 1e-12);
    check_warp("rotated 180 degrees", &turned, t_depth, a_depth, a_rgb, map_mirror);

    static float small_depth[20 * 12], small_rgb[20 * 12 * 3];
    fill(small_depth, small_rgb, 20, 12, 2.5f);
    double C2[3] = {0, 0, 2.5};
    gv_camera closer = camera(20, 12, 10, 10, 6, IDENTITY, C2);
    CHECK(gv_reproject_point(&target, 10.5, 6.5, 5, &closer, &u, &v, &z) == 1);
    CHECK_NEAR(u, 0.5, 1e-12);
    CHECK_NEAR(v, 0.5, 1e-12);
    CHECK_NEAR(z, 2.5, 1e-12);
    check_warp("closer, 20x12", &closer, t_depth, small_depth, small_rgb, map_closer);

    /* behind the anchor: a camera at z = 10 looking down +z does not see the plane */
    double C3[3] = {0, 0, 10};
    gv_camera past = camera(W, H, 20, 20, 12, IDENTITY, C3);
    CHECK(gv_reproject_point(&target, 20, 12, 5, &past, &u, &v, &z) == 0);
}

/* Sideways 0.5 again, but the anchor's depth map says a nearer surface (depth 3) covers its
 * columns 10-14: the target pixels that land there (columns 12-16) are hidden. Target pixels
 * without depth (row 5) are never covered. Depth within the 5 % tolerance passes (5.2 at
 * column 30, target 32), beyond it does not (5.3 at column 31, target 33). */
static int hidden_map(int i, int j, int *x, int *y)
{
    *x = i - 2, *y = j;
    return !(*x >= 10 && *x <= 14) && j != 5 && *x != 31;
}

static void test_occlusion(void)
{
    static float t_depth[W * H], a_depth[W * H], a_rgb[W * H * 3];
    fill(t_depth, a_rgb, W, H, 5);
    fill(a_depth, a_rgb, W, H, 5);
    for (int y = 0; y < H; y++) {
        for (int x = 10; x <= 14; x++) a_depth[y * W + x] = 3;
        a_depth[y * W + 30] = 5.2f, a_depth[y * W + 31] = 5.3f;
    }
    for (int i = 0; i < W; i++) t_depth[5 * W + i] = 0;
    double C1[3] = {0.5, 0, 0};
    gv_camera side = camera(W, H, 20, 20, 12, IDENTITY, C1);
    check_warp("nearer surface in the anchor", &side, t_depth, a_depth, a_rgb, hidden_map);
}

/* Sideways 0.5625: a shift of 2.25 pixels, so target pixel i lands at u = i - 1.75, in anchor
 * pixel i - 2, and interpolates 1/4 of pixel i - 3 with 3/4 of pixel i - 2. Where pixel i - 3
 * is a nearer surface (anchor column 20), the colour is pixel i - 2's alone. */
static void test_depth_edge(void)
{
    static float t_depth[W * H], a_depth[W * H], a_rgb[W * H * 3], warped[W * H * 3];
    static uint8_t covered[W * H];
    fill(t_depth, a_rgb, W, H, 5);
    fill(a_depth, a_rgb, W, H, 5);
    for (int y = 0; y < H; y++) a_depth[y * W + 20] = 2;
    gv_camera target = target_camera();
    double C[3] = {0.5625, 0, 0};
    gv_camera side = camera(W, H, 20, 20, 12, IDENTITY, C);
    CHECK(gv_reproject_anchor(&target, t_depth, &side, a_depth, a_rgb, 0.05, warped, covered) == 0);
    int j = 7;
    for (int i = 0; i < W; i++) {
        const float *got = warped + (j * W + i) * 3;
        int visible = i >= 2 && i - 2 != 20; /* i = 2 lands at u = 0.25, inside pixel 0 */
        CHECK(covered[j * W + i] == visible);
        if (!visible) continue;
        double sum = 0, want = 0;
        for (int x = i - 3; x <= i - 2; x++) {
            if (x < 0 || x == 20) continue; /* outside, or across the edge */
            double w = x == i - 3 ? 0.25 : 0.75;
            want += w * anchor_colour(x, j, 1), sum += w;
        }
        CHECK_NEAR(got[1], want / sum, 1e-6);
    }
}

static void test_bad_calls(void)
{
    static float d[W * H], rgb[W * H * 3];
    static uint8_t m[W * H];
    gv_camera t = target_camera(), a = target_camera();
    CHECK_FAILS_WITH(gv_reproject_anchor(&t, d, &a, d, rgb, 0, rgb, m), "tolerance");
    CHECK_FAILS_WITH(gv_reproject_anchor(&t, d, &a, d, rgb, NAN, rgb, m), "tolerance");
    a.fx = 0;
    CHECK_FAILS_WITH(gv_reproject_anchor(&t, d, &a, d, rgb, 0.05, rgb, m), "anchor camera");
}

int main(void)
{
    test_plane();
    test_occlusion();
    test_depth_edge();
    test_bad_calls();
    return check_summary();
}
