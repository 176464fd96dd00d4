/* A frame padded to a larger size by reflection, and cropped back (image.h). The restorer's
 * VAE and DiT take only multiples of their block (VAE factor x DiT patch); a clip of any other
 * size is padded on its right and bottom, restored and cropped (docs/RESTORATION.md, "Any
 * image size"). Right and bottom only, so a pixel keeps its coordinates and the cameras'
 * intrinsics stay as they are. */
#include "gaussvid/core/core.h"
#include "gaussvid/io/image.h"

#include <string.h>

int gv_reflect_index(int i, int n)
{
    if (n <= 1) return 0;
    int period = 2 * (n - 1); /* a b c d c b | a b c d c b | ... */
    int j = i % period;
    if (j < 0) j += period;
    return j < n ? j : period - j;
}

int gv_image_pad_reflect(const gv_image *in, gv_image *out)
{
    if (out->width < in->width || out->height < in->height || out->channels != in->channels)
        return gv_fail("pad: a %dx%dx%d image does not pad to %dx%dx%d", in->width, in->height, in->channels,
                       out->width, out->height, out->channels);
    const int c = in->channels;
    for (int y = 0; y < out->height; y++) {
        const uint8_t *src = in->pixels + (size_t)gv_reflect_index(y, in->height) * in->width * c;
        uint8_t *dst = out->pixels + (size_t)y * out->width * c;
        memcpy(dst, src, (size_t)in->width * c);
        for (int x = in->width; x < out->width; x++)
            memcpy(dst + (size_t)x * c, src + (size_t)gv_reflect_index(x, in->width) * c, (size_t)c);
    }
    return 0;
}

int gv_image_crop(const gv_image *in, gv_image *out)
{
    if (out->width > in->width || out->height > in->height || out->channels != in->channels)
        return gv_fail("crop: a %dx%dx%d image does not crop to %dx%dx%d", in->width, in->height, in->channels,
                       out->width, out->height, out->channels);
    for (int y = 0; y < out->height; y++)
        memcpy(out->pixels + (size_t)y * out->width * out->channels, in->pixels + (size_t)y * in->width * in->channels,
               (size_t)out->width * out->channels);
    return 0;
}
