/* Shared by the files of src/train: checkpoint metadata helpers and the comparison of configs. */
#ifndef GAUSSVID_TRAIN_INTERNAL_H
#define GAUSSVID_TRAIN_INTERNAL_H

#include "gaussvid/train/checkpoint.h"
#include "gaussvid/io/safetensors.h"
#include "gaussvid/train/train.h"

/* Opens a checkpoint and checks its "format" metadata; fails naming the file. */
int gv_ckpt_open(gv_st_file *f, const char *path);
/* Parses the "config" and training-state metadata of an open checkpoint. */
int gv_ckpt_read_meta(const gv_st_file *f, gv_model_config *cfg, gv_train_state *s);
/* A file a checkpoint names (its VAE, its text context, a scene checkpoint's base): as
 * written, else the same relative path or file name in the checkpoint's folder, else the file
 * name in the model folders (gv_find_model: $GAUSSVID_MODELS, beside the program, installed),
 * into out: 1 found as written or beside, 2 in the model folders (a file of the same name
 * there may be another model: the caller checks it), 0 not found. GV_CHECKPOINT_LOOKED says
 * where, for messages. */
#define GV_CHECKPOINT_LOOKED "as written, beside the checkpoint and in the model folders ($GAUSSVID_MODELS, beside the program, installed)"
int gv_checkpoint_find_beside(const char *ckpt, const char *named, char *out, size_t size);
/* training_scenes.c: r's training scenes from the state of checkpoint ckpt (metadata "scenes",
 * else the record beside the file); a bad record sets scenes_known -1 and scenes_error. */
void gv_restorer_read_scenes(gv_restorer *r, const char *ckpt, const gv_train_state *s);
/* checkpoint.c: the network, the VAE and the text context of checkpoint f, whose config and
 * state r holds; variant (or NULL): the config of an adaptation's variant (adapt --variant),
 * whose network takes f's weights as fine-tuning takes a base's. f may be handed to the
 * network (its BF16 weights stay mapped); gv_st_close of f is then a no-op. */
int gv_restorer_read_network(gv_st_file *f, gv_restorer *r, const gv_model_config *variant);
/* scene_checkpoint.c: the rest of gv_restorer_open for a scene checkpoint f, whose config and
 * state r holds: its record, its base (opened once) and, as what asks, the network. */
int gv_scene_restorer_open(gv_st_file *f, gv_restorer_part what, gv_restorer *r);
/* checkpoint_state.c: gv_checkpoint_load_base from an open base, with its text context; *kept:
 * BF16 weights point into f's mapping, which the caller must hand to m (gv_dit_keep_file). */
int gv_checkpoint_load_base_open(const gv_st_file *f, gv_dit *m, int take_camera, int *camera_loaded, int *kept);
/* The part (GV_PART_*) of a network tensor, from the model's weight list. */
unsigned gv_dit_param_part(const gv_dit *m, const char *name);
/* 1 for a tensor fine-tuning trains (the adapters a scene checkpoint holds). */
int gv_dit_param_is_adapter(const gv_dit *m, const char *name);
/* checkpoint_state.c: the metadata of a checkpoint file (format, kind, config, parts, the
 * training state); adapters_only: "parts" names those of the adapters alone. */
int gv_ckpt_add_state(gv_st_builder *b, const gv_dit *m, const gv_model_config *cfg, const gv_train_state *s,
                      int adapters_only);

/* train_options.c: the options that decide a run's steps, as one line (checkpoint metadata
 * "training"); their checks; the draws of clip b of a step: timestep, weights and context in
 * d, the window it sees of a grid of tokens_h x tokens_w tokens (the whole grid without
 * crop), and its noise eps[n], n the floats of the (windowed) latent. */
typedef struct {
    int y, x, h, w;              /* first row and column, rows and columns, in tokens */
} gv_train_window;
void gv_train_options_text(const gv_train_options *o, char *out, size_t size);
int gv_train_check_options(const gv_train_options *o);
void gv_train_draw(const gv_train_options *o, const gv_pretrain_schedule *grid, long step, int b, double w_cur,
                   int tokens_h, int tokens_w, gv_sample_draw *d, gv_train_window *win);
void gv_train_noise(const gv_train_options *o, long step, int b, int64_t n, float *eps);

/* trainer.c: the per-clip weights of --relative-loss, 1 / identity loss normalised to mean 1
 * (identities floored at 1e-3 of their mean); *out is malloc'd, data->count values. */
int gv_train_relative_weights(const gv_latent_set *data, double **out);

/* grad_sum.c: a step's gradient summed over its clips, each clip's from zero, then over the
 * ranks (docs/DISTRIBUTED.md). add: the parameters' gradients (one clip's) into the sum, and
 * zeroes them; finish: the sum over the ranks into the parameters' gradients. */
typedef struct {
    float *sum;                  /* every trainable float, in the registry's order */
    int64_t count;
    int clips;                   /* clips added since the last finish */
} gv_grad_sum;
int gv_grad_sum_init(gv_grad_sum *s, const gv_params *ps);
void gv_grad_sum_free(gv_grad_sum *s);
void gv_grad_sum_add(gv_grad_sum *s, gv_params *ps);
int gv_grad_sum_finish(gv_grad_sum *s, gv_params *ps);
/* FNV-1a 64 of the trainable tensors' values: the ranks compare it at each checkpoint. */
uint64_t gv_params_checksum(const gv_params *ps);

#endif
