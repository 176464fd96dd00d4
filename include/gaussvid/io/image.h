/* 8-bit images: PNG (grey, grey+alpha, RGB, RGBA, palette; 8 and 16 bit are read as 8-bit)
 * and JPEG read, PNG written atomically. Pixels are row-major, channels interleaved (HWC).
 *
 * Reading: 16-bit samples keep their high byte (v >> 8), as PIL and OpenCV do; palette
 * images become RGB (RGBA when the palette has transparency); grey below 8 bits is expanded
 * to 8 bits. A JPEG with corrupt data (any libjpeg warning, e.g. a premature end) is
 * refused rather than returned with grey blocks. Every failure is one line naming the file. */
#ifndef GAUSSVID_IMAGE_H
#define GAUSSVID_IMAGE_H

#include <stddef.h>
#include <stdint.h>

typedef struct {
    int width, height, channels; /* channels: 1, 2, 3 or 4 */
    uint8_t *pixels;             /* width * height * channels bytes */
} gv_image;

/* Reads a PNG or a JPEG (recognised by its signature, not its name); a JPEG is turned
 * upright as its EXIF orientation tag says (the way viewers show it). */
int gv_image_read(const char *path, gv_image *out);
/* Reads the pixels as stored, without applying the EXIF orientation, which goes to
 * *orientation (1..8; 1 for a PNG or a JPEG without the tag). COLMAP reads JPEGs this way. */
int gv_image_read_stored(const char *path, gv_image *out, int *orientation);
/* Reads and converts to 3-channel RGB (grey is replicated; alpha is dropped). */
int gv_image_read_rgb(const char *path, gv_image *out);
/* Reads a PNG (1..4 channels out). */
int gv_image_read_png(const char *path, gv_image *out);
/* Reads a baseline or progressive JPEG (1 channel for greyscale, else 3; CMYK refused),
 * turned upright by its EXIF orientation; _stored leaves it as stored and gives the tag. */
int gv_image_read_jpeg(const char *path, gv_image *out);
int gv_image_read_jpeg_stored(const char *path, gv_image *out, int *orientation);
/* Writes a baseline JPEG (1 or 3 channels; quality 1..100, 4:2:0 chroma as libjpeg's
 * default) under a temporary name renamed into place; no EXIF segment, so upright as stored. */
int gv_image_write_jpeg(const char *path, const gv_image *img, int quality);
/* The EXIF orientation tag (0x0112) of an APP1 segment's payload, which starts "Exif\0\0":
 * 1..8 as the EXIF standard numbers them (1 upright, 3 turned 180 degrees, 6 to be turned 90
 * degrees clockwise, 8 counter-clockwise, 2, 4, 5, 7 their mirror images); 1 when the tag is
 * absent or the segment malformed. Both byte orders (II, MM). */
int gv_exif_orientation(const uint8_t *segment, size_t size);
/* The image as a viewer shows a photo with that EXIF orientation: pixel (u, v) of out is
 * stored pixel (v, H-1-u) for 6, (W-1-v, u) for 8, (W-1-u, H-1-v) for 3, and so on; 5..8
 * swap width and height. */
int gv_image_orient(const gv_image *in, int orientation, gv_image *out);
/* Writes an 8-bit PNG with the image's channel count, under a temporary name renamed
 * into place. */
int gv_image_write_png(const char *path, const gv_image *img);
/* Encodes an 8-bit PNG into memory (as gv_image_write_png writes it); *bytes is malloc'd. */
int gv_image_encode_png(const gv_image *img, uint8_t **bytes, size_t *size);
/* Allocates zeroed pixels; fails on a non-positive size, channels outside 1..4 or a size
 * above 2^31 bytes. */
int gv_image_alloc(gv_image *img, int width, int height, int channels);
void gv_image_free(gv_image *img);
/* New 3-channel copy: grey is replicated, alpha is dropped (no compositing). */
int gv_image_to_rgb(const gv_image *in, gv_image *out);
/* Converts to float in [0, 1], HWC, same channel count; out holds w*h*c floats. As
 * torchvision's to_tensor: v / 255 in float32. */
void gv_image_to_float(const gv_image *img, float *out);
/* Converts float HWC in [0, 1] to 8 bits as torchvision's save_image does:
 * clamp(x * 255 + 0.5, 0, 255) truncated (float32 arithmetic; NaN gives 0). */
void gv_image_from_float(gv_image *img, const float *in);
/* Area-average (box filter) downscale by an integer factor k >= 1. The output size is
 * (round(W/k), round(H/k)) with Python's round (half to even, as 3DGS loadCam computes it),
 * at least 1. Each output pixel is the exact area-weighted mean of the source region it
 * covers (a W/W' by H/H' rectangle, fractional pixels weighted by their overlap), rounded to
 * nearest (halves up); when k divides the size this is the mean of a k x k block. */
int gv_image_downscale(const gv_image *in, int factor, gv_image *out);

/* ---- labels (image_text.c): a 5x7 bitmap font of printable ASCII -------------------- */
#define GV_GLYPH_W 5
#define GV_GLYPH_H 7
/* Width in pixels of text drawn at an integer scale: (6 n - 1) scale for n characters. */
int gv_text_width(const char *text, int scale);
/* Draws text with its top-left corner at (x, y), each font pixel a scale x scale block of
 * colour rgb, one column of space between characters; bytes outside printable ASCII are drawn
 * as '?'; whatever falls outside the image is clipped. RGB or RGBA images (others unchanged). */
void gv_image_draw_text(gv_image *img, int x, int y, const char *text, int scale, const uint8_t rgb[3]);
/* Darkens a rectangle (clipped to the image): each colour value times keep (0..1), rounded. */
void gv_image_shade_rect(gv_image *img, int x, int y, int w, int h, double keep);

/* Padding by reflection (image_pad.c), for networks that take only multiples of a block: the
 * index in 0..n-1 that position i (any integer) mirrors to, the edge not repeated
 * (... c b | a b c d | c b a ...), period 2 (n - 1); 0 when n = 1. */
int gv_reflect_index(int i, int n);
/* in at the top-left of out (allocated, at least as large, as many channels, another buffer);
 * the rest of out mirrors it: out(x, y) = in(reflect(x, W), reflect(y, H)). Reflection, not
 * replication of the edge pixel: the padding continues the picture's texture and gradients
 * instead of drawing streaks the networks never saw in training, and a constant picture pads
 * to itself either way. */
int gv_image_pad_reflect(const gv_image *in, gv_image *out);
/* The top-left out->width x out->height of in into out (allocated, as many channels): undoes
 * gv_image_pad_reflect exactly. */
int gv_image_crop(const gv_image *in, gv_image *out);

#endif
