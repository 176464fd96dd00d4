/* Resolution scheduling (src/splat/resolution.c): the schedule's exact levels, the box filter
 * on hand values, and a camera at 1/f rendering what the box-filtered full render shows on a
 * hand-built scene (and not when its principal point is half a pixel off); the radii of the
 * densification statistic counted in full-resolution pixels. */
#include <omp.h>

#include "check.h"
#include "gaussvid/core/core.h"
#include "gaussvid/splat/splat_train.h"

static void test_schedule(void)
{
    /* start 4, 8000 iterations, full at 0.5: 1/4 for 1..2000, 1/2 for 2001..4000, then 1. */
    int its[] = {1, 2, 1999, 2000, 2001, 3999, 4000, 4001, 7999, 8000};
    int want[] = {4, 4, 4, 4, 2, 2, 2, 1, 1, 1};
    for (int k = 0; k < 10; k++) CHECK(gv_splat_resolution_factor(its[k], 8000, 4, 0.5) == want[k]);
    /* start 8, 100 iterations, full at 0.6 (60 coarse): 8 to 20, 4 to 40, 2 to 60. */
    for (int it = 1; it <= 100; it++)
        CHECK(gv_splat_resolution_factor(it, 100, 8, 0.6) ==
              (it <= 20 ? 8 : it <= 40 ? 4 : it <= 60 ? 2 : 1));
    /* start 2 over the whole run: every iteration at 1/2. */
    for (int it = 1; it <= 10; it++) CHECK(gv_splat_resolution_factor(it, 10, 2, 1.0) == 2);
    /* 7 iterations, full at 0.5: round(3.5) = 4 coarse ones, two per step. */
    int odd[] = {4, 4, 2, 2, 1, 1, 1};
    for (int it = 1; it <= 7; it++) CHECK(gv_splat_resolution_factor(it, 7, 4, 0.5) == odd[it - 1]);
    /* Off, and a share that leaves no coarse iteration. */
    for (int it = 1; it <= 50; it++) {
        CHECK(gv_splat_resolution_factor(it, 50, 0, 0.5) == 1);
        CHECK(gv_splat_resolution_factor(it, 50, 1, 0.5) == 1);
        CHECK(gv_splat_resolution_factor(it, 50, 4, 0.001) == 1);
    }
    CHECK(gv_splat_resolution_check(0, 0.5) == 0 && gv_splat_resolution_check(8, 1.0) == 0);
    CHECK_FAILS_WITH(gv_splat_resolution_check(3, 0.5), "expected 2, 4 or 8");
    CHECK_FAILS_WITH(gv_splat_resolution_check(16, 0.5), "expected 2, 4 or 8");
    CHECK_FAILS_WITH(gv_splat_resolution_check(4, 0.0), "(0, 1]");
    CHECK_FAILS_WITH(gv_splat_resolution_check(4, 1.5), "(0, 1]");
}

static void test_box_downsample(void)
{
    /* 5 x 3 image, value of (x, y, c) = 100 y + 10 x + c; at 1/2 it is 2 x 1: the blocks
     * x 0-1 and 2-3 of rows 0-1 (column 4 and row 2 left out): 50 + 5 + c and 50 + 25 + c. */
    float in[5 * 3 * 3], out[2 * 1 * 3];
    for (int y = 0; y < 3; y++)
        for (int x = 0; x < 5; x++)
            for (int c = 0; c < 3; c++) in[(y * 5 + x) * 3 + c] = (float)(100 * y + 10 * x + c);
    gv_splat_box_downsample(in, 5, 3, 2, out);
    for (int c = 0; c < 3; c++) {
        CHECK(out[c] == 55.0f + c);
        CHECK(out[3 + c] == 75.0f + c);
    }
    /* 1/3 of 5 x 3 is one pixel: the mean of columns 0-2 of the three rows. */
    gv_splat_box_downsample(in, 5, 3, 3, out);
    for (int c = 0; c < 3; c++) CHECK_NEAR(out[c], 110.0 + c, 1e-4);
}

/* Three large overlapping Gaussians (sigma 0.5-0.8 world units at depth 4.5-5.5 with fx 120:
 * about 9-18 pixels at full size, the y axis 0.7 of the others) in front of a camera at the origin looking down +z, with an
 * off-centre principal point. */
static void hand_scene(gv_gaussians *g, gv_camera *cam)
{
    if (gv_gaussians_alloc(g, 3, 0) != 0) exit(1);
    const float means[3][3] = {{-0.6f, -0.2f, 5.0f}, {0.5f, 0.3f, 5.5f}, {0.1f, 0.6f, 4.5f}};
    const float sigma[3] = {0.6f, 0.8f, 0.5f}, dc[3][3] = {{1.2f, -0.8f, 0.3f}, {-0.5f, 1.0f, 0.8f}, {0.6f, 0.6f, -1.0f}};
    for (int i = 0; i < 3; i++) {
        for (int a = 0; a < 3; a++) {
            g->means[3 * i + a] = means[i][a];
            g->scales[3 * i + a] = logf(sigma[i] * (a == 1 ? 0.7f : 1.0f));
            g->sh[3 * i + a] = dc[i][a];
        }
        g->rotations[4 * i] = 1, g->rotations[4 * i + 3] = 0.3f * (float)i;
        g->opacities[i] = 1.0f; /* sigmoid 0.73 */
    }
    memset(cam, 0, sizeof *cam);
    cam->width = 128, cam->height = 96;
    cam->fx = 120, cam->fy = 116, cam->cx = 61.3, cam->cy = 50.2;
    cam->R[0] = cam->R[4] = cam->R[8] = 1;
    snprintf(cam->name, sizeof cam->name, "hand.png");
}

/* Renders g at cam (background bg); the caller frees the image. */
static float *render(gv_splat_renderer *r, const gv_gaussians *g, const gv_camera *cam)
{
    gv_splat_view view;
    float bg[3] = {0.1f, 0.2f, 0.3f}, *image = malloc((size_t)cam->width * cam->height * 3 * sizeof(float));
    if (!image || gv_splat_view_from_camera(&view, cam) != 0 ||
        gv_splat_render_forward(r, g, &view, 0, bg, image) != 0) {
        fprintf(stderr, "render: %s\n", gv_last_error());
        exit(1);
    }
    return image;
}

static double max_difference(const float *a, const float *b, long n)
{
    double worst = 0;
    for (long i = 0; i < n; i++) worst = fmax(worst, fabs(a[i] - b[i]));
    return worst;
}

/* Centroid of |image - background| of channel 0, in full-resolution pixel coordinates
 * (pixel (i, j) of a 1/f image is centred at f (i + 0.5), f (j + 0.5)). */
static void centroid(const float *image, int w, int h, int f, double c[2])
{
    double sum = 0, sx = 0, sy = 0;
    for (int j = 0; j < h; j++)
        for (int i = 0; i < w; i++) {
            double m = fabs(image[((size_t)j * w + i) * 3] - 0.1);
            sum += m, sx += m * f * (i + 0.5), sy += m * f * (j + 0.5);
        }
    c[0] = sx / sum, c[1] = sy / sum;
}

/* The camera at 1/f renders the box filter of the full render: the same surfaces at the same
 * places, up to the rasteriser's 0.3 px^2 dilation (in the smaller pixels, so f^2 times wider
 * in the scene) against the box's own blur (variance f^2 / 12 full pixels^2): against
 * Gaussians of sigma 9-18 full pixels a peak change of a few per cent of the colour at
 * f = 4, measured 0.0025 at f = 2 and 0.0109 at f = 4 (tolerance 0.006 and 0.02). Both
 * blurs are symmetric, so the centroid of what is drawn stays where it is (measured within
 * 0.009 and 0.037 full pixels; tolerance 0.1). A camera made with the other half-pixel convention,
 * cx' = (cx - 0.5) / f + 0.5 (pixel centres at integers), moves it by (f - 1) / 2 full
 * pixels (measured 0.485 and 1.45), and is caught. */
static void test_downsampled_camera(void)
{
    gv_gaussians g;
    gv_camera cam, small;
    hand_scene(&g, &cam);
    gv_splat_renderer r = {0};
    float *full = render(&r, &g, &cam), boxed[128 * 96 * 3];
    double c_full[2], c_small[2], c_wrong[2];
    centroid(full, 128, 96, 1, c_full);
    for (int f = 2; f <= 4; f *= 2) {
        gv_camera_downsampled(&cam, f, &small);
        CHECK(small.width == 128 / f && small.height == 96 / f);
        CHECK(small.fx == 120.0 / f && small.fy == 116.0 / f && small.cx == 61.3 / f && small.cy == 50.2 / f);
        CHECK(!memcmp(small.R, cam.R, sizeof cam.R) && !memcmp(small.t, cam.t, sizeof cam.t));
        gv_splat_box_downsample(full, 128, 96, f, boxed);
        float *image = render(&r, &g, &small);
        double d = max_difference(image, boxed, (long)small.width * small.height * 3);
        centroid(image, small.width, small.height, f, c_small);
        gv_camera wrong = small;
        wrong.cx = (cam.cx - 0.5) / f + 0.5, wrong.cy = (cam.cy - 0.5) / f + 0.5;
        float *moved = render(&r, &g, &wrong);
        centroid(moved, small.width, small.height, f, c_wrong);
        fprintf(stderr, "1/%d camera against the box-filtered full render: %.4f at worst; "
                "centroid off by (%.3f, %.3f) full pixels, (%.3f, %.3f) with the other convention\n",
                f, d, c_small[0] - c_full[0], c_small[1] - c_full[1], c_wrong[0] - c_full[0],
                c_wrong[1] - c_full[1]);
        CHECK(d < (f == 2 ? 0.006 : 0.02));
        CHECK(fabs(c_small[0] - c_full[0]) < 0.1 && fabs(c_small[1] - c_full[1]) < 0.1);
        CHECK(fabs(c_wrong[0] - c_full[0]) > 0.4 && fabs(c_wrong[1] - c_full[1]) > 0.4);
        free(image), free(moved);
    }
    free(full);
    gv_splat_renderer_free(&r);
    gv_gaussians_free(&g);
}

/* At 1/4 a radius of 3 small pixels is 12 full ones; the gradient statistic is unscaled. */
static void test_radii_in_full_pixels(void)
{
    gv_splat_densify_stats s = {0};
    CHECK(gv_splat_densify_stats_reserve(&s, 3) == 0);
    int visible[2] = {0, 2}, radii[3] = {3, 0, 5};
    float grad[3] = {0.5f, 0, 0.25f};
    gv_splat_densify_accumulate_scaled(&s, 2, visible, grad, radii, 4);
    CHECK(s.max_radii[0] == 12 && s.max_radii[1] == 0 && s.max_radii[2] == 20);
    gv_splat_densify_accumulate(&s, 2, visible, grad, radii); /* full size: smaller */
    CHECK(s.max_radii[0] == 12 && s.max_radii[2] == 20);
    CHECK(s.grad_accum[0] == 1.0f && s.grad_accum[2] == 0.5f && s.denom[0] == 2 && s.denom[1] == 0);
    gv_splat_densify_stats_free(&s);
}

/* The user's default on small views: the largest factor up to the start that leaves every
 * view a pixel on each side, halving. */
static void test_fit(void)
{
    gv_camera c[2];
    memset(c, 0, sizeof c);
    c[0].width = 256, c[0].height = 144, c[1].width = 256, c[1].height = 144;
    CHECK(gv_splat_resolution_fit(4, c, 2) == 4);
    CHECK(gv_splat_resolution_fit(8, c, 2) == 8);
    CHECK(gv_splat_resolution_fit(1, c, 2) == 1);
    CHECK(gv_splat_resolution_fit(0, c, 2) == 0); /* off stays off */
    c[1].height = 3; /* 3 pixels: 1/2 leaves 1, 1/4 none */
    CHECK(gv_splat_resolution_fit(4, c, 2) == 2);
    CHECK(gv_splat_resolution_fit(8, c, 2) == 2);
    c[1].height = 4;
    CHECK(gv_splat_resolution_fit(8, c, 2) == 4);
    c[0].width = 1; /* a 1-pixel column: full size only */
    CHECK(gv_splat_resolution_fit(4, c, 2) == 1);
    CHECK(gv_splat_resolution_fit(4, c, 0) == 4); /* no views: nothing to fit */
}

int main(void)
{
    omp_set_num_threads(1);
    test_schedule();
    test_box_downsample();
    test_downsampled_camera();
    test_radii_in_full_pixels();
    test_fit();
    return check_summary();
}
