/* The VAE's tensors: every block asks the binder for its tensors by their checkpoint names
 * (docs/reference/wan-vace-gaussvid.md 4.3) with the shapes the block computes from its channel
 * counts; the binder looks them up in the config's weight list (weight_names_vae.c), so a name or
 * shape on which the network and the list disagree is an error, and so is a listed tensor the
 * network never uses. A dry run checks the Wan presets (127 M parameters) without allocating
 * them. */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "gaussvid/core/core.h"
#include "model/vae_internal.h"

static gv_tensor dry_run_tensor; /* stands for every tensor in a dry run (never read) */

static const char *shape_text(char *out, size_t size, const int *shape, int rank)
{
    int64_t s[GV_WEIGHT_MAX_RANK];
    for (int k = 0; k < rank; k++) s[k] = shape[k];
    return gv_st_shape_str(out, size, s, rank);
}

/* Finds "prefix.suffix", checks its shape, marks it used and (unless a dry run) allocates it
 * and fills it as the list says: ones, zeros, or uniform +-bound (PyTorch's default
 * initialisation of Conv layers, bound = 1 / sqrt(fan_in), for weights and biases). */
static gv_tensor *bind(gv_vae_binder *b, const char *prefix, const char *suffix, int rank,
                       const int *shape, double bound)
{
    char name[GV_WEIGHT_NAME_MAX], want[64], have[64];
    snprintf(name, sizeof name, "%s.%s", prefix, suffix);
    const gv_weight_spec *w = gv_weight_list_find(b->list, name);
    if (!w || (w->module != GV_MODULE_VAE_ENCODER && w->module != GV_MODULE_VAE_DECODER)) {
        gv_fail("vae: the network needs %s %s, which is not a VAE tensor of the weight list", name,
                shape_text(want, sizeof want, shape, rank));
        return NULL;
    }
    int same = w->rank == rank;
    for (int k = 0; same && k < rank; k++) same = w->shape[k] == shape[k];
    if (!same) {
        gv_fail("vae: %s is %s in the weight list, the network needs %s", name,
                gv_st_shape_str(have, sizeof have, w->shape, w->rank), shape_text(want, sizeof want, shape, rank));
        return NULL;
    }
    int index = (int)(w - b->list->items);
    if (b->used[index]) {
        gv_fail("vae: the network uses %s twice", name);
        return NULL;
    }
    b->used[index] = 1;
    b->n_used++;
    b->n_params += w->numel;
    if (!b->params) return &dry_run_tensor;
    gv_tensor *t = gv_params_add(b->params, name, rank, shape, b->trainable);
    if (!t) return NULL;
    if (w->init == GV_INIT_ONES)
        for (int64_t i = 0; i < t->numel; i++) t->data[i] = 1.0f;
    else if (w->init == GV_INIT_RANDOM)
        gv_fill_uniform(t->data, t->numel, gv_seed_for_name(b->seed, name), 0, (float)-bound, (float)bound);
    if (rank == 1 || w->init == GV_INIT_ONES) gv_params_of(b->params, t)->decay = 0; /* biases, gains */
    return t;
}

int gv_vae_bind_conv(gv_vae_binder *b, gv_vae_conv *c, const char *prefix, int out, int in, int kt,
                     int kh, int kw, int slot)
{
    int w5[5] = {out, in, kt, kh, kw}, w4[4] = {out, in, kh, kw};
    double bound = 1.0 / sqrt((double)in * (kt ? kt : 1) * kh * kw);
    c->weight = kt ? bind(b, prefix, "weight", 5, w5, bound) : bind(b, prefix, "weight", 4, w4, bound);
    c->bias = c->weight ? bind(b, prefix, "bias", 1, &out, bound) : NULL;
    c->slot = slot;
    return c->weight && c->bias ? 0 : -1;
}

gv_tensor *gv_vae_bind_gamma(gv_vae_binder *b, const char *prefix, const char *suffix, int c, int images)
{
    int shape[4] = {c, 1, 1, 1};
    return bind(b, prefix, suffix, images ? 3 : 4, shape, 0.0);
}

int gv_vae_bind_residual(gv_vae_binder *b, gv_vae_layer *l, const char *prefix, int in, int out, int *n_slots)
{
    char p[GV_WEIGHT_NAME_MAX];
    memset(l, 0, sizeof *l);
    l->kind = GV_VAE_RESIDUAL;
    l->in = in;
    l->out = out;
    l->shortcut.slot = -1;
    if (!(l->gamma0 = gv_vae_bind_gamma(b, prefix, "residual.0.gamma", in, 0))) return -1;
    snprintf(p, sizeof p, "%s.residual.2", prefix);
    if (gv_vae_bind_conv(b, &l->conv2, p, out, in, 3, 3, 3, (*n_slots)++)) return -1;
    if (!(l->gamma3 = gv_vae_bind_gamma(b, prefix, "residual.3.gamma", out, 0))) return -1;
    snprintf(p, sizeof p, "%s.residual.6", prefix);
    if (gv_vae_bind_conv(b, &l->conv6, p, out, out, 3, 3, 3, (*n_slots)++)) return -1;
    snprintf(p, sizeof p, "%s.shortcut", prefix);
    if (in != out && gv_vae_bind_conv(b, &l->shortcut, p, out, in, 1, 1, 1, -1)) return -1;
    return 0;
}

int gv_vae_bind_attention(gv_vae_binder *b, gv_vae_layer *l, const char *prefix, int c)
{
    char p[GV_WEIGHT_NAME_MAX];
    memset(l, 0, sizeof *l);
    l->kind = GV_VAE_ATTENTION;
    l->in = l->out = c;
    if (!(l->norm_gamma = gv_vae_bind_gamma(b, prefix, "norm.gamma", c, 1))) return -1;
    snprintf(p, sizeof p, "%s.to_qkv", prefix);
    if (gv_vae_bind_conv(b, &l->to_qkv, p, 3 * c, c, 0, 1, 1, -1)) return -1;
    snprintf(p, sizeof p, "%s.proj", prefix);
    return gv_vae_bind_conv(b, &l->proj, p, c, c, 0, 1, 1, -1);
}

int gv_vae_bind_resample(gv_vae_binder *b, gv_vae_layer *l, const char *prefix, int c,
                         gv_vae_layer_kind kind, int *n_slots)
{
    char p[GV_WEIGHT_NAME_MAX];
    int up = kind == GV_VAE_UP2D || kind == GV_VAE_UP3D;
    memset(l, 0, sizeof *l);
    l->kind = kind;
    l->in = c;
    l->out = up ? c / 2 : c;
    l->slot = -1;
    l->time_conv.slot = -1;
    snprintf(p, sizeof p, "%s.resample.1", prefix); /* index 0 is ZeroPad2d or Upsample */
    if (gv_vae_bind_conv(b, &l->resample, p, l->out, c, 0, 3, 3, -1)) return -1;
    if (kind != GV_VAE_DOWN3D && kind != GV_VAE_UP3D) return 0;
    l->slot = (*n_slots)++;
    snprintf(p, sizeof p, "%s.time_conv", prefix);
    return gv_vae_bind_conv(b, &l->time_conv, p, kind == GV_VAE_UP3D ? 2 * c : c, c, 3, 1, 1, l->slot);
}

int gv_vae_bind_middle(gv_vae_binder *b, gv_vae_coder *coder, const char *prefix, int c)
{
    char p[GV_WEIGHT_NAME_MAX];
    snprintf(p, sizeof p, "%s.middle.0", prefix);
    if (gv_vae_bind_residual(b, &coder->middle[0], p, c, c, &coder->n_slots)) return -1;
    snprintf(p, sizeof p, "%s.middle.1", prefix);
    if (gv_vae_bind_attention(b, &coder->middle[1], p, c)) return -1;
    snprintf(p, sizeof p, "%s.middle.2", prefix);
    return gv_vae_bind_residual(b, &coder->middle[2], p, c, c, &coder->n_slots);
}

int gv_vae_bind_head(gv_vae_binder *b, gv_vae_coder *coder, const char *prefix, int c, int out)
{
    char p[GV_WEIGHT_NAME_MAX];
    if (!(coder->head_gamma = gv_vae_bind_gamma(b, prefix, "head.0.gamma", c, 0))) return -1;
    snprintf(p, sizeof p, "%s.head.2", prefix);
    return gv_vae_bind_conv(b, &coder->head_conv, p, out, c, 3, 3, 3, coder->n_slots++);
}

/* Builds both coders, conv1 and conv2, then checks that every VAE tensor of the list was
 * used. */
static int build(gv_vae_binder *b, const gv_vae_config *cfg, gv_vae_coder *enc, gv_vae_coder *dec,
                 gv_vae_conv *quant, gv_vae_conv *post_quant)
{
    int z = cfg->z_dim;
    /* conv1 (quant) works on the encoder's 2 z channels (mean, log-variance); conv2 on z */
    if (gv_vae_build_encoder(b, cfg, enc) || gv_vae_bind_conv(b, quant, "conv1", 2 * z, 2 * z, 1, 1, 1, -1) ||
        gv_vae_bind_conv(b, post_quant, "conv2", z, z, 1, 1, 1, -1) || gv_vae_build_decoder(b, cfg, dec))
        return -1;
    for (int i = 0; i < b->list->n; i++) {
        const gv_weight_spec *w = &b->list->items[i];
        if ((w->module == GV_MODULE_VAE_ENCODER || w->module == GV_MODULE_VAE_DECODER) && !b->used[i])
            return gv_fail("vae: the weight list has %s, which the network does not use", w->name);
    }
    return 0;
}

static int binder_start(gv_vae_binder *b, gv_weight_list *list, const gv_model_config *c, gv_params *params,
                        int trainable, uint64_t seed)
{
    memset(b, 0, sizeof *b);
    if (gv_weight_list_build(list, c)) return -1;
    b->list = list;
    b->params = params;
    b->trainable = trainable;
    b->seed = seed;
    b->used = calloc((size_t)list->n + 1, 1);
    if (!b->used) {
        gv_weight_list_free(list);
        return gv_fail("vae: out of memory");
    }
    return 0;
}

static void binder_end(gv_vae_binder *b, gv_weight_list *list)
{
    free(b->used);
    gv_weight_list_free(list);
}

int gv_vae_check_layout(const gv_model_config *c, int *n_tensors, int64_t *n_params)
{
    gv_weight_list list;
    gv_vae_binder b;
    gv_vae_coder enc = {0}, dec = {0};
    gv_vae_conv quant, post_quant;
    if (binder_start(&b, &list, c, NULL, 0, 0)) return -1;
    int rc = build(&b, &c->vae, &enc, &dec, &quant, &post_quant);
    if (n_tensors) *n_tensors = b.n_used;
    if (n_params) *n_params = b.n_params;
    gv_vae_coder_free(&enc);
    gv_vae_coder_free(&dec);
    binder_end(&b, &list);
    return rc;
}

int gv_vae_set_stats(gv_vae *v, const double *mean, const double *std)
{
    for (int k = 0; k < v->cfg.z_dim; k++)
        if (!isfinite(mean[k]) || !(std[k] > 0) || !isfinite(std[k]))
            return gv_fail("vae: latent statistics of channel %d are not usable (mean %g, std %g)", k, mean[k], std[k]);
    for (int k = 0; k < v->cfg.z_dim; k++) {
        v->cfg.latent_mean[k] = mean[k];
        v->cfg.latent_std[k] = std[k];
        v->mean[k] = (float)mean[k];
        v->std[k] = (float)std[k];
        v->inv_std[k] = (float)(1.0 / std[k]); /* Wan multiplies by 1 / std
                                                  (docs/reference/wan-vace-gaussvid.md 4.5) */
    }
    v->cfg.has_latent_stats = v->has_stats = 1;
    return 0;
}

int gv_vae_init(gv_vae *v, const gv_model_config *c, int trainable, uint64_t seed)
{
    memset(v, 0, sizeof *v);
    v->cfg = c->vae;
    gv_params_init(&v->params);
    gv_weight_list list;
    gv_vae_binder b;
    if (binder_start(&b, &list, c, &v->params, trainable, seed)) return -1;
    int rc = build(&b, &c->vae, &v->encoder, &v->decoder, &v->quant, &v->post_quant);
    binder_end(&b, &list);
    if (rc == 0 && c->vae.has_latent_stats) rc = gv_vae_set_stats(v, c->vae.latent_mean, c->vae.latent_std);
    if (rc) gv_vae_free(v);
    return rc;
}

void gv_vae_coder_free(gv_vae_coder *c)
{
    free(c->layers);
    memset(c, 0, sizeof *c);
}

void gv_vae_free(gv_vae *v)
{
    gv_vae_coder_free(&v->encoder);
    gv_vae_coder_free(&v->decoder);
    gv_params_free(&v->params);
    memset(v, 0, sizeof *v);
}
