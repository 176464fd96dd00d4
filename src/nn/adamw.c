/* AdamW (Loshchilov & Hutter, "Decoupled weight decay regularization", ICLR 2019) in
 * PyTorch's formulation: decay first, then the bias-corrected Adam update. */
#include "gaussvid/nn/optim.h"
#include "nn/nn_internal.h"

gv_adamw_config gv_adamw_defaults(void)
{
    gv_adamw_config c = {0.9f, 0.999f, 1e-8f, 0.01f};
    return c;
}

int gv_adamw_step(gv_params *ps, const gv_adamw_config *c, float lr)
{
    if (gv_params_check_finite(ps, 1) != 0) return gv_fail_context("adamw");
    long step = ps->step + 1;
    float correction1 = (float)(1.0 - pow(c->beta1, (double)step));
    float correction2 = (float)(1.0 - pow(c->beta2, (double)step));
    float b1 = c->beta1, b2 = c->beta2, eps = c->eps;
    for (int i = 0; i < ps->n; i++) {
        gv_param *p = ps->items[i];
        if (!p->trainable) continue;
        float *x = p->t.data, *gr = p->t.grad, *m = p->m, *v = p->v;
        float decay = p->decay ? 1.0f - lr * c->weight_decay : 1.0f;
#pragma omp parallel for simd schedule(static) if (p->t.numel >= GV_OMP_MIN)
        for (int64_t j = 0; j < p->t.numel; j++) {
            m[j] = b1 * m[j] + (1.0f - b1) * gr[j];
            v[j] = b2 * v[j] + (1.0f - b2) * gr[j] * gr[j];
            float m_hat = m[j] / correction1, v_hat = v[j] / correction2;
            x[j] = x[j] * decay - lr * m_hat / (sqrtf(v_hat) + eps);
        }
    }
    ps->step = step;
    return 0;
}
