/* The restoration network's transformer side (docs/ARCHITECTURE.md 6.3-6.7, paper 3.3): the Wan2.1 DiT
 * with its VACE context branch, the Plücker camera token encoder, dual-stream camera
 * injection, the ablation variants and LoRA. Inputs are VAE latents (the VAE is in vae.h).
 *
 * Parameters are built from the weight list of the config (weight_names.h), so every tensor
 * carries its checkpoint name and loading is a lookup by name. Layouts (batch first):
 *   latent   [B, in_dim, T, H, W]          noisy latent x_t (T, H, W latent frames and pixels)
 *   timestep B floats in [0, 1000]         (sigma * 1000, docs/reference/wan-vace-gaussvid.md 2.3)
 *   text     [B, L, text_dim]              precomputed text context (cross_attn configs)
 *   vace     [B, vace_in_dim, T, H, W]     [z_inactive | z_reactive | mask] (vace.c)
 *   plucker  [B, 6, Tp, Hpx, Wpx]          packed ray field (plucker.h), [o x d (3), d (3)]
 *   output   [B, out_dim, T, H, W]         predicted velocity
 * The per-frame restorer takes single-frame latents (T = 1) with the frames as the batch.
 * docs/MODEL.md describes the choices. */
#ifndef GAUSSVID_DIT_H
#define GAUSSVID_DIT_H

#include "gaussvid/model/model_config.h"
#include "gaussvid/nn/nn.h"
#include "gaussvid/model/weight_names.h"

/* A linear layer (PyTorch layout) with its LoRA adapter when the config gives it one. */
typedef struct {
    gv_tensor *w, *b;            /* [out, in], [out] */
    gv_tensor *lora_a, *lora_b;  /* [r, in], [out, r], or NULL */
} gv_dit_linear;

/* One Wan attention block (docs/reference/wan-vace-gaussvid.md 2.5); VACE blocks add before_proj /
 * after_proj. */
typedef struct {
    gv_tensor *modulation;        /* [1, 6, D]: shift, scale, gate (attention), then FFN */
    gv_tensor *camera_modulation; /* [1, 6, D] the camera stream's own (docs/ARCHITECTURE.md 6.5), or NULL */
    gv_dit_linear q, k, v, o;
    gv_tensor *norm_q, *norm_k;   /* [D] RMSNorm gains, or NULL without qk_norm */
    gv_tensor *norm3_w, *norm3_b; /* LayerNorm before cross-attention, or NULL */
    gv_dit_linear cq, ck, cv, co; /* cross-attention (w NULL when absent) */
    gv_tensor *cnorm_q, *cnorm_k;
    gv_dit_linear ffn0, ffn2;
    gv_dit_linear before_proj, after_proj; /* VACE block 0 / every VACE block (w NULL else) */
} gv_dit_block;

/* The Plücker token encoder (paper 3.3.1; docs/ARCHITECTURE.md 6.4). Decomposed: conv_m, conv_d and the
 * cross-gating MLPs; monolithic and early fusion: conv and the residual MLP. */
typedef struct {
    gv_tensor *conv_m_w, *conv_m_b, *conv_d_w, *conv_d_b;
    gv_dit_linear gate_d2m0, gate_d2m2, gate_m2d0, gate_m2d2;
    gv_tensor *conv_w, *conv_b;
    gv_dit_linear mlp0, mlp2;
    gv_dit_linear proj0, proj2;
    gv_tensor *norm_w, *norm_b, *gamma;
} gv_camera_encoder;

typedef enum {
    GV_DIT_FROZEN,    /* inference: nothing trainable, no gradient buffers */
    GV_DIT_FINETUNE,  /* GaussVid fine-tuning: LoRA and camera trainable, base frozen (6.7) */
    GV_DIT_FULL       /* base pretraining: every tensor trainable */
} gv_dit_train_mode;

typedef struct {
    gv_model_config cfg;
    gv_params params;             /* every tensor, by its checkpoint name */
    gv_weight_list weights;       /* the config's weight list (names, modules, inits) */
    gv_tensor *patch_w, *patch_b;
    gv_dit_linear text0, text2, time0, time2, time_proj;
    gv_dit_block *blocks;         /* num_layers */
    gv_dit_block *vace_blocks;    /* n_vace_layers */
    gv_tensor *vace_patch_w, *vace_patch_b;
    gv_tensor *head_modulation;   /* [1, 2, D] */
    gv_dit_linear head;
    gv_camera_encoder camera;
    float lora_scale;             /* alpha / rank */
    int lora_merged;              /* adapters folded into the base weights (gv_dit_merge_lora) */
    int joint_attention;          /* reference path: one attention over [video; camera] with the
                                     asymmetric mask instead of the two equivalent calls */
    gv_dit_train_mode mode;
    float *text;                  /* the prompt's text context [text_len, text_dim] that restore
                                     and training give every forward pass (the cached
                                     text_context.safetensors a checkpoint names), or NULL:
                                     a zero context */
    gv_st_file *mapped;           /* open weight files whose mappings bfloat16 weights point
                                     into (gv_dit_read_param), closed by gv_dit_free */
    int n_mapped;
} gv_dit;

/* Builds every tensor of the config (VAE excluded) from its weight list and initialises them
 * (Wan's scheme; the zero-initialised projections of the spec; docs/MODEL.md). Frozen. */
int gv_dit_init(gv_dit *m, const gv_model_config *cfg, uint64_t seed);
/* The same, but the frozen tensors of loaded_parts (GV_PART_*) get no values: a loader that
 * reads all of them from a file gives each its values (gv_dit_read_param), so no float32
 * copy of a bfloat16 base is ever made. */
int gv_dit_init_parts(gv_dit *m, const gv_model_config *cfg, uint64_t seed, unsigned loaded_parts);
void gv_dit_free(gv_dit *m);
/* Checks, without allocating any data, that the network's tensors (names and shapes, as the
 * forward pass binds them) are exactly the non-VAE tensors of the config's weight list. */
int gv_dit_check_names(const gv_model_config *cfg);
/* Chooses what is trainable (allocates or frees gradients and AdamW moments). */
int gv_dit_set_train_mode(gv_dit *m, gv_dit_train_mode mode);
/* Folds every LoRA adapter into its base weight: W += (alpha / r) B A; afterwards the forward
 * pass ignores the adapters and they are frozen. */
int gv_dit_merge_lora(gv_dit *m);

/* ---- forward ------------------------------------------------------------------------------ */
/* The camera stream of one clip, computed once and reused at every sampling step (it does not
 * depend on the noisy latent or t: docs/ARCHITECTURE.md 6.5). Stale once the weights change. */
typedef struct {
    gv_graph graph;               /* owns the tensors below */
    int batch, grid[3];           /* token grid (frames, rows, columns) */
    gv_tensor *tokens;            /* encoder output x_c [B, N, D] */
    int n_layers;                 /* 0 for early fusion (tokens are added once) */
    gv_tensor **x, **k, **v;      /* per main block: camera tokens after it, its keys (after
                                     RMSNorm and RoPE) and values [B, N, D] */
} gv_dit_camera_cache;

/* What a forward pass exposes for tests and debugging (all optional; tensors of its graph). */
typedef struct {
    gv_tensor *camera_tokens;                  /* encoder output x_c */
    gv_tensor *camera_x[GV_MAX_LAYERS];        /* camera stream after each main block */
    gv_tensor *camera_k[GV_MAX_LAYERS], *camera_v[GV_MAX_LAYERS];
    gv_tensor *hints[GV_MAX_LAYERS];           /* VACE hints (after after_proj, unscaled) */
    gv_tensor *rope_video, *rope_camera;       /* RoPE tables [N, head_dim/2, 2] */
} gv_dit_trace;

typedef struct {
    gv_tensor *latent;            /* required */
    const float *timestep;        /* B values, required */
    gv_tensor *text;              /* required when cfg.dit.cross_attn */
    gv_tensor *vace;              /* NULL: no VACE branch (as the DiT alone) */
    gv_tensor *plucker;           /* NULL: no camera tokens */
    const gv_dit_camera_cache *camera_cache; /* replaces plucker when given */
    float context_scale;          /* VACE hint scale (official default 1) */
    int bf16_time;                /* the release's time embedding: the timestep rounded to bf16
                                     before the sinusoid, the sinusoid rounded to bf16 after it
                                     (docs/GAUSSVID_RELEASE.md) */
    gv_dit_trace *trace;          /* NULL or filled */
    void (*progress)(void *ctx, int done, int total); /* NULL, or told after each VACE and main
                                     block (total = n_vace_layers + num_layers): long passes */
    void *progress_ctx;
} gv_dit_inputs;

/* Default inputs: everything NULL, context_scale 1. */
gv_dit_inputs gv_dit_inputs_default(void);
/* One DiT evaluation: the predicted velocity [B, out_dim, T, H, W], or NULL (message set). */
gv_tensor *gv_dit_forward(gv_dit *m, gv_graph *g, const gv_dit_inputs *in);
/* Runs the camera encoder and the camera stream of every block once (no gradients). */
int gv_dit_camera_cache_build(gv_dit *m, gv_tensor *plucker, gv_dit_camera_cache *cache);
void gv_dit_camera_cache_free(gv_dit_camera_cache *cache);
/* Integer RoPE positions (frame, row, column) of the video tokens of a grid in token order;
 * camera token i takes the position of video token i (docs/ARCHITECTURE.md 6.5). pos holds 3 N ints. */
void gv_dit_video_positions(int frames, int rows, int cols, int *pos);
void gv_dit_camera_positions(int frames, int rows, int cols, int *pos);
/* The camera encoder alone: x_c [B, N, D] from the packed ray field. */
gv_tensor *gv_camera_encoder_forward(const gv_dit *m, gv_graph *g, gv_tensor *plucker);

/* ---- VACE context (docs/reference/wan-vace-gaussvid.md 3.3; docs/ARCHITECTURE.md 6.3) ----- */
/* The pixel mask M of each of `frames` frames for an anchors variant (0 = inactive anchor,
 * 1 = reactive): none: all 1; first: frame 0 is 0; both: frames 0 and frames-1 are 0. */
int gv_vace_frame_mask(gv_anchors anchors, int frames, float *mask);
/* The pixel mask M [frames, H, W] on the latent grid: [sf*sf, latent_frames, H/sf, W/sf],
 * an sf x sf pixel unshuffle (channel = sf * row offset + column offset) then the temporal
 * nearest-exact resize of docs/reference/wan-vace-gaussvid.md 3.3 step 4: latent frame k takes
 * pixel frame min(floor((k + 0.5) frames / latent_frames), frames - 1). */
int gv_vace_mask_latent(const float *mask, int frames, int height, int width, int latent_frames,
                        int spatial_factor, float *out);
/* Concatenates [z_inactive (z) | z_reactive (z) | mask (sf^2)] channels into vace [C, T, h, w]. */
int gv_vace_context_concat(const float *z_inactive, const float *z_reactive, const float *mask_latent,
                           int z_dim, int mask_channels, int frames, int h, int w, float *out);

/* ---- weights (model_io.c) -----------------------------------------------------------------
 * Memory (docs/WAN_WEIGHTS.md "Memory"): a frozen linear weight of the DiT or VACE that the
 * file stores in BF16 stays in the file's mapping (tensor.h, "Weights kept in bfloat16"):
 * each linear layer converts it to float32 when it runs and drops its pages after, so a
 * forward pass holds one weight matrix in float32 at a time. Every other tensor is read as
 * float32. Trainable tensors (LoRA, camera encoder) are always float32. */
/* Gives parameter p its values from tensor p->t.name of f (which must have it with p's
 * shape): kept in BF16 as above (then *kept is set and f must stay open: gv_dit_keep_file),
 * else read as float32 and checked finite. */
int gv_dit_read_param(gv_dit *m, const gv_st_file *f, gv_param *p, int *kept);
/* Hands an open file to the model (closed by gv_dit_free); *f is emptied. */
int gv_dit_keep_file(gv_dit *m, gv_st_file *f);
/* Fails naming the first tensor that has no values (a loader missed it). */
int gv_dit_check_loaded(const gv_dit *m);
/* Tensors of the model kept in BF16, and their bytes. */
int64_t gv_dit_bf16_bytes(const gv_dit *m, int *n_tensors);
/* The text input of a forward pass: m->text in each of the batch rows, or zeros without one. */
gv_tensor *gv_dit_text_input(const gv_dit *m, gv_graph *g, int batch);
/* Sets m->text to a copy of context [text_len, text_dim] (NULL: back to the zero context). */
int gv_dit_set_text(gv_dit *m, const float *context);
/* Loads every tensor of the `parts` (GV_PART_* of weight_names.h; VAE parts ignored) from the
 * files, by name; all of them must be present with their shapes; tensors of other parts in
 * the files are loaded too when the model has them; unknown names fail (listed). */
int gv_dit_load(gv_dit *m, const char *const *paths, int n_paths, unsigned parts);
/* Writes the tensors of the parts (e.g. GV_PART_ADAPTERS for LoRA + camera alone) with the
 * config as "__metadata__" {"config": JSON, "parts": "..."}. */
int gv_dit_save(const gv_dit *m, const char *path, unsigned parts);

/* `gaussvid model run --part dit`: loads the weights (DiT, VACE, camera and LoRA as the config
 * has them), reads the named inputs (latent, timestep, text, vace_context, intrinsics + poses
 * or plucker, context_scale; docs/MODEL.md), runs one forward pass and adds the outputs
 * (velocity, camera_tokens, plucker) to `out`; their data lives in g. */
int gv_dit_run_named(const gv_model_config *c, const char *const *weights, int n_weights, const gv_st_file *inputs,
                     gv_graph *g, gv_st_builder *out);

#endif
