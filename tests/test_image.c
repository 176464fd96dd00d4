/* Image I/O: PNG round trips for every channel count, PNGs of other layouts and a JPEG
 * written here directly through libpng/libjpeg, malformed files, downscaling, the float
 * conversions and reflection padding. */
#include <png.h>
#include <stdio.h>
#include <jpeglib.h>
#include <zlib.h>

#include "check.h"
#include "gaussvid/core/core.h"
#include "gaussvid/io/image.h"

static char tmp[4096];

static const char *tmp_path(const char *name)
{
    static char path[8][4200];
    static int next;
    char *p = path[next++ % 8];
    snprintf(p, 4200, "%s/%s", tmp, name);
    return p;
}

static void write_bytes(const char *path, const void *data, size_t n)
{
    FILE *f = fopen(path, "wb");
    if (!f || fwrite(data, 1, n, f) != n) { fprintf(stderr, "cannot write %s\n", path); exit(1); }
    fclose(f);
}

/* A PNG through libpng directly: rows of packed samples (16-bit big-endian). */
static void write_png_direct(const char *path, int w, int h, int color_type, int depth,
                             const uint8_t *data, const png_color *palette, int n_palette,
                             const uint8_t *trans, int n_trans)
{
    FILE *f = fopen(path, "wb");
    png_structp png = png_create_write_struct(PNG_LIBPNG_VER_STRING, NULL, NULL, NULL);
    png_infop info = png_create_info_struct(png);
    if (!f || setjmp(png_jmpbuf(png))) { fprintf(stderr, "libpng write failed\n"); exit(1); }
    png_init_io(png, f);
    png_set_IHDR(png, info, w, h, depth, color_type, PNG_INTERLACE_NONE,
                 PNG_COMPRESSION_TYPE_DEFAULT, PNG_FILTER_TYPE_DEFAULT);
    if (palette) png_set_PLTE(png, info, palette, n_palette);
    if (trans) png_set_tRNS(png, info, trans, n_trans, NULL);
    png_write_info(png, info);
    int channels = color_type == PNG_COLOR_TYPE_RGB ? 3 : color_type == PNG_COLOR_TYPE_RGBA ? 4
                 : color_type == PNG_COLOR_TYPE_GRAY_ALPHA ? 2 : 1;
    size_t row_bytes = ((size_t)w * channels * depth + 7) / 8;
    for (int y = 0; y < h; y++) png_write_row(png, (png_bytep)data + y * row_bytes);
    png_write_end(png, NULL);
    png_destroy_write_struct(&png, &info);
    fclose(f);
}

static void test_png_round_trip(void)
{
    for (int c = 1; c <= 4; c++) {
        gv_image img, back;
        CHECK(gv_image_alloc(&img, 7, 5, c) == 0);
        for (int i = 0; i < 7 * 5 * c; i++) img.pixels[i] = (uint8_t)(i * 37 + c * 11);
        char name[32];
        snprintf(name, sizeof name, "round_%d.png", c);
        const char *path = tmp_path(name);
        CHECK(gv_image_write_png(path, &img) == 0);
        CHECK(gv_image_read(path, &back) == 0);
        CHECK(back.width == 7 && back.height == 5 && back.channels == c);
        CHECK(back.pixels && !memcmp(back.pixels, img.pixels, 7 * 5 * c));
        gv_image rgb;
        CHECK(gv_image_read_rgb(path, &rgb) == 0);
        CHECK(rgb.channels == 3 && rgb.width == 7 && rgb.height == 5);
        int ok = 1;
        for (int p = 0; p < 35; p++)
            for (int k = 0; k < 3; k++)
                ok &= rgb.pixels[p * 3 + k] == img.pixels[p * c + (c >= 3 ? k : 0)];
        CHECK(ok);
        gv_image_free(&rgb);
        gv_image_free(&back);
        gv_image_free(&img);
    }
    /* No temporary file is left behind by the atomic write. */
    char leftover[4300];
    snprintf(leftover, sizeof leftover, "ls '%s' | grep -q tmp", tmp);
    CHECK(system(leftover) != 0);
}

static void test_png_other_layouts(void)
{
    gv_image img;
    /* 16-bit RGB, 2x1: the high byte of each big-endian sample is kept. */
    const uint8_t rgb16[12] = {0x12, 0x34, 0xFF, 0xFF, 0x00, 0xFF, 0x01, 0x00, 0x80, 0x7F, 0xAB, 0xCD};
    write_png_direct(tmp_path("rgb16.png"), 2, 1, PNG_COLOR_TYPE_RGB, 16, rgb16, NULL, 0, NULL, 0);
    CHECK(gv_image_read(tmp_path("rgb16.png"), &img) == 0);
    CHECK(img.channels == 3 && img.width == 2 && img.height == 1);
    const uint8_t want_rgb16[6] = {0x12, 0xFF, 0x00, 0x01, 0x80, 0xAB};
    CHECK(img.pixels && !memcmp(img.pixels, want_rgb16, 6));
    gv_image_free(&img);

    /* 16-bit grey+alpha, 1x2. */
    const uint8_t ga16[8] = {0xFE, 0x01, 0x00, 0x10, 0x7F, 0xFF, 0xC0, 0x00};
    write_png_direct(tmp_path("ga16.png"), 1, 2, PNG_COLOR_TYPE_GRAY_ALPHA, 16, ga16, NULL, 0, NULL, 0);
    CHECK(gv_image_read(tmp_path("ga16.png"), &img) == 0);
    const uint8_t want_ga16[4] = {0xFE, 0x00, 0x7F, 0xC0};
    CHECK(img.channels == 2 && img.pixels && !memcmp(img.pixels, want_ga16, 4));
    gv_image_free(&img);

    /* 16-bit grey and 16-bit RGBA. */
    const uint8_t g16[4] = {0xAA, 0x55, 0x03, 0xFF};
    write_png_direct(tmp_path("g16.png"), 2, 1, PNG_COLOR_TYPE_GRAY, 16, g16, NULL, 0, NULL, 0);
    CHECK(gv_image_read(tmp_path("g16.png"), &img) == 0);
    CHECK(img.channels == 1 && img.pixels && img.pixels[0] == 0xAA && img.pixels[1] == 0x03);
    gv_image_free(&img);
    const uint8_t rgba16[8] = {0x10, 0, 0x20, 0, 0x30, 0, 0x40, 0xFF};
    write_png_direct(tmp_path("rgba16.png"), 1, 1, PNG_COLOR_TYPE_RGBA, 16, rgba16, NULL, 0, NULL, 0);
    CHECK(gv_image_read(tmp_path("rgba16.png"), &img) == 0);
    CHECK(img.channels == 4 && img.pixels && img.pixels[0] == 0x10 && img.pixels[3] == 0x40);
    gv_image_free(&img);

    /* 1-bit grey: 0 and 1 expand to 0 and 255. Row 0 = 1,0,1 (bits 101).  */
    const uint8_t g1[1] = {0xA0};
    write_png_direct(tmp_path("g1.png"), 3, 1, PNG_COLOR_TYPE_GRAY, 1, g1, NULL, 0, NULL, 0);
    CHECK(gv_image_read(tmp_path("g1.png"), &img) == 0);
    CHECK(img.channels == 1 && img.pixels && img.pixels[0] == 255 && img.pixels[1] == 0 &&
          img.pixels[2] == 255);
    gv_image_free(&img);

    /* Palette without and with transparency. */
    const png_color palette[3] = {{10, 20, 30}, {200, 100, 50}, {1, 2, 3}};
    const uint8_t indices[3] = {2, 0, 1};
    write_png_direct(tmp_path("pal.png"), 3, 1, PNG_COLOR_TYPE_PALETTE, 8, indices, palette, 3, NULL, 0);
    CHECK(gv_image_read(tmp_path("pal.png"), &img) == 0);
    const uint8_t want_pal[9] = {1, 2, 3, 10, 20, 30, 200, 100, 50};
    CHECK(img.channels == 3 && img.pixels && !memcmp(img.pixels, want_pal, 9));
    gv_image_free(&img);
    const uint8_t trans[2] = {0, 128};
    write_png_direct(tmp_path("palt.png"), 3, 1, PNG_COLOR_TYPE_PALETTE, 8, indices, palette, 3, trans, 2);
    CHECK(gv_image_read(tmp_path("palt.png"), &img) == 0);
    const uint8_t want_palt[12] = {1, 2, 3, 255, 10, 20, 30, 0, 200, 100, 50, 128};
    CHECK(img.channels == 4 && img.pixels && !memcmp(img.pixels, want_palt, 12));
    gv_image_free(&img);
}

/* An Adam7-interlaced RGB PNG reads back in plain row order. */
static void test_png_interlaced(void)
{
    enum { W = 9, H = 10 };
    uint8_t pixels[W * H * 3];
    png_bytep rows[H];
    for (int i = 0; i < W * H * 3; i++) pixels[i] = (uint8_t)(i * 7 + 3);
    for (int y = 0; y < H; y++) rows[y] = pixels + y * W * 3;
    const char *path = tmp_path("adam7.png");
    FILE *f = fopen(path, "wb");
    png_structp png = png_create_write_struct(PNG_LIBPNG_VER_STRING, NULL, NULL, NULL);
    png_infop info = png_create_info_struct(png);
    if (!f || setjmp(png_jmpbuf(png))) { fprintf(stderr, "libpng write failed\n"); exit(1); }
    png_init_io(png, f);
    png_set_IHDR(png, info, W, H, 8, PNG_COLOR_TYPE_RGB, PNG_INTERLACE_ADAM7,
                 PNG_COMPRESSION_TYPE_DEFAULT, PNG_FILTER_TYPE_DEFAULT);
    png_write_info(png, info);
    png_write_image(png, rows);
    png_write_end(png, NULL);
    png_destroy_write_struct(&png, &info);
    fclose(f);
    gv_image img;
    CHECK(gv_image_read(path, &img) == 0);
    CHECK(img.width == W && img.height == H && img.channels == 3);
    CHECK(img.pixels && !memcmp(img.pixels, pixels, sizeof pixels));
    gv_image_free(&img);
}

/* A smooth colour image (or grey when channels = 1) through libjpeg at quality 95, 4:4:4. */
static void write_jpeg_direct(const char *path, int w, int h, int channels, const uint8_t *pixels)
{
    struct jpeg_compress_struct cinfo;
    struct jpeg_error_mgr jerr;
    cinfo.err = jpeg_std_error(&jerr);
    jpeg_create_compress(&cinfo);
    FILE *f = fopen(path, "wb");
    if (!f) { fprintf(stderr, "cannot write %s\n", path); exit(1); }
    jpeg_stdio_dest(&cinfo, f);
    cinfo.image_width = w;
    cinfo.image_height = h;
    cinfo.input_components = channels;
    cinfo.in_color_space = channels == 1 ? JCS_GRAYSCALE : JCS_RGB;
    jpeg_set_defaults(&cinfo);
    jpeg_set_quality(&cinfo, 95, TRUE);
    for (int i = 0; i < cinfo.num_components; i++)
        cinfo.comp_info[i].h_samp_factor = cinfo.comp_info[i].v_samp_factor = 1;
    jpeg_start_compress(&cinfo, TRUE);
    while (cinfo.next_scanline < cinfo.image_height) {
        JSAMPROW row = (JSAMPROW)pixels + (size_t)cinfo.next_scanline * w * channels;
        jpeg_write_scanlines(&cinfo, &row, 1);
    }
    jpeg_finish_compress(&cinfo);
    jpeg_destroy_compress(&cinfo);
    fclose(f);
}

static void test_jpeg(void)
{
    enum { W = 40, H = 24 };
    for (int c = 1; c <= 3; c += 2) {
        uint8_t pixels[W * H * 3];
        for (int y = 0; y < H; y++)
            for (int x = 0; x < W; x++)
                for (int k = 0; k < c; k++)
                    pixels[(y * W + x) * c + k] = (uint8_t)(20 + 3 * x + 2 * y + 20 * k);
        const char *path = tmp_path(c == 1 ? "grey.jpg" : "colour.jpg");
        write_jpeg_direct(path, W, H, c, pixels);
        gv_image img;
        CHECK(gv_image_read(path, &img) == 0);
        CHECK(img.width == W && img.height == H && img.channels == c);
        int max_diff = 0;
        for (int i = 0; img.pixels && i < W * H * c; i++) {
            int d = abs((int)img.pixels[i] - (int)pixels[i]);
            if (d > max_diff) max_diff = d;
        }
        printf("JPEG (%d channels, quality 95) max abs difference: %d\n", c, max_diff);
        CHECK(img.pixels && max_diff <= 4);
        gv_image_free(&img);
    }
}

/* Copies the first `keep` bytes of src to dst, optionally flipping byte `flip`. */
static void damage_copy(const char *src, const char *dst, long keep, long flip)
{
    char *data;
    size_t n;
    if (gv_read_file(src, &data, &n) != 0) { fprintf(stderr, "%s\n", gv_last_error()); exit(1); }
    if (flip >= 0 && (size_t)flip < n) data[flip] ^= 0x5A;
    write_bytes(dst, data, keep >= 0 && (size_t)keep < n ? (size_t)keep : n);
    free(data);
}

static void test_malformed(void)
{
    gv_image img;
    /* A noisy RGB PNG, so that its IDAT is long enough to cut. */
    CHECK(gv_image_alloc(&img, 32, 32, 3) == 0);
    for (int i = 0; i < 32 * 32 * 3; i++) img.pixels[i] = (uint8_t)(gv_uniform_at(7, i) * 256);
    const char *good = tmp_path("good.png");
    CHECK(gv_image_write_png(good, &img) == 0);
    gv_image_free(&img);
    const char *cut = tmp_path("truncated.png");
    damage_copy(good, cut, 1000, -1);
    CHECK_FAILS_WITH(gv_image_read(cut, &img), "truncated.png");
    CHECK(img.pixels == NULL);
    const char *flipped = tmp_path("badcrc.png");
    damage_copy(good, flipped, -1, 200); /* inside IDAT: CRC mismatch */
    CHECK_FAILS_WITH(gv_image_read(flipped, &img), "badcrc.png");
    const char *header_only = tmp_path("header_only.png");
    damage_copy(good, header_only, 20, -1);
    CHECK_FAILS_WITH(gv_image_read(header_only, &img), "header_only.png");
    CHECK_FAILS_WITH(gv_image_read(header_only, &img), "PNG");

    /* An IHDR claiming 60000 x 60000 RGB, then an empty IDAT and IEND (valid CRCs): refused
     * before allocating. */
    uint8_t absurd[57] = {0x89, 'P', 'N', 'G', '\r', '\n', 0x1a, '\n', 0, 0, 0, 13, 'I', 'H', 'D', 'R',
                          0, 0, 0xEA, 0x60, 0, 0, 0xEA, 0x60, 8, 2, 0, 0, 0, 0, 0, 0, 0,
                          0, 0, 0, 0, 'I', 'D', 'A', 'T', 0, 0, 0, 0,
                          0, 0, 0, 0, 'I', 'E', 'N', 'D', 0, 0, 0, 0};
    for (int chunk = 8; chunk < 57; ) { /* fill in each chunk's CRC */
        int length = absurd[chunk + 3];
        uint32_t crc = (uint32_t)crc32(0, absurd + chunk + 4, 4 + length);
        uint8_t *p = absurd + chunk + 8 + length;
        p[0] = crc >> 24; p[1] = crc >> 16; p[2] = crc >> 8; p[3] = (uint8_t)crc;
        chunk += 12 + length;
    }
    write_bytes(tmp_path("absurd.png"), absurd, sizeof absurd);
    CHECK_FAILS_WITH(gv_image_read(tmp_path("absurd.png"), &img), "absurd.png");
    CHECK_FAILS_WITH(gv_image_read(tmp_path("absurd.png"), &img), "more than");

    /* JPEG: truncated in the entropy-coded data, cut after the SOI marker, and junk. */
    uint8_t pixels[64 * 48 * 3];
    for (int i = 0; i < 64 * 48 * 3; i++) pixels[i] = (uint8_t)(gv_uniform_at(9, i) * 256);
    const char *jpg = tmp_path("good.jpg");
    write_jpeg_direct(jpg, 64, 48, 3, pixels);
    CHECK(gv_image_read(jpg, &img) == 0);
    gv_image_free(&img);
    damage_copy(jpg, tmp_path("truncated.jpg"), 2000, -1);
    CHECK_FAILS_WITH(gv_image_read(tmp_path("truncated.jpg"), &img), "truncated.jpg");
    CHECK(img.pixels == NULL);
    damage_copy(jpg, tmp_path("short.jpg"), 4, -1);
    CHECK_FAILS_WITH(gv_image_read(tmp_path("short.jpg"), &img), "short.jpg");
    const uint8_t junk_jpeg[16] = {0xFF, 0xD8, 0xFF, 0x00, 1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12};
    write_bytes(tmp_path("junk.jpg"), junk_jpeg, sizeof junk_jpeg);
    CHECK_FAILS_WITH(gv_image_read(tmp_path("junk.jpg"), &img), "junk.jpg");

    /* Not an image, empty, missing, a directory; writing to a missing folder. */
    write_bytes(tmp_path("notes.png"), "hello, world\n", 13);
    CHECK_FAILS_WITH(gv_image_read(tmp_path("notes.png"), &img), "notes.png: not a PNG or JPEG");
    write_bytes(tmp_path("empty.png"), "", 0);
    CHECK_FAILS_WITH(gv_image_read(tmp_path("empty.png"), &img), "empty.png");
    CHECK_FAILS_WITH(gv_image_read(tmp_path("missing.png"), &img), "missing.png");
    CHECK_FAILS_WITH(gv_image_read(tmp, &img), tmp);
    CHECK(gv_image_alloc(&img, 2, 2, 3) == 0);
    CHECK_FAILS_WITH(gv_image_write_png(tmp_path("no/such/dir/x.png"), &img), "x.png");
    gv_image_free(&img);
    gv_image bad = {0};
    CHECK_FAILS_WITH(gv_image_write_png(tmp_path("bad.png"), &bad), "bad.png");
    CHECK(gv_image_alloc(&bad, 0, 5, 3) != 0);
    CHECK(gv_image_alloc(&bad, 5, 5, 5) != 0);
    CHECK(gv_image_alloc(&bad, 100000, 100000, 3) != 0);
}

static void test_downscale(void)
{
    gv_image in, out;
    /* 4x2 grey by 2: means of 2x2 blocks, halves rounded up. */
    const uint8_t a[8] = {0, 2, 10, 11, 4, 6, 20, 20};
    CHECK(gv_image_alloc(&in, 4, 2, 1) == 0);
    memcpy(in.pixels, a, 8);
    CHECK(gv_image_downscale(&in, 2, &out) == 0);
    CHECK(out.width == 2 && out.height == 1 && out.channels == 1);
    CHECK(out.pixels[0] == 3 && out.pixels[1] == 15); /* 12/4 = 3; 61/4 = 15.25 */
    gv_image_free(&out);
    in.pixels[0] = 1; /* block sum 13: 3.25 -> 3 */
    in.pixels[3] = 12; /* block sum 62: 15.5 -> 16 (half up) */
    CHECK(gv_image_downscale(&in, 2, &out) == 0);
    CHECK(out.pixels[0] == 3 && out.pixels[1] == 16);
    gv_image_free(&out);
    CHECK(gv_image_downscale(&in, 1, &out) == 0);
    CHECK(out.width == 4 && out.height == 2 && !memcmp(out.pixels, in.pixels, 8));
    gv_image_free(&out);
    CHECK_FAILS_WITH(gv_image_downscale(&in, 0, &out), "factor");
    gv_image_free(&in);

    /* 3x1 RGB by 2: width round(1.5) = 2, height max(1, round(0.5) = 0) = 1. Output pixel 0
     * covers source [0, 1.5): (10 + 0.5 * 40) / 1.5 = 20; pixel 1: (0.5 * 40 + 70) / 1.5 = 60. */
    CHECK(gv_image_alloc(&in, 3, 1, 3) == 0);
    const uint8_t b[9] = {10, 0, 255, 40, 3, 255, 70, 0, 255};
    memcpy(in.pixels, b, 9);
    CHECK(gv_image_downscale(&in, 2, &out) == 0);
    CHECK(out.width == 2 && out.height == 1 && out.channels == 3);
    const uint8_t want_b[6] = {20, 1, 255, 60, 1, 255}; /* 1.5/1.5 = 1 in the green channel */
    CHECK(!memcmp(out.pixels, want_b, 6));
    gv_image_free(&out);
    gv_image_free(&in);

    /* Python's round: 5 / 2 = 2.5 -> 2, 7 / 2 = 3.5 -> 4, 6 / 4 = 1.5 -> 2, 10 / 4 = 2.5 -> 2. */
    const int sizes[4][3] = {{5, 2, 2}, {7, 2, 4}, {6, 4, 2}, {10, 4, 2}};
    for (int i = 0; i < 4; i++) {
        CHECK(gv_image_alloc(&in, sizes[i][0], 3, 2) == 0);
        memset(in.pixels, 77, (size_t)sizes[i][0] * 3 * 2);
        CHECK(gv_image_downscale(&in, sizes[i][1], &out) == 0);
        CHECK(out.width == sizes[i][2]);
        int constant = 1; /* a constant image stays constant whatever the weights */
        for (int k = 0; k < out.width * out.height * 2; k++) constant &= out.pixels[k] == 77;
        CHECK(constant);
        gv_image_free(&out);
        gv_image_free(&in);
    }
}

static void test_float_conversion(void)
{
    gv_image img, back;
    CHECK(gv_image_alloc(&img, 256, 1, 1) == 0);
    CHECK(gv_image_alloc(&back, 256, 1, 1) == 0);
    for (int i = 0; i < 256; i++) img.pixels[i] = (uint8_t)i;
    float f[256];
    gv_image_to_float(&img, f);
    CHECK(f[0] == 0.0f && f[255] == 1.0f && f[51] == 0.2f);
    gv_image_from_float(&back, f);
    CHECK(!memcmp(back.pixels, img.pixels, 256));
    gv_image_free(&back);
    gv_image_free(&img);

    /* save_image rule: 0.5 -> 127.5 + 0.5 = 128; out of range clamps; NaN -> 0;
     * 0.998 * 255 + 0.5 = 254.99 -> 254; 0.0021 -> 1.0355 -> 1; 0.0019 -> 0.98 -> 0. */
    const float x[7] = {0.5f, -1.0f, 2.0f, NAN, 0.998f, 0.0021f, 0.0019f};
    const uint8_t want[7] = {128, 0, 255, 0, 254, 1, 0};
    CHECK(gv_image_alloc(&img, 7, 1, 1) == 0);
    gv_image_from_float(&img, x);
    CHECK(!memcmp(img.pixels, want, 7));
    gv_image_free(&img);
}

/* Ink at (x, y) of an RGB image: the pixel is the text colour (and nothing else was drawn). */
static int ink(const gv_image *img, int x, int y)
{
    const uint8_t *p = img->pixels + ((size_t)y * img->width + x) * 3;
    return p[0] == 255 && p[1] == 200 && p[2] == 0;
}

/* The 5x7 font against glyphs drawn here by hand ('H', '?'): scale 1 and 2, clipping at the
 * left edge, a byte outside ASCII drawn as '?', the width rule, the shading of a rectangle. */
static void test_text(void)
{
    static const char *const H_ART[7] = {"#...#", "#...#", "#...#", "#####", "#...#", "#...#", "#...#"};
    static const char *const Q_ART[7] = {".###.", "#...#", "....#", "...#.", "..#..", ".....", "..#.."};
    const uint8_t amber[3] = {255, 200, 0};
    gv_image img;
    REQUIRE(gv_image_alloc(&img, 24, 20, 3) == 0);
    gv_image_draw_text(&img, 1, 2, "H\xc3", 1, amber); /* 'H', then a UTF-8 lead byte: '?' */
    int wrong = 0, inked = 0;
    for (int y = 0; y < 20; y++)
        for (int x = 0; x < 24; x++) {
            int want = 0;
            if (y >= 2 && y < 9 && x >= 1 && x < 6) want = H_ART[y - 2][x - 1] == '#';
            if (y >= 2 && y < 9 && x >= 7 && x < 12) want = Q_ART[y - 2][x - 7] == '#';
            wrong += ink(&img, x, y) != want;
            inked += ink(&img, x, y);
        }
    CHECK(wrong == 0 && inked == 17 + 9);
    /* scale 2, half off the left edge: the right half of 'H' (columns 3, 4: 2x2 blocks) shows */
    memset(img.pixels, 0, 24 * 20 * 3);
    gv_image_draw_text(&img, -6, 0, "H", 2, amber);
    wrong = 0;
    for (int y = 0; y < 14; y++)
        for (int x = 0; x < 4; x++) wrong += ink(&img, x, y) != (H_ART[y / 2][3 + x / 2] == '#');
    CHECK(wrong == 0 && !ink(&img, 4, 0));
    CHECK(gv_text_width("ab", 1) == 11 && gv_text_width("ab", 3) == 33 && gv_text_width("", 2) == 0);
    for (int i = 0; i < 24 * 20 * 3; i++) img.pixels[i] = 200;
    gv_image_shade_rect(&img, 20, 18, 10, 10, 0.5); /* clipped to 4x2 pixels */
    int shaded = 0;
    for (int i = 0; i < 24 * 20; i++) shaded += img.pixels[3 * i] == 100;
    CHECK(shaded == 8 && img.pixels[(18 * 24 + 20) * 3 + 2] == 100 && img.pixels[(17 * 24 + 20) * 3] == 200);
    gv_image_free(&img);
}

/* Reflection padding: the mirror index by hand, a 3x2 image padded to 5x4 by hand, and pad
 * then crop returning the input exactly at odd sizes and 1-pixel edges. */
static void test_pad_crop(void)
{
    const int want4[10] = {0, 1, 2, 3, 2, 1, 0, 1, 2, 3}, want2[5] = {0, 1, 0, 1, 0};
    for (int i = 0; i < 10; i++) CHECK(gv_reflect_index(i, 4) == want4[i]);
    for (int i = 0; i < 5; i++) CHECK(gv_reflect_index(i, 2) == want2[i] && gv_reflect_index(i, 1) == 0);
    CHECK(gv_reflect_index(-1, 4) == 1 && gv_reflect_index(-3, 4) == 3);
    /* 1 2 3    1 2 3 2 1
     * 4 5 6 -> 4 5 6 5 4
     *           1 2 3 2 1
     *           4 5 6 5 4  (rows mirror with period 2 for a height of 2) */
    uint8_t px[6] = {1, 2, 3, 4, 5, 6}, big[20], back[6];
    const uint8_t want[20] = {1, 2, 3, 2, 1, 4, 5, 6, 5, 4, 1, 2, 3, 2, 1, 4, 5, 6, 5, 4};
    gv_image in = {3, 2, 1, px}, out = {5, 4, 1, big}, crop = {3, 2, 1, back};
    CHECK(gv_image_pad_reflect(&in, &out) == 0 && !memcmp(big, want, sizeof want));
    CHECK(gv_image_crop(&out, &crop) == 0 && !memcmp(back, px, sizeof px));
    CHECK_FAILS_WITH(gv_image_pad_reflect(&out, &in), "does not pad to");
    CHECK_FAILS_WITH(gv_image_crop(&in, &out), "does not crop to");
    gv_image three = {5, 4, 3, big};
    CHECK_FAILS_WITH(gv_image_pad_reflect(&in, &three), "does not pad to");
    /* round trips: odd sizes, 1-pixel rows and columns, padding wider than the image */
    const int sizes[][4] = {{37, 23, 48, 32}, {1, 1, 16, 16}, {1, 17, 16, 32}, {17, 1, 32, 16}, {2, 3, 33, 31}, {16, 16, 16, 16}};
    for (int k = 0; k < 6; k++) {
        int w = sizes[k][0], h = sizes[k][1], W = sizes[k][2], H = sizes[k][3];
        gv_image a, p, c;
        CHECK(gv_image_alloc(&a, w, h, 3) == 0 && gv_image_alloc(&p, W, H, 3) == 0 && gv_image_alloc(&c, w, h, 3) == 0);
        for (int i = 0; i < w * h * 3; i++) a.pixels[i] = (uint8_t)(i * 37 + k);
        CHECK(gv_image_pad_reflect(&a, &p) == 0 && gv_image_crop(&p, &c) == 0);
        CHECK(!memcmp(a.pixels, c.pixels, (size_t)w * h * 3));
        /* every padded pixel is the image pixel it mirrors */
        int bad = 0;
        for (int y = 0; y < H; y++)
            for (int x = 0; x < W; x++)
                bad += memcmp(p.pixels + ((size_t)y * W + x) * 3,
                              a.pixels + ((size_t)gv_reflect_index(y, h) * w + gv_reflect_index(x, w)) * 3, 3) != 0;
        CHECK(bad == 0);
        gv_image_free(&a), gv_image_free(&p), gv_image_free(&c);
    }
}

int main(void)
{
    snprintf(tmp, sizeof tmp, "%s", check_tmp_dir());
    test_png_round_trip();
    test_png_other_layouts();
    test_png_interlaced();
    test_jpeg();
    test_malformed();
    test_downscale();
    test_float_conversion();
    test_text();
    test_pad_crop();
    return check_summary();
}
