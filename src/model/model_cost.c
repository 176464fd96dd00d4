/* The forward FLOP count of the restoration network on one clip, from its config alone: the
 * arithmetic behind the small preset's budget (docs/MODEL.md), and a quick way to size new
 * configs. A multiply-add counts 2 FLOP; norms, softmax and element-wise work are left out. */
#include "gaussvid/model/model_config.h"
#include "gaussvid/core/core.h"
#include "model/config_internal.h"

#include <string.h>

/* A linear layer in -> out applied to n tokens. */
static double lin(double n, double in, double out)
{
    return 2.0 * n * in * out;
}

/* LoRA's extra work in one block: r (in + out) multiply-adds per token per adapted linear. */
static double lora_block(const gv_model_config *c, double n_self, double n_video, int vace_index)
{
    const gv_lora_config *l = &c->lora;
    double D = c->dit.dim, F = c->dit.ffn_dim, r = l->rank, total = 0;
    static const char *const qkvo[4] = {"q", "k", "v", "o"};
    char path[32];
    for (int attn = 0; attn < (c->dit.cross_attn ? 2 : 1); attn++)
        for (int i = 0; i < 4; i++) {
            strcpy(path, attn ? "cross_attn." : "self_attn.");
            strcat(path, qkvo[i]);
            /* cross-attention k and v act on the text rows, q and o on the video tokens */
            double n = !attn ? n_self : (i == 1 || i == 2) ? c->dit.text_len : n_video;
            if (gv_lora_matches(l, path)) total += 2 * n * r * (D + D);
        }
    if (gv_lora_matches(l, "ffn.0")) total += 2 * n_self * r * (D + F);
    if (gv_lora_matches(l, "ffn.2")) total += 2 * n_self * r * (F + D);
    if (vace_index == 0 && gv_lora_matches(l, "before_proj")) total += 2 * n_video * r * 2 * D;
    if (vace_index >= 0 && gv_lora_matches(l, "after_proj")) total += 2 * n_video * r * 2 * D;
    return total;
}

/* The camera encoder on n ray-field patches of kvol pixels per channel. */
static double camera_encoder(const gv_model_config *c, double n, double kvol)
{
    double C = c->camera.channels, G = c->camera.gate_hidden, P = c->camera.proj_hidden, D = c->dit.dim;
    double proj = lin(n, 2 * C, P) + lin(n, P, D);
    switch (c->variant.camera) {
    case GV_CAMERA_DECOMPOSED: return 2 * lin(n, 3 * kvol, C) + 2 * (lin(n, C, G) + lin(n, G, C)) + proj;
    case GV_CAMERA_MONOLITHIC:
    case GV_CAMERA_EARLY: return lin(n, 6 * kvol, 2 * C) + lin(n, 2 * C, 2 * G) + lin(n, 2 * G, 2 * C) + proj;
    default: return 0;
    }
}

int gv_model_cost_estimate(const gv_model_config *c, int frames, int height, int width, gv_model_cost *out)
{
    memset(out, 0, sizeof *out);
    const gv_dit_config *d = &c->dit;
    int tf = c->vae.temporal_factor, sf = c->vae.spatial_factor;
    int evaluations = c->variant.per_frame ? frames : 1;
    int clip_frames = c->variant.per_frame ? 1 : frames;
    if (frames < 1 || (clip_frames - 1) % tf)
        return gv_fail("%d frames: a clip needs 1 + k x %d frames (the VAE's temporal packing)", frames, tf);
    int lt = 1 + (clip_frames - 1) / tf;
    if (lt % d->patch_size[0]) return gv_fail("%d latent frames are not a multiple of the temporal patch %d", lt, d->patch_size[0]);
    int gh = sf * d->patch_size[1], gw = sf * d->patch_size[2];
    if (height < gh || width < gw || height % gh || width % gw)
        return gv_fail("%dx%d: height and width must be multiples of %dx%d (VAE factor x patch)", height, width, gh, gw);
    out->latent_frames = lt;
    out->latent_height = height / sf;
    out->latent_width = width / sf;
    out->evaluations = evaluations;
    double nv = (double)(lt / d->patch_size[0]) * (height / gh) * (width / gw);
    double nc = gv_model_has_camera_stream(c) ? nv : 0, n = nv + nc;
    out->video_tokens = (int)nv;
    out->camera_tokens = (int)nc;
    double D = d->dim, F = d->ffn_dim, L = d->num_layers, V = d->n_vace_layers, T = d->text_len;
    double pvol = (double)d->patch_size[0] * d->patch_size[1] * d->patch_size[2];
    double block_linear = 4 * lin(1, D, D) + lin(1, D, F) + lin(1, F, D); /* per token */
    out->flops_blocks_linear = L * n * block_linear;
    out->flops_blocks_attention = L * 4 * n * n * D;
    if (d->cross_attn) { /* video tokens only; the text embedding once */
        double per_block = 2 * lin(nv, D, D) + 2 * lin(T, D, D) + 4 * nv * T * D;
        out->flops_cross_attention = (L + V) * per_block + lin(T, d->text_dim, D) + lin(T, D, D);
    }
    if (V > 0)
        out->flops_vace = V * (nv * block_linear + 4 * nv * nv * D + lin(nv, D, D)) + lin(nv, D, D) +
                          lin(nv, d->vace_in_dim * pvol, D);
    int k[3];
    gv_model_camera_kernel(c, k);
    out->flops_camera = camera_encoder(c, nv, (double)k[0] * k[1] * k[2]);
    for (int i = 0; c->lora.rank > 0 && c->lora.blocks && i < d->num_layers; i++) out->flops_lora += lora_block(c, n, nv, -1);
    for (int j = 0; c->lora.rank > 0 && c->lora.vace_blocks && j < d->n_vace_layers; j++) out->flops_lora += lora_block(c, nv, nv, j);
    out->flops_embed_head = lin(nv, d->in_dim * pvol, D) + lin(nv, D, d->out_dim * pvol) +
                            lin(1, d->freq_dim, D) + lin(1, D, D) + lin(1, D, 6 * D);
    double *parts[] = {&out->flops_blocks_linear, &out->flops_blocks_attention, &out->flops_cross_attention,
                       &out->flops_vace, &out->flops_camera, &out->flops_lora, &out->flops_embed_head};
    for (int i = 0; i < 7; i++) {
        *parts[i] *= evaluations;
        out->flops_total += *parts[i];
    }
    return 0;
}
