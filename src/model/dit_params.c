/* The DiT's tensors: a walk over the network that names every tensor it uses, as the forward
 * pass binds it, and checks each against the config's weight list (weight_names.c). With a
 * registry the walk also creates the tensors, so the network is built FROM the list and
 * loading is a lookup by name; without one it checks names and shapes only (the published
 * 1.3B and 14B lists, without allocating gigabytes). Then the initial values. */
#include "model/dit_internal.h"
#include "model/config_internal.h"
#include "gaussvid/core/core.h"

#include <math.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

typedef struct {
    const gv_model_config *c;
    const gv_weight_list *list;
    gv_params *params;   /* NULL: check only */
    unsigned empty_parts;/* tensors of these parts are registered without values (a loader fills them) */
    unsigned char *seen; /* one flag per list entry */
} binder;

static int bind(binder *b, gv_tensor **slot, int rank, const int64_t *shape, const char *fmt, ...)
    __attribute__((format(printf, 5, 6)));

static int bind(binder *b, gv_tensor **slot, int rank, const int64_t *shape, const char *fmt, ...)
{
    char name[GV_WEIGHT_NAME_MAX];
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(name, sizeof name, fmt, ap);
    va_end(ap);
    const gv_weight_spec *w = gv_weight_list_find(b->list, name);
    if (!w) return gv_fail("%s: the network uses tensor %s, which its weight list lacks", b->c->name, name);
    int same = w->rank == rank;
    for (int k = 0; same && k < rank; k++) same = w->shape[k] == shape[k];
    if (!same) {
        char a[96], e[96];
        return gv_fail("%s: %s is %s in the network but %s in the weight list", b->c->name, name,
                       gv_st_shape_str(a, sizeof a, shape, rank), gv_st_shape_str(e, sizeof e, w->shape, w->rank));
    }
    size_t index = (size_t)(w - b->list->items);
    if (b->seen[index]) return gv_fail("%s: tensor %s bound twice", b->c->name, name);
    b->seen[index] = 1;
    if (!b->params) return 0;
    int dims[GV_MAX_DIMS];
    for (int k = 0; k < rank; k++) dims[k] = (int)shape[k];
    *slot = (gv_module_part(w->module) & b->empty_parts) && !w->trainable ? gv_params_add_empty(b->params, name, rank, dims)
                                                        : gv_params_add(b->params, name, rank, dims, 0);
    return *slot ? 0 : -1;
}

static int bind_linear(binder *b, gv_dit_linear *l, const char *prefix, int64_t out, int64_t in, int lora)
{
    if (bind(b, &l->w, 2, (int64_t[]){out, in}, "%s.weight", prefix) ||
        bind(b, &l->b, 1, (int64_t[]){out}, "%s.bias", prefix))
        return -1;
    if (!lora) return 0;
    int64_t r = b->c->lora.rank;
    return bind(b, &l->lora_a, 2, (int64_t[]){r, in}, "%s.lora_A.weight", prefix) ||
                   bind(b, &l->lora_b, 2, (int64_t[]){out, r}, "%s.lora_B.weight", prefix)
               ? -1
               : 0;
}

/* A linear layer of a block at `path` within it; LoRA by the config's target rule. */
static int block_linear(binder *b, gv_dit_linear *l, const char *block, const char *path, int64_t out, int64_t in,
                        int lora_on)
{
    char prefix[GV_WEIGHT_NAME_MAX];
    snprintf(prefix, sizeof prefix, "%s.%s", block, path);
    return bind_linear(b, l, prefix, out, in, lora_on && gv_lora_matches(&b->c->lora, path));
}

/* Reference 2.8 and 3.1; vace_index >= 0 for VACE block vace_index. */
static int bind_block(binder *b, gv_dit_block *blk, const char *name, int vace_index)
{
    const gv_dit_config *d = &b->c->dit;
    const int64_t D = d->dim, F = d->ffn_dim;
    const gv_lora_config *lc = &b->c->lora;
    int lora_on = lc->rank > 0 && (vace_index < 0 ? lc->blocks : lc->vace_blocks);
    if (bind(b, &blk->modulation, 3, (int64_t[]){1, 6, D}, "%s.modulation", name) ||
        block_linear(b, &blk->q, name, "self_attn.q", D, D, lora_on) ||
        block_linear(b, &blk->k, name, "self_attn.k", D, D, lora_on) ||
        block_linear(b, &blk->v, name, "self_attn.v", D, D, lora_on) ||
        block_linear(b, &blk->o, name, "self_attn.o", D, D, lora_on))
        return -1;
    if (d->qk_norm && (bind(b, &blk->norm_q, 1, (int64_t[]){D}, "%s.self_attn.norm_q.weight", name) ||
                       bind(b, &blk->norm_k, 1, (int64_t[]){D}, "%s.self_attn.norm_k.weight", name)))
        return -1;
    if (d->cross_attn) {
        if (d->cross_attn_norm && (bind(b, &blk->norm3_w, 1, (int64_t[]){D}, "%s.norm3.weight", name) ||
                                   bind(b, &blk->norm3_b, 1, (int64_t[]){D}, "%s.norm3.bias", name)))
            return -1;
        if (block_linear(b, &blk->cq, name, "cross_attn.q", D, D, lora_on) ||
            block_linear(b, &blk->ck, name, "cross_attn.k", D, D, lora_on) ||
            block_linear(b, &blk->cv, name, "cross_attn.v", D, D, lora_on) ||
            block_linear(b, &blk->co, name, "cross_attn.o", D, D, lora_on))
            return -1;
        if (d->qk_norm && (bind(b, &blk->cnorm_q, 1, (int64_t[]){D}, "%s.cross_attn.norm_q.weight", name) ||
                           bind(b, &blk->cnorm_k, 1, (int64_t[]){D}, "%s.cross_attn.norm_k.weight", name)))
            return -1;
    }
    if (block_linear(b, &blk->ffn0, name, "ffn.0", F, D, lora_on) || block_linear(b, &blk->ffn2, name, "ffn.2", D, F, lora_on))
        return -1;
    if (vace_index == 0 && block_linear(b, &blk->before_proj, name, "before_proj", D, D, lora_on)) return -1;
    if (vace_index >= 0 && block_linear(b, &blk->after_proj, name, "after_proj", D, D, lora_on)) return -1;
    if (vace_index < 0 && gv_model_has_camera_stream(b->c) &&
        bind(b, &blk->camera_modulation, 3, (int64_t[]){1, 6, D}, "%s.camera_modulation", name))
        return -1;
    return 0;
}

/* Paper 3.3.1 and docs/MODEL.md "This project's tensors". */
static int bind_camera(binder *b, gv_camera_encoder *e)
{
    const gv_model_config *c = b->c;
    if (c->variant.camera == GV_CAMERA_NONE) return 0;
    const int64_t C = c->camera.channels, G = c->camera.gate_hidden, P = c->camera.proj_hidden, D = c->dit.dim;
    int k[3];
    gv_model_camera_kernel(c, k);
    if (c->variant.camera == GV_CAMERA_DECOMPOSED) {
        if (bind(b, &e->conv_m_w, 5, (int64_t[]){C, 3, k[0], k[1], k[2]}, "camera_encoder.conv_m.weight") ||
            bind(b, &e->conv_m_b, 1, (int64_t[]){C}, "camera_encoder.conv_m.bias") ||
            bind(b, &e->conv_d_w, 5, (int64_t[]){C, 3, k[0], k[1], k[2]}, "camera_encoder.conv_d.weight") ||
            bind(b, &e->conv_d_b, 1, (int64_t[]){C}, "camera_encoder.conv_d.bias") ||
            bind_linear(b, &e->gate_d2m0, "camera_encoder.gate_d2m.0", G, C, 0) ||
            bind_linear(b, &e->gate_d2m2, "camera_encoder.gate_d2m.2", C, G, 0) ||
            bind_linear(b, &e->gate_m2d0, "camera_encoder.gate_m2d.0", G, C, 0) ||
            bind_linear(b, &e->gate_m2d2, "camera_encoder.gate_m2d.2", C, G, 0))
            return -1;
    } else if (bind(b, &e->conv_w, 5, (int64_t[]){2 * C, 6, k[0], k[1], k[2]}, "camera_encoder.conv.weight") ||
               bind(b, &e->conv_b, 1, (int64_t[]){2 * C}, "camera_encoder.conv.bias") ||
               bind_linear(b, &e->mlp0, "camera_encoder.mlp.0", 2 * G, 2 * C, 0) ||
               bind_linear(b, &e->mlp2, "camera_encoder.mlp.2", 2 * C, 2 * G, 0)) {
        return -1;
    }
    return bind_linear(b, &e->proj0, "camera_encoder.proj.0", P, 2 * C, 0) ||
                   bind_linear(b, &e->proj2, "camera_encoder.proj.2", D, P, 0) ||
                   bind(b, &e->norm_w, 1, (int64_t[]){D}, "camera_encoder.norm.weight") ||
                   bind(b, &e->norm_b, 1, (int64_t[]){D}, "camera_encoder.norm.bias") ||
                   bind(b, &e->gamma, 1, (int64_t[]){1}, "camera_encoder.gamma")
               ? -1
               : 0;
}

static int bind_all(binder *b, gv_dit *m)
{
    const gv_dit_config *d = &b->c->dit;
    const int64_t D = d->dim, pt = d->patch_size[0], ph = d->patch_size[1], pw = d->patch_size[2];
    char name[32];
    if (bind(b, &m->patch_w, 5, (int64_t[]){D, d->in_dim, pt, ph, pw}, "patch_embedding.weight") ||
        bind(b, &m->patch_b, 1, (int64_t[]){D}, "patch_embedding.bias"))
        return -1;
    if (d->cross_attn && (bind_linear(b, &m->text0, "text_embedding.0", D, d->text_dim, 0) ||
                          bind_linear(b, &m->text2, "text_embedding.2", D, D, 0)))
        return -1;
    if (bind_linear(b, &m->time0, "time_embedding.0", D, d->freq_dim, 0) ||
        bind_linear(b, &m->time2, "time_embedding.2", D, D, 0) ||
        bind_linear(b, &m->time_proj, "time_projection.1", 6 * D, D, 0))
        return -1;
    for (int i = 0; i < d->num_layers; i++) {
        snprintf(name, sizeof name, "blocks.%d", i);
        if (bind_block(b, &m->blocks[i], name, -1)) return -1;
    }
    if (bind(b, &m->head_modulation, 3, (int64_t[]){1, 2, D}, "head.modulation") ||
        bind_linear(b, &m->head, "head.head", d->out_dim * pt * ph * pw, D, 0))
        return -1;
    for (int j = 0; j < d->n_vace_layers; j++) {
        snprintf(name, sizeof name, "vace_blocks.%d", j);
        if (bind_block(b, &m->vace_blocks[j], name, j)) return -1;
    }
    if (d->n_vace_layers > 0 &&
        (bind(b, &m->vace_patch_w, 5, (int64_t[]){D, d->vace_in_dim, pt, ph, pw}, "vace_patch_embedding.weight") ||
         bind(b, &m->vace_patch_b, 1, (int64_t[]){D}, "vace_patch_embedding.bias")))
        return -1;
    return bind_camera(b, &m->camera);
}

int gv_dit_bind(gv_dit *m, const gv_model_config *c, const gv_weight_list *list, gv_params *params,
                unsigned empty_parts)
{
    binder b = {c, list, params, empty_parts, calloc((size_t)list->n + 1, 1)};
    if (!b.seen) return gv_fail("out of memory for the weight list flags");
    int rc = bind_all(&b, m);
    for (int i = 0; rc == 0 && i < list->n; i++) {
        const gv_weight_spec *w = &list->items[i];
        if (gv_module_part(w->module) != GV_PART_VAE && !b.seen[i])
            rc = gv_fail("%s: tensor %s of the weight list is not used by the network", c->name, w->name);
    }
    free(b.seen);
    return rc;
}

int gv_dit_check_names(const gv_model_config *cfg)
{
    gv_dit m;
    memset(&m, 0, sizeof m);
    gv_weight_list list;
    if (gv_weight_list_build(&list, cfg) != 0) return -1;
    m.blocks = calloc((size_t)cfg->dit.num_layers, sizeof *m.blocks);
    m.vace_blocks = calloc((size_t)cfg->dit.n_vace_layers + 1, sizeof *m.vace_blocks);
    int rc = m.blocks && m.vace_blocks ? gv_dit_bind(&m, cfg, &list, NULL, 0) : gv_fail("out of memory for the blocks");
    free(m.blocks);
    free(m.vace_blocks);
    gv_weight_list_free(&list);
    return rc;
}

/* ---- initial values ----------------------------------------------------------------------- */

static int ends_with(const char *s, const char *suffix)
{
    size_t a = strlen(s), b = strlen(suffix);
    return a >= b && !strcmp(s + a - b, suffix);
}

/* Fan-in of the weight that a bias belongs to ("x.bias" -> "x.weight"). */
static int64_t bias_fan_in(const gv_weight_list *l, const char *bias_name)
{
    char w[GV_WEIGHT_NAME_MAX];
    size_t len = strlen(bias_name) - 4;
    snprintf(w, sizeof w, "%.*sweight", (int)len, bias_name);
    const gv_weight_spec *s = gv_weight_list_find(l, w);
    return s && s->rank >= 2 ? s->numel / s->shape[0] : 1;
}

/* Wan's init_weights (reference W:model): Linear and patch weights Xavier-uniform on the
 * [out, in * k] view, text/time embedding weights N(0, 0.02^2), modulations N(0, 1/D);
 * PyTorch's default U(+-1/sqrt(fan_in)) for convolution biases; PEFT's U(+-1/sqrt(in)) for
 * lora_A. Zeros, ones and the constant come from the spec. */
static void init_random(float *x, const gv_weight_spec *s, const gv_weight_list *l, uint64_t seed, int64_t dim)
{
    if (ends_with(s->name, "modulation")) {
        gv_fill_normal(x, s->numel, seed, 0, 0.0f, (float)(1.0 / sqrt((double)dim)));
    } else if (s->rank >= 2 && ends_with(s->name, "lora_A.weight")) {
        float bound = (float)(1.0 / sqrt((double)s->shape[1]));
        gv_fill_uniform(x, s->numel, seed, 0, -bound, bound);
    } else if (s->rank >= 2 && (!strncmp(s->name, "text_embedding.", 15) || !strncmp(s->name, "time_embedding.", 15))) {
        gv_fill_normal(x, s->numel, seed, 0, 0.0f, 0.02f);
    } else if (s->rank >= 2) {
        double fan_out = (double)s->shape[0], fan_in = (double)s->numel / fan_out;
        float bound = (float)sqrt(6.0 / (fan_in + fan_out));
        gv_fill_uniform(x, s->numel, seed, 0, -bound, bound);
    } else {
        float bound = (float)(1.0 / sqrt((double)bias_fan_in(l, s->name)));
        gv_fill_uniform(x, s->numel, seed, 0, -bound, bound);
    }
}

int gv_dit_init_values(gv_dit *m, uint64_t seed)
{
    for (int i = 0; i < m->params.n; i++) {
        gv_tensor *t = &m->params.items[i]->t;
        const gv_weight_spec *s = gv_weight_list_find(&m->weights, t->name);
        if (!s) return gv_fail("%s: no spec for tensor %s", m->cfg.name, t->name);
        if (!t->data) continue; /* registered empty: a loader gives it its values */
        switch (s->init) {
        case GV_INIT_ZEROS: memset(t->data, 0, (size_t)t->numel * sizeof(float)); break;
        case GV_INIT_ONES: for (int64_t k = 0; k < t->numel; k++) t->data[k] = 1.0f; break;
        case GV_INIT_CONSTANT: for (int64_t k = 0; k < t->numel; k++) t->data[k] = (float)s->init_value; break;
        default: init_random(t->data, s, &m->weights, gv_seed_for_name(seed, t->name), m->cfg.dit.dim); break;
        }
    }
    return 0;
}
