/* The published GaussVid checkpoint (one safetensors file, "epoch-4.safetensors") applied to
 * a Wan2.1-VACE release as the authors' loader applies it (docs/GAUSSVID_RELEASE.md):
 *
 *   - keys are routed by prefix, tested in this order: "pipe.vace." (the VACE branch),
 *     "pipe.dit." (the DiT), "pipe.vae.model.decoder." (VAE decoder tensors); a key under
 *     "pipe.vae." containing "decoder" elsewhere is a decoder entry under its full name (it
 *     never matches, and is listed as skipped); every other key is ignored;
 *   - under pipe.dit. and pipe.vace., a key with a path component "lora_B" (PEFT) or
 *     "lora_up" (kohya) names a LoRA pair: the component after it is dropped when one more
 *     follows (PEFT's adapter name, "default"), a leading "diffusion_model" is dropped, the
 *     last component must be "weight" and the rest is the module path; its partner is the
 *     same key with lora_A (lora_down). Other keys there (full parameters, alpha tensors,
 *     lora_A without its lora_B) are ignored: the release's fuser has no alpha;
 *   - a pair fuses into the base tensor MODULE.weight: W <- bf16(bf16(W) + bf16(B A)), with B
 *     and A rounded to bf16 first, B A summed over the rank in ascending order in double and
 *     rounded to float32 then to bf16 (one GPU GEMM with float32 accumulation, then bf16);
 *     or, at float32 precision, W + B A with no bf16 anywhere (for inspection);
 *   - a decoder entry NAME replaces the VAE tensor "decoder.NAME" when it exists with the same
 *     shape (rounded to bf16 as the release's bf16 VAE holds it); otherwise it is skipped.
 *
 * Stricter than the release where the release would run a different network silently: a
 * LoRA pair whose module is not a 2-D weight of its target (pipe.dit.: the tensors not
 * starting with "vace"; pipe.vace.: those starting with "vace"), whose shapes do not match it
 * or each other, a lora_B without its lora_A, two pairs for one module, or a tensor that is
 * not F32, F16, BF16 or F64 fails naming the key. */
#ifndef GAUSSVID_RELEASE_LORA_H
#define GAUSSVID_RELEASE_LORA_H

#include <stdint.h>
#include <stdio.h>

#include "gaussvid/io/safetensors.h"

/* What happens to a key of the checkpoint. */
typedef enum {
    GV_RKEY_FUSED,             /* one of a LoRA pair, fused into a base tensor */
    GV_RKEY_DECODER_REPLACED,  /* replaces a VAE decoder tensor */
    GV_RKEY_DECODER_UNKNOWN,   /* a decoder entry naming no VAE tensor: skipped */
    GV_RKEY_DECODER_SHAPE,     /* a decoder entry of another shape than its tensor: skipped */
    GV_RKEY_DECODER_NO_VAE,    /* a decoder entry, no VAE given: skipped */
    GV_RKEY_IGNORED_PREFIX,    /* not under pipe.dit., pipe.vace. or a pipe.vae decoder */
    GV_RKEY_IGNORED_NOT_LORA,  /* under pipe.dit./pipe.vace. but no LoRA weight (alpha, full
                                  parameters, ...) */
    GV_RKEY_IGNORED_UNPAIRED,  /* a lora_A/lora_down no lora_B/lora_up names */
    GV_RKEY_N_FATES
} gv_release_fate;

typedef struct {
    const char *key;           /* into the checkpoint file */
    gv_release_fate fate;
    char target[200];          /* the base or VAE tensor it goes to (fused, decoder) */
} gv_release_key;

typedef struct {
    char weight[200];          /* the base tensor, e.g. "blocks.0.self_attn.q.weight" */
    const gv_st_tensor *a, *b; /* lora_A [r, in] and lora_B [out, r] in the checkpoint */
    int rank;
} gv_release_module;

typedef struct {
    int n_keys;
    gv_release_key *keys;      /* in the file's order */
    int n_modules;
    gv_release_module *modules;/* sorted by weight name */
    int count[GV_RKEY_N_FATES];/* keys per fate */
    int rank_min, rank_max;    /* over the modules (0 when none) */
} gv_release_plan;

/* Routes every key of `lora` against the base (DiT + VACE tensors, official names) and, when
 * given, the VAE (official names, "decoder.*"); fails naming the key (see above). */
int gv_release_plan_build(gv_release_plan *p, const gv_st_file *lora, const gv_st_file *base, const gv_st_file *vae);
void gv_release_plan_free(gv_release_plan *p);
/* The pair fused into that base tensor, or NULL. */
const gv_release_module *gv_release_plan_module(const gv_release_plan *p, const char *weight);
/* The decoder entry replacing that VAE tensor ("decoder.*"), or NULL. */
const gv_st_tensor *gv_release_plan_decoder(const gv_release_plan *p, const gv_st_file *lora, const char *vae_name);
/* The fate's word as --list-keys prints it ("fused", "replaced", "skipped", "ignored"). */
const char *gv_release_fate_word(gv_release_fate f);
/* "12 modules fused (24 keys, rank 4), 1 decoder tensor replaced, 2 decoder entries skipped
 * (1 unknown name, 1 other shape), 5 keys ignored (2 outside the prefixes, ...)". */
void gv_release_plan_summary(const gv_release_plan *p, char *out, size_t size);
/* One line per key: its fate, the key, and its target or the reason. */
void gv_release_plan_list(const gv_release_plan *p, FILE *out);

typedef enum { GV_FUSE_BF16, GV_FUSE_F32 } gv_fuse_precision;
/* "bf16" or "f32". */
int gv_fuse_precision_from_name(const char *name, gv_fuse_precision *out);

/* The fused weight of one module into out (numel floats of w, bf16 values at GV_FUSE_BF16);
 * the base tensor w belongs to `base`, the pair m to `lora`. */
int gv_release_fuse(const gv_st_file *base, const gv_st_tensor *w, const gv_st_file *lora, const gv_release_module *m,
                    gv_fuse_precision precision, float *out);

/* One tensor made when a safetensors builder writes it (gv_st_add_produced): the base tensor
 * fused with its pair (module set), replaced by a checkpoint entry (replacement set), or
 * converted; stored as BF16 (GV_FUSE_BF16) or F32. Must live until the write. */
typedef struct {
    const gv_st_file *file;           /* where `tensor` lives */
    const gv_st_tensor *tensor;       /* the base or VAE tensor */
    const gv_st_file *lora;
    const gv_release_module *module;  /* fused when set */
    const gv_st_tensor *replacement;  /* a decoder entry of the checkpoint when set */
    gv_fuse_precision precision;
} gv_release_job;
int gv_release_add_job(gv_st_builder *b, gv_release_job *job);

/* `gaussvid model merge`: writes out_path with every tensor of base (fused where the plan
 * has a pair; at GV_FUSE_BF16 every float tensor as BF16, at GV_FUSE_F32 as F32; other dtypes
 * copied), tensor by tensor; and, with vae and vae_out, the VAE with the decoder entries
 * replaced (same precision rule). Base and VAE metadata are kept, plus "merged_lora". */
int gv_release_merge(const gv_release_plan *p, const gv_st_file *lora, const gv_st_file *base, const char *out_path,
                     const gv_st_file *vae, const char *vae_out, gv_fuse_precision precision);

#endif
