/* Helpers shared by the tests of the tensor engine (include after check.h): random variables
 * registered as parameters, and a gradient check that prints how far apart the analytic and
 * numeric gradients are. */
#ifndef GAUSSVID_TESTS_NN_TESTUTIL_H
#define GAUSSVID_TESTS_NN_TESTUTIL_H

#include "gaussvid/core/core.h"
#include "gaussvid/nn/nn.h"

/* A trainable parameter filled with lo + (hi - lo) * U[0, 1) from stream `seed`. */
static inline gv_tensor *nt_uniform(gv_params *ps, const char *name, int ndim, const int *shape,
                                    uint64_t seed, float lo, float hi)
{
    gv_tensor *t = gv_params_add(ps, name, ndim, shape, 1);
    if (t) gv_fill_uniform(t->data, t->numel, seed, 0, lo, hi);
    return t;
}

/* A trainable parameter filled with N(0, std^2) from stream `seed`. */
static inline gv_tensor *nt_normal(gv_params *ps, const char *name, int ndim, const int *shape,
                                   uint64_t seed, float std)
{
    gv_tensor *t = gv_params_add(ps, name, ndim, shape, 1);
    if (t) gv_fill_normal(t->data, t->numel, seed, 0, 0.0f, std);
    return t;
}

/* Runs gv_gradcheck and prints one line; counts as one CHECK. */
static inline void nt_gradcheck(const char *label, gv_params *ps, gv_build_fn build, void *ctx,
                                const gv_gradcheck_opts *opts)
{
    gv_gradcheck_opts o = opts ? *opts : gv_gradcheck_defaults();
    gv_gradcheck_report r;
    gv_clear_error();
    int rc = gv_gradcheck(ps, build, ctx, &o, &r);
    printf("gradcheck %-34s %4d elements, max |err| %.2e, relative %.2e%s%s\n", label, r.n_checked,
           r.max_abs_err, r.rel_norm_err, rc ? "  FAILED: " : "", rc ? gv_last_error() : "");
    CHECK(rc == 0 && r.n_checked > 0);
}

/* Largest |a - b| over n elements. */
static inline double nt_max_diff(const float *a, const double *b, int64_t n)
{
    double m = 0;
    for (int64_t i = 0; i < n; i++) {
        double d = fabs((double)a[i] - b[i]);
        if (!(d <= m)) m = d;
    }
    return m;
}

#endif
