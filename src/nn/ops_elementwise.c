/* Element-wise arithmetic with NumPy broadcasting: add, sub, mul, div, and s*x + c. */
#include "nn/nn_internal.h"

/* Shapes padded on the left to 5 dimensions; a broadcast operand has stride 0 where its
 * size is 1 and the output's is not. */
typedef struct {
    int64_t n[GV_MAX_DIMS];  /* output sizes */
    int64_t sa[GV_MAX_DIMS]; /* strides of a in the output's index space */
    int64_t sb[GV_MAX_DIMS];
} bcast;

static void operand_strides(const gv_tensor *t, const int64_t *n, int64_t *stride)
{
    int64_t s = 1;
    for (int d = GV_MAX_DIMS - 1; d >= 0; d--) {
        int k = d - (GV_MAX_DIMS - t->ndim);
        int size = k >= 0 ? t->shape[k] : 1;
        stride[d] = (size == 1 && n[d] != 1) ? 0 : s;
        s *= size;
    }
}

static void bcast_setup(const gv_tensor *out, bcast *b)
{
    for (int d = 0; d < GV_MAX_DIMS; d++) {
        int k = d - (GV_MAX_DIMS - out->ndim);
        b->n[d] = k >= 0 ? out->shape[k] : 1;
    }
    operand_strides(out->src[0], b->n, b->sa);
    operand_strides(out->src[1], b->n, b->sb);
}

static inline float apply(int op, float a, float b)
{
    switch (op) {
    case GV_OP_ADD: return a + b;
    case GV_OP_SUB: return a - b;
    case GV_OP_MUL: return a * b;
    default: return a / b;
    }
}

/* d out / d a (which = 0) or d out / d b (which = 1), times dy. */
static inline float partial(int op, int which, float dy, float a, float b)
{
    switch (op) {
    case GV_OP_ADD: return dy;
    case GV_OP_SUB: return which ? -dy : dy;
    case GV_OP_MUL: return which ? dy * a : dy * b;
    default: return which ? -dy * a / (b * b) : dy / b;
    }
}

/* out = a (op) b; out [broadcast(a, b)] */
int gv_binary_forward(gv_graph *g, gv_tensor *out)
{
    const gv_tensor *a = out->src[0], *b = out->src[1];
    const float *x = a->data, *y = b->data;
    float *z = out->data;
    int op = out->op;
    if (a->numel == out->numel && b->numel == out->numel) { /* one loop per op: vectorised */
        int64_t n = out->numel;
        switch (op) {
        case GV_OP_ADD:
#pragma omp parallel for simd schedule(static) if (n >= GV_OMP_MIN)
            for (int64_t i = 0; i < n; i++) z[i] = x[i] + y[i];
            break;
        case GV_OP_SUB:
#pragma omp parallel for simd schedule(static) if (n >= GV_OMP_MIN)
            for (int64_t i = 0; i < n; i++) z[i] = x[i] - y[i];
            break;
        case GV_OP_MUL:
#pragma omp parallel for simd schedule(static) if (n >= GV_OMP_MIN)
            for (int64_t i = 0; i < n; i++) z[i] = x[i] * y[i];
            break;
        default:
#pragma omp parallel for simd schedule(static) if (n >= GV_OMP_MIN)
            for (int64_t i = 0; i < n; i++) z[i] = x[i] / y[i];
        }
        return 0;
    }
    bcast s;
    bcast_setup(out, &s);
    int64_t outer = s.n[0] * s.n[1] * s.n[2] * s.n[3], inner = s.n[4];
#pragma omp parallel for schedule(static) if (out->numel >= GV_OMP_MIN)
    for (int64_t o = 0; o < outer; o++) {
        int64_t i3 = o % s.n[3], i2 = o / s.n[3] % s.n[2], i1 = o / (s.n[3] * s.n[2]) % s.n[1];
        int64_t i0 = o / (s.n[3] * s.n[2] * s.n[1]);
        const float *xa = x + i0 * s.sa[0] + i1 * s.sa[1] + i2 * s.sa[2] + i3 * s.sa[3];
        const float *yb = y + i0 * s.sb[0] + i1 * s.sb[1] + i2 * s.sb[2] + i3 * s.sb[3];
        float *zo = z + o * inner;
        for (int64_t i = 0; i < inner; i++) zo[i] = apply(op, xa[i * s.sa[4]], yb[i * s.sb[4]]);
    }
    return 0;
}

/* da += reduce(dy * d out/d a) to a's shape; the same for b. A broadcast operand receives
 * sums over the repeated positions, accumulated in order by one thread. */
static void binary_grad(gv_tensor *out, int which)
{
    const gv_tensor *a = out->src[0], *b = out->src[1];
    const float *x = a->data, *y = b->data, *dy = out->grad;
    float *dx = out->src[which]->grad;
    int op = out->op;
    if (a->numel == out->numel && b->numel == out->numel) {
#pragma omp parallel for simd schedule(static) if (out->numel >= GV_OMP_MIN)
        for (int64_t i = 0; i < out->numel; i++) dx[i] += partial(op, which, dy[i], x[i], y[i]);
        return;
    }
    bcast s;
    bcast_setup(out, &s);
    const int64_t *st = which ? s.sb : s.sa;
    int64_t outer = s.n[0] * s.n[1] * s.n[2] * s.n[3], inner = s.n[4];
    int full = out->src[which]->numel == out->numel; /* no two positions share a target */
#pragma omp parallel for schedule(static) if (full && out->numel >= GV_OMP_MIN)
    for (int64_t o = 0; o < outer; o++) {
        int64_t i3 = o % s.n[3], i2 = o / s.n[3] % s.n[2], i1 = o / (s.n[3] * s.n[2]) % s.n[1];
        int64_t i0 = o / (s.n[3] * s.n[2] * s.n[1]);
        const float *xa = x + i0 * s.sa[0] + i1 * s.sa[1] + i2 * s.sa[2] + i3 * s.sa[3];
        const float *yb = y + i0 * s.sb[0] + i1 * s.sb[1] + i2 * s.sb[2] + i3 * s.sb[3];
        float *d = dx + i0 * st[0] + i1 * st[1] + i2 * st[2] + i3 * st[3];
        const float *g = dy + o * inner;
        for (int64_t i = 0; i < inner; i++)
            d[i * st[4]] += partial(op, which, g[i], xa[i * s.sa[4]], yb[i * s.sb[4]]);
    }
}

int gv_binary_backward(gv_graph *g, gv_tensor *out)
{
    if (gv_wants_grad(out, 0)) binary_grad(out, 0);
    if (gv_wants_grad(out, 1)) binary_grad(out, 1);
    return 0;
}

static gv_tensor *binary(gv_graph *g, gv_op op, gv_tensor *a, gv_tensor *b)
{
    if (!a || !b) return NULL;
    int ndim = a->ndim > b->ndim ? a->ndim : b->ndim;
    int shape[GV_MAX_DIMS];
    for (int d = 0; d < ndim; d++) {
        int ka = d - (ndim - a->ndim), kb = d - (ndim - b->ndim);
        int na = ka >= 0 ? a->shape[ka] : 1, nb = kb >= 0 ? b->shape[kb] : 1;
        if (na != nb && na != 1 && nb != 1) {
            char sa[64], sb[64];
            gv_fail("%s: shapes %s and %s do not broadcast", gv_op_name(op),
                    gv_shape_str(a, sa, sizeof sa), gv_shape_str(b, sb, sizeof sb));
            return NULL;
        }
        shape[d] = na > nb ? na : nb;
    }
    gv_tensor *src[2] = {a, b};
    return gv_op_run(g, gv_op_new(g, op, ndim, shape, 2, src, 0));
}

gv_tensor *gv_add(gv_graph *g, gv_tensor *a, gv_tensor *b) { return binary(g, GV_OP_ADD, a, b); }
gv_tensor *gv_sub(gv_graph *g, gv_tensor *a, gv_tensor *b) { return binary(g, GV_OP_SUB, a, b); }
gv_tensor *gv_mul(gv_graph *g, gv_tensor *a, gv_tensor *b) { return binary(g, GV_OP_MUL, a, b); }
gv_tensor *gv_div(gv_graph *g, gv_tensor *a, gv_tensor *b) { return binary(g, GV_OP_DIV, a, b); }

/* out = s * x + c; out [x]; fparam = {s, c} */
int gv_affine_op_forward(gv_graph *g, gv_tensor *out)
{
    const float *x = out->src[0]->data;
    float s = out->fparam[0], c = out->fparam[1];
#pragma omp parallel for simd schedule(static) if (out->numel >= GV_OMP_MIN)
    for (int64_t i = 0; i < out->numel; i++) out->data[i] = s * x[i] + c;
    return 0;
}

int gv_affine_op_backward(gv_graph *g, gv_tensor *out)
{
    float *dx = out->src[0]->grad, s = out->fparam[0];
#pragma omp parallel for simd schedule(static) if (out->numel >= GV_OMP_MIN)
    for (int64_t i = 0; i < out->numel; i++) dx[i] += s * out->grad[i];
    return 0;
}

gv_tensor *gv_affine(gv_graph *g, gv_tensor *x, float s, float c)
{
    if (!x) return NULL;
    gv_tensor *out = gv_op_new(g, GV_OP_AFFINE, x->ndim, x->shape, 1, &x, 0);
    if (!out) return NULL;
    out->fparam[0] = s;
    out->fparam[1] = c;
    return gv_op_run(g, out);
}

gv_tensor *gv_scale(gv_graph *g, gv_tensor *x, float s) { return gv_affine(g, x, s, 0.0f); }
