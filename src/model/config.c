/* Model configs: validation, variants, equality and derived sizes. The JSON form is in
 * config_json.c, the built-in presets in config_presets.c, the format in docs/MODEL.md. */
#include "gaussvid/model/model_config.h"
#include "gaussvid/core/core.h"
#include "model/config_internal.h"

#include <math.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

int gv_config_bad(const char *source, const char *key, const char *fmt, ...)
{
    char text[512];
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(text, sizeof text, fmt, ap);
    va_end(ap);
    return gv_fail("%s: %s: %s", source ? source : "config", key, text);
}

static const char *const camera_names[] = {"none", "early", "monolithic", "decomposed"};
static const char *const anchor_names[] = {"none", "first", "both"};

const char *gv_camera_variant_name(gv_camera_variant v)
{
    return (unsigned)v < 4 ? camera_names[v] : "?";
}

const char *gv_anchors_name(gv_anchors a)
{
    return (unsigned)a < 3 ? anchor_names[a] : "?";
}

int gv_camera_variant_from_name(const char *name)
{
    for (int i = 0; i < 4; i++)
        if (!strcmp(name, camera_names[i])) return i;
    return -1;
}

int gv_anchors_from_name(const char *name)
{
    for (int i = 0; i < 3; i++)
        if (!strcmp(name, anchor_names[i])) return i;
    return -1;
}

/* The linear layers of a block that LoRA may adapt, by their path within the block, and
 * the short forms PEFT's suffix rule allows. */
static const char *const lora_target_names[] = {
    "q", "k", "v", "o", "self_attn.q", "self_attn.k", "self_attn.v", "self_attn.o",
    "cross_attn.q", "cross_attn.k", "cross_attn.v", "cross_attn.o", "ffn.0", "ffn.2",
    "before_proj", "after_proj", NULL};

int gv_lora_target_known(const char *name)
{
    for (int i = 0; lora_target_names[i]; i++)
        if (!strcmp(name, lora_target_names[i])) return 1;
    return 0;
}

int gv_lora_matches(const gv_lora_config *l, const char *path)
{
    size_t len = strlen(path);
    for (int i = 0; l->rank > 0 && i < l->n_targets; i++) {
        const char *t = l->targets[i];
        size_t tl = strlen(t);
        if (!strcmp(path, t) || (len > tl && path[len - tl - 1] == '.' && !strcmp(path + len - tl, t))) return 1;
    }
    return 0;
}

void gv_model_config_defaults(gv_model_config *c)
{
    memset(c, 0, sizeof *c);
    c->dit.qk_norm = 1;
    c->dit.cross_attn_norm = 1;
    c->dit.cross_attn = 1;
    c->dit.eps = 1e-6;
    c->camera.channels = 128;   /* the authors' encoder (docs/reference/wan-vace-gaussvid.md 1.4) */
    c->camera.gate_hidden = 256;
    c->camera.proj_hidden = 0;  /* 0 until set: the DiT width */
    c->camera.gamma_init = 0.1; /* paper eq. (3): gamma starts at 0.1 */
    c->lora.rank = 32;          /* paper section 4: rank 32 */
    c->lora.alpha = 32;
    c->lora.blocks = c->lora.vace_blocks = 1;
    const char *targets[] = {"q", "k", "v", "o", "ffn.0", "ffn.2"};
    c->lora.n_targets = 6;
    for (int i = 0; i < 6; i++) snprintf(c->lora.targets[i], GV_LORA_TARGET_MAX, "%s", targets[i]);
    c->variant.camera = GV_CAMERA_DECOMPOSED;
    c->variant.anchors = GV_ANCHORS_BOTH;
}

static int in_range(const char *src, const char *key, long v, long lo, long hi)
{
    if (v < lo || v > hi) return gv_config_bad(src, key, "must be in [%ld, %ld] (got %ld)", lo, hi, v);
    return 0;
}

static int validate_dit(const gv_model_config *c, const char *src)
{
    const gv_dit_config *d = &c->dit;
    if (in_range(src, "dit.dim", d->dim, 1, 65536) || in_range(src, "dit.ffn_dim", d->ffn_dim, 1, 1 << 20) ||
        in_range(src, "dit.freq_dim", d->freq_dim, 2, 65536) ||
        in_range(src, "dit.num_heads", d->num_heads, 1, 65536) ||
        in_range(src, "dit.num_layers", d->num_layers, 1, GV_MAX_LAYERS) ||
        in_range(src, "dit.in_dim", d->in_dim, 1, GV_VAE_MAX_Z_DIM) ||
        in_range(src, "dit.out_dim", d->out_dim, 1, GV_VAE_MAX_Z_DIM))
        return -1;
    for (int k = 0; k < 3; k++)
        if (in_range(src, "dit.patch_size", d->patch_size[k], 1, 16)) return -1;
    if (d->freq_dim % 2) return gv_config_bad(src, "dit.freq_dim", "must be even (cos and sin halves), got %d", d->freq_dim);
    if (d->dim % d->num_heads)
        return gv_config_bad(src, "dit.dim", "%d is not divisible by dit.num_heads (%d)", d->dim, d->num_heads);
    int head_dim = d->dim / d->num_heads;
    if (head_dim % 2 || head_dim < 6) /* docs/reference/wan-vace-gaussvid.md 2.6: RoPE pairs split
                                         over frame, height, width */
        return gv_config_bad(src, "dit.num_heads", "head dimension dim/num_heads = %d must be even and at least 6 (3D RoPE)", head_dim);
    if (d->cross_attn) {
        if (in_range(src, "dit.text_dim", d->text_dim, 1, 65536) || in_range(src, "dit.text_len", d->text_len, 1, 65536)) return -1;
    } else if (in_range(src, "dit.text_dim", d->text_dim, 0, 65536) || in_range(src, "dit.text_len", d->text_len, 0, 65536)) {
        return -1;
    }
    if (!(d->eps > 0 && d->eps <= 0.1)) return gv_config_bad(src, "dit.eps", "must be in (0, 0.1] (got %g)", d->eps);
    if (in_range(src, "dit.vace_layers", d->n_vace_layers, 0, d->num_layers)) return -1;
    for (int j = 0; j < d->n_vace_layers; j++) {
        int layer = d->vace_layers[j];
        if (layer < 0 || layer >= d->num_layers)
            return gv_config_bad(src, "dit.vace_layers", "layer %d is not a block index in [0, %d)", layer, d->num_layers);
        if (j == 0 && layer != 0) /* docs/reference/wan-vace-gaussvid.md 3.1: block 0 must be in the
                                     list (before_proj) */
            return gv_config_bad(src, "dit.vace_layers", "must start with layer 0 (got %d)", layer);
        if (j > 0 && layer <= d->vace_layers[j - 1])
            return gv_config_bad(src, "dit.vace_layers", "must be strictly increasing (%d after %d)", layer, d->vace_layers[j - 1]);
    }
    if (d->in_dim != c->vae.z_dim)
        return gv_config_bad(src, "dit.in_dim", "%d differs from vae.z_dim (%d), the latent channels", d->in_dim, c->vae.z_dim);
    if (d->out_dim != c->vae.z_dim)
        return gv_config_bad(src, "dit.out_dim", "%d differs from vae.z_dim (%d), the latent channels", d->out_dim, c->vae.z_dim);
    /* The VACE context's channels (docs/reference/wan-vace-gaussvid.md 3.3). */
    int want = 2 * c->vae.z_dim + c->vae.spatial_factor * c->vae.spatial_factor;
    if (d->n_vace_layers > 0 && d->vace_in_dim != want)
        return gv_config_bad(src, "dit.vace_in_dim", "%d should be 2 vae.z_dim + vae.spatial_factor^2 = %d (inactive, reactive latents and mask)",
                             d->vace_in_dim, want);
    if (d->n_vace_layers == 0 && in_range(src, "dit.vace_in_dim", d->vace_in_dim, 0, 1 << 16)) return -1;
    return 0;
}

static int is_power_of_two_scale(double s)
{
    for (int k = -8; k <= 8; k++)
        if (s == ldexp(1.0, k)) return 1;
    return 0;
}

static int validate_vae(const gv_vae_config *v, const char *src)
{
    if (in_range(src, "vae.dim", v->dim, 1, 4096) || in_range(src, "vae.z_dim", v->z_dim, 1, GV_VAE_MAX_Z_DIM) ||
        in_range(src, "vae.dim_mult", v->n_levels, 2, GV_VAE_MAX_LEVELS) ||
        in_range(src, "vae.num_res_blocks", v->num_res_blocks, 1, 16) ||
        in_range(src, "vae.attn_scales", v->n_attn_scales, 0, GV_VAE_MAX_ATTN_SCALES))
        return -1;
    for (int k = 0; k < v->n_levels; k++) {
        if (in_range(src, "vae.dim_mult", v->dim_mult[k], 1, 64)) return -1;
        /* Decoder3d halves the channels of every stage it upsamples
         * (docs/reference/wan-vace-gaussvid.md 4.2). */
        if (k >= 1 && (v->dim * v->dim_mult[k]) % 2)
            return gv_config_bad(src, "vae.dim_mult", "vae.dim x dim_mult[%d] = %d must be even (the decoder's upsampling halves it)",
                                 k, v->dim * v->dim_mult[k]);
    }
    for (int k = 0; k < v->n_attn_scales; k++)
        if (!is_power_of_two_scale(v->attn_scales[k]))
            return gv_config_bad(src, "vae.attn_scales", "%g is not a power of two between 2^-8 and 2^8", v->attn_scales[k]);
    int n_temporal = 0;
    for (int k = 0; k < v->n_levels - 1; k++) n_temporal += v->temperal_downsample[k] != 0;
    if (n_temporal != 0 && n_temporal != 2)
        return gv_config_bad(src, "vae.temperal_downsample", "needs 0 or 2 true flags (temporal factor 1 or 4), got %d", n_temporal);
    int tf = 1 << n_temporal, sf = 1 << (v->n_levels - 1);
    if (v->temporal_factor != tf)
        return gv_config_bad(src, "vae.temporal_factor", "%d disagrees with vae.temperal_downsample (factor %d)", v->temporal_factor, tf);
    if (v->spatial_factor != sf)
        return gv_config_bad(src, "vae.spatial_factor", "%d disagrees with vae.dim_mult (%d levels: factor %d)", v->spatial_factor, v->n_levels, sf);
    for (int k = 0; v->has_latent_stats && k < v->z_dim; k++) {
        if (!isfinite(v->latent_mean[k])) return gv_config_bad(src, "vae.latent_mean", "entry %d is not finite", k);
        if (!(isfinite(v->latent_std[k]) && v->latent_std[k] > 0))
            return gv_config_bad(src, "vae.latent_std", "entry %d must be positive and finite (got %g)", k, v->latent_std[k]);
    }
    return 0;
}

static int validate_lora(const gv_model_config *c, const char *src)
{
    const gv_lora_config *l = &c->lora;
    if (in_range(src, "lora.rank", l->rank, 0, 4096) || in_range(src, "lora.targets", l->n_targets, 0, GV_LORA_MAX_TARGETS)) return -1;
    if (l->rank == 0) return 0;
    if (!(isfinite(l->alpha) && l->alpha > 0)) return gv_config_bad(src, "lora.alpha", "must be positive (got %g)", l->alpha);
    if (l->n_targets == 0) return gv_config_bad(src, "lora.targets", "is empty while lora.rank is %d", l->rank);
    if (!l->blocks && !l->vace_blocks) return gv_config_bad(src, "lora.modules", "is empty while lora.rank is %d", l->rank);
    for (int i = 0; i < l->n_targets; i++) {
        const char *t = l->targets[i];
        if (!gv_lora_target_known(t))
            return gv_config_bad(src, "lora.targets", "\"%s\" is not a linear layer of a block (q, k, v, o, self_attn.*, cross_attn.*, ffn.0, ffn.2, before_proj, after_proj)", t);
        for (int j = 0; j < i; j++)
            if (!strcmp(t, l->targets[j])) return gv_config_bad(src, "lora.targets", "\"%s\" is listed twice", t);
        if (!strncmp(t, "cross_attn.", 11) && !c->dit.cross_attn)
            return gv_config_bad(src, "lora.targets", "\"%s\" matches no layer: dit.cross_attn is false", t);
        if (strstr(t, "_proj") && !(l->vace_blocks && c->dit.n_vace_layers > 0))
            return gv_config_bad(src, "lora.targets", "\"%s\" exists only in VACE blocks, which get no adapters here", t);
    }
    if (l->vace_blocks && !l->blocks && c->dit.n_vace_layers == 0)
        return gv_config_bad(src, "lora.modules", "\"vace_blocks\" but the model has no VACE blocks");
    return 0;
}

int gv_model_config_validate(const gv_model_config *c, const char *source)
{
    const char *src = source ? source : "config";
    size_t name_len = strnlen(c->name, GV_CONFIG_NAME_MAX);
    if (name_len == 0 || name_len >= GV_CONFIG_NAME_MAX) return gv_config_bad(src, "name", "must have 1 to %d characters", GV_CONFIG_NAME_MAX - 1);
    for (size_t i = 0; i < name_len; i++)
        if ((unsigned char)c->name[i] < 0x20 || c->name[i] == 0x7f) return gv_config_bad(src, "name", "contains a control character");
    if (validate_vae(&c->vae, src) || validate_dit(c, src)) return -1;
    const gv_camera_config *k = &c->camera;
    if (in_range(src, "camera.channels", k->channels, 1, 65536) || in_range(src, "camera.gate_hidden", k->gate_hidden, 1, 65536) ||
        in_range(src, "camera.proj_hidden", k->proj_hidden, 1, 1 << 18))
        return -1;
    if (!isfinite(k->gamma_init)) return gv_config_bad(src, "camera.gamma_init", "is not finite");
    if ((unsigned)c->variant.camera > GV_CAMERA_DECOMPOSED) return gv_config_bad(src, "variant.camera", "unknown variant");
    if ((unsigned)c->variant.anchors > GV_ANCHORS_BOTH) return gv_config_bad(src, "variant.anchors", "unknown anchor mode");
    if (c->variant.per_frame && c->variant.anchors != GV_ANCHORS_NONE) /* docs/ARCHITECTURE.md 6.6 */
        return gv_config_bad(src, "variant.anchors", "a per-frame restorer has no anchors: use \"none\" (got \"%s\")",
                             gv_anchors_name(c->variant.anchors));
    if (c->variant.skip && c->variant.residual)
        return gv_config_bad(src, "variant.residual", "the skip and residual outputs exclude each other");
    if (c->variant.coverage && (c->variant.per_frame || c->variant.anchors != GV_ANCHORS_BOTH))
        return gv_config_bad(src, "variant.coverage", "the coverage mask is by both anchors: needs anchors \"both\" "
                             "and not per-frame");
    return validate_lora(c, src);
}

/* ---- variants ------------------------------------------------------------------------- */

/* "true" or "false" into *out, else a one-line error naming the key. */
static int bool_value(const char *src, const char *key, const char *value, int *out)
{
    if (strcmp(value, "true") && strcmp(value, "false")) return gv_config_bad(src, key, "\"%s\" is not true or false", value);
    *out = !strcmp(value, "true");
    return 0;
}

static int set_one(gv_model_config *c, const char *key, const char *value, const char *src)
{
    if (!strcmp(key, "camera")) {
        int v = gv_camera_variant_from_name(value);
        if (v < 0) return gv_config_bad(src, "variant.camera", "\"%s\" is not none, early, monolithic or decomposed", value);
        c->variant.camera = (gv_camera_variant)v;
    } else if (!strcmp(key, "anchors")) {
        int a = gv_anchors_from_name(value);
        if (a < 0) return gv_config_bad(src, "variant.anchors", "\"%s\" is not none, first or both", value);
        c->variant.anchors = (gv_anchors)a;
    } else if (!strcmp(key, "per_frame")) {
        return bool_value(src, "variant.per_frame", value, &c->variant.per_frame);
    } else if (!strcmp(key, "skip")) {
        return bool_value(src, "variant.skip", value, &c->variant.skip);
    } else if (!strcmp(key, "residual")) {
        return bool_value(src, "variant.residual", value, &c->variant.residual);
    } else if (!strcmp(key, "coverage")) {
        return bool_value(src, "variant.coverage", value, &c->variant.coverage);
    } else if (!strcmp(key, "lora")) {
        char *end;
        long rank = strtol(value, &end, 10);
        if (end == value || *end || rank < 0 || rank > 4096) return gv_config_bad(src, "lora.rank", "\"%s\" is not a rank in [0, 4096]", value);
        if (c->lora.rank > 0 && rank > 0) c->lora.alpha *= (double)rank / c->lora.rank; /* keep alpha / rank */
        else if (rank > 0) c->lora.alpha = (double)rank;
        c->lora.rank = (int)rank;
    } else {
        return gv_config_bad(src, key, "unknown variant key (camera, anchors, per_frame, skip, residual, coverage, lora)");
    }
    return 0;
}

int gv_model_config_set_variant(gv_model_config *c, const char *spec, const char *source)
{
    const char *src = source ? source : "--variant";
    char buf[256];
    if (strlen(spec) >= sizeof buf) return gv_fail("%s: variant \"%.40s...\" is too long", src, spec);
    snprintf(buf, sizeof buf, "%s", spec);
    char *save = NULL;
    for (char *item = strtok_r(buf, ",", &save); item; item = strtok_r(NULL, ",", &save)) {
        char *eq = strchr(item, '=');
        int rc;
        if (eq) {
            *eq = '\0';
            rc = set_one(c, item, eq + 1, src);
        } else if (!strcmp(item, "per-frame") || !strcmp(item, "per_frame")) {
            rc = set_one(c, "per_frame", "true", src);
            if (!rc) c->variant.anchors = GV_ANCHORS_NONE;
        } else if (!strcmp(item, "skip") || !strcmp(item, "residual")) {
            /* the two output forms exclude each other: naming one replaces the other */
            rc = set_one(c, item, "true", src);
            if (!rc) rc = set_one(c, item[0] == 's' ? "residual" : "skip", "false", src);
        } else if (!strcmp(item, "coverage")) {
            rc = set_one(c, "coverage", "true", src);
        } else if (gv_camera_variant_from_name(item) >= 0) {
            rc = set_one(c, "camera", item, src);
        } else {
            rc = gv_fail("%s: \"%s\" is not a variant (camera name, per-frame, skip, residual, coverage, or key=value)", src, item);
        }
        if (rc) return -1;
    }
    return gv_model_config_validate(c, src);
}

/* ---- equality and derived sizes ------------------------------------------------------- */

static int ints_equal(const int *a, const int *b, int n)
{
    return n == 0 || !memcmp(a, b, (size_t)n * sizeof *a);
}

int gv_model_config_equal(const gv_model_config *a, const gv_model_config *b)
{
    const gv_dit_config *p = &a->dit, *q = &b->dit;
    if (strcmp(a->name, b->name) || p->dim != q->dim || p->ffn_dim != q->ffn_dim || p->freq_dim != q->freq_dim ||
        p->text_dim != q->text_dim || p->num_heads != q->num_heads || p->num_layers != q->num_layers ||
        p->n_vace_layers != q->n_vace_layers || !ints_equal(p->vace_layers, q->vace_layers, p->n_vace_layers) ||
        p->vace_in_dim != q->vace_in_dim || !ints_equal(p->patch_size, q->patch_size, 3) || p->in_dim != q->in_dim ||
        p->out_dim != q->out_dim || p->text_len != q->text_len || p->eps != q->eps || p->qk_norm != q->qk_norm ||
        p->cross_attn_norm != q->cross_attn_norm || p->cross_attn != q->cross_attn)
        return 0;
    const gv_vae_config *v = &a->vae, *w = &b->vae;
    if (v->dim != w->dim || v->z_dim != w->z_dim || v->n_levels != w->n_levels ||
        !ints_equal(v->dim_mult, w->dim_mult, v->n_levels) || v->num_res_blocks != w->num_res_blocks ||
        v->n_attn_scales != w->n_attn_scales || !ints_equal(v->temperal_downsample, w->temperal_downsample, v->n_levels - 1) ||
        v->temporal_factor != w->temporal_factor || v->spatial_factor != w->spatial_factor ||
        v->has_latent_stats != w->has_latent_stats)
        return 0;
    for (int k = 0; k < v->n_attn_scales; k++)
        if (v->attn_scales[k] != w->attn_scales[k]) return 0;
    for (int k = 0; v->has_latent_stats && k < v->z_dim; k++)
        if (v->latent_mean[k] != w->latent_mean[k] || v->latent_std[k] != w->latent_std[k]) return 0;
    const gv_camera_config *m = &a->camera, *n = &b->camera;
    if (m->channels != n->channels || m->gate_hidden != n->gate_hidden || m->proj_hidden != n->proj_hidden ||
        m->gamma_init != n->gamma_init)
        return 0;
    const gv_lora_config *l = &a->lora, *r = &b->lora;
    if (l->rank != r->rank || l->alpha != r->alpha || l->n_targets != r->n_targets || l->blocks != r->blocks ||
        l->vace_blocks != r->vace_blocks)
        return 0;
    for (int i = 0; i < l->n_targets; i++)
        if (strcmp(l->targets[i], r->targets[i])) return 0;
    return a->variant.camera == b->variant.camera && a->variant.anchors == b->variant.anchors &&
           a->variant.per_frame == b->variant.per_frame && a->variant.skip == b->variant.skip &&
           a->variant.residual == b->variant.residual && a->variant.coverage == b->variant.coverage;
}

void gv_model_camera_kernel(const gv_model_config *c, int kernel[3])
{
    kernel[0] = c->vae.temporal_factor * c->dit.patch_size[0];
    kernel[1] = c->vae.spatial_factor * c->dit.patch_size[1];
    kernel[2] = c->vae.spatial_factor * c->dit.patch_size[2];
}

int gv_model_has_camera_stream(const gv_model_config *c)
{
    return c->variant.camera == GV_CAMERA_MONOLITHIC || c->variant.camera == GV_CAMERA_DECOMPOSED;
}
