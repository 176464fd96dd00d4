/* PSNR and SSIM against a direct implementation written here (double precision, the 2-D
 * window evaluated as a whole, no separability), a closed form for constant images, the
 * identical-image limits, and the SSIM gradient against central finite differences. */
#include <omp.h>

#include "check.h"
#include "gaussvid/core/core.h"
#include "gaussvid/io/metrics.h"

/* 2-D window w(i, j) proportional to exp(-((i-5)^2 + (j-5)^2) / (2 * 1.5^2)), sum 1. */
static double window2d[11][11];

static void make_window(void)
{
    double sum = 0.0;
    for (int i = 0; i < 11; i++)
        for (int j = 0; j < 11; j++)
            sum += window2d[i][j] = exp(-((i - 5.0) * (i - 5.0) + (j - 5.0) * (j - 5.0)) / 4.5);
    for (int i = 0; i < 11; i++)
        for (int j = 0; j < 11; j++) window2d[i][j] /= sum;
}

/* Direct SSIM: for every pixel and channel, the weighted moments over the 11x11 window with
 * the samples outside the image taken as zero. a is double so finite differences are clean. */
static double naive_ssim(const double *a, const float *b, int W, int H, int C)
{
    const double C1 = 0.0001, C2 = 0.0009;
    double total = 0.0;
    for (int c = 0; c < C; c++)
        for (int y = 0; y < H; y++)
            for (int x = 0; x < W; x++) {
                double ma = 0, mb = 0, maa = 0, mbb = 0, mab = 0;
                for (int i = 0; i < 11; i++)
                    for (int j = 0; j < 11; j++) {
                        int yy = y + i - 5, xx = x + j - 5;
                        if (yy < 0 || yy >= H || xx < 0 || xx >= W) continue;
                        double w = window2d[i][j];
                        double va = a[(yy * W + xx) * C + c], vb = b[(yy * W + xx) * C + c];
                        ma += w * va; mb += w * vb;
                        maa += w * va * va; mbb += w * vb * vb; mab += w * va * vb;
                    }
                double saa = maa - ma * ma, sbb = mbb - mb * mb, sab = mab - ma * mb;
                total += (2 * ma * mb + C1) * (2 * sab + C2) /
                         ((ma * ma + mb * mb + C1) * (saa + sbb + C2));
            }
    return total / ((double)W * H * C);
}

static void random_image(float *x, int n, uint64_t seed)
{
    for (int i = 0; i < n; i++) x[i] = (float)gv_uniform_at(seed, i);
}

static double naive_ssim_float(const float *a, const float *b, int W, int H, int C)
{
    double *ad = malloc(sizeof *ad * W * H * C);
    for (int i = 0; i < W * H * C; i++) ad[i] = a[i];
    double s = naive_ssim(ad, b, W, H, C);
    free(ad);
    return s;
}

static void test_against_direct(void)
{
    /* Sizes below, at and above the window; a correlated pair (b = a blurred and shifted
     * plus noise) and an independent pair. */
    const int sizes[4][3] = {{5, 4, 1}, {11, 11, 3}, {23, 17, 3}, {40, 9, 2}};
    for (int s = 0; s < 4; s++) {
        int W = sizes[s][0], H = sizes[s][1], C = sizes[s][2], n = W * H * C;
        float *a = malloc(sizeof *a * n), *b = malloc(sizeof *b * n), *c = malloc(sizeof *c * n);
        random_image(a, n, 100 + s);
        random_image(c, n, 200 + s);
        for (int i = 0; i < n; i++) b[i] = 0.7f * a[(i + C) % n] + 0.3f * c[i];
        double got = gv_ssim(a, b, W, H, C), want = naive_ssim_float(a, b, W, H, C);
        printf("SSIM %dx%dx%d correlated: %.9f direct %.9f (diff %.2e)\n", W, H, C, got, want,
               fabs(got - want));
        CHECK_NEAR(got, want, 1e-9);
        got = gv_ssim(a, c, W, H, C);
        want = naive_ssim_float(a, c, W, H, C);
        CHECK_NEAR(got, want, 1e-9);
        /* PSNR against the definition, evaluated here in double. */
        double sum = 0.0;
        for (int i = 0; i < n; i++) sum += ((double)a[i] - b[i]) * ((double)a[i] - b[i]);
        CHECK_NEAR(gv_psnr(a, b, W, H, C), 10.0 * log10(n / sum), 1e-9);
        CHECK_NEAR(gv_ssim(a, b, W, H, C), gv_ssim(b, a, W, H, C), 1e-7); /* symmetric */
        free(a);
        free(b);
        free(c);
    }
}

static void test_psnr_exact(void)
{
    enum { W = 6, H = 4, C = 3, N = W * H * C };
    float a[N], b[N];
    /* 0 against 0.5 everywhere: MSE 1/4, PSNR = 10 log10 4. */
    for (int i = 0; i < N; i++) { a[i] = 0.0f; b[i] = 0.5f; }
    CHECK_NEAR(gv_psnr(a, b, W, H, C), 10.0 * log10(4.0), 1e-12);
    /* Half the values off by 0.25: MSE 1/32, PSNR = 10 log10 32. */
    for (int i = 0; i < N; i++) b[i] = (i % 2) ? 0.25f : 0.0f;
    CHECK_NEAR(gv_psnr(a, b, W, H, C), 10.0 * log10(32.0), 1e-12);
    /* One value off by 1 among 72: PSNR = 10 log10 72. */
    for (int i = 0; i < N; i++) b[i] = 0.0f;
    b[17] = 1.0f;
    CHECK_NEAR(gv_psnr(a, b, W, H, C), 10.0 * log10(72.0), 1e-12);
}

/* Constant images a = alpha, b = beta: at a pixel whose window has mass s inside the image
 * (s = sx(x) sy(y), sx = sum of the 1-D taps that land inside), every moment is s times the
 * value: mu_a = alpha s, m_aa = alpha^2 s, so s_aa = alpha^2 s (1 - s), s_ab = alpha beta
 * s (1 - s), and
 *   S = (2 alpha beta s^2 + C1)(2 alpha beta s(1-s) + C2)
 *       / (((alpha^2 + beta^2) s^2 + C1)((alpha^2 + beta^2) s(1-s) + C2)).
 * Inside (s = 1) this is (2 alpha beta + C1) / (alpha^2 + beta^2 + C1). */
static double constant_closed_form(double alpha, double beta, int W, int H)
{
    double g[11], gsum = 0.0;
    for (int i = 0; i < 11; i++) gsum += g[i] = exp(-(i - 5.0) * (i - 5.0) / 4.5);
    double total = 0.0;
    for (int y = 0; y < H; y++)
        for (int x = 0; x < W; x++) {
            double sx = 0.0, sy = 0.0;
            for (int k = 0; k < 11; k++) {
                if (x + k - 5 >= 0 && x + k - 5 < W) sx += g[k] / gsum;
                if (y + k - 5 >= 0 && y + k - 5 < H) sy += g[k] / gsum;
            }
            double s = sx * sy, ab = alpha * beta, q = alpha * alpha + beta * beta;
            total += (2 * ab * s * s + 1e-4) * (2 * ab * s * (1 - s) + 9e-4) /
                     ((q * s * s + 1e-4) * (q * s * (1 - s) + 9e-4));
        }
    return total / ((double)W * H);
}

static void test_constant_images(void)
{
    enum { W = 30, H = 20, C = 2 };
    static float a[W * H * C], b[W * H * C];
    const double pairs[3][2] = {{0.5, 0.25}, {0.8, 0.0}, {0.125, 0.75}};
    for (int p = 0; p < 3; p++) {
        for (int i = 0; i < W * H * C; i++) { a[i] = (float)pairs[p][0]; b[i] = (float)pairs[p][1]; }
        double want = constant_closed_form(pairs[p][0], pairs[p][1], W, H);
        double got = gv_ssim(a, b, W, H, C);
        printf("SSIM constant %.3f vs %.3f: %.9f closed form %.9f\n", pairs[p][0], pairs[p][1],
               got, want);
        CHECK_NEAR(got, want, 1e-9);
    }
    /* The interior value for 0.5 vs 0.25: (2*0.125 + C1) / (0.3125 + C1) = 0.80006398... */
    CHECK_NEAR((0.25 + 1e-4) / (0.3125 + 1e-4), 0.8000639795, 1e-9);
    /* 1x1 image: only the centre tap, s = g5^2. */
    for (int i = 0; i < 2; i++) { a[i] = 0.5f; b[i] = 0.25f; }
    CHECK_NEAR(gv_ssim(a, b, 1, 1, 2), constant_closed_form(0.5, 0.25, 1, 1), 1e-9);
}

static void test_identical(void)
{
    enum { W = 17, H = 12, C = 3, N = W * H * C };
    float a[N], grad[N];
    random_image(a, N, 5);
    CHECK(isinf(gv_psnr(a, a, W, H, C)) && gv_psnr(a, a, W, H, C) > 0);
    CHECK_NEAR(gv_ssim(a, a, W, H, C), 1.0, 1e-9);
    /* SSIM is at its maximum: the gradient vanishes. */
    CHECK_NEAR(gv_ssim_with_gradient(a, a, W, H, C, grad), 1.0, 1e-9);
    double max_grad = 0.0;
    for (int i = 0; i < N; i++) max_grad = fmax(max_grad, fabs(grad[i]));
    CHECK(max_grad < 1e-7);
    /* Also on 8-bit images through the convenience call, and its size check. */
    gv_image x, y;
    CHECK(gv_image_alloc(&x, W, H, C) == 0 && gv_image_alloc(&y, W, H, C) == 0);
    gv_image_from_float(&x, a);
    memcpy(y.pixels, x.pixels, N);
    double psnr, ssim;
    CHECK(gv_image_psnr_ssim(&x, &y, &psnr, &ssim) == 0);
    CHECK(isinf(psnr) && fabs(ssim - 1.0) < 1e-9);
    y.pixels[7] ^= 1; /* one value off by 1/255: MSE = (1/255)^2 / N */
    CHECK(gv_image_psnr_ssim(&x, &y, &psnr, &ssim) == 0);
    CHECK_NEAR(psnr, 10.0 * log10(255.0 * 255.0 * N), 1e-4);
    CHECK(ssim < 1.0);
    gv_image_free(&y);
    CHECK(gv_image_alloc(&y, W, H + 1, C) == 0);
    CHECK_FAILS_WITH(gv_image_psnr_ssim(&x, &y, &psnr, &ssim), "differ in size");
    gv_image_free(&y);
    gv_image_free(&x);
    gv_clear_error();
    CHECK(isnan(gv_ssim(a, a, 0, H, C)));
    CHECK(strstr(gv_last_error(), "invalid image size") != NULL);
}

/* The analytic gradient against central differences of the direct double SSIM. */
static void test_gradient(void)
{
    enum { W = 13, H = 9, C = 2, N = W * H * C };
    float a[N], b[N], grad[N];
    double ad[N];
    random_image(a, N, 11);
    random_image(b, N, 12);
    for (int i = 0; i < N; i++) b[i] = 0.6f * a[i] + 0.4f * b[i];
    double s = gv_ssim_with_gradient(a, b, W, H, C, grad);
    CHECK_NEAR(s, gv_ssim(a, b, W, H, C), 1e-12);
    for (int i = 0; i < N; i++) ad[i] = a[i];
    const double h = 1e-4;
    double max_err = 0.0, max_grad = 0.0;
    for (int i = 0; i < N; i++) {
        double keep = ad[i];
        ad[i] = keep + h;
        double up = naive_ssim(ad, b, W, H, C);
        ad[i] = keep - h;
        double down = naive_ssim(ad, b, W, H, C);
        ad[i] = keep;
        double fd = (up - down) / (2 * h);
        max_err = fmax(max_err, fabs(fd - grad[i]));
        max_grad = fmax(max_grad, fabs(fd));
    }
    printf("SSIM gradient %dx%dx%d: max |analytic - central difference| %.3g (max |grad| %.3g)\n",
           W, H, C, max_err, max_grad);
    CHECK(max_grad > 1e-4);
    CHECK(max_err < 1e-3 * max_grad);
}

static void test_thread_count_invariance(void)
{
    enum { W = 64, H = 36, C = 3, N = W * H * C };
    static float a[N], b[N], g1[N], g2[N];
    random_image(a, N, 21);
    random_image(b, N, 22);
    int threads = omp_get_max_threads();
    omp_set_num_threads(1);
    double s1 = gv_ssim_with_gradient(a, b, W, H, C, g1);
    omp_set_num_threads(2);
    double s2 = gv_ssim_with_gradient(a, b, W, H, C, g2);
    omp_set_num_threads(threads);
    CHECK(s1 == s2);
    CHECK(!memcmp(g1, g2, sizeof g1));
}

int main(void)
{
    make_window();
    test_against_direct();
    test_psnr_exact();
    test_constant_images();
    test_identical();
    test_gradient();
    test_thread_count_invariance();
    return check_summary();
}
