/* gaussvid reconstruct --scene DIR --interval n[,n...] --out DIR: sparse 3DGS, renders,
 * restoration, refinement, evaluation and a video, stage by stage and resumable
 * (docs/RECONSTRUCT.md). */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "cli/commands.h"
#include "gaussvid/core.h"
#include "gaussvid/pipeline.h"
#include "gaussvid/report.h"
#include "gaussvid/splat_train.h"

#define DEFAULT_CKPT_NAME "gaussvid-small.safetensors"
#define DEFAULT_CKPT "models/" DEFAULT_CKPT_NAME

/* The released restorer, wherever the model folders are (core.h: $GAUSSVID_MODELS, beside the
 * program, installed), into path; fails naming every place looked and --ckpt. */
static int default_ckpt(char *path, size_t size)
{
    if (gv_find_model(DEFAULT_CKPT_NAME, path, size)) return 0;
    gv_model_dirs d;
    char where[8192];
    gv_model_dirs_list(&d);
    gv_model_dirs_describe(&d, where, sizeof where);
    return gv_fail("the default restorer %s is in none of: %s; give one with --ckpt FILE", DEFAULT_CKPT_NAME, where);
}

static void print_stage(void *ctx, int n, const char *stage, const char *summary, double seconds, double cpu)
{
    printf("n=%d %s: %s (%.1f s, %.1f s CPU)\n", n, stage, summary, seconds, cpu);
    fflush(stdout);
}

int cmd_reconstruct(int argc, char **argv)
{
    gv_reconstruct_options o;
    gv_reconstruct_defaults(&o);
    o.ckpt = NULL;
    const char *intervals = NULL, *densify = NULL;
    int seed = 0, adapt_steps = (int)o.adapt_options.train.steps;
    const gv_flag flags[] = {
        {"scene", GV_FLAG_STRING, &o.scene_dir, "DIR", "the scene folder (images/ with sparse/0 or transforms.json; gaussvid scene colmap makes one from photos)", 1},
        {"interval", GV_FLAG_STRING, &intervals, "N[,N...|A:B:S]", "sparse views: frames 0, N, 2N, ... train, the held-out frames between them are restored (N >= 4); N = 1: every view trains and a smooth path between them is restored; a list or a range a:b:s runs each", 1},
        {"out", GV_FLAG_STRING, &o.out_dir, "DIR", "where everything goes: metrics.json and nN/ per interval (docs/RECONSTRUCT.md)", 1},
        {"ckpt", GV_FLAG_STRING, &o.ckpt, "FILE", "the restorer (default " DEFAULT_CKPT_NAME ", found in $GAUSSVID_MODELS, else beside the program (../models: the source tree's " DEFAULT_CKPT "), else where make install put it (../share/gaussvid))", 0},
        {"iters", GV_FLAG_INT, &o.iters, "N", "sparse 3DGS iterations (default 8000)", 0},
        {"densify", GV_FLAG_STRING, &densify, "MODE", "its density control: reference (default, the paper's), lean (twice as fast) or mcmc", 0},
        {"refine-iters", GV_FLAG_INT, &o.refine_iters, "N", "refinement iterations (default 1000)", 0},
        {"refine-weight", GV_FLAG_DOUBLE, &o.refine_weight, "W", "loss weight of the restored frames in the refinement, in (0, 1]; training views weigh 1 (default 0.3)", 0},
        {"adapt", GV_FLAG_BOOL, &o.adapt, NULL, "adapt the restorer to the scene first (gaussvid adapt, docs/ADAPT.md) and restore with the result", 0},
        {"adapt-steps", GV_FLAG_INT, &adapt_steps, "N", "with --adapt: fine-tuning steps (default 300)", 0},
        {"adapt-config", GV_FLAG_STRING, &o.adapt_options.config, "PRESET|FILE", "with --adapt: the network the checkpoint must be (default small)", 0},
        {"lpips", GV_FLAG_STRING, &o.lpips, "FILE", "AlexNet-LPIPS weights (docs/LPIPS.md): add LPIPS to the evaluation", 0},
        {"fps", GV_FLAG_DOUBLE, &o.fps, "F", "frames per second of flythrough.mp4 (default 8)", 0},
        {"ffmpeg", GV_FLAG_STRING, &o.ffmpeg, "FILE", "the ffmpeg program (default: ffmpeg on the PATH)", 0},
        {"downscale", GV_FLAG_INT, &o.downscale, "K", "image downscale 1, 2, 4 or 8 (default 1)", 0},
        {"seed", GV_FLAG_INT, &seed, "S", "seed of the 3DGS runs and of the restorer's noise (default 0)", 0},
        {"stop-after", GV_FLAG_STRING, &o.stop_after, "STAGE", "stop after this stage: train, render, adapt, restore, refine, evaluate or video (run again to continue)", 0},
    };
    const gv_command_spec spec = {
        "reconstruct", NULL, "sparse 3DGS, restored renders, a refined model, metrics and a video of a scene",
        "Per interval n, in DIR/nN: trains sparse 3DGS on frames 0, n, 2n, ... (sparse.ply,\n"
        "sparse.splat); renders the held-out frames between them (frames/render/, each named after\n"
        "its photo); with --adapt adapts the restorer to the scene; restores every rendered frame\n"
        "in 5-frame clips (clean anchors at the training views, three renders; frames/restored/);\n"
        "refines the 3DGS on the training views and, down-weighted, the restored frames\n"
        "(refined.ply, refined.splat, frames/refined/); scores sparse, restored and refined against\n"
        "the ground truth and their 3D consistency; encodes flythrough.mp4 (ffmpeg): a fly-through\n"
        "along the training cameras (sparse | refined | nearest photo), then render | restored |\n"
        "ground truth, labelled. DIR/metrics.json has every number and is rewritten after each\n"
        "stage; running the same command again skips the finished stages. See docs/RECONSTRUCT.md.",
        flags, sizeof flags / sizeof flags[0], 0, 0};
    int parsed = gv_args_parse(&spec, argc, argv, NULL, NULL);
    if (parsed != GV_ARGS_OK) return gv_args_exit_code(parsed);
    if (gv_interval_parse(intervals, GV_INTERVAL_RECONSTRUCT, o.intervals, GV_RECONSTRUCT_MAX_INTERVALS, &o.n_intervals) || (seed < 0 && gv_fail("--seed %d: must not be negative", seed) != 0) ||
        (adapt_steps < 1 && gv_fail("--adapt-steps %d: must be positive", adapt_steps) != 0) ||
        (densify && (o.densify = gv_splat_densify_mode_parse(densify)) < 0 &&
         gv_fail("--densify %s: expected " GV_DENSIFY_MODE_NAMES, densify) != 0) ||
        (o.downscale != 1 && o.downscale != 2 && o.downscale != 4 && o.downscale != 8 &&
         gv_fail("--downscale %d: expected 1, 2, 4 or 8", o.downscale) != 0)) {
        fprintf(stderr, "gaussvid reconstruct: %s (see 'gaussvid reconstruct --help')\n", gv_last_error());
        return 2;
    }
    char found[4096];
    if (!o.ckpt) {
        if (default_ckpt(found, sizeof found)) return gv_report_failure();
        o.ckpt = found;
    }
    o.seed = (uint64_t)seed;
    o.on_stage = print_stage;
    o.adapt_options.train.steps = adapt_steps;
    o.adapt_options.train.seed = (uint64_t)seed;
    if (gv_reconstruct(&o)) return gv_report_failure();
    if (o.stop_after && strcmp(o.stop_after, "video")) return 0; /* stopped early: the summary is for a finished run */
    return gv_report_summary(o.out_dir, stdout) ? gv_report_failure() : 0;
}
