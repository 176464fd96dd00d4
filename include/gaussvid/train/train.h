/* Training the restoration network (docs/ARCHITECTURE.md section 7; paper section 3.4; docs/TRAINING.md):
 * base pretraining (standard flow matching on clean clips, the anchors as VACE context) and
 * GaussVid fine-tuning (flow matching anchored at the corrupted latent, the progressive latent
 * loss, the difficulty curriculum), with atomic checkpoints that resume bit for bit. */
#ifndef GAUSSVID_TRAIN_H
#define GAUSSVID_TRAIN_H

#include <stdint.h>

#include "gaussvid/train/checkpoint.h"
#include "gaussvid/train/condition.h"
#include "gaussvid/model/dit.h"
#include "gaussvid/nn/nn.h"
#include "gaussvid/model/vae.h"

/* ---- flow matching (train/flow.c; docs/reference/wan-vace-gaussvid.md section 5) ----- */
#define GV_FLOW_GRID 1000        /* training timesteps of the reference scheduler (5.5) */

/* sigma' = s sigma / (1 + (s - 1) sigma), the scheduler's shift
 * (docs/reference/wan-vace-gaussvid.md 5.1). */
double gv_flow_shift(double sigma, double shift);
/* x_t = (1 - t) start + t eps over n values: start = z0 in pretraining, z-hat in fine-tuning
 * (paper eq. 6). */
void gv_flow_noisy(const float *start, const float *eps, float t, int64_t n, float *x_t);
/* The velocity target v = eps - z0 (z0* in fine-tuning: paper eq. 7). */
void gv_flow_target(const float *z0, const float *eps, int64_t n, float *v);
/* The analytic skip of the `skip` output (docs/TRAINING.md "Output parameterisation"): the
 * fine-tuned velocity is v = S + t F with F the network's output and S = (1 - t)/t (x_t - z_hat),
 * which on the path x_t = (1 - t) z_hat + t eps equals (1 - t)(eps - z_hat). So eps - v =
 * x_t - t F: the clean estimate of the base's own parameterisation. Training knows eps and
 * takes the second form (defined at t = 0); the samplers know x and take the first (t > 0). */
void gv_flow_skip_from_noise(const float *z_hat, const float *eps, float t, int64_t n, float *s);
void gv_flow_skip_from_x(const float *z_hat, const float *x, double t, int64_t n, float *s);
/* The known part of the `residual` output: v = R - F with R = (x_t - z_hat)/t, which on the
 * path equals eps - z_hat. So eps - v = z_hat + F: the network's output is the correction of
 * the corrupted latent itself, whatever t (docs/TRAINING.md "Output parameterisation"). */
void gv_flow_residual_from_noise(const float *z_hat, const float *eps, int64_t n, float *r);
void gv_flow_residual_from_x(const float *z_hat, const float *x, double t, int64_t n, float *r);

/* The pretraining timesteps of the reference (5.5): a grid sigma_k = shift(1 - k / 1000),
 * k = 0..999, drawn uniformly, each with the loss weight w_k = (y_k - min y) 1000 / sum(y - min y),
 * y = exp(-2 ((1000 sigma - 500) / 1000)^2) (mean weight 1). */
typedef struct {
    double shift;
    double sigma[GV_FLOW_GRID];
    double weight[GV_FLOW_GRID];
} gv_pretrain_schedule;
void gv_pretrain_schedule_init(gv_pretrain_schedule *s, double shift);
/* The grid index of a uniform number u in [0, 1). */
int gv_pretrain_index(double u);

/* ---- fine-tuning schedules (train/curriculum.c; paper 3.4) ------------------------------- */
/* Progressive latent loss weight lambda clamp((s - S_w) / S_w, 0, 1) max(0, 1 - t / tau_p) at
 * 0-based step s (S_w > 0). */
double gv_progressive_weight(long step, long warmup, double t, double tau_p, double lambda);
/* delta(n) = (n - n_min) / (n_max - n_min), clamped to [0, 1]. */
double gv_curriculum_difficulty(int n, int n_min, int n_max);
/* delta_max(s) = 0.2 s / (S p_w) for s < S p_w, else 0.2 + 0.8 (s - S p_w) / (S (1 - p_w)),
 * at most 1. */
double gv_curriculum_threshold(long step, long total, double p_w);
/* w_cur = 1 - 0.4 delta / delta_max when delta <= delta_max (1 when both are 0), else 0
 * (the sample is skipped). */
double gv_curriculum_weight(double delta, double delta_max);

/* ---- the order of the training clips (train/data_order.c) --------------------------------
 * An endless stream of clip indices: epoch e is a Fisher-Yates permutation of 0..count-1 drawn
 * from the Philox stream (seed, e). A position in the stream (clips consumed) is the whole
 * state, so a checkpoint stores one number. */
typedef struct {
    int count;
    uint64_t seed;
    long epoch;                  /* permutation held in perm (-1: none yet) */
    int *perm;
} gv_data_order;
int gv_data_order_init(gv_data_order *d, int count, uint64_t seed);
void gv_data_order_free(gv_data_order *d);
/* The clip index at stream position pos (>= 0). */
int gv_data_order_at(gv_data_order *d, long pos);

/* A step's clips: walks the stream from *pos and takes the next `batch` clips whose
 * difficulty does not exceed the threshold (the others are skipped: *skipped counts them).
 * difficulty: per clip; threshold < 0: no curriculum (every clip taken with weight 1). The
 * threshold is raised to the easiest clip's difficulty when no clip would pass. Fills
 * index[batch] and weight[batch] (w_cur) and advances *pos. */
int gv_curriculum_batch(gv_data_order *d, const double *difficulty, double threshold, int batch, long *pos,
                        int *index, double *weight, int *skipped);

/* ---- one training sample (train/train_step.c) ---------------------------------------------- */
typedef enum {
    GV_OBJECTIVE_PRETRAIN,  /* x_t = (1 - t) z0 + t eps, v = eps - z0; anchors-only VACE context */
    GV_OBJECTIVE_FINETUNE   /* x_t = (1 - t) z-hat + t eps, v = eps - z0* (paper eq. 6-7) */
} gv_objective;

/* What is drawn or scheduled for one sample of a step. */
typedef struct {
    float t;                     /* flow time sigma in [0, 1]; the DiT sees 1000 t */
    double w_t;                  /* the timestep's loss weight (pretraining grid; else 1) */
    double w_cur;                /* curriculum weight (1 without curriculum) */
    double w_lat;                /* progressive latent loss weight (0 when off) */
    int renders;                 /* pretraining: the VACE context keeps the renders (fine-tuning always does) */
} gv_sample_draw;

typedef struct {
    double loss;                 /* w_cur (w_t L_FM + w_lat L_latent) */
    double fm;                   /* L_FM: mean squared error of the velocity */
    double latent;               /* L_latent: mean |x_t - t v - z0*| (computed even when w_lat = 0) */
} gv_sample_losses;

/* x_t and the velocity target of a clip for the objective, from the noise eps (all
 * gv_clip_latents_z_count(l) floats). */
void gv_objective_inputs(const gv_clip_latents *l, gv_objective obj, float t, const float *eps, float *x_t,
                         float *target);
/* The VACE context a sample gives the network: with renders the clip's own (anchors inactive,
 * renders reactive, as fine-tuning always has it); without, the reactive latents zeroed (only
 * the anchors: first-last-frame generation, the base's usual task). out holds
 * gv_clip_latents_vace_count(l) floats. */
void gv_objective_vace(const gv_clip_latents *l, int renders, float *out);
/* One sample: the forward pass on x_t, the losses, and (when backward) the backward pass of
 * scale * loss, accumulating into the trainable gradients. eps as above. */
int gv_train_sample(gv_dit *m, gv_graph *g, const gv_clip_latents *l, gv_objective obj, const gv_sample_draw *d,
                    const float *eps, double scale, int backward, gv_sample_losses *out);

/* ---- training runs (train/trainer.c) -------------------------------------------------------- */
struct gv_validation;
typedef struct {
    gv_objective objective;
    long steps;                  /* S: optimiser steps of the whole run */
    long stop_after;             /* end this invocation after that step (0: at S), as if interrupted */
    int batch;                   /* clips per step (gradients accumulated) */
    double lr, min_lr;           /* AdamW learning rate; the decays end at min_lr at step S */
    long warmup;                 /* linear warm-up steps */
    gv_lr_kind lr_schedule;      /* after the warm-up: constant (fine-tuning's default), cosine
                                    (pretraining's) or linear (optim.h) */
    double weight_decay, clip_norm;
    uint64_t seed;
    long checkpoint_every;       /* steps between resumable checkpoints (out + ".ckpt") */
    int resume;                  /* continue from out + ".ckpt" when it exists */
    double shift;                /* pretraining: the timestep grid's shift
                                    (docs/reference/wan-vace-gaussvid.md 5.5: 5) */
    double render_context;       /* pretraining: share of samples whose context keeps the renders (0: none) */
    int crop_h, crop_w;          /* each sample a random window of this many tokens (0: the whole grid in that axis) */
    double t_max;                /* fine-tuning: t ~ U[0, t_max] (paper: 0.48) */
    int curriculum;              /* fine-tuning: difficulty curriculum (0: shuffle) */
    int n_min, n_max;            /* delta(n) bounds (paper: 6, 26) */
    double p_w;                  /* curriculum warm-up fraction (paper: 0.05) */
    int progressive;             /* fine-tuning: progressive latent loss */
    int relative_loss;           /* fine-tuning: each clip's loss divided by its identity loss (mean weight 1) */
    double lambda, tau_p;        /* paper: 0.1, 0.3 */
    long latent_warmup;          /* S_w; 0: S / 20 (the paper's 1000 of 20000 steps) */
    int fresh_camera;            /* fine-tuning: camera encoder from its initialisation, not the base's */
    const char *out;             /* the final checkpoint (written when step S is reached) */
    const char *log_path;        /* tab-separated per-step log, or NULL */
    const gv_latent_set *val;    /* fine-tuning: clips to validate on (NULL: none); not part of the trajectory */
    long val_every;              /* steps between validations (also at the first and the last step) */
    const char *val_log;         /* tab-separated validation log, or NULL */
    /* called after each validation with the network at that step (NULL: none), e.g. to keep
     * the best step (gv_adapt_train); it must not change the network */
    int (*on_validation)(void *ctx, gv_dit *m, long step, const struct gv_validation *v);
    void *on_validation_ctx;
} gv_train_options;

/* The defaults of an objective (docs/TRAINING.md). */
void gv_train_defaults(gv_train_options *o, gv_objective objective);
/* S_w of a run: latent_warmup, or S / 20 (at least 1). */
long gv_train_latent_warmup(const gv_train_options *o);

typedef struct {
    long start_step, end_step;   /* steps this invocation took: [start, end) */
    long clips_used, clips_skipped;
    double seconds;              /* wall time of this invocation (checkpoint writes included) */
    double step_seconds;         /* wall time of the optimiser steps alone */
    double clips_per_second;     /* clips_used / step_seconds */
    double first_loss, last_loss;/* running means at the first and the last step */
    size_t arena_peak;           /* bytes of the step graph's arena at its peak */
} gv_train_report;

/* Trains m (its trainable tensors, as set by gv_dit_set_train_mode) on the clips of `data`:
 * batches chosen by the curriculum or shuffled, every draw of step s from the Philox stream
 * (seed, s), AdamW with gradient clipping; every checkpoint_every steps out + ".ckpt" (weights,
 * moments, state); at step S the final checkpoint `out` (weights and state, no moments).
 * save_cfg is the config written to the files; meta gives kind, vae, vae_checksum, base,
 * clips and data (the rest is filled here). With resume, a matching out + ".ckpt" is restored
 * first (its config, training options and data must be those of this run). */
int gv_train_run(gv_dit *m, const gv_model_config *save_cfg, const gv_latent_set *data, const gv_train_options *o,
                 const gv_train_state *meta, gv_train_report *report);
/* "N clips (split S), names fnv1a64 H": identifies a training set in checkpoints. */
void gv_train_data_text(const gv_latent_set *data, const char *split, char *out, size_t size);

/* ---- validation (train/validate.c) ---------------------------------------------------------- */
#define GV_VAL_TIMES 4           /* timesteps per clip, evenly spaced in [0, t_max] */
#define GV_VAL_GROUPS 16         /* intervals n told apart */
typedef struct gv_validation {
    int groups;                  /* distinct intervals n, in order of appearance */
    int intervals[GV_VAL_GROUPS], clips[GV_VAL_GROUPS];
    double loss[GV_VAL_GROUPS];  /* mean velocity MSE = restored latent MSE (one step eps - v) */
    double identity[GV_VAL_GROUPS]; /* the identity's: mean (z0* - z-hat)^2 */
    double gain_db[GV_VAL_GROUPS];  /* mean over clips of 10 log10(identity / loss): > 0 restores */
    int all_clips;
    double all_loss, all_identity, all_gain_db;
} gv_validation;
/* The fine-tuning loss of m on the clips of val at fixed draws (the same for every call and
 * every run), beside the identity's, per interval and over all clips. g is scratch. */
int gv_train_validate(gv_dit *m, gv_graph *g, const gv_latent_set *val, double t_max, gv_validation *out);

/* ---- setting up (train/train_setup.c) -------------------------------------------------------- */
/* Loads the VAE of a training run: its config (from the file's metadata when it has one) must
 * build the VAE of cfg; cfg->vae takes the file's latent statistics, which it must have. */
int gv_train_load_vae(const char *path, gv_model_config *cfg, gv_vae *vae);
/* The "train" clips of a dataset folder encoded by that VAE for cfg (the latent cache), and the
 * metadata that names them in checkpoints: meta's vae, vae_checksum, clips and data. When
 * want_checksum is not empty the VAE must have it (a base's VAE). */
int gv_train_load_data(const char *clips_dir, const char *vae_path, const char *want_checksum, gv_model_config *cfg,
                       gv_latent_set *set, gv_train_state *meta);
/* The "eval" clips of a dataset folder encoded the same way, to validate a run on. */
int gv_train_load_val(const char *clips_dir, const char *vae_path, gv_model_config *cfg, gv_latent_set *set);
/* The network a run trains, and meta's kind and base: pretraining builds cfg's network without
 * LoRA adapters (the base's file keeps cfg's rank for fine-tuning), every tensor trained;
 * fine-tuning loads the base when there is one (its camera encoder too unless fresh_camera)
 * and trains LoRA and the camera encoder. */
int gv_train_model(const gv_model_config *cfg, gv_objective objective, const char *base, int fresh_camera,
                   uint64_t seed, gv_dit *m, gv_train_state *meta);

#endif
