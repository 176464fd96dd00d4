/* Sum and mean over one axis, or over everything. Accumulation is in double, in an order
 * that does not depend on the thread count. */
#include <stdlib.h>

#include "nn/nn_internal.h"

#define SUM_CHUNK 4096

/* Viewing x as [outer, K, inner] around the reduced axis. */
static void reduce_dims(const gv_tensor *x, int axis, int64_t *outer, int64_t *k, int64_t *inner)
{
    *outer = *inner = 1;
    for (int d = 0; d < axis; d++) *outer *= x->shape[d];
    *k = x->shape[axis];
    for (int d = axis + 1; d < x->ndim; d++) *inner *= x->shape[d];
}

/* Sum of n floats in fixed chunks (parallel), the chunk sums added in order. */
static double sum_all(const float *x, int64_t n)
{
    int64_t n_chunks = (n + SUM_CHUNK - 1) / SUM_CHUNK;
    if (n_chunks <= 1) {
        double s = 0;
        for (int64_t i = 0; i < n; i++) s += x[i];
        return s;
    }
    double *partial = malloc((size_t)n_chunks * sizeof *partial);
    if (!partial) { /* fall back to one thread */
        double s = 0;
        for (int64_t i = 0; i < n; i++) s += x[i];
        return s;
    }
#pragma omp parallel for schedule(static) if (n >= GV_OMP_MIN)
    for (int64_t c = 0; c < n_chunks; c++) {
        int64_t end = (c + 1) * SUM_CHUNK < n ? (c + 1) * SUM_CHUNK : n;
        double s = 0;
        for (int64_t i = c * SUM_CHUNK; i < end; i++) s += x[i];
        partial[c] = s;
    }
    double s = 0;
    for (int64_t c = 0; c < n_chunks; c++) s += partial[c];
    free(partial);
    return s;
}

/* out[o, 0, i] = scale * sum_k x[o, k, i]; x [outer, K, inner], out [outer, 1, inner];
 * iparam[0] = axis, fparam[0] = scale (1, or 1/K for a mean) */
int gv_sum_op_forward(gv_graph *g, gv_tensor *out)
{
    const gv_tensor *x = out->src[0];
    int64_t outer, k, inner;
    reduce_dims(x, out->iparam[0], &outer, &k, &inner);
    double scale = out->fparam[0];
    if (outer * inner == 1) {
        out->data[0] = (float)(scale * sum_all(x->data, k));
        return 0;
    }
#pragma omp parallel for schedule(static) if (x->numel >= GV_OMP_MIN)
    for (int64_t oi = 0; oi < outer * inner; oi++) {
        int64_t o = oi / inner, i = oi % inner;
        const float *p = x->data + o * k * inner + i;
        double s = 0;
        for (int64_t j = 0; j < k; j++) s += p[j * inner];
        out->data[oi] = (float)(scale * s);
    }
    return 0;
}

/* dx[o, k, i] += scale * dout[o, 0, i] */
int gv_sum_op_backward(gv_graph *g, gv_tensor *out)
{
    gv_tensor *x = out->src[0];
    int64_t outer, k, inner;
    reduce_dims(x, out->iparam[0], &outer, &k, &inner);
    float scale = out->fparam[0];
#pragma omp parallel for schedule(static) if (x->numel >= GV_OMP_MIN)
    for (int64_t ok = 0; ok < outer * k; ok++) {
        int64_t o = ok / k;
        float *dx = x->grad + ok * inner;
        const float *dy = out->grad + o * inner;
        for (int64_t i = 0; i < inner; i++) dx[i] += scale * dy[i];
    }
    return 0;
}

static gv_tensor *reduce(gv_graph *g, gv_tensor *x, int axis, int keepdim, int mean)
{
    if (!x) return NULL;
    int a = axis < 0 ? axis + x->ndim : axis;
    if (a < 0 || a >= x->ndim) {
        gv_fail("sum: axis %d out of range for %d dimensions", axis, x->ndim);
        return NULL;
    }
    int shape[GV_MAX_DIMS];
    for (int d = 0; d < x->ndim; d++) shape[d] = d == a ? 1 : x->shape[d];
    gv_tensor *out = gv_op_new(g, GV_OP_SUM, x->ndim, shape, 1, &x, 0);
    if (!out) return NULL;
    out->iparam[0] = a;
    out->fparam[0] = mean ? 1.0f / (float)x->shape[a] : 1.0f;
    out = gv_op_run(g, out);
    if (!out || keepdim || x->ndim == 1) return out;
    int kept[GV_MAX_DIMS], n = 0;
    for (int d = 0; d < x->ndim; d++)
        if (d != a) kept[n++] = x->shape[d];
    return gv_reshape(g, out, n, kept);
}

gv_tensor *gv_sum(gv_graph *g, gv_tensor *x, int axis, int keepdim)
{
    return reduce(g, x, axis, keepdim, 0);
}

gv_tensor *gv_mean(gv_graph *g, gv_tensor *x, int axis, int keepdim)
{
    return reduce(g, x, axis, keepdim, 1);
}

static gv_tensor *reduce_all(gv_graph *g, gv_tensor *x, int mean)
{
    if (!x) return NULL;
    int n = (int)(x->numel > INT32_MAX ? -1 : x->numel);
    if (n < 0) {
        gv_fail("sum: more than 2^31 elements");
        return NULL;
    }
    return reduce(g, gv_reshape(g, x, 1, &n), 0, 1, mean);
}

gv_tensor *gv_sum_all(gv_graph *g, gv_tensor *x) { return reduce_all(g, x, 0); }
gv_tensor *gv_mean_all(gv_graph *g, gv_tensor *x) { return reduce_all(g, x, 1); }
