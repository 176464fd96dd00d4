/* Shared by the VAE's files (model/vae_*.c): the building blocks of
 * docs/reference/wan-vace-gaussvid.md section 4.2 with their causal caches (section 4.4), and the
 * binder that gives each block its tensors from the weight list. */
#ifndef GAUSSVID_VAE_INTERNAL_H
#define GAUSSVID_VAE_INTERNAL_H

#include "gaussvid/nn/ops.h"
#include "gaussvid/model/vae.h"
#include "gaussvid/model/weight_names.h"

/* Wan's RMS_norm clamps the channel norm at 1e-12 (F.normalize),
 * docs/reference/wan-vace-gaussvid.md 4.2. */
#define GV_VAE_NORM_FLOOR 1e-12f
/* Frames a k_t = 3 causal convolution keeps between chunks (Wan's CACHE_T). */
#define GV_VAE_CACHE_T 2

/* ---- binding tensors (vae_params.c) -------------------------------------------------------
 * The network asks for each tensor by name with the shape it computes itself; the binder
 * finds it in the weight list, checks the shape and marks it used, and (unless a dry run)
 * allocates and initialises it in params. */
typedef struct {
    const gv_weight_list *list;
    gv_params *params;       /* NULL: dry run, tensors are not allocated */
    unsigned char *used;     /* per list entry */
    int n_used;
    int64_t n_params;
    int trainable;
    uint64_t seed;
} gv_vae_binder;

/* Convolution "prefix.weight" [out, in, (kt,) kh, kw] (2-D when kt is 0) and its bias. */
int gv_vae_bind_conv(gv_vae_binder *b, gv_vae_conv *c, const char *prefix, int out, int in,
                     int kt, int kh, int kw, int slot);
/* RMS_norm gain "prefix.suffix": [c, 1, 1, 1] for videos (images 0), [c, 1, 1] in attention. */
gv_tensor *gv_vae_bind_gamma(gv_vae_binder *b, const char *prefix, const char *suffix, int c,
                             int images);
/* ResidualBlock(in, out), AttentionBlock(c), Resample(c, kind) at "prefix"; they take cache
 * slots from *n_slots. */
int gv_vae_bind_residual(gv_vae_binder *b, gv_vae_layer *l, const char *prefix, int in,
                         int out, int *n_slots);
int gv_vae_bind_attention(gv_vae_binder *b, gv_vae_layer *l, const char *prefix, int c);
int gv_vae_bind_resample(gv_vae_binder *b, gv_vae_layer *l, const char *prefix, int c,
                         gv_vae_layer_kind kind, int *n_slots);
/* middle.{0,1,2} of a coder at width c; head.{0,2} at width c with `out` channels out. */
int gv_vae_bind_middle(gv_vae_binder *b, gv_vae_coder *coder, const char *prefix, int c);
int gv_vae_bind_head(gv_vae_binder *b, gv_vae_coder *coder, const char *prefix, int c, int out);

/* Encoder3d / Decoder3d for cfg (vae_encoder.c, vae_decoder.c): the layer list, in the
 * official nn.Sequential order. */
int gv_vae_build_encoder(gv_vae_binder *b, const gv_vae_config *cfg, gv_vae_coder *enc);
int gv_vae_build_decoder(gv_vae_binder *b, const gv_vae_config *cfg, gv_vae_coder *dec);
void gv_vae_coder_free(gv_vae_coder *c);

/* ---- blocks (vae_blocks.c) ---------------------------------------------------------------- */
/* CausalConv3d with spatial padding pad_hw (0 or 1) and temporal kernel 1 or 3. With k_t = 3
 * the frames in front of x are the slot's cached frames, completed with zeros to 2 (a fresh
 * stream, or stream NULL, is all zeros: Wan's causal padding); the stream then keeps the last
 * 2 input frames. */
gv_tensor *gv_vae_causal_conv(gv_graph *g, const gv_vae_conv *c, gv_tensor *x, int pad_hw,
                              gv_vae_stream *s);
/* One entry of downsamples / upsamples / middle on x [B, C, T, H, W]. */
gv_tensor *gv_vae_layer_forward(gv_graph *g, const gv_vae_layer *l, gv_tensor *x,
                                gv_vae_stream *s);
/* head: RMS_norm, SiLU, CausalConv3d 3x3x3. */
gv_tensor *gv_vae_head_forward(gv_graph *g, const gv_vae_coder *c, gv_tensor *x,
                               gv_vae_stream *s);

/* gv_vae_encode and gv_vae_decode on the whole frames, whatever v->tiling says (vae.c). */
int gv_vae_encode_whole(gv_vae *v, const float *video, int frames, int height, int width, int normalize,
                        int chunk_frames, float *latent);
int gv_vae_decode_whole(gv_vae *v, const float *latent, int latent_frames, int lh, int lw, int normalized,
                        int chunked, float *video);

#endif
