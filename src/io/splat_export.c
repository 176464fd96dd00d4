/* The antimatter15 .splat format (docs/reference/gaussian-splatting.md section 18.3): 32 bytes per
 * Gaussian, no header, little-endian, sorted by descending exp(s0 + s1 + s2) * sigmoid(opacity).
 * Only the DC term of the colour survives; higher SH coefficients are dropped. */
#include <errno.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "gaussvid/core/core.h"
#include "gaussvid/io/ply.h"

#define SH_C0 0.28209479177387814  /* docs/reference/gaussian-splatting.md section 8: the degree-0
                                      SH basis constant */

typedef struct {
    double log_weight;  /* log(volume x opacity), which orders like it without overflow */
    int index;
} splat_order;

static int heavier_first(const void *a, const void *b)
{
    const splat_order *x = a, *y = b;
    if (x->log_weight != y->log_weight) return x->log_weight > y->log_weight ? -1 : 1;
    return x->index - y->index;  /* ties keep the model's order, so the output is deterministic */
}

static double sigmoid(double x)
{
    return 1.0 / (1.0 + exp(-x));
}

/* log(1 + e^x), without overflow for large x. */
static double softplus(double x)
{
    return x > 0 ? x + log1p(exp(-x)) : log1p(exp(x));
}

/* clip(v, 0, 255) then truncated to a byte, as numpy's astype(uint8) after clip does. */
static unsigned char to_byte(double v)
{
    return v <= 0 ? 0 : v >= 255 ? 255 : (unsigned char)v;
}

static void put_float(unsigned char *p, float v)
{
    uint32_t u;
    memcpy(&u, &v, 4);
    for (int b = 0; b < 4; b++) p[b] = (unsigned char)(u >> (8 * b));
}

/* The 32-byte record of Gaussian i. */
static void pack_splat(const gv_gaussians *g, int i, unsigned char record[32])
{
    int k_count = gv_sh_coefficient_count(g->sh_degree);
    const float *dc = g->sh + (size_t)i * k_count * 3;
    const float *q = g->rotations + 4 * (size_t)i;
    for (int a = 0; a < 3; a++) {
        put_float(record + 4 * a, g->means[3 * (size_t)i + a]);
        put_float(record + 12 + 4 * a, (float)exp(g->scales[3 * (size_t)i + a]));
        record[24 + a] = to_byte((0.5 + SH_C0 * dc[a]) * 255.0);
    }
    record[27] = to_byte(sigmoid(g->opacities[i]) * 255.0);
    double norm = sqrt((double)q[0] * q[0] + (double)q[1] * q[1] + (double)q[2] * q[2] +
                       (double)q[3] * q[3]);
    for (int a = 0; a < 4; a++) {
        /* A zero quaternion has no rotation to normalise: write the identity (1, 0, 0, 0). */
        double unit = norm > 0 ? q[a] / norm : (a == 0 ? 1.0 : 0.0);
        record[28 + a] = to_byte(unit * 128.0 + 128.0);
    }
}

int gv_gaussians_write_splat(const char *path, const gv_gaussians *g)
{
    if (g->sh_degree < 0 || g->sh_degree > 3)
        return gv_fail("%s: SH degree %d is not in 0..3", path, g->sh_degree);
    if (g->n < 0) return gv_fail("%s: negative Gaussian count %d", path, g->n);
    if (gv_gaussians_check_finite(g, path)) return -1;
    splat_order *order = malloc(sizeof *order * (size_t)(g->n > 0 ? g->n : 1));
    if (!order) return gv_fail("%s: out of memory for %d Gaussians", path, g->n);
    for (int i = 0; i < g->n; i++) {
        const float *s = g->scales + 3 * (size_t)i;
        /* log(exp(s0 + s1 + s2) sigmoid(o)) = s0 + s1 + s2 - softplus(-o) */
        order[i].log_weight = (double)s[0] + s[1] + s[2] - softplus(-(double)g->opacities[i]);
        order[i].index = i;
    }
    qsort(order, (size_t)g->n, sizeof *order, heavier_first);
    gv_atomic_file af;
    if (gv_atomic_open(&af, path)) {
        free(order);
        return -1;
    }
    for (int i = 0; i < g->n; i++) {
        unsigned char record[32];
        pack_splat(g, order[i].index, record);
        if (fwrite(record, 1, 32, af.f) != 32) {
            int e = errno;
            gv_atomic_abort(&af);
            free(order);
            return gv_fail("%s: write error: %s", path, strerror(e));
        }
    }
    free(order);
    return gv_atomic_commit(&af);
}
