/* VACE (docs/reference/wan-vace-gaussvid.md 3.1-3.3; docs/ARCHITECTURE.md 6.3): the context branch
 * that turns [inactive latents | reactive latents | mask] into hints for designated main blocks,
 * and the construction of that context. For restoration M = 0 on the anchors and 1 on the frames to
 * restore; the anchors variant (docs/ARCHITECTURE.md 6.6) chooses which end frames are anchors. */
#include "model/dit_internal.h"
#include "gaussvid/core/core.h"

#include <math.h>
#include <string.h>

/* Reference 3.2: c = before_proj(vace_patch_embedding(context)) + x0; every VACE block (the
 * main block's math, same e0, text and RoPE) updates c and after_proj(c) is its hint. */
int gv_vace_hints(gv_graph *g, const gv_dit *m, const gv_dit_inputs *in, gv_tensor *x0, gv_tensor *e0, gv_tensor *rope,
                  gv_tensor *ctx, gv_tensor **hints)
{
    gv_tensor *vace = in->vace;
    const int total = m->cfg.dit.n_vace_layers + m->cfg.dit.num_layers;
    const int *p = m->cfg.dit.patch_size;
    gv_conv_geom geom = {{p[0], p[1], p[2]}, {0, 0, 0, 0, 0, 0}};
    gv_tensor *c = gv_dit_tokens(g, gv_conv3d(g, vace, m->vace_patch_w, m->vace_patch_b, &geom));
    c = gv_add(g, gv_dit_lin(g, m, &m->vace_blocks[0].before_proj, c), x0);
    for (int j = 0; j < m->cfg.dit.n_vace_layers; j++) {
        gv_arena_mark mark = gv_arena_get_mark(&g->arena);
        c = gv_dit_block_video(g, m, &m->vace_blocks[j], c, e0, rope, ctx, NULL, NULL);
        hints[j] = gv_dit_lin(g, m, &m->vace_blocks[j].after_proj, c);
        if (!hints[j]) return -1;
        gv_tensor *keep[2] = {c, hints[j]}; /* inference: one block's activations at a time */
        if (gv_dit_keep_only(g, mark, keep, 2) != 0) return -1;
        c = keep[0], hints[j] = keep[1];
        if (in->progress) in->progress(in->progress_ctx, j + 1, total);
    }
    return 0;
}

int gv_vace_frame_mask(gv_anchors anchors, int frames, float *mask)
{
    if (frames < 1) return gv_fail("vace mask: %d frames", frames);
    for (int f = 0; f < frames; f++) mask[f] = 1.0f;
    if (anchors == GV_ANCHORS_FIRST || anchors == GV_ANCHORS_BOTH) mask[0] = 0.0f;
    if (anchors == GV_ANCHORS_BOTH) mask[frames - 1] = 0.0f;
    return 0;
}

int gv_vace_mask_latent(const float *mask, int frames, int height, int width, int latent_frames, int sf, float *out)
{
    if (frames < 1 || latent_frames < 1 || latent_frames > frames || sf < 1 || height < sf || width < sf ||
        height % sf || width % sf)
        return gv_fail("vace mask: %d frames of %dx%d do not map to %d latent frames with factor %d", frames, width,
                       height, latent_frames, sf);
    int h = height / sf, w = width / sf;
    for (int k = 0; k < latent_frames; k++) {
        int src = (int)floor((k + 0.5) * frames / (double)latent_frames); /* PyTorch nearest-exact */
        if (src > frames - 1) src = frames - 1;
        const float *M = mask + (int64_t)src * height * width;
        for (int dy = 0; dy < sf; dy++)
            for (int dx = 0; dx < sf; dx++) {
                float *o = out + (((int64_t)(dy * sf + dx) * latent_frames + k) * h) * w;
                for (int y = 0; y < h; y++)
                    for (int x = 0; x < w; x++) o[(int64_t)y * w + x] = M[(int64_t)(y * sf + dy) * width + x * sf + dx];
            }
    }
    return 0;
}

int gv_vace_context_concat(const float *z_inactive, const float *z_reactive, const float *mask_latent, int z_dim,
                           int mask_channels, int frames, int h, int w, float *out)
{
    if (z_dim < 1 || mask_channels < 1 || frames < 1 || h < 1 || w < 1)
        return gv_fail("vace context: bad sizes %d + %d channels, %dx%dx%d", z_dim, mask_channels, frames, h, w);
    size_t plane = (size_t)frames * h * w, zb = (size_t)z_dim * plane * sizeof(float);
    memcpy(out, z_inactive, zb);
    memcpy(out + (size_t)z_dim * plane, z_reactive, zb);
    memcpy(out + (size_t)2 * z_dim * plane, mask_latent, (size_t)mask_channels * plane * sizeof(float));
    return 0;
}
