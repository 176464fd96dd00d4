/* Per-scene adaptation, the training side (docs/ADAPT.md; docs/ARCHITECTURE.md section 12): holding back
 * part of a scene's internal pairs, fine-tuning on the rest while keeping the best step, and
 * the scene checkpoint.
 *
 * Scene checkpoints: the adapters of a restorer fine-tuned
 * on one scene's internal pairs (`gaussvid adapt`), stored alone: the tensors fine-tuning trains
 * (LoRA, the camera encoder and its modulations, the residual head when the variant has one),
 * with the base checkpoint they apply to (path and checksum) and the gate: whether the scene's
 * held-back pairs, restored with them, came out better than their renders.
 *
 * gv_restorer_load (checkpoint.h) loads a scene checkpoint as any other: the base first
 * (found as written, else beside the scene checkpoint), then the adapters over it. Whether to
 * restore at all is the gate's decision (gv_scene_checkpoint_read). */
#ifndef GAUSSVID_SCENE_ADAPT_H
#define GAUSSVID_SCENE_ADAPT_H

#include "gaussvid/checkpoint.h"
#include "gaussvid/dataset.h"
#include "gaussvid/train.h"

#define GV_SCENE_CHECKPOINT_KIND "scene"

/* What a scene checkpoint records besides the adapters and the training state. */
typedef struct {
    char scene[GV_SCENE_NAME_MAX];  /* the scene's name (its folder name) */
    int interval;                   /* n: the checkpoint restores this scene's renders at n */
    int iters;                      /* the artifact simulator's iterations for the internal pairs */
    int subsets;                    /* the subsets K of the internal pairs (0 in checkpoints from
                                       before the choice: 2) */
    char base_checksum[48];         /* "fnv1a64:<16 hex>" of the base file's bytes */
    int train_clips, held_back;     /* internal clips trained on / held back for validation */
    long best_step;                 /* the step kept (0: the base's adapters unchanged) */
    char best_by[32];               /* what chose it: "latent gain" or "PSNR change" ("" in
                                       checkpoints from before the choice existed: latent gain) */
    double val_gain_db;             /* that held-back gain at that step, in dB */
    double val_loss, val_identity;
    int gate_open;                  /* 1: restore; 0: leave the renders unchanged */
    double gate_margin_db;          /* the gate opens when the PSNR change exceeds this */
    int gate_min_frames;            /* ... and at least this many held-back frames measured it */
    int gate_frames;                /* held-back frames with ground truth that were restored */
    double gate_psnr_base, gate_psnr_restored, gate_ssim_base, gate_ssim_restored;
    char gate_sampler[256];         /* the sampler and composition the gate restored with */
    char gate_compose[16];          /* that composition's name (restore.h); "" in checkpoints from
                                       before it was recorded, which all used "residual" */
    /* The do-no-harm test (internal_pairs.h): the same held-back views' clips rendered by the
     * model of every training view, whose nearly clean middle frame a restorer that overshoots
     * makes worse. harm_frames 0: not measured (a checkpoint from before it existed). */
    double harm_max_loss_db;        /* the gate opens only when their PSNR drops by less than this */
    int harm_frames;
    double harm_psnr_base, harm_psnr_restored, harm_ssim_base, harm_ssim_restored;
    double seconds_pairs, seconds_latents, seconds_train, seconds_gate;
} gv_scene_adaptation;

/* PSNR change the gate measured (restored - base) on the held-back pairs, and on their
 * do-no-harm clips. */
double gv_scene_gate_change(const gv_scene_adaptation *a);
double gv_scene_harm_change(const gv_scene_adaptation *a);
/* The gate's decision from the measurements: 1 (open) when the held-back pairs gain more than
 * gate_margin_db over at least gate_min_frames frames and, when the do-no-harm clips were
 * measured, their change is above -harm_max_loss_db. The do-no-harm test does not rule the
 * unseen composition (gate_compose "unseen"; gv_scene_harm_rules): that changes only pixels no
 * anchor sees, and a do-no-harm clip's are right only because its own view trained them,
 * which no held-out render's can be (docs/ADAPT.md step 5). */
int gv_scene_harm_rules(const gv_scene_adaptation *a);
int gv_scene_gate_decide(const gv_scene_adaptation *a);
/* Writes the adapters of m (the tensors fine-tuning trains) with the config, state (its kind
 * becomes "scene"; its base names the base checkpoint) and a; atomic. */
int gv_scene_checkpoint_save(const char *path, const gv_dit *m, const gv_model_config *cfg, const gv_train_state *state,
                             const gv_scene_adaptation *a);
/* Reads the adaptation record of a scene checkpoint; fails when the file is not one. */
int gv_scene_checkpoint_read(const char *path, gv_scene_adaptation *a);
/* 1 when path is a gaussvid checkpoint of kind "scene" (0 for other kinds; -1 unreadable). */
int gv_scene_checkpoint_is(const char *path);
/* Loads the base it names into r with gv_restorer_load (network, VAE and its vae_path), checked
 * by checksum, then its adapters over it; r->cfg and r->state are the scene checkpoint's. */
int gv_scene_checkpoint_load(const char *path, gv_restorer *r);
/* The base file a scene checkpoint names: as written, else the same relative path or file name
 * beside the scene checkpoint; its checksum must match. */
int gv_scene_checkpoint_base(const char *path, const gv_train_state *state, const gv_scene_adaptation *a, char *out,
                             size_t size);
/* "fnv1a64:<16 hex>" of a file's bytes. */
int gv_file_checksum(const char *path, char *out, size_t size);

/* The adapters alone, for a training run's best step: save (with extra metadata key/value
 * pairs) and load over a network of the same config. */
int gv_adapters_save(const char *path, const gv_dit *m, const char *const *keys, const char *const *values, int count);
int gv_adapters_load(const char *path, gv_dit *m);

/* ---- fine-tuning on the internal pairs (train/adapt_train.c) ------------------------------ */
/* Moves the clips 1, 1 + every, 1 + 2 every, ... of all into held and the others into train
 * (all is left empty): held-back pairs spread over the scene and over both subsets when every
 * is odd. Fails when either part would be empty. */
int gv_latent_set_hold_back(gv_latent_set *all, int every, gv_latent_set *train, gv_latent_set *held);
/* A view of a's clips followed by b's (b's names prefixed with b_prefix, so that the two stay
 * distinct in the data's checksum): the clips are shared, not copied. Free it with
 * gv_latent_set_view_free, before a and b. */
int gv_latent_set_join(const gv_latent_set *a, const gv_latent_set *b, const char *b_prefix, gv_latent_set *out);
void gv_latent_set_view_free(gv_latent_set *view);

typedef struct {
    long step;                   /* the best step so far (-1: none yet) */
    double gain_db, loss, identity; /* its held-back validation (gv_validation's all_*; gain_db
                                       the score's when a score chooses) */
    double first_gain_db, first_loss; /* at step 0: the base's adapters */
} gv_adapt_best;

/* What chooses the step instead of the held-back latent gain: a score of the network as it is
 * at a validation (higher is better, in dB), e.g. the held-back pairs' PSNR change when
 * restored as the gate restores them (adapt.c). It must not change the network. */
typedef struct {
    int (*fn)(void *ctx, gv_dit *m, double *gain_db);
    void *ctx;
    const char *name;            /* recorded with the best step, so a best file another score
                                    chose is not taken over by a resumed run */
} gv_adapt_score;

/* Fine-tunes m (its trainable tensors) on train with o, validating on held every
 * o->val_every steps and at step 0, and keeps the adapters of the step with the highest mean
 * held-back latent gain, or score when given (the earliest on a tie), in best_path, which a
 * resumed run continues from (when written by the same options, score and clips). When step S
 * is reached, m holds those adapters. Returns 0 when done, 1 when the run stopped before S
 * (o->stop_after) and on the ranks of an mpirun job other than 0, which end after the last
 * step (dist.h). */
int gv_adapt_train(gv_dit *m, const gv_model_config *cfg, const gv_latent_set *train, const gv_latent_set *held,
                   gv_train_options *o, const gv_train_state *meta, const gv_adapt_score *score, const char *best_path,
                   gv_adapt_best *best, gv_train_report *report);

#endif
