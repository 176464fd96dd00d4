/* Every parameter tensor a model config implies, by name and shape, and the check of
 * safetensors files against them. For the Wan presets the names and shapes are exactly the
 * keys of the published checkpoints (docs/reference/wan-vace-gaussvid.md sections 2.8, 3.1, 4.3):
 * DiT + VACE in one file family, the VAE in another. tiny and small use the same scheme at
 * their sizes, so loading any size is a name lookup. This project's own tensors (camera
 * encoder, per-block camera modulation, LoRA) are named in docs/MODEL.md. */
#ifndef GAUSSVID_WEIGHT_NAMES_H
#define GAUSSVID_WEIGHT_NAMES_H

#include <stdint.h>

#include "gaussvid/model/model_config.h"
#include "gaussvid/io/safetensors.h"

#define GV_WEIGHT_NAME_MAX 96
#define GV_WEIGHT_MAX_RANK 5

/* The modules parameter counts are reported by. */
typedef enum {
    GV_MODULE_PATCH_EMBEDDING,  /* patch_embedding */
    GV_MODULE_TIME_EMBEDDING,   /* time_embedding, time_projection */
    GV_MODULE_TEXT_EMBEDDING,   /* text_embedding */
    GV_MODULE_BLOCKS,           /* blocks.* (without LoRA and camera modulation) */
    GV_MODULE_HEAD,             /* head.* */
    GV_MODULE_VACE,             /* vace_patch_embedding, vace_blocks.* */
    GV_MODULE_VAE_ENCODER,      /* encoder.*, conv1 */
    GV_MODULE_VAE_DECODER,      /* conv2, decoder.* */
    GV_MODULE_CAMERA,           /* camera_encoder.*, blocks.N.camera_modulation */
    GV_MODULE_LORA,             /* *.lora_A.weight, *.lora_B.weight */
    GV_N_MODULES
} gv_module;

/* Parts, the groups of modules a set of files is expected to provide (bit mask). */
enum {
    GV_PART_DIT = 1,     /* patch, time and text embeddings, blocks, head */
    GV_PART_VACE = 2,
    GV_PART_VAE = 4,
    GV_PART_CAMERA = 8,
    GV_PART_LORA = 16,
    GV_PART_BASE = GV_PART_DIT | GV_PART_VACE | GV_PART_VAE,
    GV_PART_ADAPTERS = GV_PART_CAMERA | GV_PART_LORA,
    GV_PART_ALL = 31
};

/* How a tensor starts when it is not loaded, where the specification fixes it. */
typedef enum {
    GV_INIT_RANDOM,    /* the network's choice (fan-in scaled) */
    GV_INIT_ZEROS,     /* VACE before/after_proj (docs/reference/wan-vace-gaussvid.md 3.1), lora_B,
                          the camera encoder's last projection (paper eq. 3), biases of those */
    GV_INIT_ONES,      /* norm gains */
    GV_INIT_CONSTANT   /* camera_encoder.gamma = camera.gamma_init */
} gv_weight_init;

typedef struct {
    char name[GV_WEIGHT_NAME_MAX];
    int rank;
    int64_t shape[GV_WEIGHT_MAX_RANK];
    int64_t numel;
    gv_module module;
    int trainable;       /* trained in GaussVid fine-tuning (docs/ARCHITECTURE.md 6.7): LoRA and
                            camera, and the output layer of the residual variant */
    gv_weight_init init;
    double init_value;   /* GV_INIT_CONSTANT only */
} gv_weight_spec;

typedef struct {
    int n, cap;
    gv_weight_spec *items;  /* in module order (the official state-dict order where it exists) */
    int *by_name;           /* indices sorted by name, for lookup */
} gv_weight_list;

/* Lists every tensor of the model c describes (its variant and LoRA included). */
int gv_weight_list_build(gv_weight_list *l, const gv_model_config *c);
void gv_weight_list_free(gv_weight_list *l);
/* The tensor of that name, or NULL. */
const gv_weight_spec *gv_weight_list_find(const gv_weight_list *l, const char *name);
/* The module's name as printed ("patch_embedding", "vae_encoder", ...). */
const char *gv_module_name(gv_module m);
/* The part (GV_PART_*) a module belongs to. */
unsigned gv_module_part(gv_module m);
/* The parts of the mask as the comma-separated list gv_parts_parse reads ("dit,vace,camera"),
 * in bit order, into out; returns out (checkpoint metadata "parts"). */
const char *gv_parts_text(unsigned parts, char *out, size_t size);
/* Parses a comma-separated list of parts (dit, vace, vae, camera, lora, base, adapters,
 * all) into a mask; `source` names the flag or file in the message. */
int gv_parts_parse(const char *text, unsigned *mask, const char *source);

typedef struct {
    int64_t params[GV_N_MODULES];
    int tensors[GV_N_MODULES];
    int64_t total, trainable;
    int n_tensors;
} gv_weight_counts;
/* Parameter and tensor counts per module, in total and trainable in fine-tuning. */
void gv_weight_list_count(const gv_weight_list *l, gv_weight_counts *out);
/* Fails (naming path) when the tensors of `parts` of the network c describes cannot fit in
 * `bytes` of tensor data (2 bytes per parameter at least): checked before building a network
 * whose config came from the file (src/model/weight_budget.c). */
int gv_weights_fit(const gv_model_config *c, unsigned parts, uint64_t bytes, const char *path);

/* ---- checking files ------------------------------------------------------------------- */
typedef struct {
    const char *name;   /* into the weight list or the file */
    const char *file;   /* the file it was found in (NULL for missing tensors) */
    char detail[160];   /* expected and found shape or dtype; the other file of a duplicate */
} gv_weight_issue;

typedef struct {
    int n_expected;     /* tensors of the checked parts */
    int n_found;        /* tensors in the files */
    int n_missing, n_unexpected, n_mismatched, n_duplicate;
    gv_weight_issue *missing, *unexpected, *mismatched, *duplicate;
} gv_weight_report;

/* Compares open files with the list: a tensor of the `parts` absent from every file is
 * missing; a file tensor that is no tensor of the model is unexpected; a model tensor with
 * another shape or a non-float dtype (F32, F16, BF16, F64 load) is mismatched; a name in two
 * files is duplicated. Returns -1 only when out of memory. */
int gv_weights_check(const gv_weight_list *l, unsigned parts, const gv_st_file *files, int n_files,
                     gv_weight_report *r);
/* 1 when the files load: nothing missing, unexpected, mismatched or duplicated. */
int gv_weight_report_ok(const gv_weight_report *r);
/* Records one line listing the first problems of each kind (for loaders) and returns -1;
 * `what` names the files. Returns 0 (no message) when the report is ok. */
int gv_weight_report_fail(const gv_weight_report *r, const char *what);
void gv_weight_report_free(gv_weight_report *r);

#endif
