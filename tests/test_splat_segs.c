/* SE-GS's uncertainty-aware perturbation (src/splat/segs.c):
 * - `segs` in the --regularize list;
 * - the uncertainty map of a hand-built stack (one pixel varies: its unbiased standard
 *   deviation spread by the 5 x 5 box, exact values);
 * - the threshold (the top 5 % of the pixels, floored at 0.01);
 * - the distance transform against brute force on random masks, and with no mask;
 * - the selection of Gaussians on a hand-built map (the release's squared-distance test,
 *   out-of-image centres, radius 0);
 * - the noise ratio's schedule (exact ends, geometric mean half-way);
 * - the perturbation: only marked rows move, SH untouched, their moments zeroed and the
 *   others' kept, rotations stay unit quaternions, zero noise keeps the rotation, the noise's
 *   spread matches ratio x scale, the same seed gives the same bytes;
 * - the pseudo views: the near share on hand-built cameras (exact), every pseudo view within
 *   half the closest cameras' distance and 15 degrees of a training camera.
 * The pseudo-view term SE-GS trains with is CoR-GS's (gv_splat_corgs_pseudo_grad), whose
 * gradient tests/test_splat_corgs.c checks against finite differences: SE-GS adds no loss
 * term of its own. */
#include "gaussvid/io/colmap.h"
#include "gaussvid/splat/splat_train.h"
#include "check.h"

/* `segs` in the --regularize list, alone and with the others, in the names' order. */
static void test_parse(void)
{
    char buf[64];
    CHECK(gv_splat_regularize_parse("segs") == GV_REGULARIZE_SEGS);
    int set = gv_splat_regularize_parse("segs,corgs,dropgaussian");
    CHECK(set == (GV_REGULARIZE_SEGS | GV_REGULARIZE_CORGS | GV_REGULARIZE_DROPGAUSSIAN));
    gv_splat_regularize_name(set, buf, sizeof buf);
    CHECK(strcmp(buf, "dropgaussian,corgs,segs") == 0);
    CHECK(gv_splat_regularize_parse("segs,segs") == -1);
    CHECK(gv_splat_regularize_parse("seg") == -1);
    CHECK((GV_REGULARIZE_TWO_FIELDS & GV_REGULARIZE_SEGS) && (GV_REGULARIZE_TWO_FIELDS & GV_REGULARIZE_CORGS));
}

static void test_uncertainty(void)
{
    enum { W = 9, H = 7, P = W * H };
    static float r[3][P * 3], scratch[P], out[P];
    for (int k = 0; k < 3; k++)
        for (int i = 0; i < P * 3; i++) r[k][i] = 0.5f;
    int px = 1, py = 3; /* near the left edge: the box is cut there */
    for (int k = 0; k < 3; k++)
        for (int c = 0; c < 3; c++) r[k][3 * (py * W + px) + c] = 0.25f * (float)k; /* 0, .25, .5 */
    const float *stack[3] = {r[0], r[1], r[2]};
    gv_splat_segs_uncertainty(stack, 3, W, H, scratch, out);
    /* mean 0.25, squared deviations 0.0625 + 0 + 0.0625 over 2: std 0.25 in every channel. */
    for (int y = 0; y < H; y++)
        for (int x = 0; x < W; x++) {
            int inside = abs(x - px) <= 2 && abs(y - py) <= 2;
            CHECK_NEAR(out[y * W + x], inside ? 0.25 / 25 : 0, 1e-7);
        }
    /* One render: no spread. */
    gv_splat_segs_uncertainty(stack, 1, W, H, scratch, out);
    for (int i = 0; i < P; i++) CHECK(out[i] == 0);
}

static void test_threshold(void)
{
    enum { P = 200 };
    static float u[P], scratch[P];
    for (int i = 0; i < P; i++) u[i] = (float)((i * 37) % P) / P; /* 0 .. 0.995, shuffled */
    /* floor(0.05 x 200) = 10: the 11th largest, 189 / 200. */
    CHECK_NEAR(gv_splat_segs_threshold(u, P, scratch), 189.0 / P, 1e-7);
    for (int i = 0; i < P; i++) u[i] *= 0.01f;
    CHECK_NEAR(gv_splat_segs_threshold(u, P, scratch), GV_SEGS_MIN_STD, 1e-12);
}

static void test_distance(void)
{
    enum { W = 23, H = 17, P = W * H };
    static float u[P], d2[P];
    gv_rng rng;
    gv_rng_init(&rng, 5);
    for (int trial = 0; trial < 20; trial++) {
        double share = trial < 10 ? 0.02 : 0.3;
        for (int i = 0; i < P; i++) u[i] = gv_rng_uniform(&rng) < share ? 1.0f : 0.0f;
        u[trial * 7 % P] = 1; /* at least one */
        REQUIRE(gv_splat_segs_distance(u, W, H, 0.5, d2) == 0);
        int bad = 0;
        for (int y = 0; y < H; y++)
            for (int x = 0; x < W; x++) {
                double best = INFINITY;
                for (int v = 0; v < H; v++)
                    for (int s = 0; s < W; s++)
                        if (u[v * W + s] > 0.5) best = fmin(best, (double)(x - s) * (x - s) + (double)(y - v) * (y - v));
                bad += d2[y * W + x] != best;
            }
        CHECK(bad == 0);
    }
    for (int i = 0; i < P; i++) u[i] = 0;
    REQUIRE(gv_splat_segs_distance(u, W, H, 0.5, d2) == 0);
    for (int i = 0; i < P; i++) CHECK(d2[i] >= (float)(W * W + H * H));
}

static void test_mark(void)
{
    enum { W = 10, H = 6, P = W * H };
    static float u[P], d2[P];
    u[2 * W + 3] = 1; /* the one uncertain pixel: (3, 2) */
    REQUIRE(gv_splat_segs_distance(u, W, H, 0.5, d2) == 0);
    /* centre (x, y), radius: squared distance from its pixel to (3, 2) against the radius */
    const float means2d[] = {3.5f, 2.5f,  /* 0: on it, radius 1: 0 < 1 */
                             6.2f, 2.9f,  /* 1: pixel (6, 2), 9 < 10 */
                             6.9f, 2.1f,  /* 2: pixel (6, 2), 9 < 9 is false */
                             3.0f, 5.99f, /* 3: pixel (3, 5), 9 < 16 */
                             3.0f, 6.0f,  /* 4: pixel (3, 6): outside the image */
                             -0.5f, 2.0f, /* 5: pixel (-1, 2): outside */
                             3.5f, 2.5f}; /* 6: radius 0: not in the view */
    const int radii[] = {1, 10, 9, 16, 100, 100, 0};
    unsigned char mark[7] = {0};
    CHECK(gv_splat_segs_mark(d2, W, H, 7, means2d, radii, mark) == 3);
    const unsigned char expect[7] = {1, 1, 0, 1, 0, 0, 0};
    CHECK(memcmp(mark, expect, 7) == 0);
    CHECK(gv_splat_segs_mark(d2, W, H, 7, means2d, radii, mark) == 0); /* already marked */
}

static void test_noise_ratio(void)
{
    /* 8000 iterations, from 500, every 500: first perturbation 2000, last before 7500. */
    CHECK_NEAR(gv_splat_segs_noise_ratio(2000, 8000, 500, 500), 0.08, 1e-15);
    CHECK_NEAR(gv_splat_segs_noise_ratio(1000, 8000, 500, 500), 0.08, 1e-15);
    CHECK_NEAR(gv_splat_segs_noise_ratio(7500, 8000, 500, 500), 0.02, 1e-15);
    CHECK_NEAR(gv_splat_segs_noise_ratio(4750, 8000, 500, 500), 0.04, 1e-15);
    CHECK_NEAR(gv_splat_segs_noise_ratio(600, 1000, 500, 500), 0.02, 1e-15); /* no room: min */
}

static void make_field(gv_gaussians *g, gv_splat_adam *adam, int n)
{
    CHECK(gv_gaussians_alloc(g, n, 1) == 0);
    gv_rng rng;
    gv_rng_init(&rng, 11);
    for (int i = 0; i < n; i++) {
        for (int a = 0; a < 3; a++) g->means[3 * i + a] = (float)gv_rng_normal(&rng), g->scales[3 * i + a] = -4;
        for (int a = 0; a < 4; a++) g->rotations[4 * i + a] = (float)gv_rng_normal(&rng);
        for (int a = 0; a < 12; a++) g->sh[12 * i + a] = (float)a;
        g->opacities[i] = 0.5f;
    }
    gv_splat_adam_config c;
    gv_splat_adam_defaults(&c);
    CHECK(gv_splat_adam_init(adam, &c, g, 1.0) == 0);
    for (int i = 0; i < n; i++)
        for (int a = 0; a < 3; a++) adam->m.means[3 * i + a] = adam->v.scales[3 * i + a] = 7;
}

static double rotation_difference(const float a[4], const float b[4])
{
    double qa[4] = {a[0], a[1], a[2], a[3]}, qb[4] = {b[0], b[1], b[2], b[3]}, Ra[9], Rb[9], d = 0;
    gv_colmap_qvec_to_rotmat(qa, Ra), gv_colmap_qvec_to_rotmat(qb, Rb);
    for (int k = 0; k < 9; k++) d = fmax(d, fabs(Ra[k] - Rb[k]));
    return d;
}

static void test_perturb(void)
{
    enum { N = 20000 };
    gv_gaussians g, orig, again;
    gv_splat_adam adam, adam2;
    make_field(&g, &adam, N), make_field(&orig, &adam2, N);
    gv_splat_adam_free(&adam2);
    static unsigned char mark[N];
    for (int i = 0; i < N; i++) mark[i] = i % 4 != 0;
    double scale[13];
    /* No noise: the marked rows' rotation is the same rotation (normalised), nothing else moves. */
    CHECK(gv_splat_segs_perturb(&g, &adam, mark, 0.0, 2.0, 3, scale) == N - N / 4);
    double worst = 0;
    for (int i = 0; i < N; i++) worst = fmax(worst, rotation_difference(g.rotations + 4 * i, orig.rotations + 4 * i));
    CHECK(worst < 1e-6);
    CHECK(memcmp(g.means, orig.means, sizeof(float) * 3 * N) == 0);
    CHECK_NEAR(scale[0], 2.0, 0); /* the extent */
    CHECK_NEAR(scale[2], 2.0, 0);
    CHECK_NEAR(scale[3], 1.0, 0);                               /* mean |logit| 0.5, floor 1 */
    CHECK_NEAR(scale[4], 4.0, 1e-12);                           /* mean |log-scale| */
    gv_splat_adam_free(&adam), gv_gaussians_free(&g);

    make_field(&g, &adam, N), make_field(&again, &adam2, N);
    double ratio = 0.05, sum[2] = {0, 0};
    gv_splat_segs_perturb(&g, &adam, mark, ratio, 2.0, 9, NULL);
    gv_splat_segs_perturb(&again, &adam2, mark, ratio, 2.0, 9, NULL);
    CHECK(memcmp(g.means, again.means, sizeof(float) * 3 * N) == 0); /* same seed, same bytes */
    int moved_unmarked = 0, sh_changed = 0, moments_bad = 0, not_unit = 0;
    long count = 0;
    for (int i = 0; i < N; i++) {
        double n2 = 0;
        for (int a = 0; a < 4; a++) n2 += (double)g.rotations[4 * i + a] * g.rotations[4 * i + a];
        if (mark[i]) not_unit += fabs(n2 - 1) > 1e-5;
        for (int a = 0; a < 12; a++) sh_changed += g.sh[12 * i + a] != orig.sh[12 * i + a];
        for (int a = 0; a < 3; a++) {
            double d = g.means[3 * i + a] - orig.means[3 * i + a];
            if (!mark[i]) moved_unmarked += d != 0 || g.scales[3 * i + a] != orig.scales[3 * i + a];
            else sum[0] += d * d, sum[1] += pow(g.scales[3 * i + a] - orig.scales[3 * i + a], 2), count++;
            moments_bad += mark[i] ? adam.m.means[3 * i + a] != 0 || adam.v.scales[3 * i + a] != 0
                                   : adam.m.means[3 * i + a] != 7 || adam.v.scales[3 * i + a] != 7;
        }
    }
    CHECK(moved_unmarked == 0 && sh_changed == 0 && moments_bad == 0 && not_unit == 0);
    /* 45 000 draws: the sample standard deviation is within 2 % of the true one. */
    CHECK_NEAR(sqrt(sum[0] / count), ratio * 2.0, 0.02 * ratio * 2.0);
    CHECK_NEAR(sqrt(sum[1] / count), ratio * 4.0, 0.02 * ratio * 4.0);
    gv_splat_adam_free(&adam), gv_splat_adam_free(&adam2);
    gv_gaussians_free(&g), gv_gaussians_free(&again), gv_gaussians_free(&orig);
}

/* Camera i at centre (x_i, 0, 0), rotated by angle_i degrees about y. */
static void make_camera(gv_camera *c, double x, double degrees)
{
    memset(c, 0, sizeof *c);
    c->width = 32, c->height = 24, c->fx = c->fy = 30, c->cx = 16, c->cy = 12;
    double a = degrees * M_PI / 180;
    double R[9] = {cos(a), 0, -sin(a), 0, 1, 0, sin(a), 0, cos(a)};
    memcpy(c->R, R, sizeof R);
    for (int r = 0; r < 3; r++) c->t[r] = -R[3 * r] * x; /* t = -R C */
}

static void test_pseudo_views(void)
{
    gv_camera cams[3];
    make_camera(&cams[0], 0, 0), make_camera(&cams[1], 1, 10), make_camera(&cams[2], 3, 50);
    CHECK_NEAR(gv_splat_segs_near_share(cams, 3, 0), 0.5, 1e-12);
    CHECK_NEAR(gv_splat_segs_near_share(cams, 3, 1), 0.25, 1e-12); /* 0.5 x 1 / 2 */
    make_camera(&cams[2], 1.5, 50);
    CHECK_NEAR(gv_splat_segs_near_share(cams, 3, 1), 0.375, 1e-12); /* 15 / 40 degrees */
    make_camera(&cams[2], 3, 50);
    gv_splat_segs s;
    REQUIRE(gv_splat_segs_init(&s, 3, cams, 500, 4) == 0);
    int far = 0;
    for (int i = 0; i < GV_SEGS_VIEWS; i++) {
        double c[3], best_d = INFINITY, best_a = INFINITY;
        gv_camera_center(&s.cameras[i], c);
        for (int k = 0; k < 3; k++) {
            double ck[3], d = 0, tr = 0;
            gv_camera_center(&cams[k], ck);
            for (int a = 0; a < 3; a++) d += (c[a] - ck[a]) * (c[a] - ck[a]);
            for (int a = 0; a < 9; a++) tr += s.cameras[i].R[a] * cams[k].R[a];
            best_d = fmin(best_d, sqrt(d));
            best_a = fmin(best_a, acos(fmin(fmax((tr - 1) / 2, -1), 1)) * 180 / M_PI);
        }
        far += best_d > 0.5 + 1e-9 || best_a > 15 + 1e-6;
    }
    CHECK(far == 0);
    gv_splat_segs_free(&s);
    CHECK_FAILS_WITH(gv_splat_segs_init(&s, 1, cams, 500, 4), "need two");
    CHECK_FAILS_WITH(gv_splat_segs_init(&s, 3, cams, 0, 4), "at least 1");
}

int main(void)
{
    test_parse();
    test_uncertainty();
    test_threshold();
    test_distance();
    test_mark();
    test_noise_ratio();
    test_perturb();
    test_pseudo_views();
    return check_summary();
}
