/* Adapting the restorer to one scene (`gaussvid adapt`; docs/ARCHITECTURE.md section 12; docs/ADAPT.md):
 * the scene's internal pairs (internal_pairs.h) are built, part of them held back; the adapters
 * of a cross-scene checkpoint (LoRA and the camera encoder) are fine-tuned on the rest with a
 * learning rate that decays to zero, keeping the step the held-back pairs liked best; the
 * held-back pairs are then restored as `restore` would restore the scene's renders, and the
 * gate opens only when that beats their renders. The result is a scene checkpoint
 * (scene_adapt.h) for that scene and interval, which `restore` and `eval` honour.
 *
 * Everything is kept in a work folder (default OUT.work): the internal pairs and their latent
 * cache (pairs/), the fine-tuning's resumable checkpoint, logs and best adapters, so an
 * interrupted run continues where it stopped and gives the result of an uninterrupted one. */
#ifndef GAUSSVID_ADAPT_H
#define GAUSSVID_ADAPT_H

#include "gaussvid/data/internal_pairs.h"
#include "gaussvid/restore/restore.h"
#include "gaussvid/train/scene_adapt.h"

typedef struct {
    const char *scene_dir;
    int interval;                    /* n: the scene's training views are frames 0, n, 2n, ... */
    const char *base;                /* the cross-scene checkpoint (models/gaussvid-small.safetensors) */
    const char *config;              /* the network the base must be (preset or file; NULL: "small") */
    const char *variant;             /* a variant over the base's (gv_model_config_set_variant); default
                                        "residual,coverage": the output relearned from zero, starting at
                                        the identity, and the anchors' coverage in VACE's mask; NULL or
                                        "base": the base's own */
    int fresh_camera;                /* the camera encoder from its initialisation, not the base's */
    int harm_train;                  /* 1: fine-tune and validate on the do-no-harm clips too, so
                                        the adapters learn to leave nearly clean renders alone */
    const char *out;                 /* the scene checkpoint */
    const char *work_dir;            /* NULL: out + ".work" */
    int downscale;                   /* scene images: 1, 2, 4, 8 (as splat train) */
    int iters;                       /* the artifact simulator's iterations per subset */
    int subsets;                     /* K >= 2 subsets of the training views for the internal pairs
                                        (internal_pairs.h): 2 leaves every other view out, T (the
                                        training views) or more each interior view alone */
    int densify;                     /* its density control (gv_splat_densify_mode): as the
                                        user's sparse model was trained */
    const gv_artifact_simulator *simulator; /* NULL: sparse 3DGS */
    int hold_every;                  /* internal clips 1, 1 + K, 1 + 2K, ... are held back */
    gv_train_options train;          /* steps, batch, lr and its schedule, t_max, crop, seed, val_every,
                                        stop_after; the rest is set by gv_adapt_scene */
    gv_sampler sampler;              /* how the gate restores the held-back pairs: as restore would */
    gv_compose compose;
    int early_stop_psnr;             /* 1: the step is chosen by the held-back pairs' PSNR change,
                                        restored as the gate restores them (sampler, composition);
                                        0: by their latent gain (the trainer's validation) */
    double gate_margin_db;           /* the gate opens when the held-back PSNR change exceeds this */
    int gate_min_frames;             /* ... measured on at least this many held-back frames */
    double harm_max_loss_db;         /* ... and their do-no-harm clips lose less than this (>= 0) */
} gv_adapt_options;

/* The defaults (docs/ADAPT.md): the residual output with the coverage mask, 8000 iterations, every 3rd clip held
 * back, 300 steps of 2 clips at lr 1e-3 decaying linearly to 0, t ~ U[0, 0.1], no curriculum, no progressive loss,
 * validation every 50 steps, the step chosen by the latent gain; the gate with restore's default sampler and
 * the unseen composition, margin 0,
 * at least 2 frames, a do-no-harm loss under 0.05 dB. */
void gv_adapt_defaults(gv_adapt_options *o);

typedef struct {
    int done;                        /* 1: the scene checkpoint exists; 0: stopped early (stop_after) */
    int already;                     /* 1: it existed before the call: nothing was done */
    char work_dir[4096];
    gv_internal_result pairs;
    gv_internal_result harm;         /* the do-no-harm clips */
    gv_scene_adaptation adaptation;  /* what the checkpoint records (when done) */
    gv_adapt_best best;
    gv_train_report train;
} gv_adapt_report;

/* Whether o->base can be adapted: a cross-scene checkpoint of the network o->config names
 * whose VAE gives each frame its own latent frame; one line naming the base when not (callers
 * check before hours of other work). */
int gv_adapt_check_base(const gv_adapt_options *o);

/* Adapts the base to the scene at the interval and writes o->out (atomically), or continues an
 * interrupted adaptation. Fails with one line naming the input on a scene with too few
 * training views, a base of another network than o->config, a base whose VAE packs several
 * frames into a latent frame, a missing file. */
int gv_adapt_scene(const gv_adapt_options *o, gv_adapt_report *r);

/* Means over the intermediate frames with ground truth, as rendered and restored. */
typedef struct {
    int frames;
    double psnr_base, psnr_restored, ssim_base, ssim_restored;
} gv_gate_measure;

/* The composition a scene checkpoint's gate measured, which restoring with it must use
 * (adapt_gate.c): its gate_compose, "" in checkpoints from before it was recorded (residual);
 * fails on an unknown name. */
int gv_adapt_gate_compose(const gv_scene_adaptation *a, gv_compose *out);

/* The gate's measurement (adapt_gate.c): restores every clip of a dataset folder's latent set
 * with the network, as restore would, and measures the intermediate frames with ground truth,
 * restored and as rendered. Fails when no frame has ground truth. */
int gv_adapt_measure(gv_dit *m, gv_vae *vae, const char *dataset_dir, const gv_latent_set *set, const gv_sampler *s,
                     gv_compose compose, gv_gate_measure *out);

#endif
