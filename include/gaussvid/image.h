/* 8-bit images: PNG (grey, grey+alpha, RGB, RGBA; 8 and 16 bit are read as 8-bit) and JPEG
 * read, PNG written atomically. Pixels are row-major, channels interleaved (HWC). */
#ifndef GAUSSVID_IMAGE_H
#define GAUSSVID_IMAGE_H

#include <stdint.h>

typedef struct {
    int width, height, channels; /* channels: 1, 2, 3 or 4 */
    uint8_t *pixels;             /* width * height * channels bytes */
} gv_image;

/* Reads a PNG or a JPEG (recognised by its signature, not its name). */
int gv_image_read(const char *path, gv_image *out);
/* Reads and converts to 3-channel RGB (grey is replicated; alpha is dropped). */
int gv_image_read_rgb(const char *path, gv_image *out);
int gv_image_write_png(const char *path, const gv_image *img);
int gv_image_alloc(gv_image *img, int width, int height, int channels);
void gv_image_free(gv_image *img);
/* Converts to float in [0, 1], HWC, same channel count; out holds w*h*c floats. */
void gv_image_to_float(const gv_image *img, float *out);
/* Converts float HWC in [0, 1] to 8 bits as torchvision's save_image does:
 * clamp(x * 255 + 0.5, 0, 255) truncated. */
void gv_image_from_float(gv_image *img, const float *in);

#endif
