/* Shape operations: reshape (a view), permute, concat, slice and repeat (copies). */
#include "nn/nn_internal.h"

/* x viewed as [outer, x.shape[axis], inner]. */
static void split_at(const gv_tensor *x, int axis, int64_t *outer, int64_t *inner)
{
    *outer = *inner = 1;
    for (int d = 0; d < axis; d++) *outer *= x->shape[d];
    for (int d = axis + 1; d < x->ndim; d++) *inner *= x->shape[d];
}

static int resolve_axis(const char *op, const gv_tensor *x, int axis)
{
    int a = axis < 0 ? axis + x->ndim : axis;
    if (a < 0 || a >= x->ndim)
        return gv_fail("%s: axis %d out of range for %d dimensions", op, axis, x->ndim);
    return a;
}

/* ---- reshape: out [shape] shares x's data; dx += dout ------------------------------------- */
int gv_reshape_op_forward(gv_graph *g, gv_tensor *out) { return 0; }

int gv_reshape_op_backward(gv_graph *g, gv_tensor *out)
{
    float *dx = out->src[0]->grad;
#pragma omp parallel for simd schedule(static) if (out->numel >= GV_OMP_MIN)
    for (int64_t i = 0; i < out->numel; i++) dx[i] += out->grad[i];
    return 0;
}

gv_tensor *gv_reshape(gv_graph *g, gv_tensor *x, int ndim, const int *shape)
{
    if (!x) return NULL;
    char buf[64];
    if (ndim < 1 || ndim > GV_MAX_DIMS) {
        gv_fail("reshape: %d dimensions (1 to %d allowed)", ndim, GV_MAX_DIMS);
        return NULL;
    }
    int s[GV_MAX_DIMS], infer = -1;
    int64_t known = 1;
    for (int d = 0; d < ndim; d++) {
        s[d] = shape[d];
        if (s[d] == -1 && infer < 0) infer = d;
        else if (s[d] < 1) {
            gv_fail("reshape: bad size %d in dimension %d", s[d], d);
            return NULL;
        } else known *= s[d];
    }
    if (infer >= 0) {
        if (x->numel % known) {
            gv_fail("reshape: %s does not split into blocks of %lld",
                    gv_shape_str(x, buf, sizeof buf), (long long)known);
            return NULL;
        }
        s[infer] = (int)(x->numel / known);
        known *= s[infer];
    }
    if (known != x->numel) {
        gv_fail("reshape: %s has %lld elements, the new shape %lld",
                gv_shape_str(x, buf, sizeof buf), (long long)x->numel, (long long)known);
        return NULL;
    }
    return gv_op_run(g, gv_op_new_view(g, GV_OP_RESHAPE, ndim, s, x));
}

/* ---- permute: out[i_0..i_n] = x[i at positions perm]; iparam[0..4] = perm ---------------- */
/* Output sizes padded to 5 dimensions, and the stride in x of each output axis. */
static void permute_strides(const gv_tensor *out, int64_t n[GV_MAX_DIMS], int64_t sx[GV_MAX_DIMS])
{
    const gv_tensor *x = out->src[0];
    int64_t xstride[GV_MAX_DIMS], s = 1;
    for (int d = x->ndim - 1; d >= 0; d--) xstride[d] = s, s *= x->shape[d];
    int pad = GV_MAX_DIMS - out->ndim;
    for (int d = 0; d < GV_MAX_DIMS; d++) {
        n[d] = d < pad ? 1 : out->shape[d - pad];
        sx[d] = d < pad ? 0 : xstride[out->iparam[d - pad]];
    }
}

static void permute_copy(gv_tensor *out, int backward)
{
    int64_t n[GV_MAX_DIMS], sx[GV_MAX_DIMS];
    permute_strides(out, n, sx);
    int64_t outer = n[0] * n[1] * n[2] * n[3], inner = n[4];
    const float *src = backward ? out->grad : out->src[0]->data;
    float *dx = out->src[0]->grad, *y = out->data;
#pragma omp parallel for schedule(static) if (out->numel >= GV_OMP_MIN)
    for (int64_t o = 0; o < outer; o++) {
        int64_t i3 = o % n[3], i2 = o / n[3] % n[2], i1 = o / (n[3] * n[2]) % n[1];
        int64_t i0 = o / (n[3] * n[2] * n[1]);
        int64_t base = i0 * sx[0] + i1 * sx[1] + i2 * sx[2] + i3 * sx[3];
        if (backward) /* a permutation: no two outputs share an input, so no races */
            for (int64_t i = 0; i < inner; i++) dx[base + i * sx[4]] += src[o * inner + i];
        else
            for (int64_t i = 0; i < inner; i++) y[o * inner + i] = src[base + i * sx[4]];
    }
}

int gv_permute_op_forward(gv_graph *g, gv_tensor *out)
{
    permute_copy(out, 0);
    return 0;
}

int gv_permute_op_backward(gv_graph *g, gv_tensor *out)
{
    permute_copy(out, 1);
    return 0;
}

gv_tensor *gv_permute(gv_graph *g, gv_tensor *x, const int *perm)
{
    if (!x) return NULL;
    int seen[GV_MAX_DIMS] = {0}, shape[GV_MAX_DIMS];
    for (int d = 0; d < x->ndim; d++) {
        if (perm[d] < 0 || perm[d] >= x->ndim || seen[perm[d]]++) {
            gv_fail("permute: the order is not a permutation of %d axes", x->ndim);
            return NULL;
        }
        shape[d] = x->shape[perm[d]];
    }
    gv_tensor *out = gv_op_new(g, GV_OP_PERMUTE, x->ndim, shape, 1, &x, 0);
    if (!out) return NULL;
    for (int d = 0; d < x->ndim; d++) out->iparam[d] = perm[d];
    return gv_op_run(g, out);
}

gv_tensor *gv_transpose(gv_graph *g, gv_tensor *x, int axis_a, int axis_b)
{
    if (!x) return NULL;
    int a = resolve_axis("transpose", x, axis_a), b = resolve_axis("transpose", x, axis_b);
    if (a < 0 || b < 0) return NULL;
    int perm[GV_MAX_DIMS];
    for (int d = 0; d < x->ndim; d++) perm[d] = d;
    perm[a] = b;
    perm[b] = a;
    return gv_permute(g, x, perm);
}

/* ---- concat: out [.., sum L_i, ..] = [x_0 | x_1 | ...] along iparam[0] --------------------- */
static void concat_copy(gv_tensor *out, int backward)
{
    int axis = out->iparam[0];
    int64_t outer, inner;
    split_at(out, axis, &outer, &inner);
    int64_t row = out->shape[axis] * inner, offset = 0;
    for (int s = 0; s < out->n_src; s++) {
        gv_tensor *x = out->src[s];
        int64_t len = x->shape[axis] * inner;
        if (!backward || (x->requires_grad && x->grad)) {
#pragma omp parallel for schedule(static) if (outer * len >= GV_OMP_MIN)
            for (int64_t o = 0; o < outer; o++) {
                if (backward)
                    for (int64_t i = 0; i < len; i++) x->grad[o * len + i] += out->grad[o * row + offset + i];
                else
                    memcpy(out->data + o * row + offset, x->data + o * len, (size_t)len * sizeof(float));
            }
        }
        offset += len;
    }
}

int gv_concat_op_forward(gv_graph *g, gv_tensor *out)
{
    concat_copy(out, 0);
    return 0;
}

int gv_concat_op_backward(gv_graph *g, gv_tensor *out)
{
    concat_copy(out, 1);
    return 0;
}

gv_tensor *gv_concat(gv_graph *g, gv_tensor **xs, int n, int axis)
{
    if (n < 1) {
        gv_fail("concat: no inputs");
        return NULL;
    }
    for (int i = 0; i < n; i++)
        if (!xs[i]) return NULL;
    int a = resolve_axis("concat", xs[0], axis);
    if (a < 0) return NULL;
    int shape[GV_MAX_DIMS];
    for (int d = 0; d < xs[0]->ndim; d++) shape[d] = xs[0]->shape[d];
    for (int i = 1; i < n; i++) {
        int ok = xs[i]->ndim == xs[0]->ndim;
        for (int d = 0; ok && d < xs[0]->ndim; d++)
            if (d != a && xs[i]->shape[d] != xs[0]->shape[d]) ok = 0;
        if (!ok) {
            char s0[64], si[64];
            gv_fail("concat: input %d has shape %s, input 0 %s (only axis %d may differ)", i,
                    gv_shape_str(xs[i], si, sizeof si), gv_shape_str(xs[0], s0, sizeof s0), a);
            return NULL;
        }
        shape[a] += xs[i]->shape[a];
    }
    gv_tensor *out = gv_op_new(g, GV_OP_CONCAT, xs[0]->ndim, shape, n, xs, 0);
    if (!out) return NULL;
    out->iparam[0] = a;
    return gv_op_run(g, out);
}

/* ---- slice: out [.., len, ..] = x[.., start:start+len, ..]; iparam = {axis, start} -------- */
static void slice_copy(gv_tensor *out, int backward)
{
    gv_tensor *x = out->src[0];
    int axis = out->iparam[0];
    int64_t outer, inner;
    split_at(x, axis, &outer, &inner);
    int64_t row = x->shape[axis] * inner, len = out->shape[axis] * inner;
    int64_t offset = out->iparam[1] * inner;
#pragma omp parallel for schedule(static) if (outer * len >= GV_OMP_MIN)
    for (int64_t o = 0; o < outer; o++) {
        if (backward)
            for (int64_t i = 0; i < len; i++) x->grad[o * row + offset + i] += out->grad[o * len + i];
        else
            memcpy(out->data + o * len, x->data + o * row + offset, (size_t)len * sizeof(float));
    }
}

int gv_slice_op_forward(gv_graph *g, gv_tensor *out)
{
    slice_copy(out, 0);
    return 0;
}

int gv_slice_op_backward(gv_graph *g, gv_tensor *out)
{
    slice_copy(out, 1);
    return 0;
}

gv_tensor *gv_slice(gv_graph *g, gv_tensor *x, int axis, int start, int len)
{
    if (!x) return NULL;
    int a = resolve_axis("slice", x, axis);
    if (a < 0) return NULL;
    if (start < 0 || len < 1 || start > x->shape[a] - len) {
        gv_fail("slice: [%d, %d) is not inside axis %d of size %d", start, start + len, a,
                x->shape[a]);
        return NULL;
    }
    int shape[GV_MAX_DIMS];
    for (int d = 0; d < x->ndim; d++) shape[d] = d == a ? len : x->shape[d];
    gv_tensor *out = gv_op_new(g, GV_OP_SLICE, x->ndim, shape, 1, &x, 0);
    if (!out) return NULL;
    out->iparam[0] = a;
    out->iparam[1] = start;
    return gv_op_run(g, out);
}

/* ---- repeat: out [.., times*L, ..], out[o, r*L + l, i] = x[o, l, i]; iparam = {axis, times} */
int gv_repeat_op_forward(gv_graph *g, gv_tensor *out)
{
    gv_tensor *x = out->src[0];
    int64_t outer, inner;
    split_at(x, out->iparam[0], &outer, &inner);
    int64_t len = x->shape[out->iparam[0]] * inner, times = out->iparam[1];
#pragma omp parallel for schedule(static) if (out->numel >= GV_OMP_MIN)
    for (int64_t o = 0; o < outer; o++)
        for (int64_t r = 0; r < times; r++)
            memcpy(out->data + (o * times + r) * len, x->data + o * len, (size_t)len * sizeof(float));
    return 0;
}

int gv_repeat_op_backward(gv_graph *g, gv_tensor *out)
{
    gv_tensor *x = out->src[0];
    int64_t outer, inner;
    split_at(x, out->iparam[0], &outer, &inner);
    int64_t len = x->shape[out->iparam[0]] * inner, times = out->iparam[1];
#pragma omp parallel for schedule(static) if (out->numel >= GV_OMP_MIN)
    for (int64_t o = 0; o < outer; o++)
        for (int64_t r = 0; r < times; r++)
            for (int64_t i = 0; i < len; i++)
                x->grad[o * len + i] += out->grad[(o * times + r) * len + i];
    return 0;
}

gv_tensor *gv_repeat(gv_graph *g, gv_tensor *x, int axis, int times)
{
    if (!x) return NULL;
    int a = resolve_axis("repeat", x, axis);
    if (a < 0) return NULL;
    if (times < 1 || (int64_t)times * x->shape[a] > INT32_MAX) {
        gv_fail("repeat: bad count %d", times);
        return NULL;
    }
    int shape[GV_MAX_DIMS];
    for (int d = 0; d < x->ndim; d++) shape[d] = d == a ? times * x->shape[a] : x->shape[d];
    gv_tensor *out = gv_op_new(g, GV_OP_REPEAT, x->ndim, shape, 1, &x, 0);
    if (!out) return NULL;
    out->iparam[0] = a;
    out->iparam[1] = times;
    return gv_op_run(g, out);
}
