/* The 3DGS model PLY and the .splat export: storage, bit-exact round trips for SH degrees
 * 0..3, the channel-major f_rest mapping on hand-built files (binary and ASCII, shuffled
 * property order, extra properties), malformed models, and .splat bytes computed by hand. */
#include <float.h>
#include <math.h>

#include "check.h"
#include "gaussvid/core/core.h"
#include "gaussvid/io/gaussians.h"
#include "gaussvid/io/ply.h"
#include "ply_bytes.h"

static char dir[4096];

static const char *tmp_path(const char *name)
{
    static char paths[8][4200];
    static int next;
    char *p = paths[next++ % 8];
    snprintf(p, sizeof paths[0], "%s/%s", dir, name);
    return p;
}

static void test_storage(void)
{
    CHECK(gv_sh_coefficient_count(0) == 1 && gv_sh_coefficient_count(1) == 4 &&
          gv_sh_coefficient_count(2) == 9 && gv_sh_coefficient_count(3) == 16);
    gv_gaussians g;
    CHECK(gv_gaussians_alloc(&g, 3, 2) == 0);
    CHECK(g.n == 3 && g.capacity >= 3 && g.sh_degree == 2);
    int zero = 1;
    for (int i = 0; i < 3 * 9 * 3; i++) zero &= g.sh[i] == 0;
    for (int i = 0; i < 3 * 4; i++) zero &= g.rotations[i] == 0;
    CHECK(zero);
    for (int i = 0; i < 3 * 27; i++) g.sh[i] = (float)i;
    g.means[8] = 42;
    CHECK(gv_gaussians_reserve(&g, 1000) == 0);
    CHECK(g.capacity >= 1000 && g.n == 3 && g.means[8] == 42 && g.sh[80] == 80);
    CHECK(g.sh[81] == 0 && g.sh[1000 * 27 - 1] == 0 && g.rotations[3999] == 0);
    gv_gaussians_free(&g);
    CHECK(g.means == NULL && g.n == 0);
    CHECK_FAILS_WITH(gv_gaussians_alloc(&g, 3, 4), "SH degree 4");
    CHECK_FAILS_WITH(gv_gaussians_alloc(&g, -1, 0), "negative");
    CHECK(gv_gaussians_alloc(&g, 0, 3) == 0 && g.n == 0 && g.means != NULL);
    gv_gaussians_free(&g);
}

/* A model with random raw parameters plus values that test exactness at the edges. */
static void make_model(gv_gaussians *g, int n, int degree, uint64_t seed)
{
    if (gv_gaussians_alloc(g, n, degree)) { fprintf(stderr, "alloc failed\n"); exit(1); }
    int k = gv_sh_coefficient_count(degree);
    uint64_t at = 0;
    for (int i = 0; i < 3 * n; i++) g->means[i] = (float)(3 * gv_normal_at(seed, at++));
    for (int i = 0; i < 3 * k * n; i++) g->sh[i] = (float)gv_normal_at(seed, at++);
    for (int i = 0; i < n; i++) g->opacities[i] = (float)(2 * gv_normal_at(seed, at++));
    for (int i = 0; i < 3 * n; i++) g->scales[i] = (float)(gv_normal_at(seed, at++) - 4);
    for (int i = 0; i < 4 * n; i++) g->rotations[i] = (float)gv_normal_at(seed, at++);
    g->means[0] = -0.0f;
    g->sh[1] = 1e-45f;  /* subnormal */
    g->scales[2] = -FLT_MAX;
    g->opacities[n - 1] = FLT_MAX;
    g->rotations[3] = FLT_MIN;
}

/* The reference header (section 18.1), spelled out independently of the writer. */
static void reference_header(char *out, size_t size, int n, int n_rest)
{
    int used = snprintf(out, size, "ply\nformat binary_little_endian 1.0\nelement vertex %d\n", n);
    const char *names[] = {"x", "y", "z", "nx", "ny", "nz", "f_dc_0", "f_dc_1", "f_dc_2"};
    for (int i = 0; i < 9; i++) used += snprintf(out + used, size - used, "property float %s\n", names[i]);
    for (int j = 0; j < n_rest; j++) used += snprintf(out + used, size - used, "property float f_rest_%d\n", j);
    used += snprintf(out + used, size - used, "property float opacity\n");
    for (int i = 0; i < 3; i++) used += snprintf(out + used, size - used, "property float scale_%d\n", i);
    for (int i = 0; i < 4; i++) used += snprintf(out + used, size - used, "property float rot_%d\n", i);
    snprintf(out + used, size - used, "end_header\n");
}

static float float_at(const unsigned char *p)
{
    uint32_t u = (uint32_t)p[0] | (uint32_t)p[1] << 8 | (uint32_t)p[2] << 16 | (uint32_t)p[3] << 24;
    float v;
    memcpy(&v, &u, 4);
    return v;
}

static int same_model(const gv_gaussians *a, const gv_gaussians *b)
{
    int k = gv_sh_coefficient_count(a->sh_degree);
    size_t n = (size_t)a->n;
    return a->n == b->n && a->sh_degree == b->sh_degree &&
           !memcmp(a->means, b->means, n * 3 * 4) && !memcmp(a->sh, b->sh, n * k * 3 * 4) &&
           !memcmp(a->opacities, b->opacities, n * 4) && !memcmp(a->scales, b->scales, n * 3 * 4) &&
           !memcmp(a->rotations, b->rotations, n * 4 * 4);
}

static void test_round_trip(void)
{
    for (int degree = 0; degree <= 3; degree++) {
        int n = 37, k = gv_sh_coefficient_count(degree), n_rest = 3 * (k - 1);
        gv_gaussians g, back;
        make_model(&g, n, degree, 100 + (uint64_t)degree);
        const char *first = tmp_path("first.ply"), *second = tmp_path("second.ply");
        CHECK(gv_gaussians_write_ply(first, &g) == 0);
        CHECK(gv_gaussians_read_ply(first, &back) == 0);
        CHECK(same_model(&g, &back));
        CHECK(gv_gaussians_write_ply(second, &back) == 0);
        size_t size1, size2;
        unsigned char *bytes1 = slurp(first, &size1), *bytes2 = slurp(second, &size2);
        CHECK(bytes1 && bytes2 && size1 == size2 && memcmp(bytes1, bytes2, size1) == 0);

        /* The layout: the reference header, then 4 (17 + 3 (K - 1)) bytes per Gaussian. */
        char header[4096];
        reference_header(header, sizeof header, n, n_rest);
        size_t h = strlen(header), row = 4 * (size_t)(17 + n_rest);
        CHECK(size1 == h + n * row && memcmp(bytes1, header, h) == 0);
        /* Gaussian 5, read straight from the bytes: f_rest_{c (K-1) + (k-1)} = sh[k][c]. */
        const unsigned char *r = bytes1 + h + 5 * row;
        int ok = float_at(r + 12) == 0 && float_at(r + 16) == 0 && float_at(r + 20) == 0;
        for (int c = 0; c < 3; c++) {
            ok &= float_at(r + 4 * (6 + c)) == g.sh[(5 * k + 0) * 3 + c];
            for (int kk = 1; kk < k; kk++)
                ok &= float_at(r + 4 * (9 + c * (k - 1) + kk - 1)) == g.sh[(5 * k + kk) * 3 + c];
        }
        ok &= float_at(r + 4 * (9 + n_rest)) == g.opacities[5];
        ok &= float_at(r + 4 * (13 + n_rest)) == g.rotations[20];
        CHECK(ok);
        free(bytes1);
        free(bytes2);
        gv_gaussians_free(&g);
        gv_gaussians_free(&back);
    }
}

/* Value of property `name` for Gaussian i in the hand-built files. */
static double hand_value(const char *name, int i)
{
    if (!strncmp(name, "f_rest_", 7)) return 1000 * i + atoi(name + 7);
    if (!strncmp(name, "f_dc_", 5)) return 100 * i + 50 + atoi(name + 5);
    if (!strncmp(name, "scale_", 6)) return -1 - i - 0.25 * atoi(name + 6);
    if (!strncmp(name, "rot_", 4)) return 0.5 + i + 0.125 * atoi(name + 4);
    if (!strcmp(name, "opacity")) return -3.5 + i;
    if (name[1] == '\0') return 10 * i + (name[0] - 'x');  /* x, y, z */
    return 77;  /* nx, extra properties */
}

/* A degree-`degree` model with the properties in a scrambled order (f_rest descending, so
 * that a name sort would misplace f_rest_10), doubles, comments and extra properties. */
static void write_hand_built(const char *path, int degree, int ascii, int n)
{
    int n_rest = 3 * (gv_sh_coefficient_count(degree) - 1);
    char names[80][16];
    int count = 0;
    const char *front[] = {"rot_3", "rot_1", "rot_0", "rot_2", "filter_3D"};
    for (int i = 0; i < 5; i++) snprintf(names[count++], 16, "%s", front[i]);
    for (int j = n_rest - 1; j >= 0; j--) snprintf(names[count++], 16, "f_rest_%d", j);
    const char *back[] = {"z", "x", "y", "nx", "opacity", "f_dc_2", "f_dc_0", "f_dc_1",
                          "scale_0", "scale_2", "scale_1"};
    for (int i = 0; i < 11; i++) snprintf(names[count++], 16, "%s", back[i]);
    bytes b = {0};
    char line[256];
    snprintf(line, sizeof line, "ply\nformat %s 1.0\ncomment hand built\nelement vertex %d\n",
             ascii ? "ascii" : "binary_little_endian", n);
    put_text(&b, line);
    for (int p = 0; p < count; p++) {
        /* x and the scales as double; filter_3D as uchar (ignored, any type is fine). */
        const char *type = !strcmp(names[p], "filter_3D") ? "uchar"
                           : (names[p][0] == 'x' || names[p][0] == 's') ? "double" : "float";
        snprintf(line, sizeof line, "property %s %s\n", type, names[p]);
        put_text(&b, line);
    }
    put_text(&b, "element extra 1\nproperty list uchar int ids\nend_header\n");
    for (int i = 0; i < n; i++) {
        for (int p = 0; p < count; p++) {
            double v = hand_value(names[p], i);
            int is_double = names[p][0] == 'x' || names[p][0] == 's';
            if (ascii) {
                snprintf(line, sizeof line, "%s%.17g", p ? " " : "", !strcmp(names[p], "filter_3D") ? 7 : v);
                put_text(&b, line);
            } else if (!strcmp(names[p], "filter_3D")) put_uint(&b, 7, 1);
            else if (is_double) put_f64(&b, v);
            else put_f32(&b, (float)v);
        }
        if (ascii) put_text(&b, "\n");
    }
    put_text(&b, ascii ? "2 5 6\n" : "\x02");
    bytes_save(&b, path);
    bytes_free(&b);
}

static void test_hand_built_mapping(void)
{
    for (int degree = 0; degree <= 3; degree++) {
        for (int ascii = 0; ascii <= 1; ascii++) {
            const char *path = tmp_path("hand.ply");
            int n = 4, k = gv_sh_coefficient_count(degree);
            write_hand_built(path, degree, ascii, n);
            gv_gaussians g;
            CHECK(gv_gaussians_read_ply(path, &g) == 0);
            CHECK(g.n == n && g.sh_degree == degree);
            int ok = g.n == n;
            for (int i = 0; i < n && ok; i++) {
                char name[16];
                for (int c = 0; c < 3; c++) {
                    snprintf(name, sizeof name, "f_dc_%d", c);
                    ok &= g.sh[(i * k + 0) * 3 + c] == (float)hand_value(name, i);
                    for (int kk = 1; kk < k; kk++) {
                        snprintf(name, sizeof name, "f_rest_%d", c * (k - 1) + kk - 1);
                        ok &= g.sh[(i * k + kk) * 3 + c] == (float)hand_value(name, i);
                    }
                    ok &= g.means[3 * i + c] == (float)hand_value(c == 0 ? "x" : c == 1 ? "y" : "z", i);
                    snprintf(name, sizeof name, "scale_%d", c);
                    ok &= g.scales[3 * i + c] == (float)hand_value(name, i);
                }
                for (int a = 0; a < 4; a++) {
                    snprintf(name, sizeof name, "rot_%d", a);
                    ok &= g.rotations[4 * i + a] == (float)hand_value(name, i);
                }
                ok &= g.opacities[i] == (float)hand_value("opacity", i);
            }
            if (!ok) fprintf(stderr, "hand-built mapping wrong: degree %d ascii %d\n", degree, ascii);
            CHECK(ok);
            gv_gaussians_free(&g);
        }
    }
    /* Degree 3 by the formula of the brief: f_rest_{c*15+(k-1)} -> sh[(i*K + k)*3 + c]. */
    write_hand_built(tmp_path("hand3.ply"), 3, 0, 2);
    gv_gaussians g;
    CHECK(gv_gaussians_read_ply(tmp_path("hand3.ply"), &g) == 0);
    CHECK(g.n == 2 && g.sh[(1 * 16 + 1) * 3 + 0] == 1000 + 0);   /* f_rest_0: k 1, red */
    CHECK(g.n == 2 && g.sh[(1 * 16 + 15) * 3 + 0] == 1000 + 14); /* f_rest_14: k 15, red */
    CHECK(g.n == 2 && g.sh[(1 * 16 + 1) * 3 + 1] == 1000 + 15);  /* f_rest_15: k 1, green */
    CHECK(g.n == 2 && g.sh[(1 * 16 + 10) * 3 + 2] == 1000 + 39); /* f_rest_39: k 10, blue */
    gv_gaussians_free(&g);
}

/* A header of the reference layout with `omit` left out and `rename` as the name of
 * f_rest_<rename_index> when given; rows of zeros except `poison` at (row, name). */
static void write_model(const char *path, int n, int n_rest, const char *omit, int rename_index,
                        const char *rename, const char *poison_name, int poison_row, float poison,
                        int end_header)
{
    const char *fixed[] = {"x", "y", "z", "nx", "ny", "nz", "f_dc_0", "f_dc_1", "f_dc_2"};
    const char *tail[] = {"opacity", "scale_0", "scale_1", "scale_2", "rot_0", "rot_1", "rot_2", "rot_3"};
    char names[80][24];
    int count = 0;
    for (int i = 0; i < 9; i++) snprintf(names[count++], 24, "%s", fixed[i]);
    for (int j = 0; j < n_rest; j++) {
        if (j == rename_index) snprintf(names[count++], 24, "%s", rename);
        else snprintf(names[count++], 24, "f_rest_%d", j);
    }
    for (int i = 0; i < 8; i++) snprintf(names[count++], 24, "%s", tail[i]);
    bytes b = {0};
    char line[128];
    snprintf(line, sizeof line, "ply\nformat binary_little_endian 1.0\nelement vertex %d\n", n);
    put_text(&b, line);
    for (int p = 0; p < count; p++) {
        if (omit && !strcmp(names[p], omit)) continue;
        snprintf(line, sizeof line, "property float %s\n", names[p]);
        put_text(&b, line);
    }
    if (end_header) put_text(&b, "end_header\n");
    for (int i = 0; i < (n < 4 ? n : 4); i++)
        for (int p = 0; p < count; p++) {
            if (omit && !strcmp(names[p], omit)) continue;
            int hit = poison_name && i == poison_row && !strcmp(names[p], poison_name);
            put_f32(&b, hit ? poison : 0.0f);
        }
    bytes_save(&b, path);
    bytes_free(&b);
}

static void expect_bad_model(const char *name, const char *needle, const char *needle2)
{
    const char *path = tmp_path(name);
    gv_gaussians g;
    gv_clear_error();
    int rc = gv_gaussians_read_ply(path, &g);
    const char *message = gv_last_error();
    int ok = rc != 0 && strstr(message, path) && strstr(message, needle) &&
             (!needle2 || strstr(message, needle2)) && g.means == NULL && g.n == 0;
    if (!ok) fprintf(stderr, "%s: expected '%s', got rc %d: %s\n", name, needle, rc, message);
    CHECK(ok);
}

static void test_malformed_models(void)
{
    write_model(tmp_path("norot2.ply"), 2, 9, "rot_2", -1, NULL, NULL, 0, 0, 1);
    expect_bad_model("norot2.ply", "no property 'rot_2'", NULL);
    write_model(tmp_path("rest10.ply"), 2, 10, NULL, -1, NULL, NULL, 0, 0, 1);
    expect_bad_model("rest10.ply", "10 f_rest properties", "0, 9, 24 or 45");
    write_model(tmp_path("gap.ply"), 2, 9, NULL, 8, "f_rest_12", NULL, 0, 0, 1);
    expect_bad_model("gap.ply", "no property 'f_rest_8'", NULL);
    write_model(tmp_path("rest50.ply"), 2, 45, NULL, 44, "f_rest_50", NULL, 0, 0, 1);
    expect_bad_model("rest50.ply", "f_rest_50", "more than 45");
    write_model(tmp_path("suffix.ply"), 2, 9, NULL, 3, "f_rest_x", NULL, 0, 0, 1);
    expect_bad_model("suffix.ply", "f_rest_x", "numeric suffix");
    write_model(tmp_path("nan.ply"), 3, 24, NULL, -1, NULL, "opacity", 1, NAN, 1);
    expect_bad_model("nan.ply", "vertex 1: property 'opacity' is not finite", NULL);
    write_model(tmp_path("inf.ply"), 3, 45, NULL, -1, NULL, "f_rest_44", 2, -INFINITY, 1);
    expect_bad_model("inf.ply", "vertex 2: property 'f_rest_44' is not finite", NULL);
    write_model(tmp_path("noend.ply"), 2, 0, NULL, -1, NULL, NULL, 0, 0, 0);
    expect_bad_model("noend.ply", "end_header", NULL);
    write_model(tmp_path("absurd.ply"), 2000000000, 0, NULL, -1, NULL, NULL, 0, 0, 1);
    expect_bad_model("absurd.ply", "declares 2000000000 rows", NULL);

    /* A file we wrote, cut short by 10 bytes. */
    gv_gaussians g;
    make_model(&g, 5, 1, 7);
    const char *path = tmp_path("cut.ply");
    CHECK(gv_gaussians_write_ply(path, &g) == 0);
    size_t size;
    unsigned char *data = slurp(path, &size);
    FILE *f = fopen(path, "wb");
    CHECK(data && f && fwrite(data, 1, size - 10, f) == size - 10);
    if (f) fclose(f);
    free(data);
    expect_bad_model("cut.ply", "truncated", NULL);

    /* Types: x as uchar is not a coordinate. */
    bytes b = {0};
    put_text(&b, "ply\nformat ascii 1.0\nelement vertex 1\nproperty uchar x\nend_header\n1\n");
    bytes_save(&b, tmp_path("uchar.ply"));
    bytes_free(&b);
    expect_bad_model("uchar.ply", "'x' has type uchar (expected float or double)", NULL);
    expect_bad_model("absent.ply", "cannot open", NULL);

    /* The writers refuse a NaN (naming the Gaussian) and leave nothing behind. */
    g.scales[3 * 2 + 1] = NAN;
    const char *bad = tmp_path("nan-out.ply");
    CHECK_FAILS_WITH(gv_gaussians_write_ply(bad, &g), "Gaussian 2 has a non-finite scale");
    CHECK(!gv_file_exists(bad));
    CHECK_FAILS_WITH(gv_gaussians_write_splat(tmp_path("nan.splat"), &g), "Gaussian 2");
    CHECK(!gv_file_exists(tmp_path("nan.splat")));
    gv_gaussians_free(&g);
}

#define SH_C0 0.28209479177387814

static void test_splat_bytes(void)
{
    /* Three Gaussians of degree 1 (the higher SH must be dropped), worked out by hand:
     *  G0: scales log 1 -> 1, opacity ln 9 -> 0.9: weight 0.9.
     *      colour (0.5 + C0 f) 255 with f = 0, 10, -10: 127.5 -> 127, 255 (clipped), 0;
     *      alpha 229.5 -> 229; quaternion (2, 0, 0, 0) -> (1, 0, 0, 0) -> 255 (clipped), 128 x3.
     *  G1: scales log 2 -> 2 each, opacity ln 3 -> 0.75: weight 8 x 0.75 = 6.
     *      f = 0.25/C0 -> 0.75 x 255 = 191.25 -> 191; f = -0.25/C0 -> 63.75 -> 63;
     *      f = 1 -> 0.78209 x 255 = 199.43 -> 199; alpha 191.25 -> 191;
     *      quaternion (0, 3, 0, -4) / 5 -> 128, 0.6 x 128 + 128 = 204.8 -> 204, 128, 25.6 -> 25.
     *  G2: scales log (4, 4, 1), opacity -ln 99 -> 0.01: weight 16 x 0.01 = 0.16; alpha 2.55 -> 2;
     *      colour 127 x3; quaternion (0, 0, 0, 1) -> 128, 128, 128, 255.
     * Order G1, G0, G2 (by volume alone G2 would lead, by opacity alone G0). */
    gv_gaussians g;
    CHECK(gv_gaussians_alloc(&g, 3, 1) == 0);
    const float means[9] = {1, 2, 3, -1, 0.5f, 4, 7, 8, 9};
    memcpy(g.means, means, sizeof means);
    float *sh0 = g.sh, *sh1 = g.sh + 4 * 3;
    sh0[0] = 0, sh0[1] = 10, sh0[2] = -10;
    sh1[0] = (float)(0.25 / SH_C0), sh1[1] = (float)(-0.25 / SH_C0), sh1[2] = 1;
    for (int i = 3; i < 12; i++) sh0[i] = sh1[i] = 5;  /* degree-1 terms: ignored */
    g.opacities[0] = (float)log(9.0), g.opacities[1] = (float)log(3.0);
    g.opacities[2] = (float)-log(99.0);
    for (int a = 0; a < 3; a++) g.scales[a] = 0, g.scales[3 + a] = (float)log(2.0);
    g.scales[6] = g.scales[7] = (float)log(4.0);
    const float rot[12] = {2, 0, 0, 0, 0, 3, 0, -4, 0, 0, 0, 1};
    memcpy(g.rotations, rot, sizeof rot);
    const char *path = tmp_path("three.splat");
    CHECK(gv_gaussians_write_splat(path, &g) == 0);
    size_t size;
    unsigned char *s = slurp(path, &size);
    CHECK(s && size == 96);
    if (s && size == 96) {
        const unsigned char *first = s, *second = s + 32, *third = s + 64;
        CHECK(float_at(first) == -1 && float_at(first + 4) == 0.5f && float_at(first + 8) == 4);
        CHECK_NEAR(float_at(first + 12), 2, 1e-6);
        CHECK_NEAR(float_at(first + 20), 2, 1e-6);
        const unsigned char rgba1[8] = {191, 63, 199, 191, 128, 204, 128, 25};
        CHECK(memcmp(first + 24, rgba1, 8) == 0);
        CHECK(float_at(second) == 1 && float_at(second + 4) == 2 && float_at(second + 8) == 3);
        CHECK(float_at(second + 12) == 1 && float_at(second + 16) == 1 && float_at(second + 20) == 1);
        const unsigned char rgba0[8] = {127, 255, 0, 229, 255, 128, 128, 128};
        CHECK(memcmp(second + 24, rgba0, 8) == 0);
        CHECK(float_at(third) == 7 && float_at(third + 20) == 1);
        CHECK_NEAR(float_at(third + 12), 4, 1e-6);
        const unsigned char rgba2[8] = {127, 127, 127, 2, 128, 128, 128, 255};
        CHECK(memcmp(third + 24, rgba2, 8) == 0);
    }
    free(s);
    gv_gaussians_free(&g);

    /* Equal weights keep the model's order; a zero quaternion becomes the identity. */
    CHECK(gv_gaussians_alloc(&g, 3, 0) == 0);
    for (int i = 0; i < 3; i++) g.means[3 * i] = (float)i;
    g.rotations[4] = 1;
    CHECK(gv_gaussians_write_splat(path, &g) == 0);
    s = slurp(path, &size);
    CHECK(s && size == 96);
    if (s && size == 96) {
        CHECK(float_at(s) == 0 && float_at(s + 32) == 1 && float_at(s + 64) == 2);
        CHECK(s[28] == 255 && s[29] == 128 && s[30] == 128 && s[31] == 128);
    }
    free(s);
    gv_gaussians_free(&g);
}

int main(void)
{
    snprintf(dir, sizeof dir, "%s", check_tmp_dir());
    test_storage();
    test_round_trip();
    test_hand_built_mapping();
    test_malformed_models();
    test_splat_bytes();
    return check_summary();
}
