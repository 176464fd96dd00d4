/* The report's error maps: the mean absolute difference over R, G and B, coloured so that
 * small errors stay dark and large ones stand out (include/gaussvid/report/report.h,
 * docs/REPORT.md). */
#include "gaussvid/report/report.h"
#include "gaussvid/core/core.h"

#include <math.h>
#include <stdlib.h>

/* Black, blue, red, yellow, white at 0, 1/4, 2/4, 3/4 and 4/4 of the full scale: brightness
 * grows with the error and every step changes hue, so levels can be told apart. */
static const uint8_t STOPS[5][3] = {{0, 0, 0}, {0, 0, 255}, {255, 0, 0}, {255, 255, 0}, {255, 255, 255}};

void gv_error_colour(double error, uint8_t rgb[3])
{
    double x = error / GV_ERROR_MAP_FULL_SCALE * 4.0;
    if (!(x > 0)) x = 0; /* NaN too */
    if (x >= 4) x = 4;
    int k = x >= 4 ? 3 : (int)x;
    double f = x - k;
    for (int c = 0; c < 3; c++)
        rgb[c] = (uint8_t)lround(STOPS[k][c] + f * (STOPS[k + 1][c] - STOPS[k][c]));
}

int gv_error_map(const gv_image *a, const gv_image *b, gv_image *out)
{
    if (a->width != b->width || a->height != b->height)
        return gv_fail("error map: images of different sizes (%dx%d and %dx%d)", a->width, a->height,
                       b->width, b->height);
    if (a->channels != 3 || b->channels != 3)
        return gv_fail("error map: RGB images expected (%d and %d channels)", a->channels, b->channels);
    if (gv_image_alloc(out, a->width, a->height, 3) != 0) return -1;
    size_t pixels = (size_t)a->width * a->height;
    for (size_t i = 0; i < pixels; i++) {
        int sum = 0;
        for (int c = 0; c < 3; c++) sum += abs((int)a->pixels[3 * i + c] - (int)b->pixels[3 * i + c]);
        gv_error_colour(sum / 3.0, out->pixels + 3 * i);
    }
    return 0;
}
