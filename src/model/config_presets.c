/* The built-in model presets (also shipped as configs/<name>.json; docs/MODEL.md explains
 * the choices). The Wan presets use the published numbers of the reference's sections 2.1,
 * 3.1, 4.1 and 4.5; their camera encoder uses the authors' sizes (section 1.4). */
#include "gaussvid/model/model_config.h"
#include "gaussvid/core/core.h"
#include "model/config_internal.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>

static const char *const preset_names[] = {"tiny", "small", "wan2.1-vace-1.3b", "wan2.1-vace-14b", NULL};

const char *const *gv_model_preset_names(void)
{
    return preset_names;
}

/* Wan2.1's VAE: dim 96, z 16, [1,2,4,4], 2 res blocks, no stage attention, time down
 * [F,T,T] (docs/reference/wan-vace-gaussvid.md 4.1) and its per-channel latent statistics
 * (docs/reference/wan-vace-gaussvid.md 4.5). */
static void wan_vae(gv_vae_config *v)
{
    static const double mean[16] = {-0.7571, -0.7089, -0.9113, 0.1075, -0.1745, 0.9653, -0.1517, 1.5508,
                                    0.4134, -0.0715, 0.5517, -0.3632, -0.1922, -0.9497, 0.2503, -0.2921};
    static const double std[16] = {2.8184, 1.4541, 2.3275, 2.6558, 1.2196, 1.7708, 2.6052, 2.0743,
                                   3.2687, 2.1526, 2.8652, 1.5579, 1.6382, 1.1253, 2.8251, 1.9160};
    const int mult[4] = {1, 2, 4, 4};
    v->dim = 96;
    v->z_dim = 16;
    v->n_levels = 4;
    memcpy(v->dim_mult, mult, sizeof mult);
    v->num_res_blocks = 2;
    v->n_attn_scales = 0;
    v->temperal_downsample[0] = 0;
    v->temperal_downsample[1] = v->temperal_downsample[2] = 1;
    v->temporal_factor = 4;
    v->spatial_factor = 8;
    v->has_latent_stats = 1;
    memcpy(v->latent_mean, mean, sizeof mean);
    memcpy(v->latent_std, std, sizeof std);
}

/* Wan2.1 DiT (docs/reference/wan-vace-gaussvid.md 2.1): shared numbers of the 1.3B and 14B
 * models. */
static void wan_dit(gv_dit_config *d, int dim, int ffn_dim, int heads, int layers, int vace_step, int n_vace)
{
    d->dim = dim;
    d->ffn_dim = ffn_dim;
    d->freq_dim = 256;
    d->text_dim = 4096; /* umT5-xxl */
    d->text_len = 512;
    d->num_heads = heads;
    d->num_layers = layers;
    d->n_vace_layers = n_vace;
    for (int j = 0; j < n_vace; j++) d->vace_layers[j] = j * vace_step;
    d->vace_in_dim = 96;
    d->patch_size[0] = 1;
    d->patch_size[1] = d->patch_size[2] = 2;
    d->in_dim = d->out_dim = 16;
    d->eps = 1e-6;
    d->qk_norm = d->cross_attn_norm = d->cross_attn = 1;
}

static void preset_wan_1_3b(gv_model_config *c)
{
    /* VACE-1.3B: 1536 / 8960 / 12 heads / 30 layers, hints at 0, 2, ..., 28 (15 blocks). */
    wan_dit(&c->dit, 1536, 8960, 12, 30, 2, 15);
    wan_vae(&c->vae);
    c->camera.proj_hidden = 1536;
}

static void preset_wan_14b(gv_model_config *c)
{
    /* VACE-14B: 5120 / 13824 / 40 heads / 40 layers, hints at 0, 5, ..., 35 (8 blocks). */
    wan_dit(&c->dit, 5120, 13824, 40, 40, 5, 8);
    wan_vae(&c->vae);
    c->camera.proj_hidden = 5120;
}

/* small: the CPU default. Token grid of a 5-frame 144x256 clip: VAE 4x spatial, no temporal
 * packing (16 x 5 x 36 x 64 latents; a 4x temporal VAE caps a perfect restorer's gain at
 * +0.5 dB, docs/VAE.md), patch 1x4x4: 5 x 9 x 16 = 720 video tokens plus 720 camera tokens.
 * docs/MODEL.md counts its FLOPs against the 0.5 s step budget. */
static void preset_small(gv_model_config *c)
{
    gv_dit_config *d = &c->dit;
    d->dim = 192;
    d->ffn_dim = 768;
    d->freq_dim = 256;
    d->num_heads = 3;
    d->num_layers = 5; /* 6 took 589 ms a step on two idle cores; 5 take 434 (docs/MODEL.md) */
    d->n_vace_layers = 2;
    d->vace_layers[0] = 0;
    d->vace_layers[1] = 3;
    d->vace_in_dim = 2 * 16 + 4 * 4;
    d->patch_size[0] = 1;
    d->patch_size[1] = d->patch_size[2] = 4;
    d->in_dim = d->out_dim = 16;
    d->cross_attn = 0; /* docs/ARCHITECTURE.md 6.3: no text in the small preset */
    gv_vae_config *v = &c->vae;
    v->dim = 32;
    v->z_dim = 16;
    v->n_levels = 3;
    v->dim_mult[0] = 1;
    v->dim_mult[1] = 2;
    v->dim_mult[2] = 4;
    v->num_res_blocks = 1;
    v->temperal_downsample[0] = v->temperal_downsample[1] = 0;
    v->temporal_factor = 1;
    v->spatial_factor = 4;
    c->camera.channels = 64;
    c->camera.gate_hidden = 128;
    c->camera.proj_hidden = 192;
    c->lora.rank = 16;
    c->lora.alpha = 16;
}

/* tiny: for tests. The same structure as Wan (text cross-attention, VAE stages
 * [1,2,2,2] with time down [F,T,T], so 2D and 3D resampling both occur) at toy widths. */
static void preset_tiny(gv_model_config *c)
{
    gv_dit_config *d = &c->dit;
    d->dim = 32;
    d->ffn_dim = 64;
    d->freq_dim = 16;
    d->text_dim = 16;
    d->text_len = 4;
    d->num_heads = 2;
    d->num_layers = 2;
    d->n_vace_layers = 2;
    d->vace_layers[0] = 0;
    d->vace_layers[1] = 1;
    d->vace_in_dim = 2 * 4 + 8 * 8;
    d->patch_size[0] = 1;
    d->patch_size[1] = d->patch_size[2] = 2;
    d->in_dim = d->out_dim = 4;
    gv_vae_config *v = &c->vae;
    const int mult[4] = {1, 2, 2, 2};
    v->dim = 8;
    v->z_dim = 4;
    v->n_levels = 4;
    memcpy(v->dim_mult, mult, sizeof mult);
    v->num_res_blocks = 1;
    v->temperal_downsample[1] = v->temperal_downsample[2] = 1;
    v->temporal_factor = 4;
    v->spatial_factor = 8;
    c->camera.channels = 4;
    c->camera.gate_hidden = 8;
    c->camera.proj_hidden = 32;
    c->lora.rank = 2;
    c->lora.alpha = 2;
}

int gv_model_config_preset(gv_model_config *c, const char *name)
{
    gv_model_config_defaults(c);
    if (!strcmp(name, "tiny")) preset_tiny(c);
    else if (!strcmp(name, "small")) preset_small(c);
    else if (!strcmp(name, "wan2.1-vace-1.3b")) preset_wan_1_3b(c);
    else if (!strcmp(name, "wan2.1-vace-14b")) preset_wan_14b(c);
    else return gv_fail("%s: unknown model preset (tiny, small, wan2.1-vace-1.3b, wan2.1-vace-14b)", name);
    snprintf(c->name, sizeof c->name, "%s", name);
    return gv_model_config_validate(c, name);
}

int gv_model_config_load(gv_model_config *c, const char *spec)
{
    size_t len = strlen(spec);
    int is_path = strchr(spec, '/') || (len >= 5 && !strcmp(spec + len - 5, ".json"));
    for (int i = 0; !is_path && preset_names[i]; i++)
        if (!strcmp(spec, preset_names[i])) return gv_model_config_preset(c, spec);
    if (!is_path && !gv_file_exists(spec))
        return gv_fail("%s: neither a model preset (tiny, small, wan2.1-vace-1.3b, wan2.1-vace-14b) nor a file", spec);
    char *text = NULL;
    size_t size = 0;
    if (gv_read_file(spec, &text, &size) != 0) return -1;
    int rc = 0;
    if (strlen(text) != size) rc = gv_fail("%s: contains a NUL byte (not a JSON text)", spec);
    else rc = gv_model_config_parse(c, text, spec);
    free(text);
    return rc;
}
