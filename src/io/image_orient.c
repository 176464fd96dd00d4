/* EXIF orientation (image.h): the tag read from a JPEG's APP1 "Exif" segment, and the pixels
 * turned the way the tag says a viewer shows them. Phones store a portrait photo as the
 * sensor read it (landscape) and set the tag (6: turn 90 degrees clockwise); libjpeg ignores
 * the tag, so gaussvid reads it here. */
#include "gaussvid/io/image.h"
#include "gaussvid/core/core.h"

#include <string.h>

#define EXIF_TAG_ORIENTATION 0x0112
#define EXIF_TYPE_SHORT 3

static unsigned read16(const uint8_t *p, int little)
{
    return little ? (unsigned)p[0] | (unsigned)p[1] << 8 : (unsigned)p[0] << 8 | (unsigned)p[1];
}

static uint32_t read32(const uint8_t *p, int little)
{
    return little ? (uint32_t)read16(p, 1) | (uint32_t)read16(p + 2, 1) << 16
                  : (uint32_t)read16(p, 0) << 16 | (uint32_t)read16(p + 2, 0);
}

int gv_exif_orientation(const uint8_t *segment, size_t size)
{
    if (size < 6 + 8 || memcmp(segment, "Exif\0\0", 6)) return 1;
    const uint8_t *tiff = segment + 6;
    size_t n = size - 6;
    int little;
    if (!memcmp(tiff, "II", 2)) little = 1;
    else if (!memcmp(tiff, "MM", 2)) little = 0;
    else return 1;
    if (read16(tiff + 2, little) != 42) return 1;
    uint32_t ifd = read32(tiff + 4, little);
    if (ifd > n || n - ifd < 2) return 1;
    unsigned entries = read16(tiff + ifd, little);
    for (unsigned i = 0; i < entries; i++) {
        size_t at = ifd + 2 + 12 * (size_t)i;
        if (at + 12 > n) return 1;
        const uint8_t *e = tiff + at;
        if (read16(e, little) != EXIF_TAG_ORIENTATION) continue;
        if (read16(e + 2, little) != EXIF_TYPE_SHORT || read32(e + 4, little) != 1) return 1;
        unsigned value = read16(e + 8, little); /* a SHORT sits at the start of the field */
        return value >= 1 && value <= 8 ? (int)value : 1;
    }
    return 1;
}

/* The stored pixel (x, y) that the shown pixel (u, v) comes from, for a stored W x H image. */
static void stored_of_shown(int orientation, int W, int H, int u, int v, int *x, int *y)
{
    switch (orientation) {
    case 2: *x = W - 1 - u, *y = v; break;
    case 3: *x = W - 1 - u, *y = H - 1 - v; break;
    case 4: *x = u, *y = H - 1 - v; break;
    case 5: *x = v, *y = u; break;
    case 6: *x = v, *y = H - 1 - u; break;
    case 7: *x = W - 1 - v, *y = H - 1 - u; break;
    case 8: *x = W - 1 - v, *y = u; break;
    default: *x = u, *y = v; break;
    }
}

int gv_image_orient(const gv_image *in, int orientation, gv_image *out)
{
    if (orientation < 1 || orientation > 8) return gv_fail("image: EXIF orientation %d is not in 1..8", orientation);
    int swap = orientation >= 5;
    int W = in->width, H = in->height, C = in->channels;
    if (gv_image_alloc(out, swap ? H : W, swap ? W : H, C) != 0) return -1;
    for (int v = 0; v < out->height; v++)
        for (int u = 0; u < out->width; u++) {
            int x, y;
            stored_of_shown(orientation, W, H, u, v, &x, &y);
            memcpy(out->pixels + ((size_t)v * out->width + u) * C, in->pixels + ((size_t)y * W + x) * C, (size_t)C);
        }
    return 0;
}
