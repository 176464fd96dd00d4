/* What `gaussvid restore` and `gaussvid eval` share: the checkpoint, the sampler and
 * composition flags, and loading the network. */
#ifndef GAUSSVID_CLI_CMD_RESTORE_H
#define GAUSSVID_CLI_CMD_RESTORE_H

#include "gaussvid/checkpoint.h"
#include "gaussvid/eval.h"
#include "gaussvid/restore.h"

typedef struct {
    const char *ckpt, *sampler, *compose, *split, *lpips;
    double t0, shift, blend;
    int steps, samples, seed, no_cache;
} gv_restore_cli;

#define GV_RESTORE_CLI_FLAGS 12

/* Fills flags[0..GV_RESTORE_CLI_FLAGS) for c (with the defaults set in c). */
void gv_restore_cli_flags(gv_restore_cli *c, gv_flag *flags, const char *split_help);
/* The restore options of the flags; fails (a usage error) naming the flag. */
int gv_restore_cli_options(const gv_restore_cli *c, gv_restore_options *o);
/* Loads the checkpoint's network (frozen) and VAE; vae_path receives the VAE file it names
 * (or the checkpoint itself when it holds the VAE). */
int gv_restore_cli_load(const char *ckpt, gv_dit *m, gv_vae *vae, gv_model_config *cfg, char *vae_path, size_t size);
/* A scene checkpoint's gate (scene_adapt.h): sets o->keep_renders when it is closed and writes
 * the line that says what happens into line (empty for other checkpoints); *gate gets "open",
 * "closed" or NULL. */
int gv_restore_cli_gate(const char *ckpt, gv_restore_options *o, char *line, size_t size, const char **gate);
/* Loads the LPIPS weights of --lpips into net and returns it, or NULL without the flag;
 * *failed is set when the file does not load. */
const gv_lpips *gv_restore_cli_lpips(const gv_restore_cli *c, gv_lpips *net, int *failed);
/* Prints "usage error" as the commands do and returns 2. */
int gv_restore_cli_usage(const char *command, const char *message);

#endif
