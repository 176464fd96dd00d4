/* Helpers shared by weight_names.c and weight_names_vae.c. */
#ifndef GAUSSVID_WEIGHT_NAMES_INTERNAL_H
#define GAUSSVID_WEIGHT_NAMES_INTERNAL_H

#include "gaussvid/model/weight_names.h"

/* Appends one tensor "prefix.suffix" (prefix may be ""). Fails when out of memory or when
 * the name does not fit. */
int gv_weight_add(gv_weight_list *l, gv_module m, gv_weight_init init, const char *prefix,
                  const char *suffix, const int64_t *shape, int rank);
#define GV_SHAPE(...) (const int64_t[]){__VA_ARGS__}, (int)(sizeof((int64_t[]){__VA_ARGS__}) / sizeof(int64_t))

/* The VAE's encoder, conv1, conv2 and decoder (docs/reference/wan-vace-gaussvid.md 4.3). */
int gv_weight_list_add_vae(gv_weight_list *l, const gv_vae_config *v);

#endif
