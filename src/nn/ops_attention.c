/* Multi-head scaled dot-product attention with an additive mask, computed block by block of
 * query rows so that only a [rows, Nk] slice of the scores exists at a time (per thread).
 * The forward keeps the log-sum-exp of every row; the backward recomputes the probabilities
 * from it (the memory plan of FlashAttention, with the blocks done by sgemm).
 *
 * Layout: q [B, Nq, H*Dk], k [B, Nk, H*Dk], v [B, Nk, H*Dv], out [B, Nq, H*Dv]; head h uses
 * the columns h*Dk .. h*Dk+Dk-1, so the heads are strided sub-matrices that sgemm reads in
 * place (lda = H*Dk). mask [Nq, Nk] is added to the scores of every batch and head. */
#include <cblas.h>
#include <omp.h>

#include "nn/nn_internal.h"

#define SCORE_BLOCK_FLOATS (1 << 18) /* a block of scores: 1 MiB, about one core's L2 */
#define GROUPS 8 /* fixed split of the query blocks when there are few (batch, head) pairs */

typedef struct {
    int B, Nq, Nk, H, Dk, Dv;
    float scale;
    const float *q, *k, *v, *mask;
    int ldq, ldv; /* H*Dk and H*Dv: row strides of q/k and v/out */
    int rb;       /* query rows per block */
} attn_shape;

/* Query rows per block: as many as fit SCORE_BLOCK_FLOATS scores (between 32 and 256, a
 * multiple of 8). Larger blocks let sgemm pack K and V fewer times; smaller ones keep the
 * scores in cache. It depends on the shape only, so the results do not depend on threads. */
static int row_block(int Nk)
{
    int rb = SCORE_BLOCK_FLOATS / Nk / 8 * 8;
    return rb < 32 ? 32 : (rb > 256 ? 256 : rb);
}

static attn_shape shape_of(const gv_tensor *out)
{
    const int *p = out->iparam;
    attn_shape a = {p[0], p[1], p[2], p[3], p[4], p[5], out->fparam[0],
                    out->src[0]->data, out->src[1]->data, out->src[2]->data,
                    out->n_src > 3 ? out->src[3]->data : NULL, p[3] * p[4], p[3] * p[5], row_block(p[2])};
    return a;
}

/* S [rb, Nk] = scale * Q K^T + mask for query rows r0..r0+rb of batch b, head h. */
static void scores(const attn_shape *a, int b, int h, int r0, int rb, float *S)
{
    const float *Q = a->q + ((int64_t)b * a->Nq + r0) * a->ldq + h * a->Dk;
    const float *K = a->k + (int64_t)b * a->Nk * a->ldq + h * a->Dk;
    cblas_sgemm(CblasRowMajor, CblasNoTrans, CblasTrans, rb, a->Nk, a->Dk, a->scale, Q, a->ldq,
                K, a->ldq, 0.0f, S, a->Nk);
    if (!a->mask) return;
    for (int i = 0; i < rb; i++) {
        const float *m = a->mask + (int64_t)(r0 + i) * a->Nk;
        float *s = S + (int64_t)i * a->Nk;
#pragma omp simd
        for (int j = 0; j < a->Nk; j++) s[j] += m[j];
    }
}

/* ---- forward: out = softmax(scale q k^T + mask) v per head; saved = lse [B, H, Nq] -------- */
static void forward_block(const attn_shape *a, float *out, float *lse, int b, int h, int r0,
                          int rb, float *S)
{
    scores(a, b, h, r0, rb, S);
    for (int i = 0; i < rb; i++) {
        float *s = S + (int64_t)i * a->Nk, max = -INFINITY;
#pragma omp simd reduction(max : max)
        for (int j = 0; j < a->Nk; j++) max = s[j] > max ? s[j] : max;
        float *l = lse + ((int64_t)b * a->H + h) * a->Nq + r0 + i;
        if (max == -INFINITY) { /* every key masked: the row attends to nothing */
            memset(s, 0, (size_t)a->Nk * sizeof(float));
            *l = INFINITY;
            continue;
        }
        float sum = 0;
#pragma omp simd reduction(+ : sum)
        for (int j = 0; j < a->Nk; j++) {
            s[j] = gv_expf(s[j] - max);
            sum += s[j];
        }
        float inv = 1.0f / sum;
#pragma omp simd
        for (int j = 0; j < a->Nk; j++) s[j] *= inv;
        *l = max + logf(sum);
    }
    const float *V = a->v + (int64_t)b * a->Nk * a->ldv + h * a->Dv;
    float *O = out + ((int64_t)b * a->Nq + r0) * a->ldv + h * a->Dv;
    cblas_sgemm(CblasRowMajor, CblasNoTrans, CblasNoTrans, rb, a->Dv, a->Nk, 1.0f, S, a->Nk, V,
                a->ldv, 0.0f, O, a->ldv);
}

int gv_attention_op_forward(gv_graph *g, gv_tensor *out)
{
    attn_shape a = shape_of(out);
    float *lse = out->saved = gv_scratch(g, (int64_t)a.B * a.H * a.Nq);
    if (!lse) return -1;
    gv_arena_mark m = gv_arena_get_mark(&g->arena);
    int n_threads = omp_get_max_threads();
    float *scratch = gv_scratch(g, (int64_t)n_threads * a.rb * a.Nk);
    if (!scratch) return -1;
    int n_blocks = (a.Nq + a.rb - 1) / a.rb;
    int64_t n_items = (int64_t)a.B * a.H * n_blocks;
#pragma omp parallel if ((int64_t)a.B * a.H * a.Nq * a.Nk >= GV_OMP_MIN)
    {
        float *S = scratch + (int64_t)omp_get_thread_num() * a.rb * a.Nk;
#pragma omp for schedule(dynamic, 1)
        for (int64_t it = 0; it < n_items; it++) {
            int blk = (int)(it % n_blocks), h = (int)(it / n_blocks % a.H), b = (int)(it / n_blocks / a.H);
            int r0 = blk * a.rb, rb = a.Nq - r0 < a.rb ? a.Nq - r0 : a.rb;
            forward_block(&a, out->data, lse, b, h, r0, rb, S);
        }
    }
    gv_arena_rewind(&g->arena, m);
    return 0;
}

/* ---- backward for query rows r0..r0+rb of (b, h) -------------------------------------------
 * P = exp(S - lse); dV += P^T dO; dP = dO V^T; dS = P (dP - D) with D_i = dO_i . O_i;
 * dQ += scale dS K; dK += scale dS^T Q. dK and dV go to (dK, ldk) and (dV, ldv), which are
 * either the gradients themselves or a private partial buffer. */
typedef struct {
    const attn_shape *a;
    const float *out, *dout, *lse;
    float *dq; /* NULL when q needs no gradient */
} attn_grads;

static void backward_block(const attn_grads *gr, int b, int h, int r0, int rb, float *dK, int ldk,
                           float *dV, int ldv, float *P, float *dP)
{
    const attn_shape *a = gr->a;
    scores(a, b, h, r0, rb, P);
    const float *dO = gr->dout + ((int64_t)b * a->Nq + r0) * a->ldv + h * a->Dv;
    const float *O = gr->out + ((int64_t)b * a->Nq + r0) * a->ldv + h * a->Dv;
    const float *V = a->v + (int64_t)b * a->Nk * a->ldv + h * a->Dv;
    const float *K = a->k + (int64_t)b * a->Nk * a->ldq + h * a->Dk;
    const float *Q = a->q + ((int64_t)b * a->Nq + r0) * a->ldq + h * a->Dk;
    const float *lse = gr->lse + ((int64_t)b * a->H + h) * a->Nq + r0;
    for (int i = 0; i < rb; i++) {
        float *p = P + (int64_t)i * a->Nk, l = lse[i];
#pragma omp simd
        for (int j = 0; j < a->Nk; j++) p[j] = gv_expf(p[j] - l);
    }
    if (dV)
        cblas_sgemm(CblasRowMajor, CblasTrans, CblasNoTrans, a->Nk, a->Dv, rb, 1.0f, P, a->Nk, dO,
                    a->ldv, 1.0f, dV, ldv);
    if (!dK && !gr->dq) return;
    cblas_sgemm(CblasRowMajor, CblasNoTrans, CblasTrans, rb, a->Nk, a->Dv, 1.0f, dO, a->ldv, V,
                a->ldv, 0.0f, dP, a->Nk);
    for (int i = 0; i < rb; i++) {
        float d = 0;
        for (int j = 0; j < a->Dv; j++) d += dO[(int64_t)i * a->ldv + j] * O[(int64_t)i * a->ldv + j];
        float *p = P + (int64_t)i * a->Nk, *dp = dP + (int64_t)i * a->Nk;
#pragma omp simd
        for (int j = 0; j < a->Nk; j++) dp[j] = p[j] * (dp[j] - d);
    }
    if (gr->dq)
        cblas_sgemm(CblasRowMajor, CblasNoTrans, CblasNoTrans, rb, a->Dk, a->Nk, a->scale, dP, a->Nk,
                    K, a->ldq, 1.0f, gr->dq + ((int64_t)b * a->Nq + r0) * a->ldq + h * a->Dk, a->ldq);
    if (dK)
        cblas_sgemm(CblasRowMajor, CblasTrans, CblasNoTrans, a->Nk, a->Dk, rb, a->scale, dP, a->Nk,
                    Q, a->ldq, 1.0f, dK, ldk);
}

/* Few (batch, head) pairs (fewer than GROUPS): split the query blocks of one pair into GROUPS
 * fixed groups with private dK/dV partials, added in group order (thread-count independent). */
static int backward_grouped(gv_graph *g, const attn_grads *gr, float *dk, float *dv, float *scratch)
{
    const attn_shape *a = gr->a;
    int n_blocks = (a->Nq + a->rb - 1) / a->rb;
    int groups = n_blocks < GROUPS ? n_blocks : GROUPS;
    int64_t kd = (int64_t)a->Nk * a->Dk, vd = (int64_t)a->Nk * a->Dv;
    float *part_k = dk ? gv_scratch(g, groups * kd) : NULL;
    float *part_v = dv ? gv_scratch(g, groups * vd) : NULL;
    if ((dk && !part_k) || (dv && !part_v)) return -1;
    for (int b = 0; b < a->B; b++) {
        for (int h = 0; h < a->H; h++) {
            if (part_k) memset(part_k, 0, (size_t)(groups * kd) * sizeof(float));
            if (part_v) memset(part_v, 0, (size_t)(groups * vd) * sizeof(float));
#pragma omp parallel for schedule(dynamic, 1) if ((int64_t)a->Nq * a->Nk >= GV_OMP_MIN)
            for (int grp = 0; grp < groups; grp++) {
                float *P = scratch + (int64_t)omp_get_thread_num() * 2 * a->rb * a->Nk;
                for (int blk = grp * n_blocks / groups; blk < (grp + 1) * n_blocks / groups; blk++) {
                    int r0 = blk * a->rb, rb = a->Nq - r0 < a->rb ? a->Nq - r0 : a->rb;
                    backward_block(gr, b, h, r0, rb, part_k ? part_k + grp * kd : NULL, a->Dk,
                                   part_v ? part_v + grp * vd : NULL, a->Dv, P, P + a->rb * a->Nk);
                }
            }
#pragma omp parallel for schedule(static) if ((int64_t)a->Nk * (a->Dk + a->Dv) * groups >= GV_OMP_MIN)
            for (int n = 0; n < a->Nk; n++) {
                for (int grp = 0; grp < groups && dk; grp++)
                    for (int j = 0; j < a->Dk; j++)
                        dk[((int64_t)b * a->Nk + n) * a->ldq + h * a->Dk + j] += part_k[grp * kd + (int64_t)n * a->Dk + j];
                for (int grp = 0; grp < groups && dv; grp++)
                    for (int j = 0; j < a->Dv; j++)
                        dv[((int64_t)b * a->Nk + n) * a->ldv + h * a->Dv + j] += part_v[grp * vd + (int64_t)n * a->Dv + j];
            }
        }
    }
    return 0;
}

int gv_attention_op_backward(gv_graph *g, gv_tensor *out)
{
    attn_shape a = shape_of(out);
    attn_grads gr = {&a, out->data, out->grad, out->saved,
                     gv_wants_grad(out, 0) ? out->src[0]->grad : NULL};
    float *dk = gv_wants_grad(out, 1) ? out->src[1]->grad : NULL;
    float *dv = gv_wants_grad(out, 2) ? out->src[2]->grad : NULL;
    int n_threads = omp_get_max_threads();
    float *scratch = gv_scratch(g, (int64_t)n_threads * 2 * a.rb * a.Nk);
    if (!scratch) return -1;
    /* The schedule depends on the shape only, not on the thread count, so the sums are the
     * same with any number of threads. */
    if (a.B * a.H < GROUPS) return backward_grouped(g, &gr, dk, dv, scratch);
    int n_blocks = (a.Nq + a.rb - 1) / a.rb;
#pragma omp parallel for schedule(dynamic, 1) if ((int64_t)a.B * a.H * a.Nq * a.Nk >= GV_OMP_MIN)
    for (int bh = 0; bh < a.B * a.H; bh++) { /* each pair owns its columns of dK and dV */
        int b = bh / a.H, h = bh % a.H;
        float *P = scratch + (int64_t)omp_get_thread_num() * 2 * a.rb * a.Nk;
        for (int blk = 0; blk < n_blocks; blk++) {
            int r0 = blk * a.rb, rb = a.Nq - r0 < a.rb ? a.Nq - r0 : a.rb;
            backward_block(&gr, b, h, r0, rb,
                           dk ? dk + (int64_t)b * a.Nk * a.ldq + h * a.Dk : NULL, a.ldq,
                           dv ? dv + (int64_t)b * a.Nk * a.ldv + h * a.Dv : NULL, a.ldv, P,
                           P + a.rb * a.Nk);
        }
    }
    return 0;
}

gv_tensor *gv_attention(gv_graph *g, gv_tensor *q, gv_tensor *k, gv_tensor *v,
                        gv_tensor *mask, int n_heads, float scale)
{
    if (!q || !k || !v) return NULL;
    char sq[64], sk[64], sv[64];
    int ok = q->ndim >= 2 && k->ndim == q->ndim && v->ndim == q->ndim && n_heads >= 1;
    for (int d = 0; ok && d < q->ndim - 2; d++)
        ok = k->shape[d] == q->shape[d] && v->shape[d] == q->shape[d];
    int C = gv_dim(q, -1), Cv = gv_dim(v, -1), Nq = gv_dim(q, -2), Nk = gv_dim(k, -2);
    ok = ok && C % n_heads == 0 && Cv % n_heads == 0 && gv_dim(k, -1) == C && gv_dim(v, -2) == Nk;
    if (!ok) {
        gv_fail("attention: q %s, k %s, v %s do not fit %d heads", gv_shape_str(q, sq, sizeof sq),
                gv_shape_str(k, sk, sizeof sk), gv_shape_str(v, sv, sizeof sv), n_heads);
        return NULL;
    }
    if (mask && (mask->ndim != 2 || mask->shape[0] != Nq || mask->shape[1] != Nk)) {
        gv_fail("attention: mask %s is not [%d, %d]", gv_shape_str(mask, sq, sizeof sq), Nq, Nk);
        return NULL;
    }
    int64_t B = q->numel / ((int64_t)Nq * C);
    if (gv_check_blas_dims("attention", B * Nq, Nk, C) != 0) return NULL;
    int shape[GV_MAX_DIMS];
    for (int d = 0; d < q->ndim; d++) shape[d] = q->shape[d];
    shape[q->ndim - 1] = Cv;
    gv_tensor *src[4] = {q, k, v, mask};
    gv_tensor *out = gv_op_new(g, GV_OP_ATTENTION, q->ndim, shape, mask ? 4 : 3, src, 0);
    if (!out) return NULL;
    int params[6] = {(int)B, Nq, Nk, n_heads, C / n_heads, Cv / n_heads};
    memcpy(out->iparam, params, sizeof params);
    out->fparam[0] = scale;
    return gv_op_run(g, out);
}
