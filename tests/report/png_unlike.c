/* The share of a rectangle of a PNG whose pixels are unlike a colour: tests/cli/report_browser.sh
 * measures with it how much of the viewer's canvas, in a screenshot that Chromium took by
 * itself, shows the model rather than the background (no Python or Node at test time).
 *
 * Usage: png_unlike FILE.png X Y W H RRGGBB TOLERANCE
 * Prints the fraction (0..1) of the pixels of [X, X+W) x [Y, Y+H) whose largest channel
 * difference from RRGGBB exceeds TOLERANCE (0..255). Grey images are compared by their one
 * channel against each of R, G and B; alpha is ignored. One line naming the problem and exit
 * status 2 on bad arguments, 1 on an unreadable file or a rectangle outside the image. */
#include "gaussvid/core/core.h"
#include "gaussvid/io/image.h"

#include <errno.h>
#include <stdio.h>
#include <stdlib.h>

static int parse_long(const char *text, int base, long lo, long hi, long *out)
{
    char *end;
    errno = 0;
    long v = strtol(text, &end, base);
    if (errno || end == text || *end || v < lo || v > hi) return -1;
    *out = v;
    return 0;
}

static int channel_difference(const gv_image *img, long x, long y, const long rgb[3])
{
    const uint8_t *p = img->pixels + ((size_t)y * (size_t)img->width + (size_t)x) * (size_t)img->channels;
    int colour = img->channels >= 3; /* grey (+ alpha) compares its one channel */
    int worst = 0;
    for (int c = 0; c < 3; c++) {
        int d = abs((int)p[colour ? c : 0] - (int)rgb[c]);
        if (d > worst) worst = d;
    }
    return worst;
}

int main(int argc, char **argv)
{
    long x, y, w, h, hex, tolerance;
    if (argc != 8 || parse_long(argv[2], 10, 0, 1L << 20, &x) || parse_long(argv[3], 10, 0, 1L << 20, &y) ||
        parse_long(argv[4], 10, 1, 1L << 20, &w) || parse_long(argv[5], 10, 1, 1L << 20, &h) ||
        parse_long(argv[6], 16, 0, 0xffffff, &hex) || parse_long(argv[7], 10, 0, 255, &tolerance)) {
        fprintf(stderr, "usage: png_unlike FILE.png X Y W H RRGGBB TOLERANCE (W, H >= 1; TOLERANCE 0..255)\n");
        return 2;
    }
    gv_image img;
    if (gv_image_read_png(argv[1], &img) != 0) {
        fprintf(stderr, "png_unlike: %s\n", gv_last_error());
        return 1;
    }
    if (x + w > img.width || y + h > img.height) {
        fprintf(stderr, "png_unlike: %s: the rectangle %ldx%ld at (%ld, %ld) is outside the %dx%d image\n", argv[1],
                w, h, x, y, img.width, img.height);
        gv_image_free(&img);
        return 1;
    }
    const long rgb[3] = {(hex >> 16) & 255, (hex >> 8) & 255, hex & 255};
    long unlike = 0;
    for (long j = y; j < y + h; j++)
        for (long i = x; i < x + w; i++)
            if (channel_difference(&img, i, j, rgb) > tolerance) unlike++;
    printf("%.4f\n", (double)unlike / ((double)w * (double)h));
    gv_image_free(&img);
    return 0;
}
