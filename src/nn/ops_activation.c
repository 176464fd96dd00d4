/* Activations: GELU (tanh approximation), SiLU, sigmoid, and softmax over the last axis. */
#include "nn/nn_internal.h"

/* tanh through exp (vectorisable): 1 - 2 / (exp(2u) + 1), exact limits +-1. */
static inline float tanh_fast(float u) { return 1.0f - 2.0f / (gv_expf(2.0f * u) + 1.0f); }
static inline float sigmoid_fast(float x) { return 1.0f / (1.0f + gv_expf(-x)); }

#define GELU_K 0.7978845608028654f /* sqrt(2 / pi) */
#define GELU_C 0.044715f

/* ---- GELU: y = 0.5 x (1 + tanh(k (x + c x^3))); out [x] -------------------------------------- */
int gv_gelu_op_forward(gv_graph *g, gv_tensor *out)
{
    const float *x = out->src[0]->data;
    float *y = out->data;
#pragma omp parallel for simd schedule(static) if (out->numel >= GV_OMP_MIN)
    for (int64_t i = 0; i < out->numel; i++)
        y[i] = 0.5f * x[i] * (1.0f + tanh_fast(GELU_K * (x[i] + GELU_C * x[i] * x[i] * x[i])));
    return 0;
}

/* dy/dx = 0.5 (1 + t) + 0.5 x (1 - t^2) k (1 + 3 c x^2) */
int gv_gelu_op_backward(gv_graph *g, gv_tensor *out)
{
    const float *x = out->src[0]->data, *dy = out->grad;
    float *dx = out->src[0]->grad;
#pragma omp parallel for simd schedule(static) if (out->numel >= GV_OMP_MIN)
    for (int64_t i = 0; i < out->numel; i++) {
        float v = x[i], t = tanh_fast(GELU_K * (v + GELU_C * v * v * v));
        float d = 0.5f * (1.0f + t) + 0.5f * v * (1.0f - t * t) * GELU_K * (1.0f + 3.0f * GELU_C * v * v);
        dx[i] += dy[i] * d;
    }
    return 0;
}

/* ---- SiLU: y = x s(x); dy/dx = s (1 + x (1 - s)) ------------------------------------------------ */
int gv_silu_op_forward(gv_graph *g, gv_tensor *out)
{
    const float *x = out->src[0]->data;
    float *y = out->data;
#pragma omp parallel for simd schedule(static) if (out->numel >= GV_OMP_MIN)
    for (int64_t i = 0; i < out->numel; i++) y[i] = x[i] * sigmoid_fast(x[i]);
    return 0;
}

int gv_silu_op_backward(gv_graph *g, gv_tensor *out)
{
    const float *x = out->src[0]->data, *dy = out->grad;
    float *dx = out->src[0]->grad;
#pragma omp parallel for simd schedule(static) if (out->numel >= GV_OMP_MIN)
    for (int64_t i = 0; i < out->numel; i++) {
        float s = sigmoid_fast(x[i]);
        dx[i] += dy[i] * s * (1.0f + x[i] * (1.0f - s));
    }
    return 0;
}

/* ---- sigmoid: y = 1 / (1 + exp(-x)); dy/dx = y (1 - y) ------------------------------------------ */
int gv_sigmoid_op_forward(gv_graph *g, gv_tensor *out)
{
    const float *x = out->src[0]->data;
    float *y = out->data;
#pragma omp parallel for simd schedule(static) if (out->numel >= GV_OMP_MIN)
    for (int64_t i = 0; i < out->numel; i++) y[i] = sigmoid_fast(x[i]);
    return 0;
}

int gv_sigmoid_op_backward(gv_graph *g, gv_tensor *out)
{
    const float *y = out->data, *dy = out->grad;
    float *dx = out->src[0]->grad;
#pragma omp parallel for simd schedule(static) if (out->numel >= GV_OMP_MIN)
    for (int64_t i = 0; i < out->numel; i++) dx[i] += dy[i] * y[i] * (1.0f - y[i]);
    return 0;
}

/* ---- softmax over the last axis: y = exp(x - max) / sum; dx = y (dy - sum dy y) ------------- */
int gv_softmax_op_forward(gv_graph *g, gv_tensor *out)
{
    const gv_tensor *x = out->src[0];
    int64_t D = gv_dim(x, -1), R = x->numel / D;
#pragma omp parallel for schedule(static) if (R * D >= GV_OMP_MIN)
    for (int64_t r = 0; r < R; r++) {
        const float *xr = x->data + r * D;
        float *y = out->data + r * D, max = -INFINITY;
        for (int64_t i = 0; i < D; i++) max = xr[i] > max ? xr[i] : max;
        if (max == -INFINITY) { /* every entry masked: define the row as zeros */
            memset(y, 0, (size_t)D * sizeof(float));
            continue;
        }
        float sum = 0;
#pragma omp simd reduction(+ : sum)
        for (int64_t i = 0; i < D; i++) {
            y[i] = gv_expf(xr[i] - max);
            sum += y[i];
        }
        float inv = 1.0f / sum;
        for (int64_t i = 0; i < D; i++) y[i] *= inv;
    }
    return 0;
}

int gv_softmax_op_backward(gv_graph *g, gv_tensor *out)
{
    int64_t D = gv_dim(out, -1), R = out->numel / D;
#pragma omp parallel for schedule(static) if (R * D >= GV_OMP_MIN)
    for (int64_t r = 0; r < R; r++) {
        const float *y = out->data + r * D, *dy = out->grad + r * D;
        float *dx = out->src[0]->grad + r * D;
        double dot = 0;
        for (int64_t i = 0; i < D; i++) dot += (double)dy[i] * y[i];
        for (int64_t i = 0; i < D; i++) dx[i] += y[i] * (dy[i] - (float)dot);
    }
    return 0;
}

static gv_tensor *unary(gv_graph *g, gv_op op, gv_tensor *x)
{
    if (!x) return NULL;
    return gv_op_run(g, gv_op_new(g, op, x->ndim, x->shape, 1, &x, 0));
}

gv_tensor *gv_gelu(gv_graph *g, gv_tensor *x) { return unary(g, GV_OP_GELU, x); }
gv_tensor *gv_silu(gv_graph *g, gv_tensor *x) { return unary(g, GV_OP_SILU, x); }
gv_tensor *gv_sigmoid(gv_graph *g, gv_tensor *x) { return unary(g, GV_OP_SIGMOID, x); }
gv_tensor *gv_softmax(gv_graph *g, gv_tensor *x) { return unary(g, GV_OP_SOFTMAX, x); }
