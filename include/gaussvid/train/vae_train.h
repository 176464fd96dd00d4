/* Training and evaluating the VAE on scene frames (`gaussvid vae train`, `vae eval`;
 * docs/VAE.md). Frames are kept as 8-bit RGB; clips are T consecutive frames (or every
 * stride-th frame) cropped at a position, in the VAE's layout [3, T, h, w] in [-1, 1]. */
#ifndef GAUSSVID_VAE_TRAIN_H
#define GAUSSVID_VAE_TRAIN_H

#include <stdint.h>

#include "gaussvid/model/model_config.h"
#include "gaussvid/model/vae.h"

/* ---- frames of scenes (train/vae_data.c) ----------------------------------------------- */
typedef struct {
    char dir[4096];
    int n_frames, width, height;  /* every frame of a scene has the same size */
    uint8_t *pixels;              /* n_frames x height x width x 3 */
} gv_vae_scene;

typedef struct {
    int n;
    gv_vae_scene *scenes;
    int64_t total_frames;
} gv_vae_frames;

/* Loads every frame of each scene folder (gv_scene_load; downscale 1, 2, 4 or 8); fails
 * naming the folder when a scene has frames of different sizes. */
int gv_vae_frames_load(gv_vae_frames *f, const char *const *dirs, int n_dirs, int downscale);
void gv_vae_frames_free(gv_vae_frames *f);
/* Frames t0, t0 + stride, ..., t0 + (T - 1) stride of s, the w x h window at (x0, y0),
 * mirrored left-right when flip, into out [3, T, h, w] as p / 127.5 - 1
 * (docs/reference/wan-vace-gaussvid.md 4.5). The caller keeps every index inside the scene. */
void gv_vae_clip_extract(const gv_vae_scene *s, int t0, int stride, int T, int x0, int y0, int w,
                         int h, int flip, float *out);

/* Reconstruction quality of the VAE on held-out frames (gv_vae_evaluate, eval.h). */
typedef struct {
    int n_clips, n_frames;
    double psnr, ssim;           /* means over frames, of images in [0, 1] */
    double psnr_first;           /* frames encoded alone (the first of each clip) */
    double psnr_grouped;         /* the other frames (encoded in groups of r) */
    double seconds;
} gv_vae_eval_result;

/* ---- training (train/vae_train.c) -------------------------------------------------------
 * Objective (docs/VAE.md): mean |x^ - x| + l2_weight mean (x^ - x)^2 + kl_weight KL, with
 * x^ decoded from z = mu + sigma eps (eps ~ N(0, 1); z = mu when kl_weight is 0) and KL the
 * posterior's divergence from N(0, 1) summed over latent values and divided by the number of
 * pixel values (the Stable Diffusion / Wan convention, where the weight is about 1e-6). */
typedef struct {
    long steps;                  /* optimiser steps in total (resume continues to it) */
    long stop_after;                /* end this run after that step, without statistics (0: at steps) */
    int batch;                   /* clips per step */
    int frames;                  /* frames per clip, 1 + k r */
    int crop_h, crop_w;          /* crop, multiples of the spatial factor */
    int max_stride;              /* frame spacing drawn from 1..max_stride */
    int image_every;             /* every k-th clip is a single frame (0: never) */
    double lr, min_lr;           /* AdamW, warm-up then cosine to min_lr */
    long warmup;
    double weight_decay, clip_norm;
    double l2_weight, kl_weight;
    uint64_t seed;
    long checkpoint_every;       /* steps between checkpoints (and weights written) */
    long eval_every;             /* steps between held-out evaluations (0: none) */
    int eval_clips;              /* held-out clips per evaluation */
    int stats_clips;             /* clips the latent statistics are computed on */
    int resume;                  /* continue from out's checkpoint when it exists */
    const char *out;             /* weights; the checkpoint is out + ".ckpt" */
    const char *log_path;        /* tab-separated progress (may be NULL) */
    const char *config_spec;     /* written into the metadata (may be NULL) */
    /* the held-out evaluation every eval_every steps (gv_vae_evaluate, eval.h; NULL: none) */
    int (*evaluate)(gv_vae *v, const gv_vae_frames *f, int frames, int stride, int max_clips, gv_vae_eval_result *r);
} gv_vae_train_options;

void gv_vae_train_defaults(gv_vae_train_options *o);
/* Trains the VAE of c on `train` (eval: held-out frames for the periodic evaluation, or
 * NULL), writes checkpoints atomically, then computes the per-channel latent mean and std
 * over stats_clips clips of the training frames and writes the final weights with them. */
int gv_vae_train(const gv_model_config *c, const gv_vae_frames *train, const gv_vae_frames *eval,
                 const gv_vae_train_options *o);

#endif
