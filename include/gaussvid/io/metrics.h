/* Image quality metrics as the official 3DGS evaluation computes them
 * (docs/reference/gaussian-splatting.md section 19; docs/METRICS.md): PSNR over all values, and
 * SSIM with the 11x11 Gaussian window (sigma 1.5), zero padding of 5 ("same" size), per channel,
 * C1 = 0.01^2, C2 = 0.03^2, averaged over every pixel and channel. Images are float HWC in
 * [0, 1]. */
#ifndef GAUSSVID_METRICS_H
#define GAUSSVID_METRICS_H

#include "gaussvid/io/image.h"

#define GV_SSIM_WINDOW 11    /* taps of the 1-D Gaussian; the 2-D window is its outer product */
#define GV_SSIM_SIGMA 1.5
#define GV_SSIM_C1 (0.01 * 0.01)
#define GV_SSIM_C2 (0.03 * 0.03)

/* The normalised 1-D window g[i] = exp(-(i - 5)^2 / (2 sigma^2)) / sum. */
void gv_ssim_window(double g[GV_SSIM_WINDOW]);
/* Mean squared error over all width*height*channels values (double accumulation). */
double gv_mse(const float *a, const float *b, int width, int height, int channels);
/* PSNR = -10 log10(MSE) for data range 1; +INFINITY when the images are identical. */
double gv_psnr(const float *a, const float *b, int width, int height, int channels);
/* Mean SSIM (1 for identical images). Returns NAN, with the error recorded, on a bad size
 * or when memory runs out. */
double gv_ssim(const float *a, const float *b, int width, int height, int channels);
/* Mean SSIM, and in grad_a (w*h*c floats, HWC) its gradient d SSIM / d a with respect to
 * the first image (b is held constant). grad_a may be NULL. NAN on failure as gv_ssim. */
double gv_ssim_with_gradient(const float *a, const float *b, int width, int height,
                             int channels, float *grad_a);
/* PSNR and SSIM of two 8-bit images of the same width, height and channel count, each
 * value read as v / 255. Fails (naming the sizes) when they differ. */
int gv_image_psnr_ssim(const gv_image *a, const gv_image *b, double *psnr, double *ssim);

/* SSIM as the GaussVid release measures it (docs/GAUSSVID_RELEASE.md): scikit-image's
 * structural_similarity(a, b, channel_axis=2, data_range=255) on 8-bit images: per channel,
 * a 7x7 uniform window, sample (co)variances (x 49/48), C1 = (0.01 255)^2,
 * C2 = (0.03 255)^2, the map's mean over the pixels at least 3 from every border, then the
 * mean over channels; in double (src/io/ssim_skimage.c). Fails (naming the sizes) when the
 * images differ or are smaller than 7x7. */
#define GV_SSIM_SKIMAGE_WINDOW 7
int gv_image_ssim_skimage(const gv_image *a, const gv_image *b, double *ssim);

#endif
