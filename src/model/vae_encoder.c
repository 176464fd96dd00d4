/* Encoder3d (docs/reference/wan-vace-gaussvid.md 4.3): conv1, then per stage num_res_blocks
 * residual blocks (with an attention block after each when the stage's scale is in attn_scales) and
 * a downsample between stages (3D where temperal_downsample says so), middle, head; then the VAE's
 * conv1 (quant) gives the posterior's mean and log-variance. */
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

int gv_vae_build_encoder(gv_vae_binder *b, const gv_vae_config *cfg, gv_vae_coder *enc)
{
    char p[GV_WEIGHT_NAME_MAX];
    int n = cfg->n_levels, per_stage = 2 * cfg->num_res_blocks + 1;
    enc->layers = calloc((size_t)n * per_stage, sizeof *enc->layers);
    if (!enc->layers) return gv_fail("vae: out of memory");
    int dims[GV_VAE_MAX_LEVELS + 1]; /* dim x [1, dim_mult...] */
    dims[0] = cfg->dim;
    for (int i = 0; i < n; i++) dims[i + 1] = cfg->dim * cfg->dim_mult[i];
    if (gv_vae_bind_conv(b, &enc->conv_in, "encoder.conv1", dims[0], 3, 3, 3, 3, enc->n_slots++)) return -1;
    double scale = 1.0;
    int in = dims[0];
    for (int i = 0; i < n; i++) {
        int out = dims[i + 1];
        for (int r = 0; r < cfg->num_res_blocks; r++) {
            snprintf(p, sizeof p, "encoder.downsamples.%d", enc->n_layers);
            if (gv_vae_bind_residual(b, &enc->layers[enc->n_layers++], p, in, out, &enc->n_slots)) return -1;
            in = out;
            if (!has_scale(cfg, scale)) continue;
            snprintf(p, sizeof p, "encoder.downsamples.%d", enc->n_layers);
            if (gv_vae_bind_attention(b, &enc->layers[enc->n_layers++], p, out)) return -1;
        }
        if (i == n - 1) break;
        snprintf(p, sizeof p, "encoder.downsamples.%d", enc->n_layers);
        gv_vae_layer_kind kind = cfg->temperal_downsample[i] ? GV_VAE_DOWN3D : GV_VAE_DOWN2D;
        if (gv_vae_bind_resample(b, &enc->layers[enc->n_layers++], p, out, kind, &enc->n_slots)) return -1;
        scale /= 2.0;
    }
    if (gv_vae_bind_middle(b, enc, "encoder", in)) return -1;
    return gv_vae_bind_head(b, enc, "encoder", in, 2 * cfg->z_dim); /* mean and log-variance */
}

gv_tensor *gv_vae_encoder_forward(gv_graph *g, gv_vae *v, gv_tensor *x, gv_vae_stream *s)
{
    if (!x) return NULL;
    char sx[64];
    if (x->ndim != 5 || x->shape[1] != 3 || x->shape[3] % v->cfg.spatial_factor ||
        x->shape[4] % v->cfg.spatial_factor) {
        gv_fail("vae encode: input %s is not [B, 3, T, H, W] with H and W multiples of %d",
                gv_shape_str(x, sx, sizeof sx), v->cfg.spatial_factor);
        return NULL;
    }
    if (s && (x->shape[0] != 1 || s->n_slots < v->encoder.n_slots)) {
        gv_fail("vae encode: a stream needs batch 1 and %d cache slots", v->encoder.n_slots);
        return NULL;
    }
    const gv_vae_coder *e = &v->encoder;
    int r = v->cfg.temporal_factor, T = x->shape[2];
    if (s && s->started[e->conv_in.slot] ? T % r : (T - 1) % r) {
        gv_fail("vae encode: %d frames; a clip needs 1 + k x %d, a later chunk k x %d", T, r, r);
        return NULL;
    }
    gv_tensor *h = gv_vae_causal_conv(g, &e->conv_in, x, 1, s);
    for (int i = 0; i < e->n_layers; i++) h = gv_vae_layer_forward(g, &e->layers[i], h, s);
    for (int i = 0; i < 3; i++) h = gv_vae_layer_forward(g, &e->middle[i], h, s);
    h = gv_vae_head_forward(g, e, h, s);
    return gv_vae_causal_conv(g, &v->quant, h, 0, NULL);
}
