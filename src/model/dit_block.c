/* Wan2.1 attention blocks (docs/reference/wan-vace-gaussvid.md 2.5) and their dual-stream form
 * (paper 3.3.2, docs/ARCHITECTURE.md 6.5): adaptive-LayerNorm modulation, self-attention with
 * RMSNorm on q and k over the full width and 3D RoPE, cross-attention to the text context,
 * GELU(tanh) FFN, gated residuals.
 *
 * Camera tokens go through the same block weights (LoRA included) with their own modulation
 * (the block's camera_modulation + e0 of t = 0), attend to camera keys only, and skip
 * cross-attention. Video queries see [video keys; camera keys]. Splitting the joint attention
 * this way is exactly the asymmetric mask of the paper; gv_dit_block_joint computes the masked
 * form literally (the reference the tests compare with). */
#include "model/dit_internal.h"
#include "gaussvid/core/core.h"

#include <math.h>

gv_tensor *gv_dit_mod_row(gv_graph *g, gv_tensor *mod, int i)
{
    return gv_slice(g, mod, 1, i, 1);
}

gv_tensor *gv_dit_modulate(gv_graph *g, gv_tensor *x, gv_tensor *mod, int s, float eps)
{
    gv_tensor *shift = gv_dit_mod_row(g, mod, s), *scale = gv_affine(g, gv_dit_mod_row(g, mod, s + 1), 1.0f, 1.0f);
    if (mod && mod->shape[0] == 1) { /* one modulation for every row: LayerNorm's own affine, one pass */
        int D = mod->shape[2];
        return gv_layer_norm(g, x, gv_reshape(g, scale, 1, &D), gv_reshape(g, shift, 1, &D), eps);
    }
    return gv_add(g, gv_mul(g, gv_layer_norm(g, x, NULL, NULL, eps), scale), shift);
}

static float eps_of(const gv_dit *m)
{
    return (float)m->cfg.dit.eps;
}

static float attn_scale(const gv_dit *m)
{
    return 1.0f / sqrtf((float)(m->cfg.dit.dim / m->cfg.dit.num_heads));
}

/* Self-attention inputs of tokens h: q and k RMSNorm-ed over D (before the head split), then
 * rotated by the RoPE table; v plain (docs/reference/wan-vace-gaussvid.md 2.5). */
static void self_qkv(gv_graph *g, const gv_dit *m, const gv_dit_block *b, gv_tensor *h, gv_tensor *rope,
                     gv_tensor **q, gv_tensor **k, gv_tensor **v)
{
    int heads = m->cfg.dit.num_heads;
    *k = gv_dit_lin(g, m, &b->k, h);
    *v = gv_dit_lin(g, m, &b->v, h);
    if (b->norm_k) *k = gv_rms_norm(g, *k, b->norm_k, eps_of(m));
    *k = gv_rope(g, *k, rope, heads);
    if (!q) return; /* keys and values only */
    *q = gv_dit_lin(g, m, &b->q, h);
    if (b->norm_q) *q = gv_rms_norm(g, *q, b->norm_q, eps_of(m));
    *q = gv_rope(g, *q, rope, heads);
}

/* x + CrossAttn(norm3(x), ctx): no gate, no RoPE (docs/reference/wan-vace-gaussvid.md 2.5). */
static gv_tensor *cross_attention(gv_graph *g, const gv_dit *m, const gv_dit_block *b, gv_tensor *x, gv_tensor *ctx)
{
    gv_tensor *h = b->norm3_w ? gv_layer_norm(g, x, b->norm3_w, b->norm3_b, eps_of(m)) : x;
    gv_tensor *q = gv_dit_lin(g, m, &b->cq, h), *k = gv_dit_lin(g, m, &b->ck, ctx), *v = gv_dit_lin(g, m, &b->cv, ctx);
    if (b->cnorm_q) {
        q = gv_rms_norm(g, q, b->cnorm_q, eps_of(m));
        k = gv_rms_norm(g, k, b->cnorm_k, eps_of(m));
    }
    gv_tensor *a = gv_attention(g, q, k, v, NULL, m->cfg.dit.num_heads, attn_scale(m));
    return gv_add(g, x, gv_dit_lin(g, m, &b->co, a));
}

/* x + gate_f FFN(LN(x) (1 + scale_f) + shift_f). */
static gv_tensor *ffn(gv_graph *g, const gv_dit *m, const gv_dit_block *b, gv_tensor *x, gv_tensor *mod)
{
    gv_tensor *h = gv_dit_modulate(g, x, mod, 3, eps_of(m));
    gv_tensor *f = gv_dit_lin(g, m, &b->ffn2, gv_gelu(g, gv_dit_lin(g, m, &b->ffn0, h)));
    return gv_add(g, x, gv_mul(g, f, gv_dit_mod_row(g, mod, 5)));
}

gv_tensor *gv_dit_block_video(gv_graph *g, const gv_dit *m, const gv_dit_block *b, gv_tensor *x, gv_tensor *e0,
                              gv_tensor *rope, gv_tensor *ctx, gv_tensor *kc, gv_tensor *vc)
{
    gv_tensor *mod = gv_add(g, b->modulation, e0), *q, *k, *v;
    self_qkv(g, m, b, gv_dit_modulate(g, x, mod, 0, eps_of(m)), rope, &q, &k, &v);
    if (kc) { /* video queries see every key: their own and the camera stream's */
        k = gv_concat(g, (gv_tensor *[]){k, kc}, 2, 1);
        v = gv_concat(g, (gv_tensor *[]){v, vc}, 2, 1);
    }
    gv_tensor *a = gv_attention(g, q, k, v, NULL, m->cfg.dit.num_heads, attn_scale(m));
    x = gv_add(g, x, gv_mul(g, gv_dit_lin(g, m, &b->o, a), gv_dit_mod_row(g, mod, 2)));
    if (ctx && b->cq.w) x = cross_attention(g, m, b, x, ctx);
    return ffn(g, m, b, x, mod);
}

gv_tensor *gv_dit_block_camera(gv_graph *g, const gv_dit *m, const gv_dit_block *b, gv_tensor *xc, gv_tensor *e0c,
                               gv_tensor *rope, gv_tensor **k_out, gv_tensor **v_out)
{
    gv_tensor *mod = gv_add(g, b->camera_modulation, e0c), *q, *k, *v;
    self_qkv(g, m, b, gv_dit_modulate(g, xc, mod, 0, eps_of(m)), rope, &q, &k, &v);
    *k_out = k;
    *v_out = v;
    if (!q) return NULL;
    gv_tensor *a = gv_attention(g, q, k, v, NULL, m->cfg.dit.num_heads, attn_scale(m)); /* camera keys only */
    xc = gv_add(g, xc, gv_mul(g, gv_dit_lin(g, m, &b->o, a), gv_dit_mod_row(g, mod, 2)));
    return ffn(g, m, b, xc, mod);
}

int gv_dit_block_joint(gv_graph *g, const gv_dit *m, const gv_dit_block *b, gv_tensor **xv, gv_tensor **xc,
                       gv_tensor *e0, gv_tensor *e0c, gv_tensor *rope2, gv_tensor *mask, gv_tensor *ctx)
{
    gv_tensor *mod_v = gv_add(g, b->modulation, e0), *mod_c = gv_add(g, b->camera_modulation, e0c), *q, *k, *v;
    int nv = gv_dim(*xv, 1), nc = gv_dim(*xc, 1);
    gv_tensor *h = gv_concat(g, (gv_tensor *[]){gv_dit_modulate(g, *xv, mod_v, 0, eps_of(m)),
                                                gv_dit_modulate(g, *xc, mod_c, 0, eps_of(m))}, 2, 1);
    self_qkv(g, m, b, h, rope2, &q, &k, &v);
    gv_tensor *o = gv_dit_lin(g, m, &b->o, gv_attention(g, q, k, v, mask, m->cfg.dit.num_heads, attn_scale(m)));
    gv_tensor *x_v = gv_add(g, *xv, gv_mul(g, gv_slice(g, o, 1, 0, nv), gv_dit_mod_row(g, mod_v, 2)));
    gv_tensor *x_c = gv_add(g, *xc, gv_mul(g, gv_slice(g, o, 1, nv, nc), gv_dit_mod_row(g, mod_c, 2)));
    if (ctx && b->cq.w) x_v = cross_attention(g, m, b, x_v, ctx);
    *xv = ffn(g, m, b, x_v, mod_v);
    *xc = ffn(g, m, b, x_c, mod_c);
    return *xv && *xc ? 0 : -1;
}

gv_tensor *gv_dit_camera_e0(gv_graph *g, const gv_dit *m)
{
    const float zero = 0.0f; /* docs/ARCHITECTURE.md 6.5: the camera stream is modulated as at t = 0 */
    gv_tensor *e, *e0;
    return gv_dit_time(g, m, &zero, 1, 0, &e, &e0) == 0 ? e0 : NULL;
}

int gv_dit_camera_stream(gv_graph *g, const gv_dit *m, gv_tensor *xc, gv_tensor *rope, gv_tensor **x, gv_tensor **k,
                         gv_tensor **v)
{
    gv_tensor *e0c = gv_dit_camera_e0(g, m);
    int L = m->cfg.dit.num_layers;
    for (int i = 0; i < L; i++) {
        if (i == L - 1) { /* the last block's camera output feeds nothing: keys and values only */
            gv_tensor *mod = gv_add(g, m->blocks[i].camera_modulation, e0c);
            self_qkv(g, m, &m->blocks[i], gv_dit_modulate(g, xc, mod, 0, eps_of(m)), rope, NULL, &k[i], &v[i]);
            x[i] = NULL;
            return k[i] && v[i] ? 0 : -1;
        }
        gv_arena_mark mark = gv_arena_get_mark(&g->arena);
        xc = x[i] = gv_dit_block_camera(g, m, &m->blocks[i], xc, e0c, rope, &k[i], &v[i]);
        if (!xc || !k[i] || !v[i]) return -1;
        gv_tensor *keep[3] = {x[i], k[i], v[i]}; /* inference: what later blocks and the cache need */
        if (gv_dit_keep_only(g, mark, keep, 3) != 0) return -1;
        xc = x[i] = keep[0], k[i] = keep[1], v[i] = keep[2];
    }
    return 0;
}
