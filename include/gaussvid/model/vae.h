/* The causal 3D VAE of the restoration network: Wan2.1's VAE family at any size
 * (docs/ARCHITECTURE.md 6.2; docs/reference/wan-vace-gaussvid.md section 4; docs/VAE.md).
 *
 * Videos are channel-first float tensors [B, 3, T, H, W] with values in [-1, 1] (pixel p in
 * 0..255 is p / 127.5 - 1). T = 1 + k r frames (r = the temporal factor, 4 in Wan, 1 or 4 in
 * this project's presets) encode to 1 + k latent frames: the first frame alone, then groups of
 * r. H and W must be multiples of the spatial factor s. Latents are [B, z_dim, 1 + k, H/s, W/s].
 *
 * Parameters are built from the config's weight list (weight_names.h), so they carry the
 * published checkpoint keys and the Wan presets load Wan2.1_VAE weights by name. Two ways to
 * run: one-shot (the whole clip in one graph: training, gradients) and chunked (the first
 * frame, then r frames at a time through the causal caches, as Wan encodes; latent frame by
 * latent frame to decode): the same result in bounded memory, inference only. */
#ifndef GAUSSVID_VAE_H
#define GAUSSVID_VAE_H

#include <stdint.h>

#include "gaussvid/model/model_config.h"
#include "gaussvid/io/safetensors.h"
#include "gaussvid/nn/tensor.h"

/* One convolution: weight [out, in, kt, kh, kw] (3-D convs) or [out, in, kh, kw] (the 2-D
 * ones), bias [out]; slot = its causal cache (k_t = 3 and time_conv), -1 for none. */
typedef struct {
    gv_tensor *weight, *bias;
    int slot;
} gv_vae_conv;

typedef enum {
    GV_VAE_RESIDUAL, GV_VAE_ATTENTION, GV_VAE_DOWN2D, GV_VAE_DOWN3D, GV_VAE_UP2D, GV_VAE_UP3D
} gv_vae_layer_kind;

/* One entry of encoder.downsamples / decoder.upsamples / *.middle
 * (docs/reference/wan-vace-gaussvid.md 4.2). */
typedef struct {
    gv_vae_layer_kind kind;
    int in, out;                       /* channels */
    gv_tensor *gamma0, *gamma3;        /* residual.0.gamma, residual.3.gamma */
    gv_vae_conv conv2, conv6, shortcut; /* residual.2, residual.6, shortcut (weight NULL: identity) */
    gv_tensor *norm_gamma;             /* attention: norm.gamma */
    gv_vae_conv to_qkv, proj;          /* attention: 1x1 Conv2d */
    gv_vae_conv resample, time_conv;   /* resample.1 (3x3 Conv2d) and time_conv (3D modes) */
    int slot;                          /* resample: the 3D modes' temporal state */
} gv_vae_layer;

/* Encoder3d or Decoder3d: conv1, the stages, middle, head. */
typedef struct {
    gv_vae_conv conv_in;               /* encoder.conv1 / decoder.conv1 */
    int n_layers;
    gv_vae_layer *layers;              /* downsamples.* / upsamples.* */
    gv_vae_layer middle[3];            /* residual, attention, residual */
    gv_tensor *head_gamma;             /* head.0.gamma */
    gv_vae_conv head_conv;             /* head.2 */
    int n_slots;                       /* causal caches this coder uses */
} gv_vae_coder;

typedef struct {
    gv_vae_config cfg;
    gv_params params;                  /* every tensor, by its checkpoint name */
    gv_vae_coder encoder, decoder;
    gv_vae_conv quant, post_quant;     /* conv1 (2 z -> 2 z) and conv2 (z -> z), 1x1x1 */
    int has_stats;                     /* per-channel latent normalisation known */
    float mean[GV_VAE_MAX_Z_DIM], inv_std[GV_VAE_MAX_Z_DIM], std[GV_VAE_MAX_Z_DIM];
    const struct gv_vae_tiling *tiling; /* NULL: whole frames; else gv_vae_encode and
                                           gv_vae_decode work in tiles (gv_vae_*_tiled) */
} gv_vae;

/* Tiles as the GaussVid release's VAE works (docs/GAUSSVID_RELEASE.md), in latent cells:
 * decoding cuts the latent into tile_h x tile_w tiles at origins 0, stride, 2 stride, ...
 * (an origin is skipped when the tile before it already reaches the end; the last tiles are
 * clipped), decodes each, and blends them with weights that ramp (k + 1) / border over
 * border = (tile - stride) cells' worth of pixels on every side that is not an image
 * border, the weight of a pixel the smaller of its row and column ramps; encoding does the
 * same in pixels (tile and stride times the spatial factor) with ramps in latent cells.
 * bf16_accumulate: the sums of tile x weight and of weights are rounded to bf16 after each
 * tile, as the release's CPU accumulators are. */
typedef struct gv_vae_tiling {
    int tile_h, tile_w, stride_h, stride_w;
    int bf16_accumulate;
} gv_vae_tiling;
/* The release's: tiles of 30 x 52 latent cells, strides 15 x 26, bf16 accumulators. */
extern const gv_vae_tiling GV_VAE_TILING_RELEASE;
/* The tile origins along one axis of `size` cells; returns their count (at most max). */
int gv_vae_tile_origins(int size, int tile, int stride, int *origins, int max);

/* ---- construction, files (model/vae_params.c) ------------------------------------------- */
/* Allocates the VAE of c->vae with every tensor of the weight list, initialised as
 * specified there (random ones PyTorch-style: uniform +-1/sqrt(fan_in), from seed); trainable
 * or frozen. Takes the latent statistics from the config when it has them. */
int gv_vae_init(gv_vae *v, const gv_model_config *c, int trainable, uint64_t seed);
void gv_vae_free(gv_vae *v);
/* Checks, without allocating any tensor data, that the network this code builds for c uses
 * every VAE tensor of the weight list exactly once with its listed shape; n_tensors and
 * n_params (either may be NULL) receive the counts. */
int gv_vae_check_layout(const gv_model_config *c, int *n_tensors, int64_t *n_params);
/* Loads every VAE tensor by name (F32, F16, BF16 or F64) from a safetensors file; missing,
 * unexpected (non-VAE names are ignored only when allow_other) and mis-shaped tensors fail,
 * listed. Latent statistics in the file's metadata ("latent_mean", "latent_std": JSON
 * arrays) replace the config's. */
int gv_vae_load(gv_vae *v, const char *path, int allow_other);
/* The same from a file already open (a checkpoint that holds its VAE's tensors). */
int gv_vae_read(gv_vae *v, const gv_st_file *f, int allow_other);
/* Writes every tensor (F32) and the metadata: "config" (the model config JSON, latent
 * statistics included when known), "latent_mean"/"latent_std" when known, and the extra
 * key/value pairs (n_extra, may be 0). Atomic. */
int gv_vae_save(const gv_vae *v, const gv_model_config *c, const char *path,
                const char *const *extra_keys, const char *const *extra_values, int n_extra);
/* Reads the "config" metadata of a file written by gv_vae_save into c; fails (naming the
 * file) when there is none or it does not parse. */
int gv_vae_file_config(const char *path, gv_model_config *c);
/* Sets the per-channel latent statistics (z_dim values each; std > 0). */
int gv_vae_set_stats(gv_vae *v, const double *mean, const double *std);

/* ---- streaming state of the causal caches (model/vae_blocks.c) -------------------------- */
/* Per cache slot: whether it has seen a chunk, and the last frames it keeps
 * (docs/reference/wan-vace-gaussvid.md 4.4: 2 input frames of a k_t = 3 conv; 1 frame of a
 * downsample3d; the up3d's 2 input frames). */
typedef struct {
    int n_slots;
    int *started, *frames;             /* frames held per slot: 0..2 */
    int *channels, *height, *width;
    float **data;                      /* frames * channels * height * width floats (B = 1) */
} gv_vae_stream;
int gv_vae_stream_init(gv_vae_stream *s, int n_slots);
void gv_vae_stream_free(gv_vae_stream *s);

/* ---- differentiable forward (model/vae_encoder.c, vae_decoder.c, vae.c) ------------------ */
/* Encoder3d + conv1 on a video [B, 3, T, H, W]: the posterior moments [B, 2 z, T', H/s, W/s]
 * (mean = channels 0..z-1, log-variance = z..2z-1). stream NULL: one shot from the clip's
 * start; otherwise the clip is the next chunk of a stream (B = 1, no gradient). */
gv_tensor *gv_vae_encoder_forward(gv_graph *g, gv_vae *v, gv_tensor *x, gv_vae_stream *stream);
/* conv2 + Decoder3d on a latent mean [B, z, T', h, w] (not normalised): the video
 * [B, 3, 1 + r (T' - 1), s h, s w], not clamped. stream as above. */
gv_tensor *gv_vae_decoder_forward(gv_graph *g, gv_vae *v, gv_tensor *mu, gv_vae_stream *stream);
/* z = (mu - mean_c) / std_c and its inverse (docs/reference/wan-vace-gaussvid.md 4.5); fail without
 * statistics. */
gv_tensor *gv_vae_normalize(gv_graph *g, const gv_vae *v, gv_tensor *mu);
gv_tensor *gv_vae_denormalize(gv_graph *g, const gv_vae *v, gv_tensor *z);

/* ---- clip shapes ------------------------------------------------------------------------ */
/* Latent frames of T input frames: 1 + (T - 1) / r; fails unless T = 1 + k r. */
int gv_vae_latent_frames(const gv_vae_config *c, int frames, int *latent_frames);
/* Checks a clip's size (frames as above; height and width positive multiples of s). */
int gv_vae_check_clip(const gv_vae_config *c, int frames, int height, int width);

/* ---- inference on float arrays (model/vae.c) -------------------------------------------- */
/* Encodes video [3, T, H, W] (values in [-1, 1]) to the latent mean [z, T', H/s, W/s],
 * normalised when `normalize` (requires statistics). chunk_frames: 0 = one shot; otherwise
 * the first frame alone, then chunk_frames frames at a time through the caches (a multiple
 * of r; Wan uses r). Runs without gradients on its own graph. */
int gv_vae_encode(gv_vae *v, const float *video, int frames, int height, int width,
                  int normalize, int chunk_frames, float *latent);
/* Decodes a latent [z, T', h, w] (normalised when `normalized`) to video [3, T, s h, s w]
 * clamped to [-1, 1]. chunked: one latent frame at a time through the caches (Wan), else
 * one shot. */
int gv_vae_decode(gv_vae *v, const float *latent, int latent_frames, int lh, int lw,
                  int normalized, int chunked, float *video);
/* gv_vae_encode and gv_vae_decode in tiles (gv_vae_tiling), whatever v->tiling says; the
 * tiles themselves are coded whole. */
int gv_vae_encode_tiled(gv_vae *v, const gv_vae_tiling *t, const float *video, int frames, int height, int width,
                        int normalize, int chunk_frames, float *latent);
int gv_vae_decode_tiled(gv_vae *v, const gv_vae_tiling *t, const float *latent, int latent_frames, int lh, int lw,
                        int normalized, int chunked, float *video);

/* ---- residual decoding (model/vae.c; docs/VAE.md) -------------------------------------- */
/* The restorer's frames as render + D(z_restored) - D(z_render), clamped to [-1, 1]: the
 * VAE's reconstruction error cancels where the restorer leaves the latent unchanged
 * (z_restored = z_render gives the render back bit for bit). render and out are [3, T, H, W]
 * with T = 1 + r (latent_frames - 1), H = s lh, W = s lw; latents [z, latent_frames, lh, lw],
 * normalised when `normalized`; both are decoded one latent frame at a time (Wan). */
int gv_vae_decode_residual(gv_vae *v, const float *render, const float *z_render, const float *z_restored,
                           int latent_frames, int lh, int lw, int normalized, float *out);
/* out = clamp(render + restored - rendered, -1, 1) over n values (the step above). */
void gv_vae_compose_residual(const float *render, const float *restored, const float *rendered, int64_t n, float *out);

/* ---- the VACE context of a clip (model/vace_context.c; docs/ARCHITECTURE.md 6.3;
 * docs/reference/wan-vace-gaussvid.md 3.3) */
/* [E(V (1 - M)) | E(V M) | M on the latent grid] for video V [3, T, H, W] in [-1, 1] and the
 * anchors variant's mask M (gv_vace_frame_mask: 0 on anchors, 1 on frames to restore):
 * out [2 z + s^2, T', H/s, W/s] (dit.h: the `vace` input). Latents are normalised when the
 * VAE has statistics, raw otherwise; encoded chunked as Wan. */
int gv_vace_context_build(gv_vae *v, const float *video, int frames, int height, int width, gv_anchors anchors,
                          float *out);
/* The same from a per-pixel mask M [T, H, W] (values in [0, 1]): the coverage variant's
 * (condition.h). With every frame's plane constant at the anchors variant's value it is
 * gv_vace_context_build exactly. */
int gv_vace_context_build_masked(gv_vae *v, const float *video, int frames, int height, int width,
                                 const float *mask, float *out);

/* ---- model run --part vae-encode | vae-decode (model/vae_run.c) ------------------------- */
/* Load the VAE from the first of the weight files that holds it, then read "video"
 * [(B,) 3, T, H, W] and add "mean" and, when the VAE has statistics, "latent" (the
 * normalised mean) to out (encode); or read "latent" (normalised) or else "mean" (raw)
 * [(B,) z, T', h, w] and add "video", clamped to [-1, 1] (decode). Output data lives in g. */
int gv_vae_run_encode_named(const gv_model_config *c, const char *const *weights, int n_weights,
                            const gv_st_file *inputs, gv_graph *g, gv_st_builder *out);
int gv_vae_run_decode_named(const gv_model_config *c, const char *const *weights, int n_weights,
                            const gv_st_file *inputs, gv_graph *g, gv_st_builder *out);

#endif
