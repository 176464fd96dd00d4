/* The 3D consistency metric (src/eval/consistency.c) on hand-built cases: a textured plane
 * seen by cameras shifted sideways, where a frame warped into its neighbour lands on whole
 * pixels, so the covered pixels, the coverage and the PSNR are exact: identical surfaces give
 * the cap, a brightness offset c gives 10 log10(1 / c^2); a nearer occluder in one frame
 * removes the pixels it hides from the comparison. The same through a model (a wall of
 * Gaussians, whose rendered depth is the wall's) and PNG files; bad inputs fail with a line
 * naming the file. */
#include <stdint.h>

#include "check.h"
#include "gaussvid/eval/consistency.h"
#include "gaussvid/core/core.h"
#include "gaussvid/io/image.h"

enum { W = 32, H = 32, PIXELS = W * H };
#define FOCAL 16.0
#define WALL_Z 2.0
#define STEP 0.25 /* camera k sits at x = STEP k: the wall shifts by FOCAL STEP / WALL_Z = 2 pixels */

static gv_camera wall_camera(int k)
{
    gv_camera c;
    memset(&c, 0, sizeof c);
    c.width = W, c.height = H, c.fx = c.fy = FOCAL, c.cx = W / 2.0, c.cy = H / 2.0;
    c.R[0] = c.R[4] = c.R[8] = 1;
    c.t[0] = -STEP * k;
    snprintf(c.name, sizeof c.name, "cam%d", k);
    return c;
}

/* The wall's texture in 8 bits: column m of the wall is pixel column m - 2k of camera k. */
static int texture(int m, int y, int c)
{
    return (37 * m + 11 * y + 53 * c) % 200 + 20; /* in 20..219: an offset of up to 36 never clips */
}

/* Camera k's view of the wall, brighter by `offset` (8-bit steps), as floats v / 255. */
static void view(int k, int offset, float *rgb)
{
    for (int y = 0; y < H; y++)
        for (int x = 0; x < W; x++)
            for (int c = 0; c < 3; c++) rgb[(y * W + x) * 3 + c] = (float)(texture(x + 2 * k, y, c) + offset) / 255.0f;
}

static void flat_depth(float *depth, float z)
{
    for (int p = 0; p < PIXELS; p++) depth[p] = z;
}

static void test_pair_by_hand(void)
{
    static float rgb0[PIXELS * 3], rgb1[PIXELS * 3], d0[PIXELS], d1[PIXELS];
    gv_camera c0 = wall_camera(0), c1 = wall_camera(1);
    view(0, 0, rgb0), view(1, 0, rgb1);
    flat_depth(d0, WALL_Z), flat_depth(d1, WALL_Z);
    gv_consistency_pair p;
    /* camera 1's column i sees camera 0's column i + 2: inside for i < 30 */
    REQUIRE(gv_consistency_pair_measure(&c0, rgb0, d0, &c1, rgb1, d1, 0.05, &p) == 0);
    printf("  identical: %ld pixels, coverage %.4f, mse %.3g, PSNR %.2f\n", p.pixels, p.coverage, p.mse, p.psnr);
    CHECK(p.pixels == 30 * H);
    CHECK_NEAR(p.coverage, 30.0 / 32.0, 1e-15);
    CHECK(p.mse < 1e-20);
    CHECK(p.psnr == GV_CONSISTENCY_PSNR_CAP);
    /* brightness offset c = 0.1 exactly (floats): PSNR = 10 log10(1 / c^2) = 20 dB */
    static float brighter[PIXELS * 3];
    for (int i = 0; i < PIXELS * 3; i++) brighter[i] = rgb1[i] + 0.1f;
    REQUIRE(gv_consistency_pair_measure(&c0, rgb0, d0, &c1, brighter, d1, 0.05, &p) == 0);
    printf("  offset 0.1: PSNR %.9f, hand 10 log10(1 / 0.1^2) = 20\n", p.psnr);
    CHECK(p.pixels == 30 * H);
    CHECK_NEAR(p.psnr, 20.0, 1e-5);
    /* the other way: camera 0's column i sees camera 1's column i - 2 */
    REQUIRE(gv_consistency_pair_measure(&c1, brighter, d1, &c0, rgb0, d0, 0.05, &p) == 0);
    CHECK(p.pixels == 30 * H);
    CHECK_NEAR(p.psnr, 20.0, 1e-5);
    /* a nearer surface (depth 1) over camera 0's columns 0-9 hides them: camera 1's columns
     * i < 8 land there and fail the occlusion test, leaving columns 8..29 */
    for (int y = 0; y < H; y++)
        for (int x = 0; x < 10; x++) d0[y * W + x] = 1;
    REQUIRE(gv_consistency_pair_measure(&c0, rgb0, d0, &c1, brighter, d1, 0.05, &p) == 0);
    printf("  occluded: %ld pixels, PSNR %.6f\n", p.pixels, p.psnr);
    CHECK(p.pixels == 22 * H);
    CHECK_NEAR(p.psnr, 20.0, 1e-5);
    /* no surface in the neighbour: nothing compared, PSNR undefined */
    flat_depth(d1, 0);
    REQUIRE(gv_consistency_pair_measure(&c0, rgb0, d0, &c1, rgb1, d1, 0.05, &p) == 0);
    CHECK(p.pixels == 0 && p.coverage == 0 && isnan(p.psnr));
    CHECK_FAILS_WITH(gv_consistency_pair_measure(&c0, rgb0, d0, &c1, rgb1, d1, 0, &p), "tolerance");
}

/* The wall as flat opaque Gaussians 0.1 apart over x, y in [-3.5, 3.5] at z = 2 (the wall of
 * test_condition_coverage): its rendered depth is 2 wherever these cameras look. */
static void wall_of_gaussians(gv_gaussians *g)
{
    const int side = 71;
    CHECK(gv_gaussians_alloc(g, side * side, 0) == 0);
    for (int i = 0; i < side * side; i++) {
        g->means[3 * i] = -3.5f + 0.1f * (float)(i % side), g->means[3 * i + 1] = -3.5f + 0.1f * (float)(i / side);
        g->means[3 * i + 2] = (float)WALL_Z;
        g->scales[3 * i] = g->scales[3 * i + 1] = logf(0.08f), g->scales[3 * i + 2] = logf(0.001f);
        g->rotations[4 * i] = 1, g->rotations[4 * i + 1] = g->rotations[4 * i + 2] = g->rotations[4 * i + 3] = 0;
        g->opacities[i] = 5;
        g->sh[3 * i] = g->sh[3 * i + 1] = g->sh[3 * i + 2] = 0.5f;
    }
}

static void write_view(const char *path, int k, int offset)
{
    static float rgb[PIXELS * 3];
    view(k, offset, rgb);
    gv_image img;
    CHECK(gv_image_alloc(&img, W, H, 3) == 0);
    for (int i = 0; i < PIXELS * 3; i++) img.pixels[i] = (uint8_t)lrintf(rgb[i] * 255.0f);
    CHECK(gv_image_write_png(path, &img) == 0);
    gv_image_free(&img);
}

/* Three frames from cameras 0, 1, 2; the middle one 5 steps brighter: every pair differs by
 * exactly c = 5 / 255 on the 30 covered columns, PSNR 20 log10(51). */
static void test_sequence_of_files(const char *tmp)
{
    gv_gaussians g;
    wall_of_gaussians(&g);
    gv_camera cams[3] = {wall_camera(0), wall_camera(1), wall_camera(2)};
    char names[4][4200];
    const char *paths[3] = {names[0], names[1], names[2]};
    for (int k = 0; k < 3; k++) {
        snprintf(names[k], sizeof names[k], "%s/frame%d.png", tmp, k);
        write_view(names[k], k, k == 1 ? 5 : 0);
    }
    gv_consistency c;
    REQUIRE(gv_consistency_measure(&g, cams, paths, 3, NULL, &c) == 0);
    double hand = 20 * log10(255.0 / 5);
    printf("  sequence: %d pairs, %d scored, mean PSNR %.9f (hand %.9f), coverage %.4f\n", c.n_pairs, c.scored,
           c.mean_psnr, hand, c.mean_coverage);
    CHECK(c.n_frames == 3 && c.n_pairs == 4 && c.scored == 4);
    static const int from[4] = {0, 1, 1, 2}, to[4] = {1, 0, 2, 1};
    for (int k = 0; k < 4 && c.pairs; k++) {
        CHECK(c.pairs[k].from == from[k] && c.pairs[k].to == to[k]);
        CHECK(c.pairs[k].pixels == 30 * H);
        CHECK_NEAR(c.pairs[k].psnr, hand, 1e-6);
    }
    CHECK_NEAR(c.mean_psnr, hand, 1e-6);
    CHECK_NEAR(c.mean_coverage, 30.0 / 32.0, 1e-12);
    gv_consistency_free(&c);
    /* the same frames without the offset: identical on every covered pixel, the cap */
    write_view(names[1], 1, 0);
    REQUIRE(gv_consistency_measure(&g, cams, paths, 3, NULL, &c) == 0);
    CHECK(c.scored == 4 && c.mean_psnr == GV_CONSISTENCY_PSNR_CAP);
    gv_consistency_free(&c);

    /* bad inputs: one frame, a missing file, a frame of another size */
    CHECK_FAILS_WITH(gv_consistency_measure(&g, cams, paths, 1, NULL, &c), "1 frame");
    snprintf(names[3], sizeof names[3], "%s/missing.png", tmp);
    const char *missing[3] = {names[0], names[3], names[2]};
    CHECK_FAILS_WITH(gv_consistency_measure(&g, cams, missing, 3, NULL, &c), "missing.png");
    CHECK(c.pairs == NULL);
    gv_camera small = cams[2];
    small.width = 16, small.cx = 8;
    gv_camera mixed[3] = {cams[0], cams[1], small};
    CHECK_FAILS_WITH(gv_consistency_measure(&g, mixed, paths, 3, NULL, &c), "frame2.png is 32x32 but its camera");
    gv_gaussians_free(&g);
}

int main(void)
{
    const char *tmp = check_tmp_dir();
    if (!tmp) return 1;
    test_pair_by_hand();
    test_sequence_of_files(tmp);
    return check_summary();
}
