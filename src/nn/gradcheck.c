/* Gradient check: the backward pass against central finite differences of
 * L = sum_i out_i r_i, with r fixed random weights (so every output element matters and no
 * gradient is hidden by a symmetric loss). Used by the tests of every op and of the model. */
#include <stdio.h>
#include <stdlib.h>

#include "gaussvid/nn/nn.h"
#include "nn/nn_internal.h"

gv_gradcheck_opts gv_gradcheck_defaults(void)
{
    gv_gradcheck_opts o = {1e-2, 2e-3, 2e-2, 40, 1};
    return o;
}

/* L(out) = sum out_i r_i in double. */
static double projected(const gv_tensor *out, const float *r)
{
    double s = 0;
    for (int64_t i = 0; i < out->numel; i++) s += (double)out->data[i] * r[i];
    return s;
}

static int evaluate(gv_graph *g, gv_build_fn build, void *ctx, const float *r, int64_t numel,
                    double *value)
{
    gv_graph_reset(g);
    gv_tensor *out = build(g, ctx);
    if (!out) return gv_fail_context("gradcheck: build");
    if (out->numel != numel) return gv_fail("gradcheck: the output changed size");
    *value = projected(out, r);
    return 0;
}

static int check_param(gv_graph *g, gv_param *p, gv_build_fn build, void *ctx, const float *r,
                       int64_t numel, const gv_gradcheck_opts *o, gv_gradcheck_report *rep,
                       double *worst_ratio, double *err2, double *num2)
{
    int64_t n = p->t.numel, count = (o->max_per_tensor > 0 && n > o->max_per_tensor) ? o->max_per_tensor : n;
    for (int64_t c = 0; c < count; c++) {
        int64_t idx = count == n ? c : (int64_t)(gv_uniform_at(o->seed + 7, (uint64_t)c) * (double)n);
        float orig = p->t.data[idx];
        float xp = orig + (float)o->h, xm = orig - (float)o->h;
        double lp, lm;
        p->t.data[idx] = xp;
        int rc = evaluate(g, build, ctx, r, numel, &lp);
        p->t.data[idx] = xm;
        if (rc == 0) rc = evaluate(g, build, ctx, r, numel, &lm);
        p->t.data[idx] = orig;
        if (rc != 0) return -1;
        double numeric = (lp - lm) / ((double)xp - (double)xm);
        double analytic = p->t.grad[idx], err = fabs(analytic - numeric);
        double ratio = err / (o->atol + o->rtol * fabs(numeric));
        rep->n_checked++;
        if (!(ratio <= 1.0)) rep->n_bad++;
        if (err > rep->max_abs_err) rep->max_abs_err = err;
        *err2 += err * err;
        *num2 += numeric * numeric;
        if (!(ratio <= *worst_ratio)) {
            *worst_ratio = ratio;
            snprintf(rep->worst, sizeof rep->worst, "%s[%lld]: analytic %.6g, numeric %.6g",
                     p->t.name, (long long)idx, analytic, numeric);
        }
    }
    return 0;
}

int gv_gradcheck(gv_params *vars, gv_build_fn build, void *ctx, const gv_gradcheck_opts *o,
                 gv_gradcheck_report *report)
{
    gv_gradcheck_report rep = {0};
    gv_graph g;
    gv_graph_init(&g, 0);
    gv_params_zero_grad(vars);
    int rc = -1;
    float *r = NULL;
    gv_tensor *out = build(&g, ctx);
    if (!out) {
        gv_fail_context("gradcheck: build");
        goto done;
    }
    int64_t numel = out->numel;
    if (!(r = malloc((size_t)numel * sizeof *r))) {
        gv_fail("gradcheck: out of memory");
        goto done;
    }
    gv_fill_normal(r, numel, o->seed, 0, 0.0f, 1.0f);
    if (out->requires_grad && gv_backward_seed(&g, out, r) != 0) goto done;
    gv_graph_set_grad(&g, 0);
    double worst = -1, err2 = 0, num2 = 0;
    for (int i = 0; i < vars->n; i++) {
        gv_param *p = vars->items[i];
        if (p->trainable &&
            check_param(&g, p, build, ctx, r, numel, o, &rep, &worst, &err2, &num2) != 0)
            goto done;
    }
    rep.rel_norm_err = sqrt(err2) / (sqrt(num2) > 1e-30 ? sqrt(num2) : 1e-30);
    rc = rep.n_bad ? gv_fail("gradcheck: %d of %d elements off; worst %s", rep.n_bad,
                             rep.n_checked, rep.worst)
                   : 0;
done:
    free(r);
    gv_graph_free(&g);
    if (report) *report = rep;
    return rc;
}
