/* Importing a published Wan2.1-VACE release folder (docs/WAN_WEIGHTS.md): the DiT + VACE
 * weights (one safetensors file, or shards with an index; F32 or BF16) and the VAE
 * (Wan2.1_VAE.pth) become a gaussvid base checkpoint and its VAE file, which `restore`,
 * `eval` and `train` take as they take any base. Every tensor is checked by name, shape,
 * dtype and value (no NaN or infinity) against the config; the DiT tensors are copied in
 * their own dtype, straight from the mapped release files, so a 14B import needs no memory
 * beyond the page cache and writes no more bytes than the release holds. */
#ifndef GAUSSVID_MODEL_IMPORT_H
#define GAUSSVID_MODEL_IMPORT_H

#include <stdint.h>

#include "gaussvid/model/model_config.h"

#define GV_RELEASE_PATH_MAX 4200

/* The files of a release folder, as published (huggingface Wan-AI/Wan2.1-VACE-*). */
typedef struct {
    char dit[GV_RELEASE_PATH_MAX];    /* diffusion_pytorch_model.safetensors.index.json, else
                                         diffusion_pytorch_model.safetensors */
    char vae[GV_RELEASE_PATH_MAX];    /* Wan2.1_VAE.pth, else Wan2.1_VAE.safetensors */
    char config[GV_RELEASE_PATH_MAX]; /* the release's config.json, or "" when absent */
    char t5[GV_RELEASE_PATH_MAX];     /* models_t5_umt5-xxl-enc-bf16.pth, or "" */
    char tokenizer[GV_RELEASE_PATH_MAX]; /* google/umt5-xxl/spiece.model, or "" */
    char lora[GV_RELEASE_PATH_MAX];   /* the GaussVid checkpoint to fuse (release_lora.h), or "" */
} gv_release_files;

/* GaussVid's prompt (docs/reference/wan-vace-gaussvid.md 1.2). */
#define GV_GAUSSVID_PROMPT "Remove degradation and restore clean video."

/* Finds the files in dir; a missing DiT or VAE fails naming the folder and the file names
 * looked for. */
int gv_release_find(const char *dir, gv_release_files *files);

typedef struct {
    int dit_tensors;
    int64_t dit_values, dit_bytes;
    int dit_dtypes[4];        /* tensors stored as F32, BF16, F16, F64 */
    int vae_tensors;
    int64_t vae_values;
    char vae_checksum[48];
    int text_tokens;          /* tokens of the prompt's context; 0 when none was computed */
    char lora_summary[512];   /* gv_release_plan_summary of files->lora, or "" */
} gv_import_summary;

/* Checks the release config.json (when there is one) against cfg, the DiT + VACE and VAE
 * tensors against cfg's weight list (dit and vace parts; the VAE; nothing missing,
 * unexpected or mis-shaped; finite values), then writes out_dir/vae.safetensors (F32, with
 * the config and cfg's latent statistics) and out_dir/base.safetensors (a gaussvid base
 * checkpoint: the config with variant camera = none, since the release has no camera
 * encoder; the DiT + VACE tensors in the release's dtypes; the VAE named with its
 * checksum). With a prompt, a text encoder and a tokenizer (files->t5, files->tokenizer), and
 * a config with cross-attention, also out_dir/text_context.safetensors: the prompt's context
 * [text_len, text_dim], named in the base's metadata. The files appear together or not at
 * all. */
/* With files->lora: the GaussVid checkpoint applied as the release applies it
 * (release_lora.h): each fused DiT/VACE weight stored as BF16 with the release's rounding
 * (the others as published), the decoder entries replacing VAE tensors (rounded to bf16). */
int gv_model_import(const gv_release_files *files, const gv_model_config *cfg, const char *prompt,
                    const char *out_dir, gv_import_summary *summary);

#endif
