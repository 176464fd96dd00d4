/* LPIPS (AlexNet) with random weights written here under the lpips package's names: the
 * whole forward against a direct double-precision implementation written in this file
 * (convolutions as plain loops with the padding tested per tap), a hand-derived two-channel
 * case, identity and symmetry, the size limits, F16/BF16 files, concurrent calls, and
 * malformed weight files (missing, unexpected, mis-shaped, mistyped, non-finite keys). */
#include <omp.h>

#include "check.h"
#include "gaussvid/core/core.h"
#include "gaussvid/io/image.h"
#include "gaussvid/eval/lpips.h"
#include "gaussvid/io/safetensors.h"

/* torchvision alexnet().features as LPIPS slices it: conv (c_in, c_out, k, stride, pad),
 * with a 3x3 stride-2 max-pool before slices 2 and 3. */
static const struct { int c_in, c_out, k, s, p, pool; } layer[5] = {
    {3, 64, 11, 4, 2, 0}, {64, 192, 5, 1, 2, 1}, {192, 384, 3, 1, 1, 1},
    {384, 256, 3, 1, 1, 0}, {256, 256, 3, 1, 1, 0},
};
/* The names of lpips.LPIPS(net='alex').state_dict(), per layer: weight, bias, head. */
static const char *const names[15] = {
    "net.slice1.0.weight", "net.slice1.0.bias", "lin0.model.1.weight",
    "net.slice2.3.weight", "net.slice2.3.bias", "lin1.model.1.weight",
    "net.slice3.6.weight", "net.slice3.6.bias", "lin2.model.1.weight",
    "net.slice4.8.weight", "net.slice4.8.bias", "lin3.model.1.weight",
    "net.slice5.10.weight", "net.slice5.10.bias", "lin4.model.1.weight",
};

typedef struct {
    float *data[15];
    int64_t shape[15][4];
    int rank[15];
} test_net;

static void net_shapes(test_net *n)
{
    for (int l = 0; l < 5; l++) {
        int64_t *w = n->shape[3 * l], *b = n->shape[3 * l + 1], *h = n->shape[3 * l + 2];
        w[0] = layer[l].c_out, w[1] = layer[l].c_in, w[2] = w[3] = layer[l].k;
        b[0] = layer[l].c_out;
        h[0] = 1, h[1] = layer[l].c_out, h[2] = h[3] = 1;
        n->rank[3 * l] = 4, n->rank[3 * l + 1] = 1, n->rank[3 * l + 2] = 4;
    }
}

static int64_t numel(const test_net *n, int k)
{
    int64_t e = 1;
    for (int i = 0; i < n->rank[k]; i++) e *= n->shape[k][i];
    return e;
}

/* He-scaled normal conv weights, small biases, non-negative heads (as the published heads,
 * which training clamps at zero). */
static void net_random(test_net *n, uint64_t seed)
{
    net_shapes(n);
    gv_rng r;
    gv_rng_init(&r, seed);
    for (int k = 0; k < 15; k++) {
        int l = k / 3, kind = k % 3;
        int64_t e = numel(n, k);
        n->data[k] = malloc((size_t)e * sizeof(float));
        double std = sqrt(2.0 / (layer[l].c_in * layer[l].k * layer[l].k));
        for (int64_t i = 0; i < e; i++)
            n->data[k][i] = kind == 0 ? (float)(std * gv_rng_normal(&r))
                          : kind == 1 ? (float)(0.1 * gv_rng_normal(&r))
                                      : (float)gv_rng_uniform(&r);
    }
}

static void net_free(test_net *n)
{
    for (int k = 0; k < 15; k++) free(n->data[k]);
}

/* Adds every tensor but `skip` (NULL: none) as `dtype`. */
static void add_net(gv_st_builder *b, const test_net *n, gv_st_dtype dtype, const char *skip)
{
    for (int k = 0; k < 15; k++)
        if (!skip || strcmp(skip, names[k]) != 0)
            CHECK(gv_st_add_f32(b, names[k], dtype, n->shape[k], n->rank[k], n->data[k]) == 0);
}

static void write_net(const char *path, const test_net *n, gv_st_dtype dtype)
{
    gv_st_builder b;
    gv_st_builder_init(&b);
    add_net(&b, n, dtype, NULL);
    CHECK(gv_st_write(&b, path) == 0);
    gv_st_builder_free(&b);
}

/* ---- the reference: direct loops in double ------------------------------------------ */
typedef struct {
    int c, h, w;
    double *v; /* [c][h][w] */
} map;

static map map_new(int c, int h, int w)
{
    map m = {c, h, w, calloc((size_t)c * h * w, sizeof(double))};
    return m;
}

static map ref_conv_relu(map in, const float *w, const float *bias, int l)
{
    int k = layer[l].k, s = layer[l].s, p = layer[l].p;
    map out = map_new(layer[l].c_out, (in.h + 2 * p - k) / s + 1, (in.w + 2 * p - k) / s + 1);
    for (int co = 0; co < out.c; co++)
        for (int y = 0; y < out.h; y++)
            for (int x = 0; x < out.w; x++) {
                double sum = bias[co];
                for (int ci = 0; ci < in.c; ci++)
                    for (int ky = 0; ky < k; ky++)
                        for (int kx = 0; kx < k; kx++) {
                            int iy = y * s + ky - p, ix = x * s + kx - p;
                            if (iy < 0 || iy >= in.h || ix < 0 || ix >= in.w) continue;
                            sum += w[((co * in.c + ci) * k + ky) * k + kx] *
                                   in.v[(ci * in.h + iy) * in.w + ix];
                        }
                out.v[(co * out.h + y) * out.w + x] = sum > 0 ? sum : 0;
            }
    return out;
}

static map ref_pool(map in)
{
    map out = map_new(in.c, (in.h - 3) / 2 + 1, (in.w - 3) / 2 + 1);
    for (int c = 0; c < in.c; c++)
        for (int y = 0; y < out.h; y++)
            for (int x = 0; x < out.w; x++) {
                double m = -INFINITY;
                for (int i = 0; i < 3; i++)
                    for (int j = 0; j < 3; j++)
                        m = fmax(m, in.v[(c * in.h + 2 * y + i) * in.w + 2 * x + j]);
                out.v[(c * out.h + y) * out.w + x] = m;
            }
    return out;
}

/* The five ReLU outputs of x (HWC, values in [-1, 1]), each divided by its channel norm. */
static void ref_features(const test_net *n, const double *x, int W, int H, map f[5])
{
    const double shift[3] = {-0.030, -0.088, -0.188}, scale[3] = {0.458, 0.448, 0.450};
    map in = map_new(3, H, W);
    for (int c = 0; c < 3; c++)
        for (int i = 0; i < W * H; i++) in.v[c * W * H + i] = (x[3 * i + c] - shift[c]) / scale[c];
    map scaled = in;
    for (int l = 0; l < 5; l++) {
        map src = layer[l].pool ? ref_pool(in) : in;
        f[l] = ref_conv_relu(src, n->data[3 * l], n->data[3 * l + 1], l);
        if (layer[l].pool) free(src.v);
        in = f[l];
    }
    free(scaled.v);
    for (int l = 0; l < 5; l++) {
        int np = f[l].h * f[l].w;
        for (int i = 0; i < np; i++) {
            double s = 0;
            for (int c = 0; c < f[l].c; c++) s += f[l].v[c * np + i] * f[l].v[c * np + i];
            for (int c = 0; c < f[l].c; c++) f[l].v[c * np + i] /= sqrt(s) + 1e-10;
        }
    }
}

static double ref_lpips(const test_net *n, const double *xa, const double *xb, int W, int H,
                        double per[5])
{
    map fa[5], fb[5];
    ref_features(n, xa, W, H, fa);
    ref_features(n, xb, W, H, fb);
    double total = 0;
    for (int l = 0; l < 5; l++) {
        int np = fa[l].h * fa[l].w;
        double s = 0;
        for (int c = 0; c < fa[l].c; c++)
            for (int i = 0; i < np; i++) {
                double d = fa[l].v[c * np + i] - fb[l].v[c * np + i];
                s += n->data[3 * l + 2][c] * d * d;
            }
        per[l] = s / np;
        total += per[l];
        free(fa[l].v);
        free(fb[l].v);
    }
    return total;
}

/* ---- images ----------------------------------------------------------------------------- */
/* A smooth colour pattern plus noise, 8-bit. */
static void make_image(gv_image *img, int W, int H, uint64_t seed, double noise)
{
    CHECK(gv_image_alloc(img, W, H, 3) == 0);
    for (int y = 0; y < H; y++)
        for (int x = 0; x < W; x++)
            for (int c = 0; c < 3; c++) {
                size_t i = ((size_t)y * W + x) * 3 + c;
                double v = 0.5 + 0.35 * sin(0.3 * x + 0.2 * y * (c + 1) + (double)(seed % 7)) +
                           noise * (gv_uniform_at(seed, i) - 0.5);
                img->pixels[i] = (uint8_t)(v < 0 ? 0 : v > 1 ? 255 : lround(v * 255));
            }
}

static float *to_unit(const gv_image *img)
{
    size_t n = (size_t)img->width * img->height * 3;
    float *f = malloc(n * sizeof *f);
    gv_image_to_float(img, f);
    return f;
}

/* [-1, 1] inputs as the package builds them: v / 127.5 - 1 (im2tensor). */
static double *to_signed(const gv_image *img)
{
    size_t n = (size_t)img->width * img->height * 3;
    double *x = malloc(n * sizeof *x);
    for (size_t i = 0; i < n; i++) x[i] = img->pixels[i] / 127.5 - 1.0;
    return x;
}

/* ---- checks ----------------------------------------------------------------------------- */
static double worst_rel;

static void check_against_reference(const gv_lpips *net, const test_net *n, int W, int H,
                                    uint64_t seed)
{
    gv_image a, b;
    make_image(&a, W, H, seed, 0.1);
    make_image(&b, W, H, seed + 1, 0.3);
    double *xa = to_signed(&a), *xb = to_signed(&b), ref_per[5];
    double ref = ref_lpips(n, xa, xb, W, H, ref_per);
    double got = -1, got_per[5];
    CHECK(gv_lpips_distance(net, &a, &b, &got) == 0);
    CHECK_NEAR(got, ref, 1e-4 * ref);
    worst_rel = fmax(worst_rel, fabs(got - ref) / ref);

    /* the float form: x = 2 v - 1 with v = u8 / 255, the same values up to rounding */
    float *ua = to_unit(&a), *ub = to_unit(&b);
    double got_f = -1;
    CHECK(gv_lpips_distance_f32(net, ua, ub, W, H, got_per, &got_f) == 0);
    double sum = 0;
    for (int l = 0; l < 5; l++) {
        CHECK_NEAR(got_per[l], ref_per[l], 1e-4 * ref_per[l] + 1e-9);
        CHECK(ref_per[l] > 0);
        worst_rel = fmax(worst_rel, fabs(got_per[l] - ref_per[l]) / ref_per[l]);
        sum += got_per[l];
    }
    CHECK_NEAR(sum, got_f, 1e-12 * got_f);
    CHECK_NEAR(got_f, ref, 1e-4 * ref);

    /* identity is exact; symmetry is exact ((a - b)^2 == (b - a)^2 in floating point) */
    double same = -1, swapped = -1;
    CHECK(gv_lpips_distance(net, &a, &a, &same) == 0);
    CHECK(same == 0.0);
    CHECK(gv_lpips_distance_f32(net, ub, ub, W, H, got_per, &same) == 0);
    CHECK(same == 0.0);
    for (int l = 0; l < 5; l++) CHECK(got_per[l] == 0.0);
    CHECK(gv_lpips_distance(net, &b, &a, &swapped) == 0);
    CHECK(swapped == got);
    printf("%dx%d: LPIPS %.6f, reference %.6f, relative difference %.2e\n", W, H, got, ref,
           fabs(got - ref) / ref);
    free(xa), free(xb), free(ua), free(ub);
    gv_image_free(&a), gv_image_free(&b);
}

/* Two-channel case derived by hand: conv1 channel 0 copies R and channel 1 copies G at the
 * kernel centre (which is inside the image for every output pixel), everything else is zero,
 * only lin0 has weights (w0 on channel 0, w1 on channel 1). For constant images relu1 is
 * (u_R, u_G)^+ everywhere, u = (x - shift) / scale. White: both positive. Red (255, 0, 0):
 * u_G < 0 so the unit feature is (1, 0). LPIPS = w0 (uR / r - 1)^2 + w1 (uG / r)^2. */
static void test_hand_case_banded(const gv_lpips *net, double w0, double w1);

static void test_hand_case(const char *dir)
{
    test_net n;
    net_shapes(&n);
    for (int k = 0; k < 15; k++) n.data[k] = calloc((size_t)numel(&n, k), sizeof(float));
    n.data[0][(0 * 3 + 0) * 121 + 5 * 11 + 5] = 1.0f; /* out 0 <- R at (5, 5) */
    n.data[0][(1 * 3 + 1) * 121 + 5 * 11 + 5] = 1.0f; /* out 1 <- G at (5, 5) */
    const double w0 = 0.25, w1 = 0.5;
    n.data[2][0] = (float)w0, n.data[2][1] = (float)w1;
    char path[4200];
    snprintf(path, sizeof path, "%s/hand.safetensors", dir);
    write_net(path, &n, GV_ST_F32);
    gv_lpips net;
    CHECK(gv_lpips_load(&net, path) == 0);
    gv_image white, red;
    CHECK(gv_image_alloc(&white, 40, 33, 3) == 0);
    CHECK(gv_image_alloc(&red, 40, 33, 3) == 0);
    memset(white.pixels, 255, 40 * 33 * 3);
    for (int i = 0; i < 40 * 33; i++) red.pixels[3 * i] = 255;
    double uR = (1.0 + 0.030) / 0.458, uG = (1.0 + 0.088) / 0.448, r = sqrt(uR * uR + uG * uG);
    double want = w0 * (uR / r - 1) * (uR / r - 1) + w1 * (uG / r) * (uG / r), got = -1;
    CHECK(gv_lpips_distance(&net, &white, &red, &got) == 0);
    CHECK_NEAR(got, want, 1e-6);
    printf("hand case: LPIPS %.7f, by hand %.7f\n", got, want);
    gv_image_free(&white), gv_image_free(&red);
    test_hand_case_banded(&net, w0, w1);
    gv_lpips_free(&net);
    net_free(&n);
}


/* The same net on two random 440x440 images, where relu1 (108x108 pixels, 363 rows of
 * columns each) is more than one band of the implementation's 16 MiB im2col buffer: relu1
 * pixel (y, x) sees input pixel (4y + 3, 4x + 3), so its unit feature and the distance
 * follow pixel by pixel. A misplaced band would move features to the wrong pixels. */
static double hand_feature(const gv_image *img, int y, int x, int channel)
{
    const uint8_t *p = img->pixels + ((size_t)(4 * y + 3) * img->width + 4 * x + 3) * 3;
    double uR = fmax(0, (p[0] / 127.5 - 1 + 0.030) / 0.458);
    double uG = fmax(0, (p[1] / 127.5 - 1 + 0.088) / 0.448);
    return (channel == 0 ? uR : uG) / (sqrt(uR * uR + uG * uG) + 1e-10);
}

static void test_hand_case_banded(const gv_lpips *net, double w0, double w1)
{
    enum { SIDE = 440, RELU1 = (SIDE + 4 - 11) / 4 + 1 };
    gv_image a, b;
    CHECK(gv_image_alloc(&a, SIDE, SIDE, 3) == 0);
    CHECK(gv_image_alloc(&b, SIDE, SIDE, 3) == 0);
    for (size_t i = 0; i < (size_t)SIDE * SIDE * 3; i++) {
        a.pixels[i] = (uint8_t)(gv_uniform_at(41, i) * 256);
        b.pixels[i] = (uint8_t)(gv_uniform_at(42, i) * 256);
    }
    double want = 0, got = -1;
    for (int y = 0; y < RELU1; y++)
        for (int x = 0; x < RELU1; x++) {
            double d0 = hand_feature(&a, y, x, 0) - hand_feature(&b, y, x, 0);
            double d1 = hand_feature(&a, y, x, 1) - hand_feature(&b, y, x, 1);
            want += w0 * d0 * d0 + w1 * d1 * d1;
        }
    want /= RELU1 * RELU1;
    CHECK(363.0 * RELU1 * RELU1 > (1 << 22)); /* more than one band */
    CHECK(gv_lpips_distance(net, &a, &b, &got) == 0);
    CHECK_NEAR(got, want, 1e-6 * want);
    printf("hand case, %dx%d (banded): LPIPS %.7f, by hand %.7f\n", SIDE, SIDE, got, want);
    gv_image_free(&a), gv_image_free(&b);
}

static void test_sizes(const gv_lpips *net)
{
    gv_image a, b, small, grey;
    make_image(&a, 31, 31, 3, 0.2);
    make_image(&b, 31, 31, 4, 0.2);
    double d = -1;
    CHECK(gv_lpips_distance(net, &a, &b, &d) == 0);
    CHECK(d > 0);
    make_image(&small, 30, 31, 3, 0.2);
    CHECK_FAILS_WITH(gv_lpips_distance(net, &small, &small, &d), "at least 31x31");
    CHECK_FAILS_WITH(gv_lpips_check_size(31, 30), "31x30 image is too small");
    CHECK(gv_lpips_check_size(31, 31) == 0);
    CHECK_FAILS_WITH(gv_lpips_distance(net, &a, &small, &d), "same size");
    CHECK(gv_image_alloc(&grey, 31, 31, 1) == 0);
    CHECK_FAILS_WITH(gv_lpips_distance(net, &grey, &grey, &d), "3 channels");
    float *ua = to_unit(&a), *ub = to_unit(&b);
    ub[3 * (2 * 31 + 5) + 1] = NAN;
    CHECK_FAILS_WITH(gv_lpips_distance_f32(net, ua, ub, 31, 31, NULL, &d), "pixel (5, 2)");
    free(ua), free(ub);
    gv_image_free(&a), gv_image_free(&b), gv_image_free(&small), gv_image_free(&grey);
}

/* Half-precision files: the same values stored as F32 and as F16 (or BF16) give the same
 * weights and the same distance, bit for bit. */
static void test_half_types(const test_net *n, const char *dir)
{
    gv_st_dtype types[2] = {GV_ST_F16, GV_ST_BF16};
    gv_image a, b;
    make_image(&a, 48, 40, 11, 0.2);
    make_image(&b, 48, 40, 12, 0.2);
    for (int t = 0; t < 2; t++) {
        test_net r = *n;
        for (int k = 0; k < 15; k++) {
            int64_t e = numel(n, k);
            r.data[k] = malloc((size_t)e * sizeof(float));
            for (int64_t i = 0; i < e; i++)
                r.data[k][i] = t == 0 ? gv_f16_to_f32(gv_f32_to_f16(n->data[k][i]))
                                      : gv_bf16_to_f32(gv_f32_to_bf16(n->data[k][i]));
        }
        char p32[4200], p16[4200];
        snprintf(p32, sizeof p32, "%s/rounded%d_f32.safetensors", dir, t);
        snprintf(p16, sizeof p16, "%s/rounded%d_half.safetensors", dir, t);
        write_net(p32, &r, GV_ST_F32);
        write_net(p16, &r, types[t]);
        gv_lpips n32, n16;
        CHECK(gv_lpips_load(&n32, p32) == 0);
        CHECK(gv_lpips_load(&n16, p16) == 0);
        CHECK(n32.n_params == n16.n_params && n32.n_params == 2470848);
        CHECK(memcmp(n32.params, n16.params, n32.n_params * sizeof(float)) == 0);
        double d32 = -1, d16 = -2;
        CHECK(gv_lpips_distance(&n32, &a, &b, &d32) == 0);
        CHECK(gv_lpips_distance(&n16, &a, &b, &d16) == 0);
        CHECK(d32 == d16 && d32 > 0);
        gv_lpips_free(&n32), gv_lpips_free(&n16);
        net_free(&r);
    }
    gv_image_free(&a), gv_image_free(&b);
}

/* Concurrent calls on one net give what sequential calls give. */
static void test_threads(const gv_lpips *net)
{
    enum { PAIRS = 4 };
    gv_image a[PAIRS], b[PAIRS];
    double seq[PAIRS], par[PAIRS];
    int rc[PAIRS];
    for (int i = 0; i < PAIRS; i++) {
        make_image(&a[i], 40 + 4 * i, 36, 20 + i, 0.2);
        make_image(&b[i], 40 + 4 * i, 36, 30 + i, 0.2);
        CHECK(gv_lpips_distance(net, &a[i], &b[i], &seq[i]) == 0);
    }
#pragma omp parallel for num_threads(2) schedule(static, 1)
    for (int i = 0; i < PAIRS; i++) rc[i] = gv_lpips_distance(net, &a[i], &b[i], &par[i]);
    for (int i = 0; i < PAIRS; i++) {
        CHECK(rc[i] == 0);
        CHECK_NEAR(par[i], seq[i], 1e-6 * seq[i]);
        gv_image_free(&a[i]), gv_image_free(&b[i]);
    }
}

/* ---- malformed weight files --------------------------------------------------------- */
/* The load fails with one line naming the file and `needle`, and leaves the net empty. */
static void expect_bad(const char *path, const char *needle)
{
    gv_lpips net;
    CHECK_FAILS_WITH(gv_lpips_load(&net, path), needle);
    CHECK(strstr(gv_last_error(), path) != NULL);
    CHECK(strchr(gv_last_error(), '\n') == NULL);
    CHECK(net.params == NULL && net.n_params == 0);
}

/* Writes the net without `skip`, plus one extra tensor (name NULL: none), as BF16 (half the
 * bytes of F32: these files only have to be refused). */
static void write_variant(const char *path, const test_net *n, const char *skip,
                          const char *extra, const int64_t *shape, int rank, const float *data)
{
    gv_st_builder b;
    gv_st_builder_init(&b);
    add_net(&b, n, GV_ST_BF16, skip);
    if (extra) CHECK(gv_st_add_f32(&b, extra, GV_ST_BF16, shape, rank, data) == 0);
    CHECK(gv_st_write(&b, path) == 0);
    gv_st_builder_free(&b);
}

static void test_bad_keys(const test_net *n, const char *dir)
{
    char path[4200];
    snprintf(path, sizeof path, "%s/bad.safetensors", dir);
    const int64_t small_conv1[4] = {64, 3, 7, 7}, conv1[4] = {64, 3, 11, 11}, bias[1] = {255};

    write_variant(path, n, "net.slice3.6.bias", NULL, NULL, 0, NULL);
    expect_bad(path, "missing net.slice3.6.bias");
    write_variant(path, n, "net.slice1.0.weight", "net.slice1.0.weight", small_conv1, 4,
                  n->data[0]);
    expect_bad(path, "net.slice1.0.weight is [64, 3, 7, 7], expected [64, 3, 11, 11]");
    write_variant(path, n, NULL, "features.0.weight", conv1, 4, n->data[0]);
    expect_bad(path, "unexpected features.0.weight");

    /* several problems: all in one line */
    gv_st_builder b;
    gv_st_builder_init(&b);
    for (int k = 0; k < 15; k++) {
        if (k == 14) continue; /* lin4 missing */
        const int64_t *shape = k == 13 ? bias : n->shape[k];
        CHECK(gv_st_add_f32(&b, names[k], GV_ST_BF16, shape, n->rank[k], n->data[k]) == 0);
    }
    CHECK(gv_st_add_f32(&b, "classifier.1.weight", GV_ST_F32, bias, 1, n->data[13]) == 0);
    CHECK(gv_st_write(&b, path) == 0);
    gv_st_builder_free(&b);
    expect_bad(path, "missing lin4.model.1.weight; unexpected classifier.1.weight; wrong "
                     "shape: net.slice5.10.bias is [255], expected [256]");

    /* many unexpected keys: four are named, the rest counted */
    gv_st_builder_init(&b);
    add_net(&b, n, GV_ST_BF16, NULL);
    for (int i = 0; i < 10; i++) {
        char name[32];
        snprintf(name, sizeof name, "extra.%d", i);
        CHECK(gv_st_add_f32(&b, name, GV_ST_F32, bias, 1, n->data[13]) == 0);
    }
    CHECK(gv_st_write(&b, path) == 0);
    gv_st_builder_free(&b);
    expect_bad(path, "unexpected extra.0, extra.1, extra.2, extra.3 and 6 more");
}

static void test_bad_values(const test_net *n, const char *dir)
{
    char path[4200];
    snprintf(path, sizeof path, "%s/bad.safetensors", dir);
    /* a dtype that is not a float type, and F64 (not accepted for LPIPS weights) */
    gv_st_builder b;
    gv_st_builder_init(&b);
    add_net(&b, n, GV_ST_BF16, "lin2.model.1.weight");
    int32_t ints[384] = {0};
    CHECK(gv_st_add_raw(&b, "lin2.model.1.weight", GV_ST_I32, n->shape[8], 4, ints) == 0);
    CHECK(gv_st_write(&b, path) == 0);
    gv_st_builder_free(&b);
    expect_bad(path, "lin2.model.1.weight is I32");
    gv_st_builder_init(&b);
    add_net(&b, n, GV_ST_BF16, "net.slice2.3.bias");
    double f64[192] = {0};
    CHECK(gv_st_add_raw(&b, "net.slice2.3.bias", GV_ST_F64, n->shape[4], 1, f64) == 0);
    CHECK(gv_st_write(&b, path) == 0);
    gv_st_builder_free(&b);
    expect_bad(path, "net.slice2.3.bias is F64");

    /* a NaN in a weight */
    int64_t e = numel(n, 9);
    float *w = malloc((size_t)e * sizeof *w);
    memcpy(w, n->data[9], (size_t)e * sizeof *w);
    w[17] = NAN;
    write_variant(path, n, "net.slice4.8.weight", "net.slice4.8.weight", n->shape[9], 4, w);
    expect_bad(path, "net.slice4.8.weight has a non-finite value (nan) at element 17");
    free(w);

    /* not a safetensors file; no file */
    snprintf(path, sizeof path, "%s/notes.safetensors", dir);
    FILE *f = fopen(path, "w");
    fputs("these are not weights\n", f);
    fclose(f);
    expect_bad(path, "notes.safetensors");
    snprintf(path, sizeof path, "%s/absent.safetensors", dir);
    expect_bad(path, "absent.safetensors");
}

/* The rest of LPIPS.state_dict(): the ScalingLayer buffers and the `lins` aliases of the
 * heads are accepted when they agree, and refused when they do not. */
static void test_optional_keys(const test_net *n, const char *dir, const gv_lpips *plain)
{
    char path[4200];
    snprintf(path, sizeof path, "%s/full.safetensors", dir);
    const int64_t s4[4] = {1, 3, 1, 1}, s1[1] = {3};
    float shift[3] = {-0.030f, -0.088f, -0.188f}, scale[3] = {0.458f, 0.448f, 0.450f};
    for (int variant = 0; variant < 4; variant++) {
        gv_st_builder b;
        gv_st_builder_init(&b);
        add_net(&b, n, GV_ST_F32, NULL);
        /* BF16 buffers still match the constants (to BF16's rounding) */
        CHECK(gv_st_add_f32(&b, "scaling_layer.shift", GV_ST_BF16, variant == 3 ? s1 : s4,
                            variant == 3 ? 1 : 4, shift) == 0);
        CHECK(gv_st_add_f32(&b, "scaling_layer.scale", GV_ST_F32, s4, 4, scale) == 0);
        for (int l = 0; l < 5; l++) {
            char name[64];
            snprintf(name, sizeof name, "lins.%d.model.1.weight", l);
            const float *data = variant == 2 && l == 3 ? n->data[3 * 4 + 2] : n->data[3 * l + 2];
            CHECK(gv_st_add_f32(&b, name, GV_ST_F32, n->shape[3 * l + 2], 4, data) == 0);
        }
        if (variant == 1) scale[1] = 0.5f; /* the builder reads the data when it writes */
        CHECK(gv_st_write(&b, path) == 0);
        gv_st_builder_free(&b);
        scale[1] = 0.448f;
        if (variant == 0) {
            gv_lpips net;
            CHECK(gv_lpips_load(&net, path) == 0);
            CHECK(net.n_params == plain->n_params &&
                  memcmp(net.params, plain->params, net.n_params * sizeof(float)) == 0);
            gv_lpips_free(&net);
        } else if (variant == 1) {
            expect_bad(path, "scaling_layer.scale[1] is 0.5 where LPIPS v0.1 uses 0.448");
        } else if (variant == 2) {
            expect_bad(path, "lins.3.model.1.weight[0]");
        } else {
            expect_bad(path, "scaling_layer.shift is [3], expected [1, 3, 1, 1]");
        }
    }
}

int main(void)
{
    const char *dir = check_tmp_dir();
    test_net n;
    net_random(&n, 7);
    char path[4200];
    snprintf(path, sizeof path, "%s/alex.safetensors", dir);
    write_net(path, &n, GV_ST_F32);
    gv_lpips net;
    CHECK(gv_lpips_load(&net, path) == 0);
    CHECK(net.n_params == 2470848);
    for (int k = 0; k < 15; k++) { /* loaded in place: weight, bias, head of each layer */
        int l = k / 3;
        const float *p = k % 3 == 0 ? net.conv_weight[l] : k % 3 == 1 ? net.conv_bias[l]
                                                                   : net.lin_weight[l];
        CHECK(memcmp(p, n.data[k], (size_t)numel(&n, k) * sizeof(float)) == 0);
    }
    check_against_reference(&net, &n, 64, 64, 100);
    check_against_reference(&net, &n, 37, 50, 200);
    check_against_reference(&net, &n, 31, 31, 300);
    printf("worst relative difference from the double-precision reference: %.2e\n", worst_rel);
    test_hand_case(dir);
    test_sizes(&net);
    test_half_types(&n, dir);
    test_threads(&net);
    test_bad_keys(&n, dir);
    test_bad_values(&n, dir);
    test_optional_keys(&n, dir, &net);
    gv_lpips_free(&net);
    gv_lpips_free(&net); /* twice: safe */
    net_free(&n);
    return check_summary();
}
