/* Pieces of the DiT shared by its files (dit.c, dit_block.c, vace.c, camera_encoder.c,
 * camera_cache.c, dit_params.c, dit_lora.c, model_io.c). */
#ifndef GAUSSVID_MODEL_DIT_INTERNAL_H
#define GAUSSVID_MODEL_DIT_INTERNAL_H

#include "gaussvid/model/dit.h"

/* y = x W^T + b, plus the LoRA update when the layer has an adapter and it is not merged. */
gv_tensor *gv_dit_lin(gv_graph *g, const gv_dit *m, const gv_dit_linear *l, gv_tensor *x);
/* LayerNorm(x) (1 + scale) + shift with shift = mod[:, s], scale = mod[:, s + 1]; mod is
 * [B, k, D], x [B, N, D] (Wan's adaptive LayerNorm, docs/reference/wan-vace-gaussvid.md 2.5). */
gv_tensor *gv_dit_modulate(gv_graph *g, gv_tensor *x, gv_tensor *mod, int s, float eps);
/* mod[:, i] as [B, 1, D]. */
gv_tensor *gv_dit_mod_row(gv_graph *g, gv_tensor *mod, int i);

/* The per-step conditioning: e = time_embedding(sinusoid(t)) [B, D] and
 * e0 = time_projection(e) as [B, 6, D] (docs/reference/wan-vace-gaussvid.md 2.3). */
/* The time embedding e and its projection e0 of B timesteps; bf16_time: as the release
 * computes it (gv_dit_inputs.bf16_time). */
int gv_dit_time(gv_graph *g, const gv_dit *m, const float *t, int batch, int bf16_time, gv_tensor **e, gv_tensor **e0);

/* A block on the video tokens x [B, N, D] (or a VACE block on its context tokens): modulated
 * self-attention whose keys and values are extended by the camera stream's kc, vc when given
 * (video queries see every key, docs/ARCHITECTURE.md 6.5), cross-attention to ctx (or none), FFN. */
gv_tensor *gv_dit_block_video(gv_graph *g, const gv_dit *m, const gv_dit_block *b, gv_tensor *x, gv_tensor *e0,
                              gv_tensor *rope, gv_tensor *ctx, gv_tensor *kc, gv_tensor *vc);
/* The same block on the camera tokens: its own modulation mod_c [1 or B, 6, D], attention to
 * camera keys only, no cross-attention. Returns the tokens after the block and its keys
 * (after RMSNorm and RoPE) and values. */
gv_tensor *gv_dit_block_camera(gv_graph *g, const gv_dit *m, const gv_dit_block *b, gv_tensor *xc, gv_tensor *mod_c,
                               gv_tensor *rope, gv_tensor **k_out, gv_tensor **v_out);
/* The reference form of the dual-stream block: one attention over [video; camera] with the
 * asymmetric mask [2N, 2N] and the concatenated RoPE table. Updates *xv and *xc. */
int gv_dit_block_joint(gv_graph *g, const gv_dit *m, const gv_dit_block *b, gv_tensor **xv, gv_tensor **xc,
                       gv_tensor *e0, gv_tensor *mod_c, gv_tensor *rope2, gv_tensor *mask, gv_tensor *ctx);

/* The camera tokens' modulation e0(t = 0) as [1, 6, D] (docs/ARCHITECTURE.md 6.5). */
gv_tensor *gv_dit_camera_e0(gv_graph *g, const gv_dit *m);
/* Runs the camera stream through every main block; fills x, k, v (num_layers each). */
int gv_dit_camera_stream(gv_graph *g, const gv_dit *m, gv_tensor *xc, gv_tensor *rope, gv_tensor **x, gv_tensor **k,
                         gv_tensor **v);
/* The tokens of a 5-D feature map [B, C, T, H, W] as [B, T H W, C]. */
gv_tensor *gv_dit_tokens(gv_graph *g, gv_tensor *map);

/* VACE hints (docs/reference/wan-vace-gaussvid.md 3.2): hints[j] for every VACE block from the
 * context tokens and x0. */
/* Inference only (no-grad graph): keeps the n tensors (allocated after `mark`) and releases
 * everything else allocated after it, so a forward pass holds one block's activations at a
 * time instead of all of them. With gradients on it does nothing. Returns 0 or -1. */
int gv_dit_keep_only(gv_graph *g, gv_arena_mark mark, gv_tensor **keep, int n);
int gv_vace_hints(gv_graph *g, const gv_dit *m, const gv_dit_inputs *in, gv_tensor *x0, gv_tensor *e0, gv_tensor *rope,
                  gv_tensor *ctx, gv_tensor **hints);

/* Walks the network's tensors: with params, registers each (frozen) and stores it in its slot;
 * without, only checks names and shapes against the list. Then requires that every non-VAE
 * tensor of the list was bound exactly once. */
int gv_dit_bind(gv_dit *m, const gv_model_config *c, const gv_weight_list *list, gv_params *params,
                unsigned empty_parts);
/* Initial values of every registered tensor from its spec (docs/MODEL.md); tensors
 * registered empty are left to their loader. */
int gv_dit_init_values(gv_dit *m, uint64_t seed);

#endif
