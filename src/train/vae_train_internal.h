/* Shared by vae_train.c, vae_checkpoint.c and the tests: clip sampling, the loss, and the
 * training run's files. */
#ifndef GAUSSVID_VAE_TRAIN_INTERNAL_H
#define GAUSSVID_VAE_TRAIN_INTERNAL_H

#include "gaussvid/core/core.h"
#include "gaussvid/train/vae_train.h"

/* A random clip of T frames (spacing 1..max_stride, mirrored and reversed at random), an
 * h x w crop of a scene drawn in proportion to its frames, into out [3, T, h, w]. */
int gv_vae_sample_clip(const gv_vae_frames *f, gv_rng *r, int T, int max_stride, int h, int w, float *out);
/* The training objective of vae_train.h on x [B, 3, T, H, W]; eps holds one N(0, 1) value per
 * latent value (unused when kl_weight is 0). *l2_out: the mean squared error term. */
gv_tensor *gv_vae_loss(gv_graph *g, gv_vae *v, gv_tensor *x, const float *eps, double l2_weight, double kl_weight,
                       gv_tensor **l2_out);
/* Writes the weights (o->out) and the checkpoint (o->out + ".ckpt": weights, AdamW moments,
 * step), each atomically. */
int gv_vae_checkpoint_save(const gv_vae *v, const gv_model_config *c, const gv_vae_train_options *o, long step,
                           double seconds);
/* Restores weights, moments and step from o->out + ".ckpt" when it exists (else *step = 0);
 * fails when it was written with other training options. */
int gv_vae_checkpoint_load(gv_vae *v, const gv_vae_train_options *o, long *step, double *seconds);
/* Per-channel mean and std of the latent mean over o->stats_clips training clips. */
int gv_vae_compute_stats(gv_vae *v, const gv_vae_frames *f, const gv_vae_train_options *o);

#endif
