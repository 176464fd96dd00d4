/* PSNR (docs/reference/gaussian-splatting.md 19.1) and the PSNR/SSIM pair of two 8-bit images. SSIM
 * is in ssim.c. */
#include "gaussvid/io/metrics.h"
#include "gaussvid/core/core.h"

#include <math.h>
#include <stdlib.h>

double gv_mse(const float *a, const float *b, int width, int height, int channels)
{
    size_t n = (size_t)width * height * channels;
    double sum = 0.0;
    for (size_t i = 0; i < n; i++) {
        double d = (double)a[i] - (double)b[i];
        sum += d * d;
    }
    return n ? sum / (double)n : 0.0;
}

double gv_psnr(const float *a, const float *b, int width, int height, int channels)
{
    double mse = gv_mse(a, b, width, height, channels);
    if (mse == 0.0) return INFINITY; /* identical images */
    return -10.0 * log10(mse);        /* = 20 log10(1 / sqrt(MSE)), data range 1 */
}

int gv_image_psnr_ssim(const gv_image *a, const gv_image *b, double *psnr, double *ssim)
{
    if (a->width != b->width || a->height != b->height || a->channels != b->channels)
        return gv_fail("images differ in size: %dx%dx%d and %dx%dx%d", a->width, a->height,
                       a->channels, b->width, b->height, b->channels);
    size_t n = (size_t)a->width * a->height * a->channels;
    float *fa = malloc(sizeof *fa * n), *fb = malloc(sizeof *fb * n);
    if (!fa || !fb) {
        free(fa);
        free(fb);
        return gv_fail("metrics: out of memory for %dx%d", a->width, a->height);
    }
    gv_image_to_float(a, fa);
    gv_image_to_float(b, fb);
    *psnr = gv_psnr(fa, fb, a->width, a->height, a->channels);
    *ssim = gv_ssim(fa, fb, a->width, a->height, a->channels);
    free(fa);
    free(fb);
    return isnan(*ssim) ? -1 : 0;
}
