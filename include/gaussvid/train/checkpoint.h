/* Checkpoints of the restoration network (docs/TRAINING.md "Checkpoint files"): one
 * safetensors file with every tensor of the network by its checkpoint name (F32; the VAE is
 * named in the metadata, or its tensors are in the file too), the config and the training
 * state in __metadata__, and for resuming the AdamW moments as "adamw.m.<name>" and
 * "adamw.v.<name>". A fine-tuned checkpoint holds the base weights as well, so it loads alone. */
#ifndef GAUSSVID_CHECKPOINT_H
#define GAUSSVID_CHECKPOINT_H

#include <stdint.h>

#include "gaussvid/data/dataset.h"
#include "gaussvid/model/dit.h"
#include "gaussvid/model/model_config.h"
#include "gaussvid/model/vae.h"

#define GV_CHECKPOINT_FORMAT "gaussvid-checkpoint"
#define GV_CHECKPOINT_VERSION 1
#define GV_CHECKPOINT_TEXT 1024
#define GV_CHECKPOINT_SCENES 8192 /* the training scenes' names, comma-separated */

/* Where a checkpoint's text context comes from (docs/WAN_WEIGHTS.md "The tokenizer and the
 * cached context"): metadata "text_context", "text_prompt", "text_encoder", "text_tokenizer";
 * all "" for a network without text (the zero context). */
typedef struct {
    char path[GV_CHECKPOINT_TEXT];      /* the cache, text_context.safetensors */
    char prompt[GV_CHECKPOINT_TEXT];    /* the prompt it encodes */
    char encoder[GV_CHECKPOINT_TEXT];   /* the umT5 weights that compute it, or "" */
    char tokenizer[GV_CHECKPOINT_TEXT]; /* their SentencePiece model, or "" */
} gv_text_source;

/* What the metadata records besides the config. */
typedef struct {
    char kind[16];                 /* "base" (pretraining) or "finetune" */
    long step;                     /* optimiser steps completed */
    long steps;                    /* steps of the whole run (S) */
    long adamw_step;               /* AdamW's step count (bias correction) */
    long data_position;            /* clips consumed from the shuffled stream (data_order) */
    long clips_used, clips_skipped;/* clips trained on / passed over by the curriculum */
    uint64_t seed;                 /* every random draw of step s comes from (seed, s) */
    double seconds;                /* training time so far */
    double loss;                   /* running mean of the loss at the last step */
    char vae[GV_CHECKPOINT_TEXT];  /* the VAE file as given to training */
    char vae_checksum[48];         /* gv_vae_checksum of its weights ("fnv1a64:<16 hex>"), or "" */
    char base[GV_CHECKPOINT_TEXT]; /* the base checkpoint a fine-tuning started from, or "" */
    char clips[GV_CHECKPOINT_TEXT];/* the dataset folder trained on (informational) */
    char data[GV_CHECKPOINT_TEXT]; /* the training clips: split, count, hash of their names */
    char training[GV_CHECKPOINT_TEXT]; /* options that decide the steps taken */
    gv_text_source text;           /* the prompt's context (a fine-tuning keeps its base's) */
    char scenes[GV_CHECKPOINT_SCENES]; /* the scenes of every clip the network and its base
                                          trained on, sorted, comma-separated; "" unknown */
} gv_train_state;

/* ---- for inference ------------------------------------------------------------------------ */
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

/* What gv_restorer_open reads beyond the records: the network and the VAE always, only when a
 * scene checkpoint's gate is open (a closed gate leaves the renders as they are), or never. */
typedef enum { GV_RESTORER_NETWORK, GV_RESTORER_NETWORK_IF_GATE_OPEN, GV_RESTORER_RECORD } gv_restorer_part;

/* A trained restorer as one open of its checkpoint (and of a scene checkpoint's base, and of
 * the VAE file it names) gives it: what every caller needs, so that nobody reopens the file. */
typedef struct {
    gv_model_config cfg;
    gv_train_state state;
    int loaded;                    /* 1: net and vae hold the weights */
    gv_dit net;                    /* frozen */
    gv_vae vae;
    char vae_path[4200];           /* the VAE file metadata "vae" names, else the checkpoint */
    int scene;                     /* 1: a scene checkpoint (kind "scene"); then: */
    gv_scene_adaptation adaptation;/*   its record and gate */
    char base_path[4200];          /*   the base it applies to, as found */
    char base_checksum[48];        /*   that file's checksum, equal to the record's */
    int scenes_known;              /* 1: training_scenes lists the scenes the network (a scene
                                      checkpoint: its base) trained on; 0: not recorded; -1:
                                      the record beside it is unreadable, scenes_error says why */
    char training_scenes[GV_CHECKPOINT_SCENES];
    char scenes_error[512];
} gv_restorer;
/* Loads a checkpoint: its config and training state, the network (built by gv_dit_init from
 * that config, every tensor read from the file; a base's LoRA adapters, absent from the file,
 * stay at their zero start) and the VAE: its tensors in the file, or else the file named by
 * metadata "vae" (gv_checkpoint_vae_path), checked against "vae_checksum". A scene checkpoint
 * (scene_adapt.h) loads its base first (found as written, else beside it; its checksum
 * streamed from the one open of the file must be the record's), then its adapters over it;
 * r->cfg and r->state are then the scene checkpoint's. Also fills the training scenes. Each
 * file is opened once. */
int gv_restorer_load(const char *path, gv_restorer *r);
/* The same with a choice of what to read (what = GV_RESTORER_NETWORK is gv_restorer_load). */
int gv_restorer_open(const char *path, gv_restorer_part what, gv_restorer *r);
void gv_restorer_free(gv_restorer *r);
/* Reads only the config and the training state of a checkpoint. */
int gv_checkpoint_read_info(const char *path, gv_model_config *cfg, gv_train_state *state);

/* ---- for training ------------------------------------------------------------------------- */
/* Writes every tensor of m, the config cfg (may describe more than m: a base's config keeps
 * the LoRA rank fine-tuning will use) and the state; with_moments adds the AdamW moments of the
 * trainable tensors. Atomic. */
int gv_checkpoint_save(const char *path, const gv_dit *m, const gv_model_config *cfg, const gv_train_state *s,
                       int with_moments);
/* Restores a training run from a checkpoint written with moments: every tensor of m and the
 * moments of its trainable tensors must be there with their shapes; sets m's AdamW step. */
int gv_checkpoint_restore(const char *path, gv_dit *m, gv_train_state *s);
/* Starts fine-tuning from a base: reads every tensor of m that the file has (the DiT and VACE
 * parts must all be there; the camera part only when take_camera is set and the file's camera
 * variant is m's, else it keeps its fresh start; the residual variant's output layer keeps its
 * zero start); a tensor of another shape fails. *camera_loaded tells which. */
int gv_checkpoint_load_base(const char *path, gv_dit *m, int take_camera, int *camera_loaded);
/* 1 when two configs build the same network weights apart from the variant, the LoRA
 * adapters and the latent statistics (what a base and its fine-tuning may differ in). */
int gv_config_same_network(const gv_model_config *a, const gv_model_config *b);
/* A config's network in a few words for messages ("tiny: dim 32, 2 layers, ..."). */
void gv_config_describe(const gv_model_config *c, char *out, size_t size);
/* The VAE file a checkpoint names (metadata "vae"): as written if it exists, else the same
 * relative path or file name in the checkpoint's folder. */
int gv_checkpoint_vae_path(const char *ckpt, const gv_train_state *s, char *out, size_t size);
/* "fnv1a64:<16 hex digits>" of gv_vae_checksum (the latent cache's key) into out. */
void gv_checkpoint_vae_checksum(const gv_vae *vae, char *out, size_t size);

/* ---- the scenes a restorer was trained on (training_scenes.c) -----------------------------
 * Metadata "scenes": the folder names of the scenes whose clips trained the network, its
 * base's included, sorted and comma-separated; absent in checkpoints written before it was
 * recorded (and in imported ones), which then say nothing. */
/* Adds the scenes of the dataset's clips of split (NULL: all) to meta->scenes. */
int gv_train_record_scenes(gv_train_state *meta, const char *clips_dir, const char *split);
/* Adds the scenes of a comma-separated list (a base's record) to meta->scenes. */
int gv_train_add_scenes(gv_train_state *meta, const char *list);
/* 1 when the comma-separated list holds name. */
int gv_scene_list_has(const char *list, const char *name);
/* One line on stderr when the restorer (loaded from ckpt, gv_restorer_open) records scene
 * among its training scenes: "warning: scene 'X' was in the restorer's training set (...): its
 * numbers do not measure generalisation". -1 when its record could not be read. */
int gv_warn_if_trained_on(const gv_restorer *r, const char *ckpt, const char *scene);

/* ---- the prompt's text context (text_context.c) --------------------------------------------
 * The DiT's cross-attention context of a prompt, [text_len, text_dim], computed by the umT5
 * encoder once and cached in a safetensors file (tensor "text_context", F32) whose metadata
 * is its key: "prompt", "text_encoder" and "text_encoder_bytes" (the encoder's path and size:
 * hashing 11 GB at every load would cost minutes), "tokenizer" and "tokenizer_checksum"
 * (FNV-1a 64 of the SentencePiece model). */
/* Computes the context of prompt with the encoder and tokenizer and writes the cache to path
 * (atomically); *n_tokens is the prompt's token count. */
int gv_text_context_write(const char *encoder, const char *tokenizer, const gv_model_config *cfg, const char *prompt,
                          const char *path, int *n_tokens);
/* The context into out [text_len, text_dim]: from the cache at src->path when its key is
 * still that of src (the prompt, and the encoder and tokenizer it names when they are there
 * to compare), else computed again and the cache rewritten (*computed = 1); without a cache,
 * computed from src->encoder and src->tokenizer. Fails in one line when it is stale or absent
 * and no encoder is there to compute it. */
int gv_text_context_get(const gv_text_source *src, const gv_model_config *cfg, float *out, int *computed);
/* Gives m the text context the checkpoint at ckpt names (state s; paths as written, else
 * beside the checkpoint); a checkpoint that names none leaves the zero context. */
int gv_checkpoint_text(const char *ckpt, const gv_train_state *s, gv_dit *m);

#endif
