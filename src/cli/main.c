/* gaussvid: one program, one subcommand per stage of the pipeline. */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "cli/commands.h"
#include "gaussvid/core.h"

#define GAUSSVID_VERSION "0.1.0"

static const gv_subcommand commands[] = {
    {"scene", cmd_scene, "scenes: validate and describe (info), synthesise (synth)"},
    {"splat", cmd_splat, "3D Gaussian Splatting: train, render, evaluate, export to .splat"},
    {"metrics", cmd_metrics, "PSNR and SSIM of two images, as the 3DGS evaluation computes them"},
    {"st", cmd_st, "safetensors files: check one and list its tensors and metadata (inspect)"},
    {"model", cmd_model, "restoration network: parameter counts and weight checks (inspect)"},
    {"bench", cmd_bench, "benchmarks: tensor engine, 3DGS trainer, network, restorer training"},
    {"dataset", cmd_dataset, "paired clip dataset: build (artifact simulation), stats, show"},
    {"vae", cmd_vae, "the restoration network's VAE: train on scene frames, evaluate reconstruction"},
    {"pretrain", cmd_pretrain, "pretrain the base first-last-frame video model on clean clips"},
    {"train", cmd_train, "GaussVid fine-tuning of a base model: LoRA + camera encoder, curriculum"},
    {"restore", cmd_restore, "restore the intermediate frames of clips with a trained checkpoint"},
    {"eval", cmd_eval, "PSNR and SSIM of baseline and restored frames per interval n (Markdown, JSON)"},
};
static const int n_commands = sizeof commands / sizeof commands[0];

static void print_usage(FILE *out)
{
    fprintf(out,
            "gaussvid %s: sparse-view 3D Gaussian Splatting restored by a 3D-aware video "
            "diffusion transformer\n\nusage: gaussvid COMMAND [options]\n\ncommands:\n",
            GAUSSVID_VERSION);
    for (int i = 0; i < n_commands; i++)
        fprintf(out, "  %-10s %s\n", commands[i].name, commands[i].summary);
    fprintf(out, "  %-10s %s\n", "help", "this list; 'gaussvid COMMAND --help' for one command");
    fprintf(out, "  %-10s %s\n", "version", "print the version");
}

/* OpenMP threads that wait by spinning make two-thread runs 5-25x slower as soon as another
 * job shares the cores (docs/BENCHMARKS.md), so waiting threads sleep unless the user chose
 * otherwise. libgomp reads its environment when it is loaded, before main, hence the one
 * re-execution; if it fails the program simply runs with the default policy. */
static void prefer_passive_wait(char **argv)
{
    if (getenv("OMP_WAIT_POLICY") || getenv("GOMP_SPINCOUNT")) return;
    if (setenv("OMP_WAIT_POLICY", "passive", 1) != 0) return;
    execv("/proc/self/exe", argv);
}

int main(int argc, char **argv)
{
    prefer_passive_wait(argv);
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
        return 0;
    }
    for (int i = 0; i < n_commands; i++)
        if (!strcmp(name, commands[i].name)) return commands[i].run(argc - 1, argv + 1);
    fprintf(stderr, "gaussvid: unknown command '%s' (see 'gaussvid help')\n", name);
    return 2;
}
