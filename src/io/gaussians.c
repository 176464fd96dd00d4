/* Storage of a set of 3D Gaussians (structure of arrays) and a finiteness check. */
#include "gaussvid/io/gaussians.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "gaussvid/core/core.h"

int gv_sh_coefficient_count(int degree)
{
    return (degree + 1) * (degree + 1);
}

/* Grows one array from `old_rows` to `rows` rows of `width` floats, zeroing the new rows. */
static int grow(float **array, int old_rows, int rows, int width)
{
    float *p = realloc(*array, (size_t)rows * (size_t)width * sizeof(float));
    if (!p) return -1;
    memset(p + (size_t)old_rows * width, 0, (size_t)(rows - old_rows) * width * sizeof(float));
    *array = p;
    return 0;
}

int gv_gaussians_reserve(gv_gaussians *g, int capacity)
{
    if (capacity <= g->capacity) return 0;
    if (g->sh_degree < 0 || g->sh_degree > 3)
        return gv_fail("gaussians: SH degree %d is not in 0..3", g->sh_degree);
    int k = gv_sh_coefficient_count(g->sh_degree);
    int old = g->capacity;
    /* Each array keeps its contents if a later one fails, so the set stays usable. */
    if (grow(&g->means, old, capacity, 3) || grow(&g->sh, old, capacity, 3 * k) ||
        grow(&g->opacities, old, capacity, 1) || grow(&g->scales, old, capacity, 3) ||
        grow(&g->rotations, old, capacity, 4)) {
        /* Arrays that did grow are larger than needed; the capacity stays the old one. */
        return gv_fail("gaussians: out of memory for %d Gaussians", capacity);
    }
    g->capacity = capacity;
    return 0;
}

void gv_gaussians_copy_row(gv_gaussians *g, int dst, int src)
{
    size_t w = 3 * (size_t)gv_sh_coefficient_count(g->sh_degree);
    memcpy(g->means + 3 * (size_t)dst, g->means + 3 * (size_t)src, 3 * sizeof(float));
    memcpy(g->sh + w * dst, g->sh + w * src, w * sizeof(float));
    g->opacities[dst] = g->opacities[src];
    memcpy(g->scales + 3 * (size_t)dst, g->scales + 3 * (size_t)src, 3 * sizeof(float));
    memcpy(g->rotations + 4 * (size_t)dst, g->rotations + 4 * (size_t)src, 4 * sizeof(float));
}

void gv_gaussians_zero_rows(gv_gaussians *g, int from, int to)
{
    if (to <= from) return;
    size_t n = (size_t)(to - from), w = 3 * (size_t)gv_sh_coefficient_count(g->sh_degree);
    memset(g->means + 3 * (size_t)from, 0, 3 * n * sizeof(float));
    memset(g->sh + w * from, 0, w * n * sizeof(float));
    memset(g->opacities + from, 0, n * sizeof(float));
    memset(g->scales + 3 * (size_t)from, 0, 3 * n * sizeof(float));
    memset(g->rotations + 4 * (size_t)from, 0, 4 * n * sizeof(float));
}

int gv_gaussians_alloc(gv_gaussians *g, int n, int sh_degree)
{
    memset(g, 0, sizeof *g);
    if (n < 0) return gv_fail("gaussians: negative count %d", n);
    if (sh_degree < 0 || sh_degree > 3)
        return gv_fail("gaussians: SH degree %d is not in 0..3", sh_degree);
    g->sh_degree = sh_degree;
    /* At least one row, so that every array pointer is valid even for an empty set. */
    if (gv_gaussians_reserve(g, n > 0 ? n : 1) != 0) {
        gv_gaussians_free(g);
        return -1;
    }
    g->n = n;
    return 0;
}

void gv_gaussians_free(gv_gaussians *g)
{
    free(g->means);
    free(g->sh);
    free(g->opacities);
    free(g->scales);
    free(g->rotations);
    memset(g, 0, sizeof *g);
}

/* Index of the first non-finite value of array[0 .. count), or -1. */
static long first_non_finite(const float *array, long count)
{
    for (long i = 0; i < count; i++)
        if (!isfinite(array[i])) return i;
    return -1;
}

int gv_gaussians_check_finite(const gv_gaussians *g, const char *what)
{
    int k = gv_sh_coefficient_count(g->sh_degree);
    struct { const char *name; const float *array; int width; } fields[] = {
        {"position", g->means, 3},    {"SH coefficient", g->sh, 3 * k},
        {"opacity", g->opacities, 1}, {"scale", g->scales, 3},
        {"rotation", g->rotations, 4},
    };
    for (int f = 0; f < 5; f++) {
        long bad = first_non_finite(fields[f].array, (long)g->n * fields[f].width);
        if (bad >= 0)
            return gv_fail("%s: Gaussian %ld has a non-finite %s (%g)", what,
                           bad / fields[f].width, fields[f].name, fields[f].array[bad]);
    }
    return 0;
}
