/* What the restoration network is conditioned on, for one 5-frame clip (paper 3.3, 3.4;
 * docs/ARCHITECTURE.md 6.3, 7; docs/RESTORATION.md): the normalised VAE latents of the ground truth (z0*)
 * and of the input clip (z-hat), the VACE context and the Plücker field of the 5 cameras;
 * and the latent cache that encodes a dataset's clips once.
 *
 * Shared by training (pretrain, train) and restoration (restore, eval). Arrays are float,
 * channel-first, batch first:
 *   z_clean, z_corrupt  [batch, z_dim, latent_frames, lh, lw]
 *   vace                [batch, vace_in_dim, latent_frames, lh, lw] = [z_inactive | z_reactive | mask]
 *   plucker             [batch, 6, plucker_frames, height, width]
 * batch is 1 for the video model. The per-frame restorer (variant per_frame) sees each of the
 * three intermediate frames as its own 1-frame clip: batch 3, latent_frames 1.
 *
 * VACE context (docs/reference/wan-vace-gaussvid.md 3.3, 3.5; paper 3.3): the control video is the
 * input clip (clean anchors, corrupted renders); M = 0 on the anchors of the config's anchors
 * variant, 1 elsewhere; inactive = video (1 - M), reactive = video M, each VAE-encoded
 * (normalised); the mask pixel-unshuffled to the latent grid. So the reactive part of the
 * intermediates is the corrupted render, as in the authors' pipeline
 * (docs/reference/wan-vace-gaussvid.md 1.2 step 2). With the variant coverage (model_config.h) and
 * a clip that carries its coverage plane (dataset.h), M on an intermediate is per pixel: 1 where
 * neither anchor sees the pixel (complete it), 0 where one does (the render agrees with what an
 * anchor shows: keep it, as an anchor's pixel is kept); a clip without the plane gets the per-frame
 * M. An end frame that is not an anchor of the variant (anchors first / none) is blanked (0 =
 * mid-grey) in the input clip, in z_corrupt and in the context: the ablation must not see its clean
 * view. Configs with text cross-attention take the model's text context [batch, text_len, text_dim]
 * (the prompt's, cached beside imported Wan weights; zeros for the small presets, which have
 * no prompts: gv_dit_text_input). */
#ifndef GAUSSVID_CONDITION_H
#define GAUSSVID_CONDITION_H

#include <stdint.h>

#include "gaussvid/data/dataset.h"
#include "gaussvid/model/model_config.h"
#include "gaussvid/scene/scene.h"
#include "gaussvid/model/vae.h"

/* One 5-frame clip prepared for the network (float, channel-first, layouts above). */
typedef struct {
    int interval;                     /* the clip's interval n */
    int frames, height, width;        /* pixel clip: 5 x H x W, padded to the block (below) */
    int batch;                        /* 1; 3 for the per-frame restorer */
    int z_dim, latent_frames, lh, lw; /* latent grid */
    int vace_dim;                     /* vace_in_dim = 2 z_dim + spatial_factor^2 */
    float *z_clean;    /* normalised VAE latent of the ground-truth clip (anchors + the three
                          clean targets) = z0* in the paper */
    float *z_corrupt;  /* latent of the input clip (clean anchors + the three corrupted
                          renders) = z-hat in the paper */
    float *vace;       /* VACE context for the config's anchors variant */
    float *plucker;    /* packed Plücker field (plucker.h) of the 5 cameras relative to the first
                          anchor; NULL for the camera variant none */
    int plucker_frames;
    uint8_t no_target[GV_CLIP_FRAMES]; /* latent frame t of batch b (index b latent_frames + t)
                          has no ground truth: a frame it packs is masked (the clip's
                          target_mask); the losses skip it. All 0 for the clips of `dataset build` */
} gv_clip_latents;

/* Floats of one z_clean / z_corrupt, of vace, of plucker. */
int64_t gv_clip_latents_z_count(const gv_clip_latents *l);
int64_t gv_clip_latents_vace_count(const gv_clip_latents *l);
int64_t gv_clip_latents_plucker_count(const gv_clip_latents *l);

/* Any image size: the VAE and the DiT take multiples of a block of spatial factor x DiT patch
 * pixels (16 x 16 for the small preset), so a clip of another size is padded on its right and
 * bottom by reflection to the next multiple (gv_clip_pad: frames and coverage plane mirrored,
 * cameras unchanged, the Plücker field's rays run on through the padding's pixels), encoded
 * and restored at that size, and cropped back by the composition (gv_restore_compose). The
 * latents' height and width are the padded ones. Training on such clips (adapt's internal
 * pairs of a scene) sees the padding too: its targets are mirrored as its inputs are, so the
 * loss there asks for what the mirrored picture shows. Sizes of at least 1 x 1 are taken.
 * gv_condition_padded_size: the padded size of a width x height picture for cfg (fails below
 * 1 pixel). */
int gv_condition_padded_size(const gv_model_config *cfg, int width, int height, int *padded_width, int *padded_height);
/* Encodes a clip for the model config (VAE with latent statistics; padded as above). Fails
 * naming the clip (scene, n) and the problem. */
int gv_clip_latents_prepare(gv_vae *vae, const gv_model_config *cfg, const gv_clip *clip, gv_clip_latents *out);
void gv_clip_latents_free(gv_clip_latents *l);
/* The parts of prepare: the sizes of a clip's latents (no arrays; checks as prepare does),
 * allocation of the arrays for those sizes (plucker when with_plucker), and the Plücker field
 * of the clip's cameras into l->plucker. */
int gv_clip_latents_shape(const gv_vae *vae, const gv_model_config *cfg, const gv_clip_info *info, gv_clip_latents *l);
int gv_clip_latents_alloc(gv_clip_latents *l, int with_plucker);
int gv_clip_latents_plucker(const gv_clip *clip, int temporal_factor, gv_clip_latents *l);

/* 1 when some latent frame of the clip has no ground truth (no_target). */
int gv_clip_latents_masked(const gv_clip_latents *l);
/* mean (z0* - z-hat)^2 over the clip's latent frames with ground truth: the loss of leaving its
 * renders unchanged. */
double gv_clip_latents_identity_loss(const gv_clip_latents *l);
/* Latent rows [y, y + h) and columns [x, x + w) of every frame of src (latents and VACE
 * context) with the matching pixels of its Plücker field: the clip seen through a window
 * (train --crop; condition_crop.c). dst is zeroed or an earlier crop: its arrays are reused
 * when the shape is the same, else reallocated (free with gv_clip_latents_free). */
int gv_clip_latents_crop(const gv_clip_latents *src, int y, int x, int h, int w, gv_clip_latents *dst);
/* The cameras of a clip's 5 frames from its intrinsics and poses. */
void gv_clip_cameras(const gv_clip *clip, gv_camera cams[GV_CLIP_FRAMES]);
/* Frames [first, first + count) of a clip's inputs or targets (8-bit HWC) as a video
 * [3, count, H, W] with values p / 127.5 - 1 (the VAE's range). */
void gv_clip_video(const uint8_t *frames, const gv_clip_info *info, int first, int count, float *video);
/* The pixel mask M [5, H, W] of a clip's VACE context (above): the anchors variant's per
 * frame, and per pixel on the intermediates with the variant coverage and the clip's plane. */
int gv_condition_vace_mask(const gv_model_config *cfg, const gv_clip *clip, float *mask);
/* 1 for the frames the variant blanks in the input (an end frame that is not an anchor). */
int gv_condition_frame_blanked(const gv_model_config *cfg, int frame);

/* ---- latent cache (latent_cache.c) -----------------------------------------------------
 * Every clip of a dataset folder (manifest.json), filtered by split ("train", "eval" or NULL
 * = all), encoded once and cached in one safetensors file inside the dataset folder,
 * latents_<VAE checksum>_<anchors>[_per-frame].safetensors, so later runs load it instead of
 * re-encoding (progress bar while encoding). An entry is reused only when its clip file's
 * content checksum matches; missing or stale entries are encoded and the file rewritten
 * atomically (holding the union of the old valid entries and the new ones). A cache that
 * cannot be read is rebuilt with a warning. Plücker fields are recomputed from the poses, not
 * stored. vae_path is only named in messages (the checksum is of the loaded weights). */
typedef struct {
    int count;
    gv_clip_latents *clips;
    char **names;                     /* the manifest's file of each clip, e.g. clips/x_n06_000.safetensors */
    int encoded;                      /* how many clips this load had to encode (0: all cached) */
    char cache_path[4096];            /* the cache file used */
} gv_latent_set;

int gv_latent_set_load(const char *dataset_dir, const char *split, const char *vae_path, gv_vae *vae,
                       const gv_model_config *cfg, gv_latent_set *out);
void gv_latent_set_free(gv_latent_set *s);
/* The most floats of one clip's z_clean over the set (0 when empty): the size of a noise buffer. */
int64_t gv_latent_set_max_z_count(const gv_latent_set *s);
/* FNV-1a 64 checksum of a VAE's weights (every tensor by name, in order) and its latent
 * statistics: the key of the latent cache. */
uint64_t gv_vae_checksum(const gv_vae *vae);
/* FNV-1a 64 of bytes, continuing from h (start with GV_FNV_OFFSET). */
#define GV_FNV_OFFSET 0xcbf29ce484222325ull
uint64_t gv_fnv1a64(uint64_t h, const void *data, size_t size);
/* The cache file of a dataset folder for a VAE checksum and config: out (size bytes). */
int gv_latent_cache_path(char *out, size_t size, const char *dataset_dir, uint64_t vae_key, const gv_model_config *cfg);

#endif
