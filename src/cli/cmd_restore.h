/* What `gaussvid restore` and `gaussvid eval` share: the checkpoint, the sampler and
 * composition flags, and loading the network. */
#ifndef GAUSSVID_CLI_CMD_RESTORE_H
#define GAUSSVID_CLI_CMD_RESTORE_H

#include "gaussvid/train/checkpoint.h"
#include "gaussvid/eval/eval.h"
#include "gaussvid/restore/restore.h"

typedef struct {
    const char *ckpt, *sampler, *compose, *split, *lpips, *scene;
    double t0, shift, blend;
    int steps, samples, seed, no_cache, interval;
} gv_restore_cli;

#define GV_RESTORE_CLI_FLAGS 14

/* Fills flags[0..GV_RESTORE_CLI_FLAGS) for c (with the defaults set in c). */
void gv_restore_cli_flags(gv_restore_cli *c, gv_flag *flags, const char *split_help);
/* The restore options of the flags; fails (a usage error) naming the flag. */
int gv_restore_cli_options(const gv_restore_cli *c, gv_restore_options *o);
/* What a restore or eval run holds: the checkpoint, the LPIPS weights of --lpips, the table,
 * and a scene checkpoint's gate ("open", "closed" or NULL for other checkpoints) with the scene
 * it was adapted to. */
typedef struct {
    gv_restorer r;
    gv_lpips lpips;
    gv_eval_table table;
    const char *gate;
    char scene[GV_SCENE_NAME_MAX];
} gv_restore_session;
/* A scene checkpoint's gate and scope (scene_adapt.h), from the record s->r was loaded with: sets o->keep_renders when the gate is
 * closed, restricts o to the scene and interval it was adapted to (failing when --scene or
 * --interval asked for others), sets o->compose to the composition the gate measured (failing
 * when compose_given named another) and writes the line that says what happens into line
 * (empty for other checkpoints); s->gate gets "open", "closed" or NULL. */
int gv_restore_cli_gate(const char *ckpt, int compose_given, gv_restore_options *o, char *line, size_t size,
                        gv_restore_session *s);
/* Loads the checkpoint (saying what it is; a scene checkpoint over its base), applies a scene
 * checkpoint's gate to o (printing the line that says what happens), loads the --lpips weights,
 * and makes o hand every restored clip to s->table. s is freed by gv_restore_cli_end whatever
 * this returns. */
int gv_restore_cli_start(const gv_restore_cli *c, gv_restore_options *o, gv_restore_session *s);
void gv_restore_cli_end(gv_restore_session *s);
/* Fails (one line) when the clips folder is not a dataset or the clip file not a clip, so that a
 * bad input is refused before the checkpoint is loaded. */
int gv_restore_cli_check_input(const char *clips_dir, const char *clip_file);
/* One warning line for each scene among the clips o selects (of the dataset clips_dir, or the
 * one clip_file) that the restorer r, loaded from ckpt, records among its training scenes
 * (checkpoint.h). */
int gv_restore_cli_warn_seen(const gv_restorer *r, const char *ckpt, const char *clips_dir, const char *clip_file,
                             const gv_restore_options *o);
/* Prints "usage error" as the commands do and returns 2. */
int gv_restore_cli_usage(const char *command, const char *message);

#endif
