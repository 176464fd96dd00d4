/* EXIF orientation: JPEGs made here through libjpeg with a hand-built APP1 segment carrying
 * each of the eight orientations (both byte orders) come out of gv_image_read as a viewer
 * shows them, checked on four coloured quadrants against positions derived by hand from the
 * EXIF standard's wording ("the 0th row is the visual right-hand side..."); the stored reader
 * gives the stored pixels and the tag; the tag parser on malformed segments; the JPEG writer
 * round trip. */
#include <stdio.h>
#include <jpeglib.h>

#include "check.h"
#include "gaussvid/core/core.h"
#include "gaussvid/io/image.h"

enum { W = 32, H = 16 };
enum { RED, GREEN, BLUE, WHITE };
static const uint8_t colour[4][3] = {{220, 20, 20}, {20, 200, 20}, {20, 20, 220}, {240, 240, 240}};

/* The APP1 payload a phone writes: "Exif\0\0", a TIFF header, IFD0 with one SHORT entry. */
static size_t exif_payload(uint8_t *p, int orientation, int little)
{
    static const uint8_t mm[] = {'E', 'x', 'i', 'f', 0, 0, 'M', 'M', 0, 42, 0, 0, 0, 8, 0, 1,
                                 0x01, 0x12, 0, 3, 0, 0, 0, 1, 0, 0, 0, 0, 0, 0, 0, 0};
    static const uint8_t ii[] = {'E', 'x', 'i', 'f', 0, 0, 'I', 'I', 42, 0, 8, 0, 0, 0, 1, 0,
                                 0x12, 0x01, 3, 0, 1, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0};
    memcpy(p, little ? ii : mm, sizeof mm);
    p[little ? 24 : 25] = (uint8_t)orientation; /* the SHORT at the start of the value field */
    return sizeof mm;
}

/* Stored W x H: red top-left, green top-right, blue bottom-left, white bottom-right quadrant
 * (4:4:4, quality 95, quadrants on 8x8 blocks); orientation 0 writes no APP1 segment. */
static void write_quadrants(const char *path, int orientation, int little)
{
    uint8_t pixels[W * H * 3], app1[64];
    for (int y = 0; y < H; y++)
        for (int x = 0; x < W; x++) memcpy(pixels + 3 * (y * W + x), colour[(y >= H / 2) * 2 + (x >= W / 2)], 3);
    struct jpeg_compress_struct cinfo;
    struct jpeg_error_mgr jerr;
    cinfo.err = jpeg_std_error(&jerr);
    jpeg_create_compress(&cinfo);
    FILE *f = fopen(path, "wb");
    if (!f) exit(1);
    jpeg_stdio_dest(&cinfo, f);
    cinfo.image_width = W, cinfo.image_height = H, cinfo.input_components = 3, cinfo.in_color_space = JCS_RGB;
    jpeg_set_defaults(&cinfo);
    jpeg_set_quality(&cinfo, 95, TRUE);
    for (int c = 0; c < 3; c++) cinfo.comp_info[c].h_samp_factor = cinfo.comp_info[c].v_samp_factor = 1;
    cinfo.write_JFIF_header = FALSE;
    jpeg_start_compress(&cinfo, TRUE);
    if (orientation) jpeg_write_marker(&cinfo, JPEG_APP0 + 1, app1, (unsigned)exif_payload(app1, orientation, little));
    for (int y = 0; y < H; y++) {
        JSAMPROW row = pixels + 3 * y * W;
        jpeg_write_scanlines(&cinfo, &row, 1);
    }
    jpeg_finish_compress(&cinfo);
    jpeg_destroy_compress(&cinfo);
    fclose(f);
}

/* The colour nearest to the pixel at (x, y); -1 when none is within 40 per channel. */
static int colour_at(const gv_image *img, int x, int y)
{
    const uint8_t *p = img->pixels + 3 * ((size_t)y * img->width + x);
    for (int k = 0; k < 4; k++)
        if (abs(p[0] - colour[k][0]) < 40 && abs(p[1] - colour[k][1]) < 40 && abs(p[2] - colour[k][2]) < 40) return k;
    return -1;
}

/* Per orientation 1..8, the colours shown at the top-left, top-right, bottom-left and
 * bottom-right: 6 turns the stored picture 90 degrees clockwise (its left column, red over
 * blue, becomes the top row, blue left of red), 8 counter-clockwise, 3 by 180; 2 mirrors left
 * and right, 4 top and bottom, 5 transposes, 7 transposes across the other diagonal. */
static const int shown[9][4] = {
    {0},
    {RED, GREEN, BLUE, WHITE},   {GREEN, RED, WHITE, BLUE}, {WHITE, BLUE, GREEN, RED}, {BLUE, WHITE, RED, GREEN},
    {RED, BLUE, GREEN, WHITE},   {BLUE, RED, WHITE, GREEN}, {WHITE, GREEN, BLUE, RED}, {GREEN, WHITE, RED, BLUE},
};

static void test_orientations(const char *dir)
{
    char path[4200];
    for (int little = 0; little < 2; little++)
        for (int o = 1; o <= 8; o++) {
            snprintf(path, sizeof path, "%s/o%d%s.jpg", dir, o, little ? "ii" : "mm");
            write_quadrants(path, o, little);
            gv_image img, stored;
            int tag = 0;
            REQUIRE(gv_image_read(path, &img) == 0);
            int w = o >= 5 ? H : W, h = o >= 5 ? W : H;
            CHECK(img.width == w && img.height == h);
            CHECK(colour_at(&img, 4, 4) == shown[o][0]);
            CHECK(colour_at(&img, w - 5, 4) == shown[o][1]);
            CHECK(colour_at(&img, 4, h - 5) == shown[o][2]);
            CHECK(colour_at(&img, w - 5, h - 5) == shown[o][3]);
            REQUIRE(gv_image_read_stored(path, &stored, &tag) == 0);
            CHECK(tag == o && stored.width == W && stored.height == H);
            CHECK(colour_at(&stored, 4, 4) == RED && colour_at(&stored, W - 5, H - 5) == WHITE);
            gv_image_free(&img);
            gv_image_free(&stored);
        }
    snprintf(path, sizeof path, "%s/none.jpg", dir);
    write_quadrants(path, 0, 0);
    gv_image img;
    int tag = 0;
    REQUIRE(gv_image_read_stored(path, &img, &tag) == 0);
    CHECK(tag == 1 && colour_at(&img, 4, 4) == RED);
    gv_image_free(&img);
}

static void test_malformed_tags(void)
{
    uint8_t p[64];
    size_t n = exif_payload(p, 6, 0);
    CHECK(gv_exif_orientation(p, n) == 6);
    CHECK(gv_exif_orientation(p, 25) == 1); /* cut inside the entry */
    CHECK(gv_exif_orientation(p, 10) == 1);
    p[25] = 9;
    CHECK(gv_exif_orientation(p, n) == 1); /* out of 1..8 */
    n = exif_payload(p, 6, 0);
    p[19] = 4; /* type LONG, not SHORT */
    CHECK(gv_exif_orientation(p, n) == 1);
    n = exif_payload(p, 6, 0);
    p[16] = 0x02; /* another tag (0x0212) */
    CHECK(gv_exif_orientation(p, n) == 1);
    n = exif_payload(p, 8, 1);
    p[10] = 0xff; /* IFD offset past the end */
    CHECK(gv_exif_orientation(p, n) == 1);
    n = exif_payload(p, 8, 1);
    p[8] = 43; /* not TIFF's 42 */
    CHECK(gv_exif_orientation(p, n) == 1);
    CHECK(gv_exif_orientation((const uint8_t *)"Exif", 4) == 1);
}

/* Oriented pixels by hand on a 3 x 2 image: stored rows "a b c" / "d e f". */
static void test_orient_exact(void)
{
    gv_image in, out;
    REQUIRE(gv_image_alloc(&in, 3, 2, 1) == 0);
    memcpy(in.pixels, "abcdef", 6);
    static const char *want[9] = {"", "abcdef", "cbafed", "fedcba", "defabc", "adbecf", "daebfc", "fcebda", "cfbead"};
    for (int o = 1; o <= 8; o++) {
        REQUIRE(gv_image_orient(&in, o, &out) == 0);
        CHECK(out.width == (o >= 5 ? 2 : 3) && !memcmp(out.pixels, want[o], 6));
        gv_image_free(&out);
    }
    CHECK_FAILS_WITH(gv_image_orient(&in, 9, &out), "orientation 9");
    gv_image_free(&in);
}

static void test_write_jpeg(const char *dir)
{
    char path[4200];
    snprintf(path, sizeof path, "%s/written.jpg", dir);
    gv_image img, back;
    REQUIRE(gv_image_alloc(&img, 40, 24, 3) == 0);
    for (int i = 0; i < 40 * 24 * 3; i++) img.pixels[i] = (uint8_t)(100 + (i / 3 % 40) + (i % 3) * 20);
    REQUIRE(gv_image_write_jpeg(path, &img, 95) == 0);
    int tag = 0, worst = 0;
    REQUIRE(gv_image_read_stored(path, &back, &tag) == 0);
    CHECK(tag == 1 && back.width == 40 && back.height == 24 && back.channels == 3);
    for (int i = 0; i < 40 * 24 * 3; i++) worst = abs(back.pixels[i] - img.pixels[i]) > worst ? abs(back.pixels[i] - img.pixels[i]) : worst;
    CHECK(worst <= 8);
    CHECK_FAILS_WITH(gv_image_write_jpeg(path, &img, 0), "quality 0");
    img.channels = 4;
    CHECK_FAILS_WITH(gv_image_write_jpeg(path, &img, 90), "1 or 3 channels");
    img.channels = 3;
    gv_image_free(&img);
    gv_image_free(&back);
}

int main(void)
{
    const char *dir = check_tmp_dir();
    test_orientations(dir);
    test_malformed_tags();
    test_orient_exact();
    test_write_jpeg(dir);
    return check_summary();
}
