/* PLY point clouds and the shared PLY header parser: ASCII, binary little- and big-endian
 * files written byte by byte with known values, the writer's round trip, and malformed files (each fails naming the file and the problem). */
#include <float.h>
#include <math.h>

#include "check.h"
#include "gaussvid/core/core.h"
#include "gaussvid/io/ply.h"
#include "io/ply_header.h"
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

/* Three points with values chosen to test exactness (1e-7 and 1/3 are not short decimals). */
static const float point_xyz[9] = {1.5f, -2.25f, 1e-7f, 0.333333343f, 1e30f, -0.0f,
                                   123456.789f, -1e-38f, 7.0f};
static const uint8_t point_rgb[9] = {0, 128, 255, 1, 2, 3, 250, 100, 7};

static int points_match(int n, const float *xyz, const uint8_t *rgb, const uint8_t *want_rgb)
{
    return n == 3 && memcmp(xyz, point_xyz, sizeof point_xyz) == 0 &&
           memcmp(rgb, want_rgb, 9) == 0;
}

static void test_ascii_points(void)
{
    /* Comments, obj_info, normals to ignore, CRLF line ends, a face element after vertex. */
    bytes b = {0};
    put_text(&b, "ply\r\nformat ascii 1.0\r\ncomment made by hand\r\nobj_info test\r\n"
                 "element vertex 3\r\nproperty float x\r\nproperty float y\r\nproperty float z\r\n"
                 "property float nx\r\nproperty uchar red\r\nproperty uint8 green\r\n"
                 "property uchar blue\r\nelement face 1\r\nproperty list uchar int vertex_indices\r\n"
                 "end_header\r\n");
    put_text(&b, "1.5 -2.25 1e-7 9 0 128 255\r\n");
    put_text(&b, "0.333333343  1e30\t-0.0 9 1 2 3\r\n\r\n");
    put_text(&b, "123456.789 -1e-38 7 9 250 100 7\r\n3 0 1 2\r\n");
    bytes_save(&b, tmp_path("ascii.ply"));
    bytes_free(&b);
    int n = 0;
    float *xyz = NULL;
    uint8_t *rgb = NULL;
    CHECK(gv_points_read_ply(tmp_path("ascii.ply"), &n, &xyz, &rgb) == 0);
    CHECK(xyz && points_match(n, xyz, rgb, point_rgb));
    CHECK(xyz && signbit(xyz[5]));
    free(xyz);
    free(rgb);
}

/* A vertex element with x y z float, an extra double, and uchar colours. */
static void put_points_binary(bytes *b)
{
    for (int i = 0; i < 3; i++) {
        put_f32(b, point_xyz[3 * i]);
        put_f64(b, 1234.5);               /* "quality": ignored */
        put_f32(b, point_xyz[3 * i + 1]);
        put_f32(b, point_xyz[3 * i + 2]);
        for (int c = 0; c < 3; c++) put_uint(b, point_rgb[3 * i + c], 1);
    }
}

static const char *binary_vertex_header =
    "element vertex 3\nproperty float x\nproperty double quality\nproperty float32 y\n"
    "property float z\nproperty uchar red\nproperty uchar green\nproperty uchar blue\n";

static void test_binary_points(void)
{
    /* Little-endian, with a fixed-size element before the vertices (skipped by its size). */
    bytes b = {0};
    put_text(&b, "ply\nformat binary_little_endian 1.0\ncomment c\nelement camera 2\n"
                 "property short a\nproperty double b\n");
    put_text(&b, binary_vertex_header);
    put_text(&b, "end_header\n");
    for (int i = 0; i < 2; i++) { put_uint(&b, 0xFFFF, 2); put_f64(&b, NAN); }
    put_points_binary(&b);
    bytes_save(&b, tmp_path("le.ply"));
    bytes_free(&b);
    int n = 0;
    float *xyz = NULL;
    uint8_t *rgb = NULL;
    CHECK(gv_points_read_ply(tmp_path("le.ply"), &n, &xyz, &rgb) == 0);
    CHECK(xyz && points_match(n, xyz, rgb, point_rgb));
    free(xyz);
    free(rgb);

    /* Big-endian, with a list element before the vertices (walked row by row). */
    b = (bytes){0};
    b.big_endian = 1;
    put_text(&b, "ply\nformat binary_big_endian 1.0\nelement face 2\n"
                 "property list uchar int32 vertex_indices\nproperty ushort flags\n");
    put_text(&b, binary_vertex_header);
    put_text(&b, "end_header\n");
    put_uint(&b, 3, 1); put_uint(&b, 0, 4); put_uint(&b, 1, 4); put_uint(&b, 2, 4); put_uint(&b, 7, 2);
    put_uint(&b, 0, 1); put_uint(&b, 9, 2);
    put_points_binary(&b);
    bytes_save(&b, tmp_path("be.ply"));
    bytes_free(&b);
    CHECK(gv_points_read_ply(tmp_path("be.ply"), &n, &xyz, &rgb) == 0);
    CHECK(xyz && points_match(n, xyz, rgb, point_rgb));
    free(xyz);
    free(rgb);
}

static void test_colour_variants(void)
{
    /* Float colours in 0..1 (scaled and rounded), double coordinates. */
    bytes b = {0};
    put_text(&b, "ply\nformat binary_little_endian 1.0\nelement vertex 2\nproperty double x\n"
                 "property double y\nproperty double z\nproperty float red\nproperty float green\n"
                 "property float blue\nend_header\n");
    put_f64(&b, 0.1); put_f64(&b, 0.2); put_f64(&b, 0.3);
    put_f32(&b, 0.0f); put_f32(&b, 1.0f); put_f32(&b, 0.5f);    /* 0, 255, 127.5 -> 128 */
    put_f64(&b, -1); put_f64(&b, 2); put_f64(&b, 3);
    put_f32(&b, -0.5f); put_f32(&b, 2.0f); put_f32(&b, 0.2f);   /* clamped 0, 255; 51 */
    bytes_save(&b, tmp_path("fcolour.ply"));
    bytes_free(&b);
    int n = 0;
    float *xyz = NULL;
    uint8_t *rgb = NULL;
    CHECK(gv_points_read_ply(tmp_path("fcolour.ply"), &n, &xyz, &rgb) == 0);
    const uint8_t want[6] = {0, 255, 128, 0, 255, 51};
    CHECK(n == 2 && rgb && memcmp(rgb, want, 6) == 0);
    CHECK(xyz && xyz[0] == 0.1f && xyz[1] == 0.2f && xyz[2] == 0.3f && xyz[3] == -1.0f);
    free(xyz);
    free(rgb);

    /* No colour at all: grey 128; integer coordinates are accepted. */
    b = (bytes){0};
    put_text(&b, "ply\nformat ascii 1.0\nelement vertex 1\nproperty int x\nproperty short y\n"
                 "property char z\nend_header\n-70000 -300 -128\n");
    bytes_save(&b, tmp_path("grey.ply"));
    bytes_free(&b);
    CHECK(gv_points_read_ply(tmp_path("grey.ply"), &n, &xyz, &rgb) == 0);
    CHECK(n == 1 && xyz && xyz[0] == -70000 && xyz[1] == -300 && xyz[2] == -128);
    CHECK(rgb && rgb[0] == 128 && rgb[1] == 128 && rgb[2] == 128);
    free(xyz);
    free(rgb);

    /* ASCII with a list element before the vertices: skipped line by line. */
    b = (bytes){0};
    put_text(&b, "ply\nformat ascii 1.0\nelement face 2\nproperty list uchar int v\nelement vertex 2\n"
                 "property float x\nproperty float y\nproperty float z\nend_header\n"
                 "3 0 1 2\n4 0 1 2 3\n0.5 1 2\n3 4 5\n");
    bytes_save(&b, tmp_path("face-first.ply"));
    bytes_free(&b);
    CHECK(gv_points_read_ply(tmp_path("face-first.ply"), &n, &xyz, &rgb) == 0);
    CHECK(n == 2 && xyz && xyz[0] == 0.5f && xyz[5] == 5.0f);
    free(xyz);
    free(rgb);
}

static void test_points_writer(void)
{
    enum { N = 500 };
    static float xyz[3 * N], back_xyz[3 * N];
    static uint8_t rgb[3 * N];
    for (int i = 0; i < 3 * N; i++) {
        /* Values over many magnitudes: every float must come back bit for bit. */
        xyz[i] = (float)(gv_normal_at(5, (uint64_t)i) * pow(10.0, (double)(i % 13) - 6));
        rgb[i] = (uint8_t)(gv_uniform_at(6, (uint64_t)i) * 256);
    }
    memcpy(xyz, point_xyz, sizeof point_xyz);
    memcpy(rgb, point_rgb, sizeof point_rgb);
    xyz[9] = FLT_MAX;
    xyz[10] = FLT_MIN;
    xyz[11] = 1e-45f;  /* the smallest subnormal */
    const char *path = tmp_path("written.ply");
    CHECK(gv_points_write_ply(path, N, xyz, rgb) == 0);
    int n = 0;
    float *got_xyz = NULL;
    uint8_t *got_rgb = NULL;
    CHECK(gv_points_read_ply(path, &n, &got_xyz, &got_rgb) == 0);
    CHECK(n == N && got_xyz && memcmp(got_xyz, xyz, sizeof xyz) == 0);
    CHECK(got_rgb && memcmp(got_rgb, rgb, sizeof rgb) == 0);
    free(got_xyz);
    free(got_rgb);

    /* The header is the one of points3D.ply; the first row is the shortest exact text. */
    size_t size;
    unsigned char *text = slurp(path, &size);
    const char *header = "ply\nformat ascii 1.0\nelement vertex 500\nproperty float x\n"
                         "property float y\nproperty float z\nproperty uchar red\n"
                         "property uchar green\nproperty uchar blue\nend_header\n"
                         "1.5 -2.25 1e-07 0 128 255\n";
    CHECK(text && size > strlen(header) && memcmp(text, header, strlen(header)) == 0);
    free(text);

    /* Without colours: x y z only, read back as grey. */
    memcpy(back_xyz, xyz, sizeof xyz);
    CHECK(gv_points_write_ply(path, 2, back_xyz, NULL) == 0);
    CHECK(gv_points_read_ply(path, &n, &got_xyz, &got_rgb) == 0);
    CHECK(n == 2 && got_rgb && got_rgb[0] == 128 && got_rgb[5] == 128);
    CHECK(got_xyz && memcmp(got_xyz, xyz, 6 * sizeof(float)) == 0);
    free(got_xyz);
    free(got_rgb);

    /* A NaN is refused and leaves no file behind. */
    back_xyz[4] = NAN;
    const char *bad = tmp_path("nan-written.ply");
    CHECK_FAILS_WITH(gv_points_write_ply(bad, 2, back_xyz, rgb), "point 1");
    CHECK(!gv_file_exists(bad));
}

/* Writes `text` (a whole file) and checks that reading it fails with a message naming the
 * file and containing `needle`, with the outputs left empty. */
static void expect_bad(const char *name, const char *text, size_t size, const char *needle)
{
    const char *path = tmp_path(name);
    FILE *f = fopen(path, "wb");
    if (!f || fwrite(text, 1, size, f) != size || fclose(f)) { CHECK(0); return; }
    int n = -1;
    float *xyz = (float *)1;
    uint8_t *rgb = (uint8_t *)1;
    gv_clear_error();
    int rc = gv_points_read_ply(path, &n, &xyz, &rgb);
    const char *message = gv_last_error();
    int ok = rc != 0 && strstr(message, path) && strstr(message, needle) && n == 0 && !xyz && !rgb;
    if (!ok) fprintf(stderr, "%s: expected a failure with '%s', got rc %d: %s\n", name, needle, rc, message);
    CHECK(ok);
}

#define BAD(name, text, needle) expect_bad(name, text, sizeof(text) - 1, needle)
#define XYZ "property float x\nproperty float y\nproperty float z\n"

static void test_malformed(void)
{
    int n;
    float *xyz;
    uint8_t *rgb;
    CHECK_FAILS_WITH(gv_points_read_ply(tmp_path("missing.ply"), &n, &xyz, &rgb), "cannot open");
    BAD("empty.ply", "", "empty file");
    BAD("magic.ply", "plx\nformat ascii 1.0\nend_header\n", "not a PLY file");
    BAD("noend.ply", "ply\nformat ascii 1.0\nelement vertex 1\n" XYZ "1 2 3\n", "end_header");
    BAD("noend-eof.ply", "ply\nformat ascii 1.0\nelement vertex 0\n" XYZ, "no end_header line");
    BAD("nul.ply", "ply\nformat ascii 1.0\ncomment a\0b\nend_header\n", "binary data before end_header");
    BAD("format.ply", "ply\nformat binary_middle_endian 1.0\nend_header\n", "unknown format");
    BAD("version.ply", "ply\nformat ascii 2.0\nend_header\n", "version");
    BAD("noformat.ply", "ply\nelement vertex 1\n" XYZ "end_header\n1 2 3\n", "before the format");
    BAD("orphan.ply", "ply\nformat ascii 1.0\nproperty float x\nend_header\n", "property before any element");
    BAD("type.ply", "ply\nformat ascii 1.0\nelement vertex 1\nproperty float16 x\nend_header\n", "unknown type 'float16'");
    BAD("keyword.ply", "ply\nformat ascii 1.0\nelemnt vertex 1\nend_header\n", "unknown keyword 'elemnt'");
    BAD("count.ply", "ply\nformat ascii 1.0\nelement vertex -4\nend_header\n", "bad count");
    BAD("twice.ply", "ply\nformat ascii 1.0\nelement vertex 1\n" XYZ "property float x\nend_header\n", "declared twice");
    BAD("listcount.ply", "ply\nformat ascii 1.0\nelement f 1\nproperty list float int i\nend_header\n", "not an integer type");
    BAD("novertex.ply", "ply\nformat ascii 1.0\nelement face 0\nend_header\n", "no element 'vertex'");
    BAD("noz.ply", "ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nproperty float y\n"
                   "end_header\n1 2\n", "no property 'z'");
    BAD("vlist.ply", "ply\nformat ascii 1.0\nelement vertex 1\n" XYZ "property list uchar int i\n"
                     "end_header\n1 2 3 0\n", "list property 'i'");
    BAD("partial.ply", "ply\nformat ascii 1.0\nelement vertex 1\n" XYZ "property uchar red\n"
                       "property uchar green\nend_header\n1 2 3 4 5\n", "2 of the colour");
    BAD("ushort.ply", "ply\nformat ascii 1.0\nelement vertex 1\n" XYZ "property ushort red\n"
                      "property ushort green\nproperty ushort blue\nend_header\n1 2 3 4 5 6\n", "expected uchar");
    /* Counts that the file cannot hold are refused before any allocation. */
    BAD("absurd.ply", "ply\nformat binary_little_endian 1.0\nelement vertex 2000000000\n" XYZ
                      "end_header\n0123456789ab", "declares 2000000000 rows");
    BAD("absurd-ascii.ply", "ply\nformat ascii 1.0\nelement vertex 9000000000000000000\n" XYZ
                            "end_header\n1 2 3\n", "declares");
    /* found by fuzz/: rows of no properties take no bytes, so their count was unbounded */
    BAD("empty-rows.ply", "ply\nformat ascii 1.0\nelement vertex 652999802\nelement face 1\n"
                          "property list uchar int vertex_indices\nend_header\n3 0 1 2\n",
        "declares 652999802 rows but no properties");
    BAD("empty-rows-binary.ply", "ply\nformat binary_little_endian 1.0\nelement vertex 2000000000\nend_header\n",
        "no properties");
    BAD("truncated.ply", "ply\nformat binary_little_endian 1.0\nelement vertex 2\n" XYZ
                         "end_header\n0123456789ab0123456789a", "truncated");
    BAD("truncated-ascii.ply", "ply\nformat ascii 1.0\nelement vertex 3\n" XYZ
                               "end_header\n1.000000 2.000000 3.000000\n4.000000 5.000000 6.000000\n",
        "2 of 3 rows");
    BAD("face-past-end.ply", "ply\nformat binary_little_endian 1.0\nelement face 1\n"
                             "property list uchar int i\nelement vertex 0\n" XYZ "end_header\n\x09\x01",
        "truncated in element 'face'");
    BAD("few.ply", "ply\nformat ascii 1.0\nelement vertex 1\n" XYZ "end_header\n1.0000 2.0000\n", "2 values");
    BAD("many.ply", "ply\nformat ascii 1.0\nelement vertex 1\n" XYZ "end_header\n1 2 3 4\n", "more than the 3 values");
    BAD("word.ply", "ply\nformat ascii 1.0\nelement vertex 1\n" XYZ "end_header\n1 abc 3\n", "'abc' is not a valid float");
    BAD("uchar.ply", "ply\nformat ascii 1.0\nelement vertex 1\n" XYZ "property uchar red\n"
                     "property uchar green\nproperty uchar blue\nend_header\n1 2 3 4 300 6\n", "'300' is not a valid uchar");
    BAD("nan.ply", "ply\nformat ascii 1.0\nelement vertex 2\n" XYZ "end_header\n1 2 3\n4 nan 6\n",
        "vertex 1 (line 9): property 'y' is not finite");
    BAD("inf.ply", "ply\nformat ascii 1.0\nelement vertex 1\nproperty double x\nproperty float y\n"
                   "property float z\nend_header\n1e300 2 3\n", "property 'x' is not finite");
}

/* The header parser on its own: types, aliases, offsets and row sizes. */
static void test_header_layout(void)
{
    const char *header = "ply\nformat binary_big_endian 1.0\nelement a 5\nproperty int8 p\n"
                         "property uint16 q\nproperty int32 r\nproperty float64 s\nelement b 1\n"
                         "property uchar u\nproperty list uint8 uint32 l\nend_header\n";
    bytes b = {0};
    put_text(&b, header);
    bytes_save(&b, tmp_path("layout.ply"));
    bytes_free(&b);
    ply_file pf;
    CHECK(ply_open(&pf, tmp_path("layout.ply")) == 0);
    const ply_header *h = &pf.header;
    CHECK(h->format == PLY_BINARY_BE && h->n_elements == 2 && h->n_properties == 6);
    CHECK(h->elements[0].count == 5 && h->elements[0].row_size == 1 + 2 + 4 + 8);
    CHECK(h->properties[3].type == PLY_DOUBLE && h->properties[3].offset == 7);
    CHECK(h->elements[1].row_size == 0 && !h->properties[4].is_list &&
          h->properties[5].is_list && h->properties[5].count_type == PLY_UCHAR &&
          h->properties[5].type == PLY_UINT && h->elements[1].first_property == 4);
    CHECK(h->header_lines == 11 && h->data_offset == (int64_t)strlen(header));
    ply_close(&pf);
}

int main(void)
{
    snprintf(dir, sizeof dir, "%s", check_tmp_dir());
    test_ascii_points();
    test_binary_points();
    test_colour_variants();
    test_points_writer();
    test_malformed();
    test_header_layout();
    return check_summary();
}
