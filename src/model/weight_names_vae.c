/* The Wan2.1 VAE's tensors with the official state-dict indices
 * (docs/reference/wan-vace-gaussvid.md 4.2, 4.3), for any config of the family: nn.Sequential
 * indices count every module, parameterless ones (SiLU, dropout, zero padding, upsampling)
 * included, so a residual block's convolutions are residual.2 and residual.6 and a resample's
 * convolution is resample.1. */
#include "gaussvid/model/weight_names.h"
#include "gaussvid/core/core.h"
#include "model/weight_names_internal.h"

#include <stdio.h>

typedef enum { DOWN2D, DOWN3D, UP2D, UP3D } resample_mode;

/* A causal 3D convolution "prefix.weight" [out, in, kt, kh, kw] and its bias. */
static int conv3d(gv_weight_list *l, gv_module m, const char *prefix, int64_t out, int64_t in, int kt, int kh, int kw)
{
    if (gv_weight_add(l, m, GV_INIT_RANDOM, prefix, "weight", GV_SHAPE(out, in, kt, kh, kw)) ||
        gv_weight_add(l, m, GV_INIT_RANDOM, prefix, "bias", GV_SHAPE(out)))
        return -1;
    return 0;
}

/* ResidualBlock(in, out): residual = [0 RMS_norm, 1 SiLU, 2 conv 3x3x3, 3 RMS_norm, 4 SiLU,
 * 5 Dropout, 6 conv 3x3x3]; shortcut = 1x1x1 conv when in != out. RMS_norm's gamma is
 * [C, 1, 1, 1] for video tensors. */
static int res_block(gv_weight_list *l, gv_module m, const char *prefix, int64_t in, int64_t out)
{
    char p[GV_WEIGHT_NAME_MAX];
    snprintf(p, sizeof p, "%s.residual.2", prefix);
    if (gv_weight_add(l, m, GV_INIT_ONES, prefix, "residual.0.gamma", GV_SHAPE(in, 1, 1, 1)) ||
        conv3d(l, m, p, out, in, 3, 3, 3) ||
        gv_weight_add(l, m, GV_INIT_ONES, prefix, "residual.3.gamma", GV_SHAPE(out, 1, 1, 1)))
        return -1;
    snprintf(p, sizeof p, "%s.residual.6", prefix);
    if (conv3d(l, m, p, out, out, 3, 3, 3)) return -1;
    snprintf(p, sizeof p, "%s.shortcut", prefix);
    if (in != out && conv3d(l, m, p, out, in, 1, 1, 1)) return -1;
    return 0;
}

/* AttentionBlock(C), per frame: RMS_norm (gamma [C, 1, 1]), to_qkv 1x1 Conv2d C -> 3C, proj
 * 1x1 Conv2d C -> C whose weight the official code zeroes. */
static int attention_block(gv_weight_list *l, gv_module m, const char *prefix, int64_t c)
{
    if (gv_weight_add(l, m, GV_INIT_ONES, prefix, "norm.gamma", GV_SHAPE(c, 1, 1)) ||
        gv_weight_add(l, m, GV_INIT_RANDOM, prefix, "to_qkv.weight", GV_SHAPE(3 * c, c, 1, 1)) ||
        gv_weight_add(l, m, GV_INIT_RANDOM, prefix, "to_qkv.bias", GV_SHAPE(3 * c)) ||
        gv_weight_add(l, m, GV_INIT_ZEROS, prefix, "proj.weight", GV_SHAPE(c, c, 1, 1)) ||
        gv_weight_add(l, m, GV_INIT_RANDOM, prefix, "proj.bias", GV_SHAPE(c)))
        return -1;
    return 0;
}

/* Resample(C): resample = [0 ZeroPad2d or Upsample, 1 Conv2d 3x3] (C -> C down, C -> C/2 up);
 * the 3D modes add time_conv, (3,1,1): C -> C stride 2 down, C -> 2C up (time doubling). */
static int resample(gv_weight_list *l, gv_module m, const char *prefix, int64_t c, resample_mode mode)
{
    int64_t out = mode == UP2D || mode == UP3D ? c / 2 : c;
    if (gv_weight_add(l, m, GV_INIT_RANDOM, prefix, "resample.1.weight", GV_SHAPE(out, c, 3, 3)) ||
        gv_weight_add(l, m, GV_INIT_RANDOM, prefix, "resample.1.bias", GV_SHAPE(out)))
        return -1;
    char p[GV_WEIGHT_NAME_MAX];
    snprintf(p, sizeof p, "%s.time_conv", prefix);
    if (mode == DOWN3D && conv3d(l, m, p, c, c, 3, 1, 1)) return -1;
    if (mode == UP3D && conv3d(l, m, p, 2 * c, c, 3, 1, 1)) return -1;
    return 0;
}

/* middle = [0 ResidualBlock, 1 AttentionBlock, 2 ResidualBlock] at width c. */
static int middle(gv_weight_list *l, gv_module m, const char *prefix, int64_t c)
{
    char p[GV_WEIGHT_NAME_MAX];
    for (int i = 0; i < 3; i++) {
        snprintf(p, sizeof p, "%s.middle.%d", prefix, i);
        if (i == 1 ? attention_block(l, m, p, c) : res_block(l, m, p, c, c)) return -1;
    }
    return 0;
}

/* head = [0 RMS_norm, 1 SiLU, 2 conv 3x3x3 c -> out]. */
static int head(gv_weight_list *l, gv_module m, const char *prefix, int64_t c, int64_t out)
{
    char p[GV_WEIGHT_NAME_MAX];
    snprintf(p, sizeof p, "%s.head.2", prefix);
    if (gv_weight_add(l, m, GV_INIT_ONES, prefix, "head.0.gamma", GV_SHAPE(c, 1, 1, 1)) || conv3d(l, m, p, out, c, 3, 3, 3))
        return -1;
    return 0;
}

static int has_scale(const gv_vae_config *v, double scale)
{
    for (int k = 0; k < v->n_attn_scales; k++)
        if (v->attn_scales[k] == scale) return 1;
    return 0;
}

/* Encoder3d(dim, 2 z_dim): widths dim x [1, dim_mult...]; per stage num_res_blocks residual
 * blocks (each followed by attention when the stage's scale, 1 halved per downsample, is in
 * attn_scales) and a downsample between stages (3D when temperal_downsample says so). */
static int encoder(gv_weight_list *l, const gv_vae_config *v)
{
    const gv_module m = GV_MODULE_VAE_ENCODER;
    char p[GV_WEIGHT_NAME_MAX];
    int64_t dims[GV_VAE_MAX_LEVELS + 1];
    dims[0] = v->dim;
    for (int i = 0; i < v->n_levels; i++) dims[i + 1] = (int64_t)v->dim * v->dim_mult[i];
    if (conv3d(l, m, "encoder.conv1", dims[0], 3, 3, 3, 3)) return -1;
    int index = 0;
    double scale = 1.0;
    int64_t in = dims[0], out = dims[0];
    for (int i = 0; i < v->n_levels; i++) {
        out = dims[i + 1];
        for (int r = 0; r < v->num_res_blocks; r++) {
            snprintf(p, sizeof p, "encoder.downsamples.%d", index++);
            if (res_block(l, m, p, in, out)) return -1;
            snprintf(p, sizeof p, "encoder.downsamples.%d", index);
            if (has_scale(v, scale) && (index++, attention_block(l, m, p, out))) return -1;
            in = out;
        }
        if (i == v->n_levels - 1) break;
        snprintf(p, sizeof p, "encoder.downsamples.%d", index++);
        if (resample(l, m, p, out, v->temperal_downsample[i] ? DOWN3D : DOWN2D)) return -1;
        scale /= 2.0;
    }
    if (middle(l, m, "encoder", out) || head(l, m, "encoder", out, 2 * v->z_dim)) return -1;
    return conv3d(l, m, "conv1", 2 * v->z_dim, 2 * v->z_dim, 1, 1, 1); /* mean and log-variance */
}

/* Decoder3d(dim, z_dim): widths dim x [dim_mult[-1], reversed dim_mult]; per stage
 * num_res_blocks + 1 residual blocks, the first taking half the width from the previous
 * upsample (the official "in_dim // 2" of stages 1-3), with attention when the stage's scale
 * (1 / 2^(levels - 2), doubled per upsample) is in attn_scales; time upsampling mirrors
 * temperal_downsample. */
static int decoder(gv_weight_list *l, const gv_vae_config *v)
{
    const gv_module m = GV_MODULE_VAE_DECODER;
    char p[GV_WEIGHT_NAME_MAX];
    int n = v->n_levels;
    int64_t dims[GV_VAE_MAX_LEVELS + 1];
    dims[0] = (int64_t)v->dim * v->dim_mult[n - 1];
    for (int i = 0; i < n; i++) dims[i + 1] = (int64_t)v->dim * v->dim_mult[n - 1 - i];
    if (conv3d(l, m, "conv2", v->z_dim, v->z_dim, 1, 1, 1) || conv3d(l, m, "decoder.conv1", dims[0], v->z_dim, 3, 3, 3) ||
        middle(l, m, "decoder", dims[0]))
        return -1;
    int index = 0;
    double scale = 1.0 / (double)(1 << (n - 2));
    int64_t out = dims[0];
    for (int i = 0; i < n; i++) {
        int64_t in = i == 0 ? dims[0] : dims[i] / 2;
        out = dims[i + 1];
        for (int r = 0; r < v->num_res_blocks + 1; r++) {
            snprintf(p, sizeof p, "decoder.upsamples.%d", index++);
            if (res_block(l, m, p, in, out)) return -1;
            snprintf(p, sizeof p, "decoder.upsamples.%d", index);
            if (has_scale(v, scale) && (index++, attention_block(l, m, p, out))) return -1;
            in = out;
        }
        if (i == n - 1) break;
        snprintf(p, sizeof p, "decoder.upsamples.%d", index++);
        if (resample(l, m, p, out, v->temperal_downsample[n - 2 - i] ? UP3D : UP2D)) return -1;
        scale *= 2.0;
    }
    return head(l, m, "decoder", out, 3);
}

int gv_weight_list_add_vae(gv_weight_list *l, const gv_vae_config *v)
{
    if (encoder(l, v) || decoder(l, v)) return -1;
    return 0;
}
