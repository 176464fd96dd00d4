/* The tensor engine of gaussvid in one include: tensors, tape and parameters (tensor.h),
 * operations (ops.h), optimisers (optim.h), and a gradient checker for tests. */
#ifndef GAUSSVID_NN_H
#define GAUSSVID_NN_H

#include "gaussvid/nn/ops.h"
#include "gaussvid/nn/optim.h"
#include "gaussvid/nn/tensor.h"

/* ---- Gradient check (nn/gradcheck.c) --------------------------------------------------------
 * Compares the backward pass with central finite differences. The variables are the
 * trainable parameters of `vars`; build(g, ctx) builds any output tensor from them on a
 * fresh graph. The checked scalar is L = sum_i out_i r_i with fixed random r (accumulated in
 * double), so every output element matters. Each variable element (or a random subset of
 * max_per_tensor of them) is moved by +-h. */
typedef gv_tensor *(*gv_build_fn)(gv_graph *g, void *ctx);
typedef struct {
    double h;            /* finite-difference step (default 1e-2) */
    double atol, rtol;   /* element passes when |analytic - numeric| <= atol + rtol |numeric| */
    int max_per_tensor;  /* elements checked per parameter (0: all) */
    uint64_t seed;
} gv_gradcheck_opts;
typedef struct {
    int n_checked, n_bad;
    double max_abs_err;  /* largest |analytic - numeric| */
    double rel_norm_err; /* ||analytic - numeric|| / ||numeric|| over all checked elements */
    char worst[200];     /* parameter, index and both values of the worst element */
} gv_gradcheck_report;
gv_gradcheck_opts gv_gradcheck_defaults(void);
/* 0 when every checked element passes; -1 (message names the worst element) otherwise. */
int gv_gradcheck(gv_params *vars, gv_build_fn build, void *ctx, const gv_gradcheck_opts *o,
                 gv_gradcheck_report *report);

#endif
