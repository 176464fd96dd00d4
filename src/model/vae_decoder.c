/* Decoder3d (docs/reference/wan-vace-gaussvid.md 4.3): the VAE's conv2 (post-quant) on the latent,
 * then conv1, middle, and per stage num_res_blocks + 1 residual blocks (the first of stages 1..
 * takes half the width, since the upsample before it halved the channels) with attention where the
 * stage's scale is in attn_scales, an upsample between stages (3D mirroring temperal_downsample:
 * Wan's temperal_upsample is its reverse), head. */
#include <stdio.h>
#include <stdlib.h>

#include "gaussvid/core/core.h"
#include "model/vae_internal.h"

static int has_scale(const gv_vae_config *v, double scale)
{
    for (int k = 0; k < v->n_attn_scales; k++)
        if (v->attn_scales[k] == scale) return 1;
    return 0;
}

int gv_vae_build_decoder(gv_vae_binder *b, const gv_vae_config *cfg, gv_vae_coder *dec)
{
    char p[GV_WEIGHT_NAME_MAX];
    int n = cfg->n_levels, per_stage = 2 * (cfg->num_res_blocks + 1) + 1;
    dec->layers = calloc((size_t)n * per_stage, sizeof *dec->layers);
    if (!dec->layers) return gv_fail("vae: out of memory");
    int dims[GV_VAE_MAX_LEVELS + 1]; /* dim x [dim_mult[-1], reversed dim_mult...] */
    dims[0] = cfg->dim * cfg->dim_mult[n - 1];
    for (int i = 0; i < n; i++) dims[i + 1] = cfg->dim * cfg->dim_mult[n - 1 - i];
    if (gv_vae_bind_conv(b, &dec->conv_in, "decoder.conv1", dims[0], cfg->z_dim, 3, 3, 3, dec->n_slots++) ||
        gv_vae_bind_middle(b, dec, "decoder", dims[0]))
        return -1;
    double scale = 1.0 / (double)(1 << (n - 2));
    int out = dims[0];
    for (int i = 0; i < n; i++) {
        int in = i == 0 ? dims[0] : dims[i] / 2;
        out = dims[i + 1];
        for (int r = 0; r < cfg->num_res_blocks + 1; r++) {
            snprintf(p, sizeof p, "decoder.upsamples.%d", dec->n_layers);
            if (gv_vae_bind_residual(b, &dec->layers[dec->n_layers++], p, in, out, &dec->n_slots)) return -1;
            in = out;
            if (!has_scale(cfg, scale)) continue;
            snprintf(p, sizeof p, "decoder.upsamples.%d", dec->n_layers);
            if (gv_vae_bind_attention(b, &dec->layers[dec->n_layers++], p, out)) return -1;
        }
        if (i == n - 1) break;
        snprintf(p, sizeof p, "decoder.upsamples.%d", dec->n_layers);
        gv_vae_layer_kind kind = cfg->temperal_downsample[n - 2 - i] ? GV_VAE_UP3D : GV_VAE_UP2D;
        if (gv_vae_bind_resample(b, &dec->layers[dec->n_layers++], p, out, kind, &dec->n_slots)) return -1;
        scale *= 2.0;
    }
    return gv_vae_bind_head(b, dec, "decoder", out, 3);
}

gv_tensor *gv_vae_decoder_forward(gv_graph *g, gv_vae *v, gv_tensor *mu, gv_vae_stream *s)
{
    if (!mu) return NULL;
    char sz[64];
    if (mu->ndim != 5 || mu->shape[1] != v->cfg.z_dim) {
        gv_fail("vae decode: latent %s is not [B, %d, T, h, w]", gv_shape_str(mu, sz, sizeof sz), v->cfg.z_dim);
        return NULL;
    }
    if (s && (mu->shape[0] != 1 || s->n_slots < v->decoder.n_slots)) {
        gv_fail("vae decode: a stream needs batch 1 and %d cache slots", v->decoder.n_slots);
        return NULL;
    }
    const gv_vae_coder *d = &v->decoder;
    gv_tensor *h = gv_vae_causal_conv(g, &v->post_quant, mu, 0, NULL);
    h = gv_vae_causal_conv(g, &d->conv_in, h, 1, s);
    for (int i = 0; i < 3; i++) h = gv_vae_layer_forward(g, &d->middle[i], h, s);
    for (int i = 0; i < d->n_layers; i++) h = gv_vae_layer_forward(g, &d->layers[i], h, s);
    return gv_vae_head_forward(g, d, h, s);
}
