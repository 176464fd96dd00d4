/* gaussvid: one program, one subcommand per stage of the pipeline. */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "cli/commands.h"
#include "gaussvid/core/core.h"
#include "gaussvid/core/dist.h"

#define GAUSSVID_VERSION "0.1.0"

static const gv_subcommand commands[] = {
    {"reconstruct", cmd_reconstruct, "from a scene to a sparse 3DGS, restored renders, a refined model, metrics, a video"},
    {"scene", cmd_scene, "scenes: from photos with COLMAP (colmap), validate and describe (info), synthesise (synth)"},
    {"splat", cmd_splat, "3D Gaussian Splatting: train, render, evaluate, export to .splat"},
    {"metrics", cmd_metrics, "PSNR and SSIM of two images, as the 3DGS evaluation computes them"},
    {"st", cmd_st, "safetensors files: check one and list its tensors and metadata (inspect)"},
    {"model", cmd_model, "restoration network: weight checks (inspect), Wan weights (import), one forward pass (run)"},
    {"bench", cmd_bench, "benchmarks: tensor engine, 3DGS trainer and kernels, network, training, Wan import and streaming"},
    {"dataset", cmd_dataset, "paired clip dataset: build (artifact simulation), stats, show"},
    {"vae", cmd_vae, "the restoration network's VAE: train on scene frames, evaluate reconstruction"},
    {"pretrain", cmd_pretrain, "pretrain the base first-last-frame video model on clean clips"},
    {"train", cmd_train, "GaussVid fine-tuning of a base model: LoRA + camera encoder, curriculum"},
    {"restore", cmd_restore, "restore the intermediate frames of clips with a trained checkpoint"},
    {"eval", cmd_eval, "PSNR and SSIM of baseline and restored frames per interval n (Markdown, JSON)"},
    {"adapt", cmd_adapt, "adapt the restorer to one scene from its own training views (scene checkpoint, gate)"},
    {"report", cmd_report, "the HTML report and browser viewers of a reconstruction folder"},
};
static const int n_commands = sizeof commands / sizeof commands[0];

static void print_usage(FILE *out)
{
    fprintf(out,
            "gaussvid %s: sparse-view 3D Gaussian Splatting restored by a 3D-aware video "
            "diffusion transformer\n\nusage: gaussvid COMMAND [options]\n\ncommands:\n",
            GAUSSVID_VERSION);
    for (int i = 0; i < n_commands; i++)
        fprintf(out, "  %-12s %s\n", commands[i].name, commands[i].summary);
    fprintf(out, "  %-12s %s\n", "help", "this list; 'gaussvid COMMAND --help' for one command");
    fprintf(out, "  %-12s %s\n", "version", "print the version");
}

/* The commands that share their work among the ranks of an mpirun job (docs/DISTRIBUTED.md);
 * any other would run K times over into the same files. */
static int shares_work(int argc, char **argv)
{
    const char *name = argv[1];
    return !strcmp(name, "pretrain") || !strcmp(name, "train") || !strcmp(name, "adapt") ||
           (!strcmp(name, "dataset") && argc > 2 && !strcmp(argv[2], "build"));
}

int main(int argc, char **argv)
{
    gv_prefer_runtime_env(argv);
    if (argc < 2) {
        print_usage(stderr);
        return 2;
    }
    const char *name = argv[1];
    if (!strcmp(name, "help") || !strcmp(name, "--help") || !strcmp(name, "-h")) {
        if (argc > 2) {
            for (int i = 0; i < n_commands; i++) {
                if (!strcmp(argv[2], commands[i].name)) {
                    char *help_argv[] = {argv[2], "--help", NULL};
                    return commands[i].run(2, help_argv);
                }
            }
        }
        print_usage(stdout);
        return 0;
    }
    if (!strcmp(name, "version") || !strcmp(name, "--version")) {
        printf("gaussvid %s\n", GAUSSVID_VERSION);
        printf("MPI: %s\n", gv_dist_library());
        return 0;
    }
    for (int i = 0; i < n_commands; i++)
        if (!strcmp(name, commands[i].name)) {
            /* under mpirun every rank runs the command; dist.h says who writes what */
            gv_dist_start(&argc, &argv);
            if (gv_dist_size() > 1 && !shares_work(argc, argv)) {
                fprintf(stderr, "gaussvid %s: runs as one process; under mpirun only pretrain, train, adapt and "
                                "dataset build share their work among the ranks\n", name);
                return gv_dist_end(2);
            }
            return gv_dist_end(commands[i].run(argc - 1, argv + 1));
        }
    fprintf(stderr, "gaussvid: unknown command '%s' (see 'gaussvid help')\n", name);
    return 2;
}
