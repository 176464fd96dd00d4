/* Matrix products through CBLAS sgemm: batched matmul with transposes, and the linear layer
 * in PyTorch's weight layout. */
#include <cblas.h>
#include <stdlib.h>

#include "nn/nn_internal.h"

#define TR(t) ((t) ? CblasTrans : CblasNoTrans)

/* ---- matmul ---------------------------------------------------------------------------------
 * C[b] = op(A[b]) op(B[b]); A [batch, M, K] (stored [batch, K, M] when ta), B [batch, K, N]
 * (stored [batch, N, K] when tb) or one 2-D B for every batch; C [batch, M, N].
 * iparam = {ta, tb, batch, M, N, K, b_shared} */
int gv_matmul_op_forward(gv_graph *g, gv_tensor *out)
{
    const int *p = out->iparam;
    int ta = p[0], tb = p[1], batch = p[2], M = p[3], N = p[4], K = p[5], shared = p[6];
    const float *A = out->src[0]->data, *B = out->src[1]->data;
    int lda = ta ? M : K, ldb = tb ? K : N;
    if (shared && !ta) { /* the batch folds into the rows of one product */
        cblas_sgemm(CblasRowMajor, CblasNoTrans, TR(tb), batch * M, N, K, 1.0f, A, lda, B, ldb,
                    0.0f, out->data, N);
        return 0;
    }
    for (int b = 0; b < batch; b++)
        cblas_sgemm(CblasRowMajor, TR(ta), TR(tb), M, N, K, 1.0f, A + (int64_t)b * M * K, lda,
                    B + (shared ? 0 : (int64_t)b * K * N), ldb, 0.0f, out->data + (int64_t)b * M * N, N);
    return 0;
}

/* dop(A) = dC op(B)^T, dop(B) = op(A)^T dC, written for each storage order. */
int gv_matmul_op_backward(gv_graph *g, gv_tensor *out)
{
    const int *p = out->iparam;
    int ta = p[0], tb = p[1], batch = p[2], M = p[3], N = p[4], K = p[5], shared = p[6];
    gv_tensor *a = out->src[0], *b = out->src[1];
    int lda = ta ? M : K, ldb = tb ? K : N;
    const float *dC = out->grad;
    int fold = shared && !ta, steps = fold ? 1 : batch, rows = fold ? batch * M : M;
    for (int s = 0; s < steps; s++) {
        const float *A = a->data + (int64_t)s * M * K, *Bm = b->data + (shared ? 0 : (int64_t)s * K * N);
        const float *dCs = dC + (int64_t)s * M * N;
        if (gv_wants_grad(out, 0)) {
            float *dA = a->grad + (int64_t)s * M * K;
            if (!ta) /* dA [M, K] += dC [M, N] op(B)^T */
                cblas_sgemm(CblasRowMajor, CblasNoTrans, tb ? CblasNoTrans : CblasTrans, rows, K, N,
                            1.0f, dCs, N, Bm, ldb, 1.0f, dA, lda);
            else /* dA [K, M] += op(B) [K, N] dC^T */
                cblas_sgemm(CblasRowMajor, TR(tb), CblasTrans, K, M, N, 1.0f, Bm, ldb, dCs, N,
                            1.0f, dA, lda);
        }
        if (gv_wants_grad(out, 1)) {
            float *dB = b->grad + (shared ? 0 : (int64_t)s * K * N);
            if (!tb) /* dB [K, N] += op(A)^T [K, M] dC */
                cblas_sgemm(CblasRowMajor, ta ? CblasNoTrans : CblasTrans, CblasNoTrans, K, N, rows,
                            1.0f, A, lda, dCs, N, 1.0f, dB, ldb);
            else /* dB [N, K] += dC^T [N, M] op(A) */
                cblas_sgemm(CblasRowMajor, CblasTrans, TR(ta), N, K, rows, 1.0f, dCs, N, A, lda,
                            1.0f, dB, ldb);
        }
    }
    return 0;
}

void gv_gemm(int M, int N, int K, const float *A, int lda, const float *B, int ldb, float *C, int ldc)
{
    cblas_sgemm(CblasRowMajor, CblasNoTrans, CblasNoTrans, M, N, K, 1.0f, A, lda, B, ldb, 0.0f, C, ldc);
}

void gv_gemm_nt(int M, int N, int K, const float *A, int lda, const float *B, int ldb, float *C,
                int ldc)
{
    cblas_sgemm(CblasRowMajor, CblasNoTrans, CblasTrans, M, N, K, 1.0f, A, lda, B, ldb, 0.0f, C, ldc);
}

gv_tensor *gv_matmul(gv_graph *g, gv_tensor *a, gv_tensor *b, int trans_a, int trans_b)
{
    if (!a || !b) return NULL;
    char sa[64], sb[64];
    if (a->ndim < 2 || b->ndim < 2) {
        gv_fail("matmul: inputs need 2 or more dimensions, got %s and %s",
                gv_shape_str(a, sa, sizeof sa), gv_shape_str(b, sb, sizeof sb));
        return NULL;
    }
    int M = trans_a ? gv_dim(a, -1) : gv_dim(a, -2), K = trans_a ? gv_dim(a, -2) : gv_dim(a, -1);
    int Kb = trans_b ? gv_dim(b, -1) : gv_dim(b, -2), N = trans_b ? gv_dim(b, -2) : gv_dim(b, -1);
    int shared = b->ndim == 2, same_batch = b->ndim == a->ndim;
    for (int d = 0; same_batch && d < a->ndim - 2; d++)
        if (a->shape[d] != b->shape[d]) same_batch = 0;
    if (K != Kb || (!shared && !same_batch)) {
        gv_fail("matmul: %s%s and %s%s do not multiply", gv_shape_str(a, sa, sizeof sa),
                trans_a ? "^T" : "", gv_shape_str(b, sb, sizeof sb), trans_b ? "^T" : "");
        return NULL;
    }
    int64_t batch = a->numel / ((int64_t)M * K);
    if (gv_check_blas_dims("matmul", batch * M, N, K) != 0) return NULL;
    int shape[GV_MAX_DIMS];
    for (int d = 0; d < a->ndim - 2; d++) shape[d] = a->shape[d];
    shape[a->ndim - 2] = M;
    shape[a->ndim - 1] = N;
    gv_tensor *src[2] = {a, b};
    gv_tensor *out = gv_op_new(g, GV_OP_MATMUL, a->ndim, shape, 2, src, 0);
    if (!out) return NULL;
    int params[7] = {trans_a != 0, trans_b != 0, (int)batch, M, N, K, shared && batch > 1};
    memcpy(out->iparam, params, sizeof params);
    return gv_op_run(g, out);
}

/* ---- linear -----------------------------------------------------------------------------------
 * y [R, out] = x [R, in] W^T + bias, with W [out, in] and bias [out]; R = all leading dims.
 * iparam = {R, in, out} */
int gv_linear_op_forward(gv_graph *g, gv_tensor *out)
{
    int R = out->iparam[0], in = out->iparam[1], n_out = out->iparam[2];
    float *scratch; /* a bfloat16 weight's float32 values, for this product only */
    const float *x = out->src[0]->data, *W = gv_tensor_values(out->src[1], &scratch);
    float *y = out->data;
    if (!W) return -1;
    cblas_sgemm(CblasRowMajor, CblasNoTrans, CblasTrans, R, n_out, in, 1.0f, x, in, W, in, 0.0f,
                y, n_out);
    free(scratch);
    if (out->n_src > 2) {
        const float *bias = out->src[2]->data;
#pragma omp parallel for schedule(static) if ((int64_t)R * n_out >= GV_OMP_MIN)
        for (int r = 0; r < R; r++) {
            float *row = y + (int64_t)r * n_out;
#pragma omp simd
            for (int j = 0; j < n_out; j++) row[j] += bias[j];
        }
    }
    return 0;
}

/* dx += dy W; dW += dy^T x; dbias += sum over rows of dy (a GEMV with a vector of ones). */
int gv_linear_op_backward(gv_graph *g, gv_tensor *out)
{
    int R = out->iparam[0], in = out->iparam[1], n_out = out->iparam[2];
    gv_tensor *x = out->src[0], *W = out->src[1];
    const float *dy = out->grad;
    if (gv_wants_grad(out, 0)) { /* a bfloat16 weight is converted again: it was not kept */
        float *scratch;
        const float *Wv = gv_tensor_values(W, &scratch);
        if (!Wv) return -1;
        cblas_sgemm(CblasRowMajor, CblasNoTrans, CblasNoTrans, R, in, n_out, 1.0f, dy, n_out,
                    Wv, in, 1.0f, x->grad, in);
        free(scratch);
    }
    if (gv_wants_grad(out, 1))
        cblas_sgemm(CblasRowMajor, CblasTrans, CblasNoTrans, n_out, in, R, 1.0f, dy, n_out,
                    x->data, in, 1.0f, W->grad, in);
    if (gv_wants_grad(out, 2)) {
        float *ones = gv_scratch(g, R);
        if (!ones) return -1;
        for (int r = 0; r < R; r++) ones[r] = 1.0f;
        cblas_sgemv(CblasRowMajor, CblasTrans, R, n_out, 1.0f, dy, n_out, ones, 1, 1.0f,
                    out->src[2]->grad, 1);
    }
    return 0;
}

gv_tensor *gv_linear(gv_graph *g, gv_tensor *x, gv_tensor *w, gv_tensor *bias)
{
    if (!x || !w) return NULL;
    char sx[64], sw[64];
    int in = gv_dim(x, -1);
    if (w->ndim != 2 || w->shape[1] != in) {
        gv_fail("linear: input %s does not match weight %s (expected [out, %d])",
                gv_shape_str(x, sx, sizeof sx), gv_shape_str(w, sw, sizeof sw), in);
        return NULL;
    }
    int n_out = w->shape[0];
    if (bias && (bias->numel != n_out || bias->ndim != 1)) {
        gv_fail("linear: bias %s does not match %d outputs", gv_shape_str(bias, sx, sizeof sx),
                n_out);
        return NULL;
    }
    int64_t R = x->numel / in;
    if (gv_check_blas_dims("linear", R, in, n_out) != 0) return NULL;
    int shape[GV_MAX_DIMS];
    for (int d = 0; d < x->ndim; d++) shape[d] = x->shape[d];
    shape[x->ndim - 1] = n_out;
    gv_tensor *src[3] = {x, w, bias};
    gv_tensor *out = gv_op_new(g, GV_OP_LINEAR, x->ndim, shape, bias ? 3 : 2, src, 0);
    if (!out) return NULL;
    out->iparam[0] = (int)R;
    out->iparam[1] = in;
    out->iparam[2] = n_out;
    return gv_op_run(g, out);
}
