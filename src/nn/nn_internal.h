/* Private plumbing of the tensor engine: the op table's function types, the helper every op
 * constructor uses, and the forward/backward pair of every op (one file per family). */
#ifndef GAUSSVID_NN_INTERNAL_H
#define GAUSSVID_NN_INTERNAL_H

#include <math.h>
#include <stdint.h>
#include <string.h>

#include "gaussvid/core/core.h"
#include "gaussvid/nn/ops.h"
#include "gaussvid/nn/tensor.h"

/* Loops over less work than this (elements) run on one thread: below it, starting and
 * joining the OpenMP team costs about as much as the loop, and far more when the cores are
 * busy with other processes (a woken thread may wait a whole time slice). */
#define GV_OMP_MIN 65536

/* Forward: fills out->data from out->src and the op settings. Backward: adds the gradient
 * of every src that requires one (its grad is already allocated and holds earlier
 * contributions) from out->grad. Both may take scratch memory from the graph's arena
 * between a mark and a rewind. Return 0, or -1 after gv_fail. */
typedef int (*gv_forward_fn)(gv_graph *g, gv_tensor *out);
typedef int (*gv_backward_fn)(gv_graph *g, gv_tensor *out);
typedef struct {
    const char *name;
    gv_forward_fn forward;
    gv_backward_fn backward;
} gv_op_info;
extern const gv_op_info gv_op_table[GV_OP_COUNT];

/* The common start of every op constructor: fails if a src is NULL (keeping the earlier
 * message), allocates the output (data uninitialised unless zero), decides whether it needs
 * a gradient (any src does, and recording is on) and records it. Returns NULL on failure. */
gv_tensor *gv_op_new(gv_graph *g, gv_op op, int ndim, const int *shape, int n_src,
                     gv_tensor *const *src, int zero);
/* Like gv_op_new, but the output shares the data of view_of (no allocation). */
gv_tensor *gv_op_new_view(gv_graph *g, gv_op op, int ndim, const int *shape, gv_tensor *view_of);
/* Runs the op's forward; on failure returns NULL (for constructors: return gv_op_run(g, t)). */
gv_tensor *gv_op_run(gv_graph *g, gv_tensor *out);
/* True when src i of out needs a gradient (and so has a buffer during backward). */
static inline int gv_wants_grad(const gv_tensor *out, int i)
{
    return i < out->n_src && out->src[i] && out->src[i]->requires_grad && out->src[i]->grad;
}
/* Scratch memory for a forward or backward step; NULL after gv_fail. */
static inline float *gv_scratch(gv_graph *g, int64_t n)
{
    return (float *)gv_arena_alloc(&g->arena, (size_t)n * sizeof(float));
}
/* Copies an int64 count that must fit the int arguments of BLAS. */
int gv_check_blas_dims(const char *op, int64_t a, int64_t b, int64_t c);

/* exp(x) for float, accurate to about 2 ulp over the range where it is a normal number,
 * exactly 0 below -87.3 (so exp(-inf) = 0), inf above 88.72, exp(88.3) in between.
 * Inlinable and branch-free so that the attention, softmax and activation loops vectorise
 * (they spend most of their time here); that needs -fno-trapping-math, which CMakeLists.txt
 * sets for src/nn (it changes no value, it only lets the compiler speculate float ops). */
static inline float gv_expf(float x)
{
    const float log2e = 1.44269504088896341f, ln2_hi = 0.693359375f, ln2_lo = -2.12194440e-4f;
    float xc = x < -87.3f ? -87.3f : x;
    xc = xc > 88.3f ? 88.3f : xc;
    float n = (xc * log2e + 12582912.0f) - 12582912.0f; /* round to nearest (1.5 * 2^23) */
    int32_t ni = (int32_t)n;
    float r = xc - n * ln2_hi - n * ln2_lo; /* |r| <= ln2 / 2 */
    /* Cephes expf polynomial for exp(r) - 1 - r. */
    float p = 1.9875691500e-4f;
    p = p * r + 1.3981999507e-3f;
    p = p * r + 8.3334519073e-3f;
    p = p * r + 4.1665795894e-2f;
    p = p * r + 1.6666665459e-1f;
    p = p * r + 5.0000001201e-1f;
    float e = p * r * r + r + 1.0f;
    union { uint32_t u; float f; } scale;
    scale.u = (uint32_t)(ni + 127) << 23;
    float y = e * scale.f;
    y = x < -87.3f ? 0.0f : y;
    return x > 88.72f ? INFINITY : y;
}

/* ---- forward/backward pairs (see each file for the shapes) ---- */
#define GV_DECLARE_OP(name)                                   \
    int name##_forward(gv_graph *g, gv_tensor *out);          \
    int name##_backward(gv_graph *g, gv_tensor *out)
GV_DECLARE_OP(gv_binary);
GV_DECLARE_OP(gv_affine_op);
GV_DECLARE_OP(gv_sum_op);
GV_DECLARE_OP(gv_reshape_op);
GV_DECLARE_OP(gv_permute_op);
GV_DECLARE_OP(gv_concat_op);
GV_DECLARE_OP(gv_slice_op);
GV_DECLARE_OP(gv_repeat_op);
GV_DECLARE_OP(gv_matmul_op);
GV_DECLARE_OP(gv_linear_op);
GV_DECLARE_OP(gv_layer_norm_op);
GV_DECLARE_OP(gv_rms_norm_op);
GV_DECLARE_OP(gv_gelu_op);
GV_DECLARE_OP(gv_silu_op);
GV_DECLARE_OP(gv_sigmoid_op);
GV_DECLARE_OP(gv_softmax_op);
GV_DECLARE_OP(gv_attention_op);
GV_DECLARE_OP(gv_rope_op);
GV_DECLARE_OP(gv_conv_op);
GV_DECLARE_OP(gv_space_to_depth_op);
GV_DECLARE_OP(gv_depth_to_space_op);
GV_DECLARE_OP(gv_upsample_op);
GV_DECLARE_OP(gv_l1_loss_op);
GV_DECLARE_OP(gv_l2_loss_op);
#undef GV_DECLARE_OP

#endif
