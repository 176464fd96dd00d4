/* gaussvid: one program, one subcommand per stage of the pipeline. */
#include <cblas.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <strings.h>
#include <unistd.h>

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

/* OpenBLAS picks its kernels from the CPU's model number; on a virtual CPU whose model it does
 * not know ("Intel(R) Xeon(R) Processor") it falls back to the SSE3 "Prescott" kernels, which
 * ran sgemm 6x slower than the AVX-512 ones on such a machine (docs/BENCHMARKS.md). The kernel
 * the CPU's feature flags allow, when OpenBLAS chose a pre-AVX2 one; NULL otherwise. */
static const char *better_blas_core(void)
{
    static const char *const pre_avx2[] = {"Prescott", "Core2", "Penryn", "Dunnington", "Nehalem", "Atom",
                                           "Sandybridge", "Katmai", "Coppermine", "Northwood", "Banias", NULL};
    const char *core = openblas_get_corename();
    int weak = 0;
    for (int i = 0; core && pre_avx2[i]; i++) weak |= !strcasecmp(core, pre_avx2[i]);
    if (!weak) return NULL;
    __builtin_cpu_init();
    if (__builtin_cpu_supports("avx512f") && __builtin_cpu_supports("avx512bw") &&
        __builtin_cpu_supports("avx512dq") && __builtin_cpu_supports("avx512vl"))
        return "SkylakeX";
    if (__builtin_cpu_supports("avx2") && __builtin_cpu_supports("fma")) return "Haswell";
    return NULL;
}

/* The run-time environment that libgomp and OpenBLAS read when they are loaded, before main,
 * hence one re-execution when something must change; if it fails the program runs as it is.
 * Unless the user chose a wait policy, a thread that waits for the others spins for 3000
 * rounds (about 30 us) and then sleeps. Sleeping at once (OMP_WAIT_POLICY=passive) costs a
 * wake-up of the idle core at each of the dozens of parallel regions and barriers of a 3DGS
 * iteration: 20 % of splat train's time on an idle machine. Spinning for long (libgomp's
 * default of about 3 ms, or OMP_WAIT_POLICY=active) spins against a descheduled peer as soon
 * as another job shares the cores: two-thread runs 6-9x slower. The short spin kept the whole
 * gain idle and cost 7-12 % under that load (docs/BENCHMARKS.md, "Thread wait policy").
 * OpenBLAS gets the kernels the CPU supports unless OPENBLAS_CORETYPE is set. */
static void prefer_runtime_env(char **argv)
{
    int changed = 0;
    if (!getenv("OMP_WAIT_POLICY") && !getenv("GOMP_SPINCOUNT"))
        changed |= setenv("GOMP_SPINCOUNT", "3000", 1) == 0;
    const char *core = getenv("OPENBLAS_CORETYPE") ? NULL : better_blas_core();
    if (core) changed |= setenv("OPENBLAS_CORETYPE", core, 1) == 0;
    if (changed) execv("/proc/self/exe", argv);
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
    prefer_runtime_env(argv);
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
