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

#include "gaussvid/train/checkpoint.h"
#include "gaussvid/data/dataset.h"
#include "gaussvid/train/train.h"

#define GV_SCENE_CHECKPOINT_KIND "scene"

/* gv_scene_adaptation, the record a scene checkpoint holds besides its adapters and training
 * state, is in checkpoint.h: a loaded restorer carries it. */

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
/* "fnv1a64:<16 hex>" of a file's bytes, read a megabyte at a time. */
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
