/* What `pretrain`, `train` and `vae train` share: the flags of a training run and their checks. */
#ifndef GAUSSVID_CLI_CMD_TRAIN_H
#define GAUSSVID_CLI_CMD_TRAIN_H

#include "gaussvid/core/core.h"
#include "gaussvid/train/train.h"

typedef struct {
    const char *out, *log;
    int steps, batch, warmup, seed, checkpoint_every, stop_after, resume;
    double lr;
    char help[5][96];            /* help lines with the command's defaults */
} gv_run_cli;

#define GV_RUN_CLI_FLAGS 10

/* flags = the command's own n_own flags, then GV_RUN_CLI_FLAGS for r, whose values are the
 * defaults the help shows (out_help describes --out); returns the count. */
int gv_run_cli_flags(gv_run_cli *r, const char *out_help, const gv_flag *own, int n_own, gv_flag *flags);
/* 0, or 2 after a usage line naming the command when a value is out of range. */
int gv_run_cli_check(const gv_run_cli *r, const char *command);
/* r's values into a run's options. */
void gv_run_cli_apply(const gv_run_cli *r, gv_train_options *o);

#endif
