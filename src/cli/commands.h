/* The subcommands of the gaussvid program. Each takes argv with argv[0] = its own name and
 * returns the process exit code: 0 success, 1 failure, 2 usage error. */
#ifndef GAUSSVID_CLI_COMMANDS_H
#define GAUSSVID_CLI_COMMANDS_H

typedef struct {
    const char *name;
    int (*run)(int argc, char **argv);
    const char *summary;
} gv_subcommand;

/* Runs the entry of `table` named by argv[1] (argv[0] is the group's name, e.g. "scene"),
 * or prints the group's help. */
int gv_run_subcommand(const char *group, const gv_subcommand *table, int n, int argc, char **argv);
/* --crop RxC of pretrain and train: rows and columns of tokens, both positive. Returns 0, or
 * prints a usage line naming the command and returns 2. */
int gv_parse_crop(const char *command, const char *text, int *rows, int *cols);

/* Sets what libgomp and OpenBLAS read when they load, unless the user set it: a short spin
 * before a waiting OpenMP thread sleeps, OpenBLAS kernels the CPU supports; then re-executes
 * the program once (runtime_env.c). Call first in main. */
void gv_prefer_runtime_env(char **argv);

int cmd_metrics(int argc, char **argv);
int cmd_metrics_consistency(int argc, char **argv);
int cmd_model(int argc, char **argv);
int cmd_model_run(int argc, char **argv);
int cmd_model_import(int argc, char **argv);
int cmd_model_merge(int argc, char **argv);
int cmd_scene(int argc, char **argv);
int cmd_scene_info(int argc, char **argv);
int cmd_scene_synth(int argc, char **argv);
int cmd_scene_colmap(int argc, char **argv);
int cmd_splat(int argc, char **argv);
int cmd_splat_export(int argc, char **argv);
int cmd_splat_train(int argc, char **argv);
int cmd_splat_render(int argc, char **argv);
int cmd_splat_eval(int argc, char **argv);
int cmd_splat_coverage(int argc, char **argv);
int cmd_st(int argc, char **argv);
int cmd_bench(int argc, char **argv);
int cmd_dataset(int argc, char **argv);
int cmd_dataset_build(int argc, char **argv);
int cmd_dataset_stats(int argc, char **argv);
int cmd_dataset_show(int argc, char **argv);
int cmd_vae(int argc, char **argv);
int cmd_vae_train(int argc, char **argv);
int cmd_vae_eval(int argc, char **argv);
int cmd_pretrain(int argc, char **argv);
int cmd_train(int argc, char **argv);
int cmd_restore(int argc, char **argv);
int cmd_eval(int argc, char **argv);
int cmd_adapt(int argc, char **argv);
int cmd_reconstruct(int argc, char **argv);
int cmd_report(int argc, char **argv);

#endif
