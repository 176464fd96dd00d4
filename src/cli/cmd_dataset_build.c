/* gaussvid dataset build --scenes DIR... --out DIR: artifact simulation and clip sampling for
 * every scene and interval (paper section 3.2; docs/FORMATS-DATASET.md). Resumable. */
#include <stdio.h>
#include <stdlib.h>

#include "cli/commands.h"
#include "gaussvid/core/core.h"
#include "gaussvid/data/dataset.h"
#include "gaussvid/splat/splat_train.h"

static int compare_ints(const void *a, const void *b)
{
    int x = *(const int *)a, y = *(const int *)b;
    return (x > y) - (x < y);
}

static int usage(const char *message)
{
    fprintf(stderr, "gaussvid dataset build: %s (see 'gaussvid dataset build --help')\n", message);
    return 2;
}

int cmd_dataset_build(int argc, char **argv)
{
    const char *intervals_text = "6:26:2", *sampling = "uniform", *out = NULL, *densify = NULL;
    gv_flag_list scenes = {.n = 0}, eval = {.n = 0};
    gv_dataset_params p;
    gv_dataset_default_params(&p);
    int seed = 0, jobs = 1;
    const gv_flag flags[] = {
        {"scenes", GV_FLAG_LIST, &scenes, "DIR...", "scene folders: the folders after it, comma-separated, the flag repeated", 1},
        {"out", GV_FLAG_STRING, &out, "DIR", "the dataset folder (created; an existing one is resumed)", 1},
        {"intervals", GV_FLAG_STRING, &intervals_text, "A:B:S", "intervals n >= 2: \"a:b:s\", \"a:b\", \"n\", comma-separated, each n once (default 6:26:2)", 0},
        {"iters", GV_FLAG_INT, &p.iters, "N", "3DGS iterations, the early stop (default 8000, the paper's)", 0},
        {"densify", GV_FLAG_STRING, &densify, "MODE", "3DGS density control: reference (default, the paper's), lean or mcmc", 0},
        {"clips-per-run", GV_FLAG_INT, &p.clips_per_run, "K", "clips per (scene, n) (default 4)", 0},
        {"anchor-gap", GV_FLAG_INT, &p.anchor_gap, "G", "anchors G training views apart, G*n frames (default 1: consecutive)", 0},
        {"sampling", GV_FLAG_STRING, &sampling, "S", "intermediate frames: uniform (default), random or released", 0},
        {"eval-scenes", GV_FLAG_LIST, &eval, "NAME...", "scenes (folder names) of the eval split; the rest are train", 0},
        {"downscale", GV_FLAG_INT, &p.downscale, "K", "image downscale 1, 2, 4 or 8 (default 1)", 0},
        {"seed", GV_FLAG_INT, &seed, "S", "random seed of training and clip sampling (default 0)", 0},
        {"jobs", GV_FLAG_INT, &jobs, "J", "runs side by side, one thread each (default 1: one run on every thread)", 0},
    };
    const gv_command_spec spec = {
        "dataset build", NULL, "simulate sparse-view artifacts and sample clean-corrupted-clean clips",
        "For every scene and interval n: 3DGS trained on frames 0, n, 2n, ... and stopped at\n"
        "--iters renders every held-out frame (its PSNR/SSIM go to runs/<scene>_n<n>.json);\n"
        "--densify lean trains twice as fast (splat train --help says how the controls differ).\n"
        "K clips are sampled: two training views G*n apart as clean anchors, three held-out\n"
        "frames between them (uniform: round(s + j*G*n/4), j = 1, 2, 3), each clip one\n"
        "safetensors file under clips/, all listed in manifest.json. Runs already in the\n"
        "manifest are skipped, so an interrupted build resumes; the same --seed gives the\n"
        "same clips. Scene folders are named by their last path component.\n"
        "--jobs J trains J runs at once, one thread each (each gives the clips of --threads 1);\n"
        "on shared cores this avoids the threads of one run waiting for one another.\n"
        "See docs/FORMATS-DATASET.md.",
        flags, sizeof flags / sizeof flags[0], 0, 0};
    int parsed = gv_args_parse(&spec, argc, argv, NULL, NULL);
    if (parsed != GV_ARGS_OK) return gv_args_exit_code(parsed);
    int intervals[GV_MAX_INTERVALS], n_intervals;
    int bad = gv_interval_parse(intervals_text, GV_INTERVAL_CLIPS, intervals, GV_MAX_INTERVALS, &n_intervals) != 0 ||
              gv_sampling_from_name(sampling, &p.sampling) != 0;
    if (!bad && densify && (p.densify = gv_splat_densify_mode_parse(densify)) < 0)
        bad = gv_fail("--densify %s: expected " GV_DENSIFY_MODE_NAMES, densify) != 0;
    if (!bad && seed < 0) bad = gv_fail("--seed %d: must be non-negative", seed) != 0;
    if (!bad && (jobs < 1 || jobs > 256)) bad = gv_fail("--jobs %d: must be in 1..256", jobs) != 0;
    if (bad) return usage(gv_last_error());
    qsort(intervals, (size_t)n_intervals, sizeof *intervals, compare_ints); /* runs by increasing n */
    p.seed = (uint64_t)seed;

    gv_dataset_build_options o = {scenes.items, scenes.n, intervals, n_intervals, eval.items, eval.n, p, out, NULL,
                                  jobs};
    gv_dataset_build_result r;
    if (gv_dataset_build(&o, &r) != 0) return gv_report_failure();
    printf("%s: %d runs (%d built, %d already there), %d clips written, %.1f s\n", out,
           r.runs_total, r.runs_built, r.runs_skipped, r.clips_written, r.seconds);
    return 0;
}
