/* scikit-image's SSIM with its defaults (include/gaussvid/io/metrics.h), on 8-bit images: the
 * window sums of a, b, a^2, b^2 and ab come from summed-area tables in double (exact: the
 * values are integers below 2^53), one channel at a time. Only the windows wholly inside the
 * image are evaluated: skimage's map is cropped by 3 pixels on every side before its mean,
 * so its border handling (reflection) never reaches the result. */
#include "gaussvid/io/metrics.h"
#include "gaussvid/core/core.h"

#include <stdlib.h>

enum { W7 = GV_SSIM_SKIMAGE_WINDOW, N_MAPS = 5 };

/* Summed-area tables of the five maps of channel c: table[m][(y + 1) (w + 1) + x + 1] holds
 * the sum over rows < y + 1 and columns < x + 1. */
static void fill_tables(const gv_image *a, const gv_image *b, int c, double *table)
{
    const int w = a->width, h = a->height, ch = a->channels, stride = w + 1;
    const size_t size = (size_t)(w + 1) * (h + 1);
    for (int m = 0; m < N_MAPS; m++)
        for (int x = 0; x <= w; x++) table[m * size + x] = 0;
    for (int y = 0; y < h; y++)
        for (int m = 0; m < N_MAPS; m++) {
            double *row = table + m * size + (size_t)(y + 1) * stride, *above = row - stride, run = 0;
            row[0] = 0;
            for (int x = 0; x < w; x++) {
                double p = a->pixels[((size_t)y * w + x) * ch + c], q = b->pixels[((size_t)y * w + x) * ch + c];
                run += m == 0 ? p : m == 1 ? q : m == 2 ? p * p : m == 3 ? q * q : p * q;
                row[x + 1] = above[x + 1] + run;
            }
        }
}

static double window_sum(const double *t, int stride, int y0, int x0)
{
    return t[(size_t)(y0 + W7) * stride + x0 + W7] - t[(size_t)y0 * stride + x0 + W7] -
           t[(size_t)(y0 + W7) * stride + x0] + t[(size_t)y0 * stride + x0];
}

/* The mean SSIM of channel c over the windows inside the image. */
static double channel_ssim(const gv_image *a, const gv_image *b, int c, double *table)
{
    const int w = a->width, h = a->height, stride = w + 1;
    const size_t size = (size_t)(w + 1) * (h + 1);
    const double np = W7 * W7, cov_norm = np / (np - 1), c1 = (0.01 * 255) * (0.01 * 255), c2 = (0.03 * 255) * (0.03 * 255);
    fill_tables(a, b, c, table);
    double sum = 0;
    for (int y0 = 0; y0 + W7 <= h; y0++)
        for (int x0 = 0; x0 + W7 <= w; x0++) {
            double mu[N_MAPS];
            for (int m = 0; m < N_MAPS; m++) mu[m] = window_sum(table + m * size, stride, y0, x0) / np;
            double vx = cov_norm * (mu[2] - mu[0] * mu[0]), vy = cov_norm * (mu[3] - mu[1] * mu[1]);
            double vxy = cov_norm * (mu[4] - mu[0] * mu[1]);
            double num = (2 * mu[0] * mu[1] + c1) * (2 * vxy + c2);
            double den = (mu[0] * mu[0] + mu[1] * mu[1] + c1) * (vx + vy + c2);
            sum += num / den;
        }
    return sum / ((double)(h - W7 + 1) * (w - W7 + 1));
}

int gv_image_ssim_skimage(const gv_image *a, const gv_image *b, double *ssim)
{
    if (a->width != b->width || a->height != b->height || a->channels != b->channels)
        return gv_fail("images differ in size: %dx%dx%d and %dx%dx%d", a->width, a->height, a->channels, b->width,
                       b->height, b->channels);
    if (a->width < W7 || a->height < W7 || a->channels < 1)
        return gv_fail("skimage SSIM: a %dx%d image is smaller than its 7x7 window", a->width, a->height);
    double *table = malloc(sizeof *table * N_MAPS * (size_t)(a->width + 1) * (a->height + 1));
    if (!table) return gv_fail("skimage SSIM: out of memory for %dx%d", a->width, a->height);
    double sum = 0;
    for (int c = 0; c < a->channels; c++) sum += channel_ssim(a, b, c, table);
    free(table);
    *ssim = sum / a->channels;
    return 0;
}
