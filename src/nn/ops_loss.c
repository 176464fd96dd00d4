/* L1 and L2 losses with per-sample weights: mean over all elements of w_b |p - t| or
 * w_b (p - t)^2, b being the index along the first axis. Summed in double over fixed chunks
 * (thread-count independent). src = {pred, target, weights?}; out [1]. */
#include <stdlib.h>

#include "nn/nn_internal.h"

#define LOSS_CHUNK 4096

static inline float sample_weight(const gv_tensor *out, int64_t i, int64_t per_sample)
{
    return out->n_src > 2 ? out->src[2]->data[i / per_sample] : 1.0f;
}

static int loss_forward(gv_graph *g, gv_tensor *out, int squared)
{
    const gv_tensor *p = out->src[0], *t = out->src[1];
    int64_t n = p->numel, per_sample = n / p->shape[0], n_chunks = (n + LOSS_CHUNK - 1) / LOSS_CHUNK;
    double *partial = malloc((size_t)n_chunks * sizeof *partial);
    if (!partial) return gv_fail("%s: out of memory", squared ? "l2_loss" : "l1_loss");
#pragma omp parallel for schedule(static) if (n >= GV_OMP_MIN)
    for (int64_t c = 0; c < n_chunks; c++) {
        int64_t end = (c + 1) * LOSS_CHUNK < n ? (c + 1) * LOSS_CHUNK : n;
        double s = 0;
        for (int64_t i = c * LOSS_CHUNK; i < end; i++) {
            double d = (double)p->data[i] - t->data[i];
            s += sample_weight(out, i, per_sample) * (squared ? d * d : fabs(d));
        }
        partial[c] = s;
    }
    double total = 0;
    for (int64_t c = 0; c < n_chunks; c++) total += partial[c];
    free(partial);
    out->data[0] = (float)(total / n);
    return 0;
}

/* L1: dp = g w_b sign(p - t) / n; L2: dp = 2 g w_b (p - t) / n; dt = -dp. */
static int loss_backward(gv_tensor *out, int squared)
{
    const gv_tensor *p = out->src[0], *t = out->src[1];
    int64_t n = p->numel, per_sample = n / p->shape[0];
    float scale = out->grad[0] / (float)n;
    float *dp = gv_wants_grad(out, 0) ? out->src[0]->grad : NULL;
    float *dt = gv_wants_grad(out, 1) ? out->src[1]->grad : NULL;
#pragma omp parallel for schedule(static) if (n >= GV_OMP_MIN)
    for (int64_t i = 0; i < n; i++) {
        float d = p->data[i] - t->data[i];
        float slope = squared ? 2.0f * d : (d > 0 ? 1.0f : (d < 0 ? -1.0f : 0.0f));
        float v = scale * sample_weight(out, i, per_sample) * slope;
        if (dp) dp[i] += v;
        if (dt) dt[i] -= v;
    }
    return 0;
}

int gv_l1_loss_op_forward(gv_graph *g, gv_tensor *out) { return loss_forward(g, out, 0); }
int gv_l1_loss_op_backward(gv_graph *g, gv_tensor *out) { return loss_backward(out, 0); }
int gv_l2_loss_op_forward(gv_graph *g, gv_tensor *out) { return loss_forward(g, out, 1); }
int gv_l2_loss_op_backward(gv_graph *g, gv_tensor *out) { return loss_backward(out, 1); }

static gv_tensor *loss(gv_graph *g, gv_op op, gv_tensor *pred, gv_tensor *target, gv_tensor *w)
{
    if (!pred || !target) return NULL;
    char sp[64], st[64];
    if (!gv_same_shape(pred, target)) {
        gv_fail("%s: prediction %s and target %s differ", gv_op_name(op),
                gv_shape_str(pred, sp, sizeof sp), gv_shape_str(target, st, sizeof st));
        return NULL;
    }
    if (w && w->numel != pred->shape[0]) {
        gv_fail("%s: %lld weights for %d samples", gv_op_name(op), (long long)w->numel, pred->shape[0]);
        return NULL;
    }
    gv_tensor *src[3] = {pred, target, w};
    return gv_op_run(g, gv_op_new(g, op, 1, (int[]){1}, w ? 3 : 2, src, 0));
}

gv_tensor *gv_l1_loss(gv_graph *g, gv_tensor *pred, gv_tensor *target, gv_tensor *weights)
{
    return loss(g, GV_OP_L1_LOSS, pred, target, weights);
}

gv_tensor *gv_l2_loss(gv_graph *g, gv_tensor *pred, gv_tensor *target, gv_tensor *weights)
{
    return loss(g, GV_OP_L2_LOSS, pred, target, weights);
}
