/* The parameter tensors of a model config: the Wan2.1 DiT and VACE branch by their official
 * checkpoint keys (docs/reference/wan-vace-gaussvid.md 2.8 and 3.1), this project's camera encoder
 * and LoRA adapters (docs/MODEL.md), and the list's lookup and counting. The VAE is in
 * weight_names_vae.c. */
#include "gaussvid/model/weight_names.h"
#include "gaussvid/core/core.h"
#include "model/config_internal.h"
#include "model/weight_names_internal.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>

static const char *const module_names[GV_N_MODULES] = {
    "patch_embedding", "time_embedding", "text_embedding", "blocks", "head", "vace",
    "vae_encoder", "vae_decoder", "camera", "lora"};

const char *gv_module_name(gv_module m)
{
    return (unsigned)m < GV_N_MODULES ? module_names[m] : "?";
}

unsigned gv_module_part(gv_module m)
{
    switch (m) {
    case GV_MODULE_VACE: return GV_PART_VACE;
    case GV_MODULE_VAE_ENCODER: case GV_MODULE_VAE_DECODER: return GV_PART_VAE;
    case GV_MODULE_CAMERA: return GV_PART_CAMERA;
    case GV_MODULE_LORA: return GV_PART_LORA;
    default: return GV_PART_DIT;
    }
}

int gv_weight_add(gv_weight_list *l, gv_module m, gv_weight_init init, const char *prefix,
                  const char *suffix, const int64_t *shape, int rank)
{
    if (l->n == l->cap) {
        int cap = l->cap ? 2 * l->cap : 256;
        gv_weight_spec *items = realloc(l->items, (size_t)cap * sizeof *items);
        if (!items) return gv_fail("out of memory for the weight list (%d tensors)", cap);
        l->items = items;
        l->cap = cap;
    }
    gv_weight_spec *w = &l->items[l->n];
    memset(w, 0, sizeof *w);
    int len = snprintf(w->name, sizeof w->name, "%s%s%s", prefix, prefix[0] ? "." : "", suffix);
    if (len < 0 || len >= (int)sizeof w->name) return gv_fail("%s.%s: tensor name too long", prefix, suffix);
    w->rank = rank;
    w->numel = 1;
    for (int k = 0; k < rank; k++) {
        w->shape[k] = shape[k];
        w->numel *= shape[k];
    }
    w->module = m;
    w->trainable = m == GV_MODULE_CAMERA || m == GV_MODULE_LORA; /* docs/ARCHITECTURE.md 6.7 */
    w->init = init;
    l->n++;
    return 0;
}

/* A PyTorch Linear(in -> out): "prefix.weight" [out, in] and "prefix.bias" [out]; Wan's
 * init_weights zeroes Linear biases. */
static int linear(gv_weight_list *l, gv_module m, const char *prefix, int64_t out, int64_t in, gv_weight_init w)
{
    if (gv_weight_add(l, m, w, prefix, "weight", GV_SHAPE(out, in)) ||
        gv_weight_add(l, m, GV_INIT_ZEROS, prefix, "bias", GV_SHAPE(out)))
        return -1;
    return 0;
}

static int linear_at(gv_weight_list *l, gv_module m, const char *block, const char *path, int64_t out, int64_t in,
                     gv_weight_init w)
{
    char prefix[GV_WEIGHT_NAME_MAX];
    snprintf(prefix, sizeof prefix, "%s.%s", block, path);
    return linear(l, m, prefix, out, in, w);
}

/* One Wan attention block (docs/reference/wan-vace-gaussvid.md 2.5 and 2.8); vace_index >= 0 for a
 * VACE block, which adds before_proj (block 0) and after_proj, both zero-initialised
 * (docs/reference/wan-vace-gaussvid.md 3.1). */
static int add_block(gv_weight_list *l, const gv_dit_config *d, gv_module m, const char *block, int vace_index)
{
    int64_t D = d->dim, F = d->ffn_dim;
    static const char *const qkvo[4] = {"q", "k", "v", "o"};
    char path[64];
    if (gv_weight_add(l, m, GV_INIT_RANDOM, block, "modulation", GV_SHAPE(1, 6, D))) return -1;
    for (int attn = 0; attn < (d->cross_attn ? 2 : 1); attn++) {
        const char *kind = attn ? "cross_attn" : "self_attn";
        if (attn && d->cross_attn_norm) {
            if (gv_weight_add(l, m, GV_INIT_ONES, block, "norm3.weight", GV_SHAPE(D)) ||
                gv_weight_add(l, m, GV_INIT_ZEROS, block, "norm3.bias", GV_SHAPE(D)))
                return -1;
        }
        for (int i = 0; i < 4; i++) {
            snprintf(path, sizeof path, "%s.%s", kind, qkvo[i]);
            if (linear_at(l, m, block, path, D, D, GV_INIT_RANDOM)) return -1;
        }
        for (int i = 0; d->qk_norm && i < 2; i++) {
            snprintf(path, sizeof path, "%s.norm_%s.weight", kind, i ? "k" : "q");
            if (gv_weight_add(l, m, GV_INIT_ONES, block, path, GV_SHAPE(D))) return -1;
        }
    }
    if (linear_at(l, m, block, "ffn.0", F, D, GV_INIT_RANDOM) || linear_at(l, m, block, "ffn.2", D, F, GV_INIT_RANDOM))
        return -1;
    if (vace_index == 0 && linear_at(l, m, block, "before_proj", D, D, GV_INIT_ZEROS)) return -1;
    if (vace_index >= 0 && linear_at(l, m, block, "after_proj", D, D, GV_INIT_ZEROS)) return -1;
    return 0;
}

static int add_dit(gv_weight_list *l, const gv_dit_config *d)
{
    int64_t D = d->dim, pt = d->patch_size[0], ph = d->patch_size[1], pw = d->patch_size[2];
    char block[32];
    if (gv_weight_add(l, GV_MODULE_PATCH_EMBEDDING, GV_INIT_RANDOM, "patch_embedding", "weight", GV_SHAPE(D, d->in_dim, pt, ph, pw)) ||
        gv_weight_add(l, GV_MODULE_PATCH_EMBEDDING, GV_INIT_RANDOM, "patch_embedding", "bias", GV_SHAPE(D)))
        return -1;
    if (d->cross_attn && (linear(l, GV_MODULE_TEXT_EMBEDDING, "text_embedding.0", D, d->text_dim, GV_INIT_RANDOM) ||
                          linear(l, GV_MODULE_TEXT_EMBEDDING, "text_embedding.2", D, D, GV_INIT_RANDOM)))
        return -1;
    if (linear(l, GV_MODULE_TIME_EMBEDDING, "time_embedding.0", D, d->freq_dim, GV_INIT_RANDOM) ||
        linear(l, GV_MODULE_TIME_EMBEDDING, "time_embedding.2", D, D, GV_INIT_RANDOM) ||
        linear(l, GV_MODULE_TIME_EMBEDDING, "time_projection.1", 6 * D, D, GV_INIT_RANDOM))
        return -1;
    for (int i = 0; i < d->num_layers; i++) {
        snprintf(block, sizeof block, "blocks.%d", i);
        if (add_block(l, d, GV_MODULE_BLOCKS, block, -1)) return -1;
    }
    /* Wan's init_weights zeroes the output layer. */
    if (gv_weight_add(l, GV_MODULE_HEAD, GV_INIT_RANDOM, "head", "modulation", GV_SHAPE(1, 2, D)) ||
        linear(l, GV_MODULE_HEAD, "head.head", d->out_dim * pt * ph * pw, D, GV_INIT_ZEROS))
        return -1;
    return 0;
}

static int add_vace(gv_weight_list *l, const gv_dit_config *d)
{
    char block[32];
    for (int j = 0; j < d->n_vace_layers; j++) {
        snprintf(block, sizeof block, "vace_blocks.%d", j);
        if (add_block(l, d, GV_MODULE_VACE, block, j)) return -1;
    }
    if (d->n_vace_layers == 0) return 0;
    int64_t D = d->dim;
    if (gv_weight_add(l, GV_MODULE_VACE, GV_INIT_RANDOM, "vace_patch_embedding", "weight",
                      GV_SHAPE(D, d->vace_in_dim, d->patch_size[0], d->patch_size[1], d->patch_size[2])) ||
        gv_weight_add(l, GV_MODULE_VACE, GV_INIT_RANDOM, "vace_patch_embedding", "bias", GV_SHAPE(D)))
        return -1;
    return 0;
}

/* The Plücker token encoder (paper 3.3.1, docs/ARCHITECTURE.md 6.4). Decomposed: conv_m on the moment
 * channels o x d, conv_d on the directions d, cross-gating MLPs gate_d2m (input F_d, gates
 * F_m) and gate_m2d, then proj (2C -> P -> D, last layer zero), LayerNorm and gamma.
 * Monolithic and early fusion: one conv over all 6 channels to 2C and a residual MLP
 * 2C -> 2G -> 2C (the authors' single-stream encoder), then the same proj, norm, gamma. */
static int add_camera(gv_weight_list *l, const gv_model_config *c)
{
    const gv_camera_variant v = c->variant.camera;
    if (v == GV_CAMERA_NONE) return 0;
    const gv_module m = GV_MODULE_CAMERA;
    int64_t C = c->camera.channels, G = c->camera.gate_hidden, P = c->camera.proj_hidden, D = c->dit.dim;
    int k[3];
    gv_model_camera_kernel(c, k);
    if (v == GV_CAMERA_DECOMPOSED) {
        if (gv_weight_add(l, m, GV_INIT_RANDOM, "camera_encoder.conv_m", "weight", GV_SHAPE(C, 3, k[0], k[1], k[2])) ||
            gv_weight_add(l, m, GV_INIT_RANDOM, "camera_encoder.conv_m", "bias", GV_SHAPE(C)) ||
            gv_weight_add(l, m, GV_INIT_RANDOM, "camera_encoder.conv_d", "weight", GV_SHAPE(C, 3, k[0], k[1], k[2])) ||
            gv_weight_add(l, m, GV_INIT_RANDOM, "camera_encoder.conv_d", "bias", GV_SHAPE(C)) ||
            linear(l, m, "camera_encoder.gate_d2m.0", G, C, GV_INIT_RANDOM) ||
            linear(l, m, "camera_encoder.gate_d2m.2", C, G, GV_INIT_RANDOM) ||
            linear(l, m, "camera_encoder.gate_m2d.0", G, C, GV_INIT_RANDOM) ||
            linear(l, m, "camera_encoder.gate_m2d.2", C, G, GV_INIT_RANDOM))
            return -1;
    } else if (gv_weight_add(l, m, GV_INIT_RANDOM, "camera_encoder.conv", "weight", GV_SHAPE(2 * C, 6, k[0], k[1], k[2])) ||
               gv_weight_add(l, m, GV_INIT_RANDOM, "camera_encoder.conv", "bias", GV_SHAPE(2 * C)) ||
               linear(l, m, "camera_encoder.mlp.0", 2 * G, 2 * C, GV_INIT_RANDOM) ||
               linear(l, m, "camera_encoder.mlp.2", 2 * C, 2 * G, GV_INIT_RANDOM)) {
        return -1;
    }
    if (linear(l, m, "camera_encoder.proj.0", P, 2 * C, GV_INIT_RANDOM) ||
        linear(l, m, "camera_encoder.proj.2", D, P, GV_INIT_ZEROS) || /* paper: last projection zero */
        gv_weight_add(l, m, GV_INIT_ONES, "camera_encoder.norm", "weight", GV_SHAPE(D)) ||
        gv_weight_add(l, m, GV_INIT_ZEROS, "camera_encoder.norm", "bias", GV_SHAPE(D)) ||
        gv_weight_add(l, m, GV_INIT_CONSTANT, "camera_encoder", "gamma", GV_SHAPE(1)))
        return -1;
    l->items[l->n - 1].init_value = c->camera.gamma_init;
    /* docs/ARCHITECTURE.md 6.5: the camera stream's own modulation in every block (the layout of
     * blocks.N.modulation: shift, scale, gate for attention, then for the FFN). */
    char block[32];
    for (int i = 0; gv_model_has_camera_stream(c) && i < c->dit.num_layers; i++) {
        snprintf(block, sizeof block, "blocks.%d", i);
        if (gv_weight_add(l, m, GV_INIT_RANDOM, block, "camera_modulation", GV_SHAPE(1, 6, D))) return -1;
    }
    return 0;
}

/* lora_A [r, in] (random) and lora_B [out, r] (zero) on every targeted linear of a block;
 * the names DiffSynth uses, so adapters interoperate (docs/reference/wan-vace-gaussvid.md 1.2). */
static int add_lora_block(gv_weight_list *l, const gv_model_config *c, const char *block, int vace_index)
{
    const gv_dit_config *d = &c->dit;
    static const char *const qkvo[4] = {"q", "k", "v", "o"};
    struct { char path[32]; int64_t out, in; } lin[12];
    int n = 0;
    for (int attn = 0; attn < (d->cross_attn ? 2 : 1); attn++)
        for (int i = 0; i < 4; i++, n++) {
            snprintf(lin[n].path, sizeof lin[n].path, "%s.%s", attn ? "cross_attn" : "self_attn", qkvo[i]);
            lin[n].out = lin[n].in = d->dim;
        }
    snprintf(lin[n].path, sizeof lin[n].path, "ffn.0"), lin[n].out = d->ffn_dim, lin[n].in = d->dim, n++;
    snprintf(lin[n].path, sizeof lin[n].path, "ffn.2"), lin[n].out = d->dim, lin[n].in = d->ffn_dim, n++;
    if (vace_index == 0) snprintf(lin[n].path, sizeof lin[n].path, "before_proj"), lin[n].out = lin[n].in = d->dim, n++;
    if (vace_index >= 0) snprintf(lin[n].path, sizeof lin[n].path, "after_proj"), lin[n].out = lin[n].in = d->dim, n++;
    char prefix[GV_WEIGHT_NAME_MAX];
    int64_t r = c->lora.rank;
    for (int i = 0; i < n; i++) {
        if (!gv_lora_matches(&c->lora, lin[i].path)) continue;
        snprintf(prefix, sizeof prefix, "%s.%s", block, lin[i].path);
        if (gv_weight_add(l, GV_MODULE_LORA, GV_INIT_RANDOM, prefix, "lora_A.weight", GV_SHAPE(r, lin[i].in)) ||
            gv_weight_add(l, GV_MODULE_LORA, GV_INIT_ZEROS, prefix, "lora_B.weight", GV_SHAPE(lin[i].out, r)))
            return -1;
    }
    return 0;
}

static int add_lora(gv_weight_list *l, const gv_model_config *c)
{
    char block[32];
    for (int i = 0; c->lora.rank > 0 && c->lora.blocks && i < c->dit.num_layers; i++) {
        snprintf(block, sizeof block, "blocks.%d", i);
        if (add_lora_block(l, c, block, -1)) return -1;
    }
    for (int j = 0; c->lora.rank > 0 && c->lora.vace_blocks && j < c->dit.n_vace_layers; j++) {
        snprintf(block, sizeof block, "vace_blocks.%d", j);
        if (add_lora_block(l, c, block, j)) return -1;
    }
    return 0;
}

static const char *spec_name(const void *items, int i)
{
    return ((const gv_weight_spec *)items)[i].name;
}

static int index_names(gv_weight_list *l)
{
    const char *repeat;
    l->by_name = malloc(((size_t)l->n + 1) * sizeof *l->by_name);
    if (!l->by_name) return gv_fail("out of memory for the weight list index");
    if (gv_names_order(l->items, l->n, spec_name, l->by_name, &repeat)) return -1;
    return repeat ? gv_fail("%s: tensor named twice", repeat) : 0;
}

int gv_weight_list_build(gv_weight_list *l, const gv_model_config *c)
{
    memset(l, 0, sizeof *l);
    if (gv_model_config_validate(c, c->name) || add_dit(l, &c->dit) || add_vace(l, &c->dit) ||
        gv_weight_list_add_vae(l, &c->vae) || add_camera(l, c) || add_lora(l, c) || index_names(l)) {
        gv_weight_list_free(l);
        return -1;
    }
    /* The residual output relearns the output layer (docs/TRAINING.md "Output parameterisation"). */
    for (int i = 0; c->variant.residual && i < l->n; i++)
        if (!strncmp(l->items[i].name, "head.head.", 10)) l->items[i].trainable = 1;
    return 0;
}

void gv_weight_list_free(gv_weight_list *l)
{
    free(l->items);
    free(l->by_name);
    memset(l, 0, sizeof *l);
}

const gv_weight_spec *gv_weight_list_find(const gv_weight_list *l, const char *name)
{
    return gv_names_find(l->items, sizeof *l->items, l->by_name, l->n, spec_name, name);
}

void gv_weight_list_count(const gv_weight_list *l, gv_weight_counts *out)
{
    memset(out, 0, sizeof *out);
    for (int i = 0; i < l->n; i++) {
        const gv_weight_spec *w = &l->items[i];
        out->params[w->module] += w->numel;
        out->tensors[w->module]++;
        out->total += w->numel;
        if (w->trainable) out->trainable += w->numel;
    }
    out->n_tensors = l->n;
}

const char *gv_parts_text(unsigned parts, char *out, size_t size)
{
    static const char *const names[] = {"dit", "vace", "vae", "camera", "lora"}; /* bit i: 1 << i */
    out[0] = '\0';
    for (int i = 0; i < 5; i++)
        if (parts & (1u << i)) {
            size_t len = strlen(out);
            snprintf(out + len, size - len, "%s%s", len ? "," : "", names[i]);
        }
    return out;
}

int gv_parts_parse(const char *text, unsigned *mask, const char *source)
{
    static const struct { const char *name; unsigned bits; } parts[] = {
        {"dit", GV_PART_DIT}, {"vace", GV_PART_VACE}, {"vae", GV_PART_VAE}, {"camera", GV_PART_CAMERA},
        {"lora", GV_PART_LORA}, {"base", GV_PART_BASE}, {"adapters", GV_PART_ADAPTERS}, {"all", GV_PART_ALL}};
    *mask = 0;
    const char *p = text;
    while (1) {
        size_t len = strcspn(p, ",");
        unsigned bits = 0;
        for (size_t i = 0; i < sizeof parts / sizeof parts[0] && !bits; i++)
            if (strlen(parts[i].name) == len && !strncmp(p, parts[i].name, len)) bits = parts[i].bits;
        if (!bits)
            return gv_fail("%s: \"%.*s\" is not a part (dit, vace, vae, camera, lora, base, adapters, all)",
                           source, (int)(len < 40 ? len : 40), p);
        *mask |= bits;
        if (!p[len]) return 0;
        p += len + 1;
    }
}
