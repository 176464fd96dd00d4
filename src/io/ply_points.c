/* Coloured point clouds in PLY: the vertex element's x, y, z and (optionally) red, green,
 * blue, as in COLMAP/3DGS points3D.ply. Any other property (nx, ny, nz, ...) is ignored. */
#include <limits.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "gaussvid/core/core.h"
#include "gaussvid/io/ply.h"
#include "io/ply_header.h"

/* A colour value as a byte: uchar as is; float and double in [0, 1], scaled and rounded. */
static uint8_t colour_byte(double v, ply_type t)
{
    if (t == PLY_UCHAR) return (uint8_t)v;
    double scaled = v * 255.0 + 0.5;
    return scaled <= 0 ? 0 : scaled >= 255 ? 255 : (uint8_t)scaled;
}

/* Finds x, y, z (any numeric type) and red, green, blue (all three or none; uchar, float or
 * double). colour[0] = -1 when there is no colour. */
static int find_point_properties(const ply_file *pf, int position[3], int colour[3])
{
    static const char *axes[3] = {"x", "y", "z"}, *channels[3] = {"red", "green", "blue"};
    const ply_header *h = &pf->header;
    int found = 0;
    for (int i = 0; i < 3; i++) {
        position[i] = ply_find_property(h, pf->element, axes[i]);
        if (position[i] < 0) return gv_fail("%s: vertex has no property '%s'", pf->path, axes[i]);
        colour[i] = ply_find_property(h, pf->element, channels[i]);
        found += colour[i] >= 0;
    }
    if (found != 0 && found != 3)
        return gv_fail("%s: vertex has %d of the colour properties red, green, blue", pf->path,
                       found);
    for (int i = 0; i < 3 && found; i++) {
        ply_type t = h->properties[pf->element->first_property + colour[i]].type;
        if (t != PLY_UCHAR && t != PLY_FLOAT && t != PLY_DOUBLE)
            return gv_fail("%s: colour property '%s' has type %s (expected uchar, float or double)",
                           pf->path, channels[i], ply_type_name(t));
    }
    return 0;
}

static int read_points(ply_file *pf, int n, float *xyz, uint8_t *rgb)
{
    int position[3], colour[3];
    double values[PLY_MAX_PROPERTIES];
    char row[96];
    if (find_point_properties(pf, position, colour)) return -1;
    const ply_property *props = &pf->header.properties[pf->element->first_property];
    for (int i = 0; i < n; i++) {
        if (ply_read_row(pf, values)) return -1;
        for (int a = 0; a < 3; a++) {
            xyz[3 * i + a] = (float)values[position[a]];
            if (!isfinite(xyz[3 * i + a]))
                return gv_fail("%s: %s: property '%s' is not finite (%g)", pf->path,
                               ply_row_name(pf, row, sizeof row), props[position[a]].name,
                               values[position[a]]);
        }
        for (int c = 0; c < 3; c++) {
            if (colour[0] < 0) { rgb[3 * i + c] = 128; continue; }
            double v = values[colour[c]];
            if (isnan(v))
                return gv_fail("%s: %s: property '%s' is nan", pf->path,
                               ply_row_name(pf, row, sizeof row), props[colour[c]].name);
            rgb[3 * i + c] = colour_byte(v, props[colour[c]].type);
        }
    }
    return 0;
}

int gv_points_read_ply(const char *path, int *n, float **xyz, uint8_t **rgb)
{
    *n = 0;
    *xyz = NULL;
    *rgb = NULL;
    ply_file pf;
    if (ply_open(&pf, path) || ply_seek_element(&pf, "vertex")) {
        ply_close(&pf);
        return -1;
    }
    int64_t count = pf.element->count;
    if (count > INT_MAX / 3) {
        ply_close(&pf);
        return gv_fail("%s: %lld vertices is too many", path, (long long)count);
    }
    /* The count was checked against the file size by ply_seek_element. */
    size_t rows = count > 0 ? (size_t)count : 1;
    float *points = malloc(rows * 3 * sizeof(float));
    uint8_t *colours = malloc(rows * 3);
    if (!points || !colours) {
        gv_fail("%s: out of memory for %lld points", path, (long long)count);
    } else if (read_points(&pf, (int)count, points, colours) == 0) {
        ply_close(&pf);
        *n = (int)count;
        *xyz = points;
        *rgb = colours;
        return 0;
    }
    ply_close(&pf);
    free(points);
    free(colours);
    return -1;
}

/* The shortest %g text that reads back as exactly v (at most 9 digits always do). */
static void format_float(char *out, size_t size, float v)
{
    for (int digits = 6; digits <= 9; digits++) {
        snprintf(out, size, "%.*g", digits, (double)v);
        if (strtof(out, NULL) == v) return;
    }
}

int gv_points_write_ply(const char *path, int n, const float *xyz, const uint8_t *rgb)
{
    if (n < 0) return gv_fail("%s: negative point count %d", path, n);
    for (long i = 0; i < 3L * n; i++)
        if (!isfinite(xyz[i]))
            return gv_fail("%s: point %ld has a non-finite coordinate (%g)", path, i / 3,
                           (double)xyz[i]);
    gv_atomic_file af;
    if (gv_atomic_open(&af, path)) return -1;
    fprintf(af.f, "ply\nformat ascii 1.0\nelement vertex %d\n"
                  "property float x\nproperty float y\nproperty float z\n", n);
    if (rgb) fprintf(af.f, "property uchar red\nproperty uchar green\nproperty uchar blue\n");
    fprintf(af.f, "end_header\n");
    for (int i = 0; i < n; i++) {
        char x[32], y[32], z[32];
        format_float(x, sizeof x, xyz[3 * i]);
        format_float(y, sizeof y, xyz[3 * i + 1]);
        format_float(z, sizeof z, xyz[3 * i + 2]);
        if (rgb)
            fprintf(af.f, "%s %s %s %d %d %d\n", x, y, z, rgb[3 * i], rgb[3 * i + 1], rgb[3 * i + 2]);
        else
            fprintf(af.f, "%s %s %s\n", x, y, z);
    }
    return gv_atomic_commit(&af);
}
