/* 8-bit images in memory: allocation, format dispatch by signature, channel and float
 * conversion, and area-average downscaling. The PNG and JPEG codecs are in image_png.c and
 * image_jpeg.c. */
#include "gaussvid/io/image.h"
#include "gaussvid/core/core.h"

#include <errno.h>
#include <limits.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

int gv_image_alloc(gv_image *img, int width, int height, int channels)
{
    memset(img, 0, sizeof *img);
    if (width <= 0 || height <= 0)
        return gv_fail("image: invalid size %dx%d", width, height);
    if (channels < 1 || channels > 4)
        return gv_fail("image: invalid channel count %d", channels);
    size_t bytes = (size_t)width * (size_t)height * (size_t)channels;
    if (bytes > (size_t)INT_MAX)
        return gv_fail("image: %dx%dx%d is too large", width, height, channels);
    img->pixels = calloc(bytes, 1);
    if (!img->pixels) return gv_fail("image: out of memory (%zu bytes)", bytes);
    img->width = width;
    img->height = height;
    img->channels = channels;
    return 0;
}

void gv_image_free(gv_image *img)
{
    free(img->pixels);
    memset(img, 0, sizeof *img);
}

/* PNG, JPEG as stored (*orientation its EXIF tag), or JPEG turned upright. */
static int read_any(const char *path, gv_image *out, int *orientation)
{
    static const uint8_t png_signature[8] = {0x89, 'P', 'N', 'G', '\r', '\n', 0x1a, '\n'};
    memset(out, 0, sizeof *out);
    if (orientation) *orientation = 1;
    FILE *f = fopen(path, "rb");
    if (!f) return gv_fail("%s: cannot open: %s", path, strerror(errno));
    uint8_t head[8];
    size_t got = fread(head, 1, sizeof head, f);
    int read_error = ferror(f);
    fclose(f);
    if (read_error) return gv_fail("%s: cannot read (not a regular file?)", path);
    if (got == 0) return gv_fail("%s: empty file, not an image", path);
    if (got == 8 && !memcmp(head, png_signature, 8)) return gv_image_read_png(path, out);
    if (got >= 3 && head[0] == 0xFF && head[1] == 0xD8 && head[2] == 0xFF)
        return orientation ? gv_image_read_jpeg_stored(path, out, orientation) : gv_image_read_jpeg(path, out);
    return gv_fail("%s: not a PNG or JPEG image (unrecognised signature)", path);
}

int gv_image_read(const char *path, gv_image *out) { return read_any(path, out, NULL); }

int gv_image_read_stored(const char *path, gv_image *out, int *orientation)
{
    return read_any(path, out, orientation);
}

int gv_image_to_rgb(const gv_image *in, gv_image *out)
{
    if (gv_image_alloc(out, in->width, in->height, 3) != 0) return -1;
    size_t n = (size_t)in->width * in->height;
    int c = in->channels;
    for (size_t i = 0; i < n; i++) {
        const uint8_t *s = in->pixels + i * c;
        uint8_t *d = out->pixels + i * 3;
        if (c >= 3) {
            d[0] = s[0]; d[1] = s[1]; d[2] = s[2];
        } else {
            d[0] = d[1] = d[2] = s[0];
        }
    }
    return 0;
}

int gv_image_read_rgb(const char *path, gv_image *out)
{
    gv_image raw;
    if (gv_image_read(path, &raw) != 0) return -1;
    if (raw.channels == 3) {
        *out = raw;
        return 0;
    }
    int rc = gv_image_to_rgb(&raw, out);
    gv_image_free(&raw);
    return rc == 0 ? 0 : gv_fail_context("%s", path);
}

void gv_image_to_float(const gv_image *img, float *out)
{
    size_t n = (size_t)img->width * img->height * img->channels;
    for (size_t i = 0; i < n; i++) out[i] = (float)img->pixels[i] / 255.0f;
}

void gv_image_from_float(gv_image *img, const float *in)
{
    size_t n = (size_t)img->width * img->height * img->channels;
    for (size_t i = 0; i < n; i++) {
        float v = in[i] * 255.0f;   /* two float32 steps, as torch's mul(255).add_(0.5) */
        v = v + 0.5f;
        if (!(v > 0.0f)) v = 0.0f; /* also NaN */
        if (v > 255.0f) v = 255.0f;
        img->pixels[i] = (uint8_t)v;
    }
}

/* Python's round(n / k) for positive integers: halves go to the even neighbour. */
static int round_half_even_div(int n, int k)
{
    int q = n / k, r = n % k;
    if (2 * r > k || (2 * r == k && (q & 1))) q++;
    return q;
}

/* Overlap, in units of 1/out_size source pixels, of source pixel j with output pixel x:
 * output x covers [x*in, (x+1)*in) and source j covers [j*out, (j+1)*out) on that scale. */
static long overlap(long x, long j, long in_size, long out_size)
{
    long lo = x * in_size > j * out_size ? x * in_size : j * out_size;
    long hi = (x + 1) * in_size < (j + 1) * out_size ? (x + 1) * in_size : (j + 1) * out_size;
    return hi > lo ? hi - lo : 0;
}

int gv_image_downscale(const gv_image *in, int factor, gv_image *out)
{
    if (factor < 1) return gv_fail("image downscale: factor %d must be at least 1", factor);
    int W = in->width, H = in->height, C = in->channels;
    int Wo = round_half_even_div(W, factor), Ho = round_half_even_div(H, factor);
    if (Wo < 1) Wo = 1;
    if (Ho < 1) Ho = 1;
    if (gv_image_alloc(out, Wo, Ho, C) != 0) return -1;
    /* Horizontal pass into integer sums (each at most 255 * W), then vertical. */
    int64_t *rows = malloc(sizeof *rows * (size_t)H * Wo * C);
    if (!rows) {
        gv_image_free(out);
        return gv_fail("image downscale: out of memory");
    }
    for (int y = 0; y < H; y++) {
        for (int x = 0; x < Wo; x++) {
            int j0 = (int)((long)x * W / Wo), j1 = (int)(((long)(x + 1) * W + Wo - 1) / Wo);
            for (int c = 0; c < C; c++) {
                int64_t s = 0;
                for (int j = j0; j < j1 && j < W; j++)
                    s += overlap(x, j, W, Wo) * in->pixels[((size_t)y * W + j) * C + c];
                rows[((size_t)y * Wo + x) * C + c] = s;
            }
        }
    }
    const int64_t area = (int64_t)W * H; /* total weight of one output pixel */
    for (int y = 0; y < Ho; y++) {
        int i0 = (int)((long)y * H / Ho), i1 = (int)(((long)(y + 1) * H + Ho - 1) / Ho);
        for (int x = 0; x < Wo; x++) {
            for (int c = 0; c < C; c++) {
                int64_t s = 0;
                for (int i = i0; i < i1 && i < H; i++)
                    s += overlap(y, i, H, Ho) * rows[((size_t)i * Wo + x) * C + c];
                out->pixels[((size_t)y * Wo + x) * C + c] = (uint8_t)((2 * s + area) / (2 * area));
            }
        }
    }
    free(rows);
    return 0;
}
