/* The configuration of a whole GaussVid restoration model: the Wan2.1 DiT with its VACE
 * context branch, the Wan2.1-family causal 3D VAE, the Plücker camera encoder, LoRA and the
 * ablation variants (docs/ARCHITECTURE.md section 6). The DiT and VAE fields carry the official Wan2.1
 * hyper-parameter names (docs/reference/wan-vace-gaussvid.md sections 2.1, 3.1, 4.1, including the
 * official spelling "temperal_downsample"); the rest are this project's. Configs are JSON
 * files (docs/MODEL.md) or built-in presets: tiny, small, wan2.1-vace-1.3b, wan2.1-vace-14b. */
#ifndef GAUSSVID_MODEL_CONFIG_H
#define GAUSSVID_MODEL_CONFIG_H

#define GV_MAX_LAYERS 256         /* num_layers and the length of vace_layers */
#define GV_VAE_MAX_LEVELS 4       /* length of dim_mult (the official decoder allows 2..4) */
#define GV_VAE_MAX_Z_DIM 64       /* latent channels (z_dim) */
#define GV_VAE_MAX_ATTN_SCALES 8
#define GV_LORA_MAX_TARGETS 16
#define GV_LORA_TARGET_MAX 16     /* bytes of one target name, with the terminating NUL */
#define GV_CONFIG_NAME_MAX 64

/* The DiT with the VACE branch (official WanModel / VaceWanModel arguments). */
typedef struct {
    int dim, ffn_dim, freq_dim, text_dim, num_heads, num_layers;
    int n_vace_layers;                 /* 0: no VACE branch */
    int vace_layers[GV_MAX_LAYERS];    /* main blocks that receive a hint, increasing, from 0 */
    int vace_in_dim;                   /* 2 z_dim + spatial_factor^2 (inactive, reactive, mask) */
    int patch_size[3];                 /* t, h, w */
    int in_dim, out_dim, text_len;
    double eps;
    int qk_norm, cross_attn_norm;      /* official flags; both true in Wan2.1 */
    int cross_attn;                    /* project field: text cross-attention present */
} gv_dit_config;

/* The VAE (official WanVAE_ arguments) plus this project's fields. */
typedef struct {
    int dim, z_dim;
    int n_levels;                      /* length of dim_mult, 2..4 */
    int dim_mult[GV_VAE_MAX_LEVELS];
    int num_res_blocks;
    int n_attn_scales;
    double attn_scales[GV_VAE_MAX_ATTN_SCALES];
    int temperal_downsample[GV_VAE_MAX_LEVELS - 1]; /* n_levels - 1 flags, official spelling */
    int temporal_factor;               /* 1 or 4 = 2^(number of true flags) */
    int spatial_factor;                /* 2^(n_levels - 1) */
    int has_latent_stats;              /* per-channel normalisation z = (mu - mean) / std */
    double latent_mean[GV_VAE_MAX_Z_DIM], latent_std[GV_VAE_MAX_Z_DIM];
} gv_vae_config;

/* Plücker token encoder sizes (paper 3.3.1; the authors' 14B encoder: 128, 256, D). */
typedef struct {
    int channels;      /* Conv3D output channels per stream (monolithic/early: 2x this) */
    int gate_hidden;   /* hidden width of the cross-gating MLPs (monolithic: 2x, residual MLP) */
    int proj_hidden;   /* projection 2 channels -> proj_hidden -> dim */
    double gamma_init; /* learnable output scale, paper: 0.1 */
} gv_camera_config;

/* LoRA adapters (docs/ARCHITECTURE.md 6.7). A target matches a linear layer of a block whose path within
 * the block equals it or ends with "." + target (PEFT's rule), so "q" adapts self_attn.q and
 * cross_attn.q. */
typedef struct {
    int rank;          /* 0: no adapters */
    double alpha;      /* the update is (alpha / rank) B A */
    int n_targets;
    char targets[GV_LORA_MAX_TARGETS][GV_LORA_TARGET_MAX];
    int blocks, vace_blocks; /* which block lists get adapters */
} gv_lora_config;

typedef enum { GV_CAMERA_NONE, GV_CAMERA_EARLY, GV_CAMERA_MONOLITHIC, GV_CAMERA_DECOMPOSED } gv_camera_variant;
typedef enum { GV_ANCHORS_NONE, GV_ANCHORS_FIRST, GV_ANCHORS_BOTH } gv_anchors;

/* The ablation switches of docs/ARCHITECTURE.md 6.6 that change the network. */
typedef struct {
    gv_camera_variant camera;
    gv_anchors anchors;
    int per_frame;     /* single frames, no anchors, no temporal attention */
    int skip;          /* fine-tuned output with the analytic skip: v = (1 - t)/t (x_t - z_hat) + t F
                          (docs/TRAINING.md "Output parameterisation"); changes no weight */
    int residual;      /* fine-tuned output as the restoration residual: eps - v = z_hat + F, the
                          head relearned from zero and trained (docs/TRAINING.md); not with skip */
    int coverage;      /* the VACE mask M per pixel on the intermediates: 1 where no anchor sees the
                          pixel, 0 where one does (the clip's coverage plane; condition.h); needs
                          anchors both, not per-frame; changes no weight */
} gv_variant_config;

typedef struct {
    char name[GV_CONFIG_NAME_MAX];
    gv_dit_config dit;
    gv_vae_config vae;
    gv_camera_config camera;
    gv_lora_config lora;
    gv_variant_config variant;
} gv_model_config;

/* ---- presets and files ---------------------------------------------------------------- */
/* The names of the built-in presets, NULL-terminated. */
const char *const *gv_model_preset_names(void);
/* Fills c with a built-in preset; fails (naming the known presets) for an unknown name. */
int gv_model_config_preset(gv_model_config *c, const char *name);
/* A preset name, or else the path of a JSON config file (a spec with '/' or ending in .json
 * is always a path). */
int gv_model_config_load(gv_model_config *c, const char *preset_or_path);
/* Parses and validates JSON text; `source` (a file name) starts every error message. */
int gv_model_config_parse(gv_model_config *c, const char *json, const char *source);
/* Checks every field and the fields' agreement (heads divide dim, in_dim = z_dim, ...). */
int gv_model_config_validate(const gv_model_config *c, const char *source);
/* The config as indented JSON with every field (variant.coverage only when true, so the configs
 * of the other variants read as before) (malloc'd; free with free()), or NULL. */
char *gv_model_config_to_json(const gv_model_config *c);
/* Writes the JSON form to a file atomically. */
int gv_model_config_write(const gv_model_config *c, const char *path);
/* 1 when two configs describe the same model and variant, else 0. */
int gv_model_config_equal(const gv_model_config *a, const gv_model_config *b);

/* ---- variants ------------------------------------------------------------------------- */
/* Applies overrides "key=value[,key=value...]": camera=none|early|monolithic|decomposed,
 * anchors=none|first|both, per_frame=true|false, skip=true|false, residual=true|false,
 * coverage=true|false, lora=RANK (0 removes the adapters); a bare camera name, "per-frame",
 * "skip", "residual" or "coverage" is short for the key form. Validates the result. */
int gv_model_config_set_variant(gv_model_config *c, const char *spec, const char *source);
/* What --variant takes, for the commands' help. */
#define GV_VARIANT_HELP                                                                            \
    "comma-separated: camera=none|early|monolithic|decomposed, anchors=none|first|both, per-frame, " \
    "skip or residual (the output form), coverage, lora=R (docs/MODEL.md)"
const char *gv_camera_variant_name(gv_camera_variant v);
const char *gv_anchors_name(gv_anchors a);

/* ---- derived sizes -------------------------------------------------------------------- */
/* The camera encoder's Conv3D kernel (= stride): VAE factor x DiT patch per axis (t, h, w). */
void gv_model_camera_kernel(const gv_model_config *c, int kernel[3]);
/* 1 when camera tokens form a second stream in the blocks (monolithic, decomposed). */
int gv_model_has_camera_stream(const gv_model_config *c);

/* Forward cost of the DiT + VACE + camera encoder on one clip (multiply-add = 2 FLOP),
 * assuming dense attention over video + camera tokens (the asymmetric mask applied, not
 * exploited). The VAE is not included: clip latents are cached (docs/ARCHITECTURE.md 6.2). */
typedef struct {
    int latent_frames, latent_height, latent_width;
    int video_tokens, camera_tokens;      /* per DiT evaluation */
    int evaluations;                      /* frames for the per-frame restorer, else 1 */
    double flops_blocks_linear, flops_blocks_attention, flops_cross_attention;
    double flops_vace, flops_camera, flops_lora, flops_embed_head, flops_total;
} gv_model_cost;
/* Fails when the clip does not fit the grid (frames = 1 + k temporal_factor; height and
 * width multiples of spatial_factor x patch). */
int gv_model_cost_estimate(const gv_model_config *c, int frames, int height, int width,
                           gv_model_cost *out);

#endif
