/* The training loss (src/splat/loss.c): L = 0.8 L1 + 0.2 (1 - SSIM) and its gradient, against
 * an independent double-precision computation written here (a direct 11x11 window, no
 * separable passes, no centring), hand-derived values for constant images, central finite
 * differences at border, corner and interior pixels, the metrics module's SSIM gradient,
 * thread independence, and bad input. */
#include <omp.h>

#include "check.h"
#include "gaussvid/core/core.h"
#include "gaussvid/io/metrics.h"
#include "gaussvid/splat/splat_train.h"

enum { MAXW = 40, MAXH = 30 };

/* Mean SSIM of two HWC 3-channel images from the definition (docs/reference/gaussian-splatting.md
 * 19.2): the 2-D window g g^T applied directly with zero padding, population moments, C1 = 1e-4,
 * C2 = 9e-4, mean over every value. */
static double ssim_direct(const double *a, const double *b, int W, int H)
{
    double g[11], sum = 0;
    gv_ssim_window(g);
    for (int c = 0; c < 3; c++)
        for (int y = 0; y < H; y++)
            for (int x = 0; x < W; x++) {
                double ma = 0, mb = 0, maa = 0, mbb = 0, mab = 0;
                for (int i = 0; i < 11; i++)
                    for (int j = 0; j < 11; j++) {
                        int yy = y + i - 5, xx = x + j - 5;
                        if (yy < 0 || yy >= H || xx < 0 || xx >= W) continue;
                        double w = g[i] * g[j], va = a[(yy * W + xx) * 3 + c];
                        double vb = b[(yy * W + xx) * 3 + c];
                        ma += w * va, mb += w * vb, maa += w * va * va, mbb += w * vb * vb;
                        mab += w * va * vb;
                    }
                double saa = maa - ma * ma, sbb = mbb - mb * mb, sab = mab - ma * mb;
                sum += (2 * ma * mb + 1e-4) * (2 * sab + 9e-4) /
                       ((ma * ma + mb * mb + 1e-4) * (saa + sbb + 9e-4));
            }
    return sum / (3.0 * W * H);
}

static double loss_direct(const double *a, const double *b, int W, int H)
{
    double l1 = 0;
    for (int i = 0; i < 3 * W * H; i++) l1 += fabs(a[i] - b[i]);
    return 0.8 * l1 / (3.0 * W * H) + 0.2 * (1 - ssim_direct(a, b, W, H));
}

/* A render and a target: smooth patterns with noise, a flat region (where float32 SSIM
 * suffers most) and values at 0 and 1. */
static void make_images(float *a, float *b, int W, int H, uint64_t seed)
{
    gv_rng r;
    gv_rng_init(&r, seed);
    for (int y = 0; y < H; y++)
        for (int x = 0; x < W; x++)
            for (int c = 0; c < 3; c++) {
                int i = (y * W + x) * 3 + c;
                double t = 0.5 + 0.35 * sin(0.3 * x + c) * cos(0.25 * y - c);
                b[i] = (float)t;
                a[i] = (float)fmin(1, fmax(0, t + 0.08 * gv_rng_normal(&r)));
                if (x > W / 2 && y > H / 2) b[i] = 0.3f, a[i] = 0.3f + 0.002f * (float)(i % 5);
            }
}

static void test_against_direct(void)
{
    enum { W = 29, H = 21, N = W * H * 3 };
    static float a[N], b[N], grad[N];
    static double ad[N], bd[N];
    make_images(a, b, W, H, 3);
    for (int i = 0; i < N; i++) ad[i] = a[i], bd[i] = b[i];
    gv_splat_loss_work w = {0};
    gv_splat_loss_value v;
    CHECK(gv_splat_loss(&w, a, b, W, H, 0.2, grad, &v) == 0);
    double ssim = ssim_direct(ad, bd, W, H), loss = loss_direct(ad, bd, W, H);
    printf("  29x21: SSIM %.9f (direct %.9f), loss %.9f (direct %.9f)\n", v.ssim, ssim, v.loss,
           loss);
    CHECK_NEAR(v.ssim, ssim, 2e-7);
    CHECK_NEAR(v.loss, loss, 1e-7);
    /* Central differences of the direct loss: corners, edges, the flat region, interior. */
    const int px[][2] = {{0, 0}, {W - 1, H - 1}, {0, 7}, {13, 0}, {3, 4}, {14, 10}, {20, 15},
                         {27, 19}, {5, 18}};
    double worst = 0, largest = 0;
    for (int k = 0; k < 9; k++)
        for (int c = 0; c < 3; c++) {
            int i = (px[k][1] * W + px[k][0]) * 3 + c;
            double h = 1e-6, x = ad[i];
            ad[i] = x + h;
            double lp = loss_direct(ad, bd, W, H);
            ad[i] = x - h;
            double lm = loss_direct(ad, bd, W, H);
            ad[i] = x;
            double num = (lp - lm) / (2 * h);
            worst = fmax(worst, fabs(grad[i] - num));
            largest = fmax(largest, fabs(num));
        }
    printf("  gradient at 27 values: max |analytic - central difference| %.2e (max |grad| "
           "%.2e)\n", worst, largest);
    CHECK(largest > 1e-5);
    CHECK(worst < 1e-3 * largest);
    gv_splat_loss_free(&w);
}

/* The metrics module's SSIM and gradient (double precision, uncentred moments). */
static void test_against_metrics(void)
{
    enum { W = 40, H = 30, N = W * H * 3 };
    static float a[N], b[N], grad[N], ssim_grad[N];
    make_images(a, b, W, H, 5);
    gv_splat_loss_work w = {0};
    gv_splat_loss_value v;
    CHECK(gv_splat_loss(&w, a, b, W, H, 0.2, grad, &v) == 0);
    double ssim = gv_ssim_with_gradient(a, b, W, H, 3, ssim_grad);
    double worst = 0, largest = 0;
    for (int i = 0; i < N; i++) {
        float d = a[i] - b[i];
        double want = 0.8 / N * (d > 0 ? 1 : d < 0 ? -1 : 0) - 0.2 * ssim_grad[i];
        worst = fmax(worst, fabs(grad[i] - want)), largest = fmax(largest, fabs(want));
    }
    printf("  40x30 against gv_ssim_with_gradient: SSIM %.9f vs %.9f, gradient max diff %.2e "
           "of %.2e\n", v.ssim, ssim, worst, largest);
    CHECK_NEAR(v.ssim, ssim, 2e-7);
    CHECK(worst < 1e-5 * largest);
    gv_splat_loss_free(&w);
}

/* Constant images p and q: inside, sigma = 0 and S = (2pq + C1) / (p^2 + q^2 + C1); where the
 * window's mass M is cut by the border, mu = M p, sigma_pp = M (1 - M) p^2, sigma_pq =
 * M (1 - M) p q. Identical images: SSIM 1, loss 0, zero gradient (up to float rounding). */
static void test_constant_images(void)
{
    enum { W = 17, H = 13, N = W * H * 3 };
    static float a[N], b[N], grad[N];
    const double p = 0.125, q = 0.75, C1 = 1e-4, C2 = 9e-4;
    for (int i = 0; i < N; i++) a[i] = (float)p, b[i] = (float)q;
    double g[11], mx[W], my[H], sum = 0;
    gv_ssim_window(g);
    for (int x = 0; x < W; x++) {
        mx[x] = 0;
        for (int k = 0; k < 11; k++) mx[x] += x + k - 5 >= 0 && x + k - 5 < W ? g[k] : 0;
    }
    for (int y = 0; y < H; y++) {
        my[y] = 0;
        for (int k = 0; k < 11; k++) my[y] += y + k - 5 >= 0 && y + k - 5 < H ? g[k] : 0;
    }
    for (int y = 0; y < H; y++)
        for (int x = 0; x < W; x++) {
            double M = mx[x] * my[y], s = M * (1 - M);
            sum += 3 * (2 * M * M * p * q + C1) * (2 * s * p * q + C2) /
                   ((M * M * (p * p + q * q) + C1) * (s * (p * p + q * q) + C2));
        }
    double want = sum / N;
    gv_splat_loss_work w = {0};
    gv_splat_loss_value v;
    CHECK(gv_splat_loss(&w, a, b, W, H, 0.2, grad, &v) == 0);
    printf("  constant 0.125 vs 0.75: SSIM %.9f, by hand %.9f; interior value %.9f\n", v.ssim,
           want, (2 * p * q + C1) / (p * p + q * q + C1));
    /* Flat images are float32's worst case: the variances are differences of equal sums,
     * off by ~5e-8, which is 5e-5 of C2 (the reference's float32 is no better). */
    CHECK_NEAR(v.ssim, want, 5e-6);
    CHECK_NEAR(v.l1, 0.625, 1e-7);
    CHECK_NEAR(v.loss, 0.8 * 0.625 + 0.2 * (1 - want), 1e-6);
    gv_splat_loss_value constant = v;

    CHECK(gv_splat_loss(&w, b, b, W, H, 0.2, grad, &v) == 0);
    double largest = 0;
    for (int i = 0; i < N; i++) largest = fmax(largest, fabs(grad[i]));
    printf("  identical images: 1 - SSIM %.2e, loss %.2e, max |gradient| %.2e (L1 alone: "
           "%.2e)\n", 1 - v.ssim, v.loss, largest, 0.8 / N);
    CHECK(fabs(1 - v.ssim) < 1e-7 && v.l1 == 0 && fabs(v.loss) < 1e-7);
    CHECK(largest < 1e-4 * 0.8 / N); /* float rounding only: the exact gradient is 0 */
    /* without a gradient buffer: the same values */
    gv_splat_loss_value v2;
    CHECK(gv_splat_loss(&w, a, b, W, H, 0.2, NULL, &v2) == 0);
    CHECK(v2.loss == constant.loss && v2.ssim == constant.ssim && v2.l1 == constant.l1);
    gv_splat_loss_free(&w);
}

/* Same bytes with 1 and 3 threads; the work area follows the size when it changes. */
static void test_threads_and_sizes(void)
{
    enum { W = 40, H = 30, N = W * H * 3 };
    static float a[N], b[N], g1[N], g3[N];
    make_images(a, b, W, H, 9);
    gv_splat_loss_work w = {0};
    gv_splat_loss_value v1, v3, small;
    omp_set_num_threads(1);
    CHECK(gv_splat_loss(&w, a, b, W, H, 0.2, g1, &v1) == 0);
    omp_set_num_threads(3);
    CHECK(gv_splat_loss(&w, a, b, 7, 5, 0.2, g3, &small) == 0); /* a smaller size between */
    CHECK(gv_splat_loss(&w, a, b, W, H, 0.2, g3, &v3) == 0);
    omp_set_num_threads(2);
    CHECK(v1.loss == v3.loss && v1.ssim == v3.ssim);
    CHECK(memcmp(g1, g3, sizeof g1) == 0);
    gv_splat_loss_free(&w);
}

static void test_bad_input(void)
{
    static float a[12], b[12], grad[12];
    gv_splat_loss_work w = {0};
    gv_splat_loss_value v;
    CHECK_FAILS_WITH(gv_splat_loss(&w, a, b, 0, 4, 0.2, grad, &v), "invalid image size 0x4");
    CHECK_FAILS_WITH(gv_splat_loss(&w, a, b, 2, -1, 0.2, grad, &v), "invalid image size");
    a[5] = NAN;
    CHECK_FAILS_WITH(gv_splat_loss(&w, a, b, 2, 2, 0.2, grad, &v), "not finite");
    a[5] = INFINITY;
    CHECK_FAILS_WITH(gv_splat_loss(&w, a, b, 2, 2, 0.2, NULL, &v), "not finite");
    gv_splat_loss_free(&w);
    gv_splat_loss_free(&w); /* freeing twice is harmless */
}

int main(void)
{
    test_against_direct();
    test_against_metrics();
    test_constant_images();
    test_threads_and_sizes();
    test_bad_input();
    return check_summary();
}
