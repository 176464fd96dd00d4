/* The tape: op outputs are created here, recorded when they need a gradient, and walked in
 * reverse by gv_backward, which gives every input its gradient buffer just before the op that
 * feeds it is differentiated. */
#include <stdlib.h>

#include "nn/nn_internal.h"

_Static_assert(GV_OP_COUNT <= 64, "gv_graph.op_seconds has room for 64 ops");

const char *gv_op_name(int op)
{
    if (op < 0 || op >= GV_OP_COUNT) return "unknown";
    return gv_op_table[op].name;
}

int gv_check_blas_dims(const char *op, int64_t a, int64_t b, int64_t c)
{
    if (a > INT32_MAX || b > INT32_MAX || c > INT32_MAX)
        return gv_fail("%s: a matrix dimension exceeds 2^31", op);
    return 0;
}

static gv_tensor *new_node(gv_graph *g, gv_op op, int ndim, const int *shape, int n_src,
                           gv_tensor *const *src)
{
    for (int i = 0; i < n_src; i++)
        if (!src[i]) return NULL; /* an earlier op failed: keep its message */
    for (int i = 0; i < n_src; i++)
        if (!src[i]->data && !(op == GV_OP_LINEAR && i == 1)) { /* bf16 weights: linear layers only */
            gv_fail("%s: input %s has no float32 values (a bfloat16 weight takes a linear layer only)", gv_op_name(op),
                    src[i]->name ? src[i]->name : "tensor");
            return NULL;
        }
    if (ndim < 1 || ndim > GV_MAX_DIMS) {
        gv_fail("%s: output would have %d dimensions (1 to %d allowed)", gv_op_name(op), ndim,
                GV_MAX_DIMS);
        return NULL;
    }
    int64_t numel = 1;
    for (int i = 0; i < ndim; i++) {
        if (shape[i] < 1) {
            gv_fail("%s: output dimension %d would have size %d", gv_op_name(op), i, shape[i]);
            return NULL;
        }
        numel *= shape[i];
    }
    gv_tensor *t = gv_arena_calloc(&g->arena, sizeof *t);
    gv_tensor **srcs = gv_arena_alloc(&g->arena, (size_t)(n_src ? n_src : 1) * sizeof *srcs);
    if (!t || !srcs) return NULL;
    t->ndim = ndim;
    for (int i = 0; i < ndim; i++) t->shape[i] = shape[i];
    t->numel = numel;
    t->op = op;
    t->n_src = n_src;
    t->src = srcs;
    for (int i = 0; i < n_src; i++) {
        srcs[i] = src[i];
        if (src[i]->requires_grad && g->grad_enabled) t->requires_grad = 1;
    }
    return t;
}

gv_tensor *gv_op_new(gv_graph *g, gv_op op, int ndim, const int *shape, int n_src,
                     gv_tensor *const *src, int zero)
{
    gv_tensor *t = new_node(g, op, ndim, shape, n_src, src);
    if (!t) return NULL;
    size_t bytes = (size_t)t->numel * sizeof(float);
    t->data = zero ? gv_arena_calloc(&g->arena, bytes) : gv_arena_alloc(&g->arena, bytes);
    return t->data ? t : NULL;
}

gv_tensor *gv_op_new_view(gv_graph *g, gv_op op, int ndim, const int *shape, gv_tensor *view_of)
{
    gv_tensor *t = new_node(g, op, ndim, shape, 1, &view_of);
    if (!t) return NULL;
    t->data = view_of->data;
    return t;
}

static int tape_push(gv_graph *g, gv_tensor *t)
{
    if (g->n_tape == g->cap_tape) {
        int cap = g->cap_tape ? 2 * g->cap_tape : 256;
        gv_tensor **tape = realloc(g->tape, (size_t)cap * sizeof *tape);
        if (!tape) return gv_fail("tape: out of memory");
        g->tape = tape;
        g->cap_tape = cap;
    }
    g->tape[g->n_tape++] = t;
    return 0;
}

gv_tensor *gv_op_run(gv_graph *g, gv_tensor *out)
{
    if (!out) return NULL;
    /* A forward that needs scratch memory takes it after what it keeps (out->saved) and
     * rewinds the arena itself. */
    double start = g->profile ? gv_now() : 0;
    int rc = gv_op_table[out->op].forward(g, out);
    if (g->profile) g->op_seconds[out->op][0] += gv_now() - start;
    if (rc != 0) return NULL;
    if (out->requires_grad && tape_push(g, out) != 0) return NULL;
    return out;
}

/* A parameter keeps its own gradient buffer; any other tensor gets one in this graph's arena
 * once per step (a buffer from another graph or an earlier step is stale: replaced). */
static int ensure_grad(gv_graph *g, gv_tensor *t)
{
    if (t->grad && (t->grad_graph == NULL || (t->grad_graph == g && t->grad_epoch == g->epoch)))
        return 0;
    t->grad = gv_arena_calloc(&g->arena, (size_t)t->numel * sizeof(float));
    t->grad_graph = g;
    t->grad_epoch = g->epoch;
    return t->grad ? 0 : -1;
}

int gv_backward_seed(gv_graph *g, gv_tensor *out, const float *out_grad)
{
    if (!out) return gv_fail("backward: no output tensor (an op failed before)");
    if (!out->requires_grad)
        return gv_fail("backward: the output depends on no tensor that requires a gradient");
    /* Activation gradients of an earlier call in this step are dropped, so each call
     * propagates only its own seed (leaves and parameters accumulate). */
    for (int i = 0; i < g->n_tape; i++) g->tape[i]->grad = NULL;
    if (ensure_grad(g, out) != 0) return -1;
    float *dout = out->grad;
#pragma omp parallel for simd schedule(static) if (out->numel >= GV_OMP_MIN)
    for (int64_t i = 0; i < out->numel; i++) dout[i] += out_grad[i];
    for (int i = g->n_tape - 1; i >= 0; i--) {
        gv_tensor *t = g->tape[i];
        if (!t->grad) continue; /* the output does not depend on it */
        for (int s = 0; s < t->n_src; s++)
            if (t->src[s]->requires_grad && ensure_grad(g, t->src[s]) != 0) return -1;
        gv_arena_mark m = gv_arena_get_mark(&g->arena);
        double start = g->profile ? gv_now() : 0;
        int rc = gv_op_table[t->op].backward(g, t);
        if (g->profile) g->op_seconds[t->op][1] += gv_now() - start;
        gv_arena_rewind(&g->arena, m); /* scratch of the backward step */
        if (rc != 0) return gv_fail_context("backward of %s", gv_op_name(t->op));
    }
    return 0;
}

int gv_backward(gv_graph *g, gv_tensor *loss)
{
    if (loss && loss->numel != 1) {
        char buf[64];
        return gv_fail("backward: the loss must have one element, not %s",
                       gv_shape_str(loss, buf, sizeof buf));
    }
    const float one = 1.0f;
    return gv_backward_seed(g, loss, &one);
}
