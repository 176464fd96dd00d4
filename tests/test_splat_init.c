/* Initialisation of the Gaussians (src/splat/knn.c, init.c): the kd-tree k-nearest-neighbour
 * distances against a brute-force search, and the values create_from_pcd gives (reference
 * doc section 3). */
#include "check.h"
#include "gaussvid/core/core.h"
#include "gaussvid/splat/splat_train.h"

/* Mean of the k smallest squared distances from point i to the others, by sorting them. */
static double brute_mean_sq(int n, const float *xyz, int k, int i)
{
    double best[16];
    int count = 0;
    for (int j = 0; j < n; j++) {
        if (j == i) continue;
        double d2 = 0;
        for (int a = 0; a < 3; a++) {
            double d = (double)xyz[3 * j + a] - xyz[3 * i + a];
            d2 += d * d;
        }
        int at;
        if (count < k) at = count++;
        else if (d2 < best[k - 1]) at = k - 1;
        else continue;
        while (at > 0 && best[at - 1] > d2) best[at] = best[at - 1], at--;
        best[at] = d2;
    }
    double sum = 0;
    for (int j = 0; j < count; j++) sum += best[j];
    return count ? sum / count : 0;
}

/* Clouds that stress a kd-tree: uniform, clustered with duplicates, and on a plane. */
static void make_cloud(int kind, int n, float *xyz, uint64_t seed)
{
    gv_rng r;
    gv_rng_init(&r, seed);
    for (int i = 0; i < n; i++) {
        for (int a = 0; a < 3; a++) xyz[3 * i + a] = (float)(10 * gv_rng_uniform(&r) - 5);
        if (kind == 1) { /* 20 tight clusters, every 7th point an exact duplicate */
            int c = (int)(gv_rng_uniform(&r) * 20);
            for (int a = 0; a < 3; a++)
                xyz[3 * i + a] = (float)(c * (a + 1) * 0.7 + 0.01 * gv_rng_normal(&r));
            if (i % 7 == 6) for (int a = 0; a < 3; a++) xyz[3 * i + a] = xyz[3 * (i - 1) + a];
        }
        if (kind == 2) xyz[3 * i + 2] = 1.5f; /* all on z = 1.5: ties on one axis */
    }
}

static void test_knn_against_brute_force(void)
{
    enum { N = 1500 };
    static float xyz[3 * N], out[N];
    for (int kind = 0; kind < 3; kind++) {
        make_cloud(kind, N, xyz, 11 + kind);
        for (int k = 1; k <= 4; k += 2) {
            CHECK(gv_knn_mean_sq_dist(N, xyz, k, out) == 0);
            double worst = 0;
            for (int i = 0; i < N; i++) {
                double ref = brute_mean_sq(N, xyz, k, i);
                double err = fabs(out[i] - ref) / (ref > 1e-12 ? ref : 1e-12);
                if (ref == 0) err = out[i] == 0 ? 0 : 1;
                if (err > worst) worst = err;
            }
            printf("knn cloud %d k %d: worst relative difference to brute force %.2e\n", kind, k,
                   worst);
            CHECK(worst < 1e-6);
        }
    }
}

static void test_knn_small_and_bad(void)
{
    float xyz[9] = {0, 0, 0, 3, 0, 0, 0, 4, 0}, out[3];
    /* Fewer points than k: the mean over the others. Point 0: (9 + 16) / 2. */
    CHECK(gv_knn_mean_sq_dist(3, xyz, 3, out) == 0);
    CHECK_NEAR(out[0], 12.5, 1e-6);
    CHECK_NEAR(out[1], (9 + 25) / 2.0, 1e-5);
    CHECK_NEAR(out[2], (16 + 25) / 2.0, 1e-5);
    CHECK(gv_knn_mean_sq_dist(1, xyz, 3, out) == 0);
    CHECK(out[0] == 0);
    CHECK_FAILS_WITH(gv_knn_mean_sq_dist(3, xyz, 0, out), "k = 0");
    CHECK_FAILS_WITH(gv_knn_mean_sq_dist(3, xyz, 17, out), "k = 17");
}

static void test_init_from_points(void)
{
    /* A 2 x 2 x 2 cube of side 0.5 and one far point: each corner's 3 nearest neighbours are
     * at 0.5, so s = 0.5; the far point's are the 3 nearest corners. */
    float xyz[27];
    int n = 0;
    for (int z = 0; z < 2; z++)
        for (int y = 0; y < 2; y++)
            for (int x = 0; x < 2; x++, n++)
                xyz[3 * n] = 0.5f * x, xyz[3 * n + 1] = 0.5f * y, xyz[3 * n + 2] = 0.5f * z;
    xyz[24] = 10, xyz[25] = 0, xyz[26] = 0;
    uint8_t rgb[27] = {0};
    for (int i = 0; i < 27; i++) rgb[i] = (uint8_t)(i * 9);
    gv_gaussians g;
    CHECK(gv_splat_init_from_points(&g, 9, xyz, rgb, 3) == 0);
    CHECK(g.n == 9 && g.sh_degree == 3);
    const double C0 = 0.28209479177387814;
    for (int i = 0; i < 9; i++) {
        for (int c = 0; c < 3; c++) CHECK_NEAR(g.sh[48 * i + c], (rgb[3 * i + c] / 255.0 - 0.5) / C0, 1e-6);
        double rest = 0;
        for (int j = 3; j < 48; j++) rest += fabs(g.sh[48 * i + j]);
        CHECK(rest == 0);
        CHECK_NEAR(g.opacities[i], log(0.1 / 0.9), 1e-6);
        CHECK(g.rotations[4 * i] == 1 && g.rotations[4 * i + 1] == 0 &&
              g.rotations[4 * i + 2] == 0 && g.rotations[4 * i + 3] == 0);
        CHECK(g.scales[3 * i] == g.scales[3 * i + 1] && g.scales[3 * i] == g.scales[3 * i + 2]);
        for (int a = 0; a < 3; a++) CHECK(g.means[3 * i + a] == xyz[3 * i + a]);
    }
    for (int i = 0; i < 8; i++) CHECK_NEAR(g.scales[3 * i], log(0.5), 1e-6);
    /* Far point (10, 0, 0): nearest corners (0.5, 0, 0), (0.5, 0.5, 0), (0.5, 0, 0.5). */
    double d2 = (9.5 * 9.5 + (9.5 * 9.5 + 0.25) * 2) / 3;
    CHECK_NEAR(g.scales[24], 0.5 * log(d2), 1e-6);
    gv_gaussians_free(&g);

    /* Duplicates: the squared distance is clamped at 1e-7 before the log. */
    float dup[12] = {1, 2, 3, 1, 2, 3, 1, 2, 3, 1, 2, 3};
    CHECK(gv_splat_init_from_points(&g, 4, dup, NULL, 0) == 0);
    CHECK_NEAR(g.scales[0], 0.5 * log(1e-7), 1e-5);
    CHECK_NEAR(g.sh[0], (128 / 255.0 - 0.5) / C0, 1e-6); /* no colour: grey 128 */
    gv_gaussians_free(&g);

    float bad[6] = {0, 0, 0, NAN, 0, 0};
    CHECK_FAILS_WITH(gv_splat_init_from_points(&g, 2, bad, NULL, 3), "point 1");
    CHECK_FAILS_WITH(gv_splat_init_from_points(&g, 0, bad, NULL, 3), "no points");
}

static void test_init_random(void)
{
    double center[3] = {1, -2, 3};
    gv_gaussians g, h;
    CHECK(gv_splat_init_random(&g, 2000, center, 0.5, 1, 42) == 0);
    CHECK(g.n == 2000 && g.sh_degree == 1);
    int inside = 1;
    double mean[3] = {0, 0, 0};
    for (int i = 0; i < g.n; i++)
        for (int a = 0; a < 3; a++) {
            double x = g.means[3 * i + a];
            inside &= x >= center[a] - 0.5 && x <= center[a] + 0.5;
            mean[a] += x / g.n;
        }
    CHECK(inside);
    for (int a = 0; a < 3; a++) CHECK_NEAR(mean[a], center[a], 0.03);
    int dc_ok = 1;
    for (int i = 0; i < g.n; i++)
        for (int c = 0; c < 3; c++) dc_ok &= g.sh[12 * i + c] >= 0 && g.sh[12 * i + c] < 1 / 255.0f;
    CHECK(dc_ok);
    CHECK(gv_splat_init_random(&h, 2000, center, 0.5, 1, 42) == 0);
    CHECK(memcmp(g.means, h.means, sizeof(float) * 6000) == 0); /* same seed, same points */
    gv_gaussians_free(&h);
    CHECK(gv_splat_init_random(&h, 2000, center, 0.5, 1, 43) == 0);
    CHECK(memcmp(g.means, h.means, sizeof(float) * 6000) != 0);
    gv_gaussians_free(&g), gv_gaussians_free(&h);
    CHECK_FAILS_WITH(gv_splat_init_random(&g, 10, center, 0, 3, 1), "box size");
}

int main(void)
{
    test_knn_against_brute_force();
    test_knn_small_and_bad();
    test_init_from_points();
    test_init_random();
    return check_summary();
}
