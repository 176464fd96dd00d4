/* Helpers shared by the model-config files (config.c, config_json.c, config_presets.c). */
#ifndef GAUSSVID_MODEL_CONFIG_INTERNAL_H
#define GAUSSVID_MODEL_CONFIG_INTERNAL_H

#include "gaussvid/model/model_config.h"

/* Records "source: key: message" and returns -1. */
int gv_config_bad(const char *source, const char *key, const char *fmt, ...)
    __attribute__((format(printf, 3, 4)));
/* Zeroes c and sets the defaults of the optional fields (docs/MODEL.md). */
void gv_model_config_defaults(gv_model_config *c);
/* The enum value of a name, or -1. */
int gv_camera_variant_from_name(const char *name);
int gv_anchors_from_name(const char *name);
/* 1 when a LoRA target names (or ends) a linear layer of a block. */
int gv_lora_target_known(const char *name);
/* 1 when LoRA adapts the linear layer at `path` within a block ("self_attn.q", "ffn.0"):
 * the path equals a target or ends with "." + target (PEFT's rule). */
int gv_lora_matches(const gv_lora_config *l, const char *path);

#endif
