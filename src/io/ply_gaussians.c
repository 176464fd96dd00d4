/* The 3DGS model PLY (docs/reference/gaussian-splatting.md section 18.1): one vertex per Gaussian
 * with x y z, nx ny nz, f_dc_0..2, f_rest_0..(3(K-1)-1) channel-major, opacity, scale_0..2,
 * rot_0..3. The reader finds properties by name; the writer uses the reference names, order and
 * float32 LE. */
#include <errno.h>
#include <limits.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "gaussvid/core/core.h"
#include "gaussvid/io/ply.h"
#include "io/ply_header.h"

enum { MAX_REST = 45 };  /* 3 * (16 - 1): degree 3 */

/* Column (property index in the vertex element) of every value the model needs. */
typedef struct {
    int xyz[3], dc[3], opacity, scale[3], rot[4];
    int n_rest;           /* 0, 9, 24 or 45 */
    int rest[MAX_REST];   /* rest[j] = column of f_rest_j */
} gaussian_columns;

static int find_column(const ply_file *pf, const char *name, int *column)
{
    *column = ply_find_property(&pf->header, pf->element, name);
    if (*column < 0) return gv_fail("%s: vertex has no property '%s'", pf->path, name);
    ply_type t = pf->header.properties[pf->element->first_property + *column].type;
    if (t != PLY_FLOAT && t != PLY_DOUBLE)
        return gv_fail("%s: property '%s' has type %s (expected float or double)", pf->path,
                       name, ply_type_name(t));
    return 0;
}

/* Collects the f_rest_<j> columns by their numeric suffix j; the count gives the degree. */
static int find_rest_columns(const ply_file *pf, gaussian_columns *c)
{
    const ply_property *props = &pf->header.properties[pf->element->first_property];
    for (int j = 0; j < MAX_REST; j++) c->rest[j] = -1;
    c->n_rest = 0;
    for (int i = 0; i < pf->element->n_properties; i++) {
        const char *name = props[i].name;
        if (strncmp(name, "f_rest_", 7)) continue;
        const char *digits = name + 7;
        if (!*digits || strspn(digits, "0123456789") != strlen(digits) || strlen(digits) > 3)
            return gv_fail("%s: property '%s' has no numeric suffix", pf->path, name);
        int j = atoi(digits);
        if (j >= MAX_REST)
            return gv_fail("%s: property '%s': more than %d f_rest properties (SH degree > 3)",
                           pf->path, name, MAX_REST);
        if (c->rest[j] >= 0) return gv_fail("%s: property '%s' repeats f_rest_%d", pf->path, name, j);
        c->rest[j] = i;
        c->n_rest++;
    }
    if (c->n_rest != 0 && c->n_rest != 9 && c->n_rest != 24 && c->n_rest != 45)
        return gv_fail("%s: %d f_rest properties; expected 0, 9, 24 or 45 (SH degree 0..3)",
                       pf->path, c->n_rest);
    for (int j = 0; j < c->n_rest; j++) {
        char name[24];
        snprintf(name, sizeof name, "f_rest_%d", j);
        if (find_column(pf, name, &c->rest[j])) return -1;
    }
    return 0;
}

static int find_columns(const ply_file *pf, gaussian_columns *c)
{
    static const char *xyz[3] = {"x", "y", "z"}, *dc[3] = {"f_dc_0", "f_dc_1", "f_dc_2"};
    static const char *scale[3] = {"scale_0", "scale_1", "scale_2"};
    static const char *rot[4] = {"rot_0", "rot_1", "rot_2", "rot_3"};
    for (int i = 0; i < 3; i++)
        if (find_column(pf, xyz[i], &c->xyz[i]) || find_column(pf, dc[i], &c->dc[i]) ||
            find_column(pf, scale[i], &c->scale[i]))
            return -1;
    for (int i = 0; i < 4; i++)
        if (find_column(pf, rot[i], &c->rot[i])) return -1;
    if (find_column(pf, "opacity", &c->opacity)) return -1;
    return find_rest_columns(pf, c);
}

/* One value of the current row as a float; NaN and infinities are refused. */
static int take(const ply_file *pf, const double *values, int column, float *out)
{
    float v = (float)values[column];
    if (!isfinite(v)) {
        char row[96];
        return gv_fail("%s: %s: property '%s' is not finite (%g)", pf->path,
                       ply_row_name(pf, row, sizeof row),
                       pf->header.properties[pf->element->first_property + column].name,
                       values[column]);
    }
    *out = v;
    return 0;
}

static int read_gaussian(ply_file *pf, const gaussian_columns *c, gv_gaussians *g, int i)
{
    double values[PLY_MAX_PROPERTIES];
    int k_count = gv_sh_coefficient_count(g->sh_degree), rest_per_channel = k_count - 1;
    float *sh = g->sh + (size_t)i * k_count * 3;
    if (ply_read_row(pf, values)) return -1;
    for (int a = 0; a < 3; a++)
        if (take(pf, values, c->xyz[a], &g->means[3 * (size_t)i + a]) ||
            take(pf, values, c->scale[a], &g->scales[3 * (size_t)i + a]) ||
            take(pf, values, c->dc[a], &sh[a]))
            return -1;
    for (int a = 0; a < 4; a++)
        if (take(pf, values, c->rot[a], &g->rotations[4 * (size_t)i + a])) return -1;
    if (take(pf, values, c->opacity, &g->opacities[i])) return -1;
    /* Section 18.1: f_rest_{ch (K-1) + (k-1)} is coefficient k of channel ch; memory is [k][ch]. */
    for (int ch = 0; ch < 3; ch++)
        for (int k = 1; k < k_count; k++)
            if (take(pf, values, c->rest[ch * rest_per_channel + k - 1], &sh[3 * k + ch]))
                return -1;
    return 0;
}

int gv_gaussians_read_ply(const char *path, gv_gaussians *out)
{
    memset(out, 0, sizeof *out);
    ply_file pf;
    gaussian_columns columns;
    if (ply_open(&pf, path) || ply_seek_element(&pf, "vertex") || find_columns(&pf, &columns)) {
        ply_close(&pf);
        return -1;
    }
    int64_t count = pf.element->count;
    int degree = columns.n_rest == 0 ? 0 : columns.n_rest == 9 ? 1 : columns.n_rest == 24 ? 2 : 3;
    if (count > INT_MAX / 48) {
        ply_close(&pf);
        return gv_fail("%s: %lld Gaussians is too many", path, (long long)count);
    }
    /* ply_seek_element checked the count against the file size before this allocation. */
    if (gv_gaussians_alloc(out, (int)count, degree)) {
        ply_close(&pf);
        return gv_fail_context("%s", path);
    }
    for (int i = 0; i < out->n; i++) {
        if (read_gaussian(&pf, &columns, out, i)) {
            ply_close(&pf);
            gv_gaussians_free(out);
            return -1;
        }
    }
    ply_close(&pf);
    return 0;
}

static unsigned char *put_float(unsigned char *p, float v)
{
    uint32_t u;
    memcpy(&u, &v, 4);
    for (int b = 0; b < 4; b++) p[b] = (unsigned char)(u >> (8 * b));  /* little-endian */
    return p + 4;
}

static void write_header(FILE *f, int n, int n_rest)
{
    fprintf(f, "ply\nformat binary_little_endian 1.0\nelement vertex %d\n", n);
    static const char *before[] = {"x", "y", "z", "nx", "ny", "nz", "f_dc_0", "f_dc_1", "f_dc_2"};
    static const char *after[] = {"opacity", "scale_0", "scale_1", "scale_2",
                                  "rot_0", "rot_1", "rot_2", "rot_3"};
    for (int i = 0; i < 9; i++) fprintf(f, "property float %s\n", before[i]);
    for (int j = 0; j < n_rest; j++) fprintf(f, "property float f_rest_%d\n", j);
    for (int i = 0; i < 8; i++) fprintf(f, "property float %s\n", after[i]);
    fprintf(f, "end_header\n");
}

/* One record in the reference order (section 18.1). */
static void pack_gaussian(const gv_gaussians *g, int i, unsigned char *record)
{
    int k_count = gv_sh_coefficient_count(g->sh_degree);
    const float *sh = g->sh + (size_t)i * k_count * 3;
    unsigned char *p = record;
    for (int a = 0; a < 3; a++) p = put_float(p, g->means[3 * (size_t)i + a]);
    for (int a = 0; a < 3; a++) p = put_float(p, 0.0f);  /* nx ny nz */
    for (int ch = 0; ch < 3; ch++) p = put_float(p, sh[ch]);
    for (int ch = 0; ch < 3; ch++)
        for (int k = 1; k < k_count; k++) p = put_float(p, sh[3 * k + ch]);
    p = put_float(p, g->opacities[i]);
    for (int a = 0; a < 3; a++) p = put_float(p, g->scales[3 * (size_t)i + a]);
    for (int a = 0; a < 4; a++) p = put_float(p, g->rotations[4 * (size_t)i + a]);
}

int gv_gaussians_write_ply(const char *path, const gv_gaussians *g)
{
    if (g->sh_degree < 0 || g->sh_degree > 3)
        return gv_fail("%s: SH degree %d is not in 0..3", path, g->sh_degree);
    if (g->n < 0) return gv_fail("%s: negative Gaussian count %d", path, g->n);
    if (gv_gaussians_check_finite(g, path)) return -1;
    int n_rest = 3 * (gv_sh_coefficient_count(g->sh_degree) - 1);
    int record_size = 4 * (17 + n_rest);
    unsigned char record[4 * (17 + MAX_REST)];
    gv_atomic_file af;
    if (gv_atomic_open(&af, path)) return -1;
    write_header(af.f, g->n, n_rest);
    for (int i = 0; i < g->n; i++) {
        pack_gaussian(g, i, record);
        if (fwrite(record, 1, (size_t)record_size, af.f) != (size_t)record_size) {
            int e = errno;
            gv_atomic_abort(&af);
            return gv_fail("%s: write error: %s", path, strerror(e));
        }
    }
    return gv_atomic_commit(&af);
}
