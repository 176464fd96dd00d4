/* Differentiable operations on gv_tensor (tensor.h). Each constructor computes its output now
 * and records it on the graph's tape when gradients are wanted.
 *
 * Errors: a constructor returns NULL after gv_fail("op: what is wrong") on a shape mismatch or
 * when the arena is exhausted, and returns NULL at once (keeping the first message) when an
 * input is NULL. A model therefore builds its whole graph and checks the final tensor once.
 *
 * Shapes are row-major; "[..., D]" means any leading dimensions. Broadcasting follows NumPy:
 * shapes are aligned on the right and a dimension of 1 (or a missing one) is repeated. */
#ifndef GAUSSVID_OPS_H
#define GAUSSVID_OPS_H

#include "gaussvid/nn/tensor.h"

/* One entry per operation; nn/op_table.c maps each to its forward and backward. */
typedef enum {
    GV_OP_LEAF = 0,
    GV_OP_ADD, GV_OP_SUB, GV_OP_MUL, GV_OP_DIV, GV_OP_AFFINE,
    GV_OP_SUM,
    GV_OP_RESHAPE, GV_OP_PERMUTE, GV_OP_CONCAT, GV_OP_SLICE, GV_OP_REPEAT,
    GV_OP_MATMUL, GV_OP_LINEAR,
    GV_OP_LAYER_NORM, GV_OP_RMS_NORM,
    GV_OP_GELU, GV_OP_SILU, GV_OP_SIGMOID, GV_OP_SOFTMAX,
    GV_OP_ATTENTION, GV_OP_ROPE,
    GV_OP_CONV,
    GV_OP_SPACE_TO_DEPTH, GV_OP_DEPTH_TO_SPACE, GV_OP_UPSAMPLE,
    GV_OP_L1_LOSS, GV_OP_L2_LOSS,
    GV_OP_COUNT
} gv_op;

/* Name of an op ("linear", ...), for messages and docs. */
const char *gv_op_name(int op);

/* ---- Element-wise (nn/ops_elementwise.c) ---------------------------------------------------- */
gv_tensor *gv_add(gv_graph *g, gv_tensor *a, gv_tensor *b); /* a + b, broadcast */
gv_tensor *gv_sub(gv_graph *g, gv_tensor *a, gv_tensor *b); /* a - b, broadcast */
gv_tensor *gv_mul(gv_graph *g, gv_tensor *a, gv_tensor *b); /* a * b, broadcast */
gv_tensor *gv_div(gv_graph *g, gv_tensor *a, gv_tensor *b); /* a / b, broadcast */
gv_tensor *gv_scale(gv_graph *g, gv_tensor *x, float s);    /* s * x */
gv_tensor *gv_affine(gv_graph *g, gv_tensor *x, float s, float c); /* s * x + c */

/* ---- Reductions (nn/ops_reduce.c) ------------------------------------------------------------ */
/* Sum or mean over one axis (negative counts from the end); keepdim keeps it as size 1. */
gv_tensor *gv_sum(gv_graph *g, gv_tensor *x, int axis, int keepdim);
gv_tensor *gv_mean(gv_graph *g, gv_tensor *x, int axis, int keepdim);
/* Sum or mean of all elements: shape [1]. */
gv_tensor *gv_sum_all(gv_graph *g, gv_tensor *x);
gv_tensor *gv_mean_all(gv_graph *g, gv_tensor *x);

/* ---- Shapes (nn/ops_shape.c) ------------------------------------------------------------------ */
/* Same data, new shape (one entry may be -1: inferred). A view: no copy. */
gv_tensor *gv_reshape(gv_graph *g, gv_tensor *x, int ndim, const int *shape);
/* out.shape[i] = x.shape[perm[i]] (a copy). */
gv_tensor *gv_permute(gv_graph *g, gv_tensor *x, const int *perm);
/* Swaps two axes (a permute). */
gv_tensor *gv_transpose(gv_graph *g, gv_tensor *x, int axis_a, int axis_b);
/* Joins n tensors along an axis; all other sizes must agree. */
gv_tensor *gv_concat(gv_graph *g, gv_tensor **xs, int n, int axis);
/* x[..., start:start+len, ...] along one axis. */
gv_tensor *gv_slice(gv_graph *g, gv_tensor *x, int axis, int start, int len);
/* Tiles x `times` times along an axis: out[.., r*n + i, ..] = x[.., i, ..]. */
gv_tensor *gv_repeat(gv_graph *g, gv_tensor *x, int axis, int times);

/* ---- Matrix products (nn/ops_matmul.c) ------------------------------------------------------ */
/* Batched product op(a) op(b): a [..., M, K] ([..., K, M] when trans_a), b [..., K, N]
 * ([..., N, K] when trans_b) with the same leading dimensions as a, or b 2-D shared by every
 * batch. Output [..., M, N]. */
gv_tensor *gv_matmul(gv_graph *g, gv_tensor *a, gv_tensor *b, int trans_a, int trans_b);
/* y = x W^T + bias, PyTorch layout: x [..., in], W [out, in], bias [out] or NULL. */
gv_tensor *gv_linear(gv_graph *g, gv_tensor *x, gv_tensor *w, gv_tensor *bias);
/* C [M, N] = A [M, K] B [K, N], row-major with leading dimensions lda, ldb, ldc, outside any
 * graph: the engine's product (CBLAS) for code that keeps its own buffers (LPIPS). */
void gv_gemm(int M, int N, int K, const float *A, int lda, const float *B, int ldb, float *C, int ldc);
/* The same with B transposed: C [M, N] = A [M, K] B^T, B [N, K] (a PyTorch Linear's weight). */
void gv_gemm_nt(int M, int N, int K, const float *A, int lda, const float *B, int ldb, float *C,
                int ldc);

/* LoRA layer (nn/lora.c): x W^T + bias + scale (x A^T) B^T with A [r, in], B [out, r]; W is
 * usually frozen and B zero-initialised (docs/ARCHITECTURE.md 6.7). Made of linear ops. */
gv_tensor *gv_lora_linear(gv_graph *g, gv_tensor *x, gv_tensor *w, gv_tensor *bias,
                          gv_tensor *a, gv_tensor *b, float scale);
/* Merges an adapter into its base weight: W += scale B A. */
int gv_lora_merge(gv_tensor *w, const gv_tensor *a, const gv_tensor *b, float scale);

/* ---- Normalisation (nn/ops_norm.c) ----------------------------------------------------------- */
/* LayerNorm over the last axis: (x - mean) / sqrt(var + eps) * w + b; w and b [D] or NULL
 * (Wan's norm1/norm2 have no affine, norm3 has). */
gv_tensor *gv_layer_norm(gv_graph *g, gv_tensor *x, gv_tensor *w, gv_tensor *b, float eps);
/* RMSNorm over the last axis: x / sqrt(mean(x^2) + eps) * w; w [D] or NULL (Wan's q/k norm). */
gv_tensor *gv_rms_norm(gv_graph *g, gv_tensor *x, gv_tensor *w, float eps);
/* Wan VAE RMS_norm over one axis (docs/reference/wan-vace-gaussvid.md section 4.2):
 * x / max(||x||_2, floor) * sqrt(C) * gamma, with gamma [C] or NULL; floor is 1e-12 in Wan. */
gv_tensor *gv_rms_norm_axis(gv_graph *g, gv_tensor *x, gv_tensor *gamma, int axis, float floor);

/* ---- Activations (nn/ops_activation.c) -------------------------------------------------------- */
/* 0.5 x (1 + tanh(sqrt(2/pi) (x + 0.044715 x^3)))
 * (docs/reference/wan-vace-gaussvid.md section 2.5). */
gv_tensor *gv_gelu(gv_graph *g, gv_tensor *x);
gv_tensor *gv_silu(gv_graph *g, gv_tensor *x);    /* x * sigmoid(x) */
gv_tensor *gv_sigmoid(gv_graph *g, gv_tensor *x);
gv_tensor *gv_softmax(gv_graph *g, gv_tensor *x); /* over the last axis */

/* ---- Attention (nn/ops_attention.c) ---------------------------------------------------------- */
/* Multi-head scaled dot-product attention in the token-major layout that linear layers
 * produce: q [..., Nq, H*Dk], k [..., Nk, H*Dk], v [..., Nk, H*Dv] (head h owns columns
 * h*Dk..h*Dk+Dk-1). mask [Nq, Nk] (added to the scores of every batch and head; -INFINITY
 * removes a key; a row that removes every key gives zeros) or NULL; no gradient flows to
 * it. scale is usually 1/sqrt(Dk). Output [..., Nq, H*Dv]. The Nq x Nk score matrix is never
 * stored: the backward pass recomputes it block by block from the saved log-sum-exp. */
gv_tensor *gv_attention(gv_graph *g, gv_tensor *q, gv_tensor *k, gv_tensor *v,
                        gv_tensor *mask, int n_heads, float scale);

/* ---- Rotary position embedding (nn/ops_rope.c) ----------------------------------------------- */
/* Wan2.1's 3D RoPE table (docs/reference/wan-vace-gaussvid.md section 2.6) for N tokens at integer
 * positions pos[3*i+0..2] = (frame, row, column): per head, head_dim/2 adjacent (real, imag) pairs,
 * split frame / height / width as head_dim - 4*(head_dim/6), 2*(head_dim/6), 2*(head_dim/6)
 * dimensions, each axis with frequencies 10000^(-2j/axis_dim). Shape [N, head_dim/2, 2]
 * holding (cos, sin), computed in double. */
gv_tensor *gv_rope3d_table(gv_graph *g, const int *pos, int n_tokens, int head_dim);
/* The table for a frames x rows x cols grid in token order frame-major, then row, then
 * column (docs/reference/wan-vace-gaussvid.md section 2.2). */
gv_tensor *gv_rope3d_table_grid(gv_graph *g, int frames, int rows, int cols, int head_dim);
/* Rotates every head of x [..., N, H*head_dim] by the table [N, head_dim/2, 2]. */
gv_tensor *gv_rope(gv_graph *g, gv_tensor *x, gv_tensor *table, int n_heads);

/* ---- Convolution (nn/ops_conv.c) ------------------------------------------------------------- */
/* Strides (t, h, w) and zero paddings (t front, t back, h top, h bottom, w left, w right). A
 * causal temporal padding of a kernel kt is front kt-1, back 0 (Wan CausalConv3d with
 * padding p: front 2p, back 0). */
typedef struct {
    int stride[3];
    int pad[6];
} gv_conv_geom;
/* Symmetric padding p_t, p_h, p_w and stride s in every axis. */
gv_conv_geom gv_conv_geom_same(int s, int p_t, int p_h, int p_w);
/* Wan CausalConv3d(padding (p_t, p_h, p_w)): front 2 p_t, back 0; spatial p on both sides. */
gv_conv_geom gv_conv_geom_causal(int s_t, int s_hw, int p_t, int p_h, int p_w);
/* x [B, Cin, T, H, W], w [Cout, Cin, kt, kh, kw], bias [Cout] or NULL -> [B, Cout, To, Ho, Wo]
 * with To = (T + pad_t - kt) / stride_t + 1 (and so on). im2col + GEMM in column chunks. */
gv_tensor *gv_conv3d(gv_graph *g, gv_tensor *x, gv_tensor *w, gv_tensor *bias,
                     const gv_conv_geom *geom);
/* x [B, Cin, H, W], w [Cout, Cin, kh, kw]; geom->stride[0] and pad[0..1] must be 1 and 0. */
gv_tensor *gv_conv2d(gv_graph *g, gv_tensor *x, gv_tensor *w, gv_tensor *bias,
                     const gv_conv_geom *geom);

/* ---- Resampling (nn/ops_resample.c) ---------------------------------------------------------- */
/* Pixel unshuffle generalised to time: x [B, C, T, H, W] (or [B, C, H, W] with rt = 1) ->
 * [B, C*rt*rh*rw, T/rt, H/rh, W/rw], out channel ((c*rt + dt)*rh + dy)*rw + dx (PyTorch's
 * pixel_unshuffle order; with rh = rw = 1 it is the Plücker packing channel = c*4 + k). */
gv_tensor *gv_pixel_unshuffle(gv_graph *g, gv_tensor *x, int rt, int rh, int rw);
/* The inverse of gv_pixel_unshuffle. */
gv_tensor *gv_pixel_shuffle(gv_graph *g, gv_tensor *x, int rt, int rh, int rw);
/* Nearest-neighbour upsampling of the last three axes (last two for a 4-D x) by integer
 * factors (ft must be 1 for a 4-D x). */
gv_tensor *gv_upsample_nearest(gv_graph *g, gv_tensor *x, int ft, int fh, int fw);

/* ---- Embeddings (nn/ops_embed.c) ------------------------------------------------------------- */
/* Wan's sinusoidal timestep embedding (docs/reference/wan-vace-gaussvid.md section 2.3): [n, dim]
 * with [cos(t w_0..), sin(t w_0..)], w_i = 10000^(-i/(dim/2)), computed in double; a leaf. */
gv_tensor *gv_timestep_embedding(gv_graph *g, const float *t, int n, int dim);

/* ---- Losses (nn/ops_loss.c) ------------------------------------------------------------------ */
/* Mean over all elements of w_b * |pred - target| (L1) or w_b * (pred - target)^2 (L2),
 * where b is the index along the first axis and weights [B] (or NULL: all 1) carries no
 * gradient. Shape [1]. */
gv_tensor *gv_l1_loss(gv_graph *g, gv_tensor *pred, gv_tensor *target, gv_tensor *weights);
gv_tensor *gv_l2_loss(gv_graph *g, gv_tensor *pred, gv_tensor *target, gv_tensor *weights);

#endif
