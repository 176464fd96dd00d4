/* LoRA (Hu et al., "LoRA: Low-rank adaptation of large language models", 2021): a frozen
 * linear layer plus a trainable low-rank update, y = x W^T + bias + scale (x A^T) B^T. Built
 * from linear ops, so the frozen W costs no weight-gradient work (docs/ARCHITECTURE.md section 6.7). */
#include <cblas.h>

#include "nn/nn_internal.h"

gv_tensor *gv_lora_linear(gv_graph *g, gv_tensor *x, gv_tensor *w, gv_tensor *bias,
                          gv_tensor *a, gv_tensor *b, float scale)
{
    if (!x || !w || !a || !b) return NULL;
    if (a->ndim != 2 || b->ndim != 2 || a->shape[1] != w->shape[1] || b->shape[0] != w->shape[0] ||
        b->shape[1] != a->shape[0]) {
        char sa[64], sb[64], sw[64];
        gv_fail("lora: A %s and B %s do not fit weight %s (expected [r, in] and [out, r])",
                gv_shape_str(a, sa, sizeof sa), gv_shape_str(b, sb, sizeof sb), gv_shape_str(w, sw, sizeof sw));
        return NULL;
    }
    gv_tensor *base = gv_linear(g, x, w, bias);
    gv_tensor *update = gv_linear(g, gv_linear(g, x, a, NULL), b, NULL);
    return gv_add(g, base, gv_scale(g, update, scale));
}

int gv_lora_merge(gv_tensor *w, const gv_tensor *a, const gv_tensor *b, float scale)
{
    if (a->ndim != 2 || b->ndim != 2 || w->ndim != 2 || a->shape[1] != w->shape[1] ||
        b->shape[0] != w->shape[0] || b->shape[1] != a->shape[0])
        return gv_fail("lora merge: %s: adapter shapes do not fit the weight", w->name ? w->name : "weight");
    int out = w->shape[0], in = w->shape[1], r = a->shape[0];
    cblas_sgemm(CblasRowMajor, CblasNoTrans, CblasNoTrans, out, in, r, scale, b->data, r, a->data,
                in, 1.0f, w->data, in);
    return 0;
}
