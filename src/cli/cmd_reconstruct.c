/* gaussvid reconstruct --scene DIR --interval n[,n...] --out DIR: sparse 3DGS, renders,
 * restoration, refinement, evaluation and a video, stage by stage and resumable
 * (docs/RECONSTRUCT.md). Settings: the defaults, then --preset, then the explicit flags. */
#include <limits.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "cli/commands.h"
#include "gaussvid/core/core.h"
#include "gaussvid/pipeline/pipeline.h"
#include "gaussvid/report/report.h"
#include "gaussvid/splat/splat_train.h"

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

/* The flags a preset sets, as given on the command line (UNSET / NULL: not given). */
#define UNSET INT_MIN
typedef struct {
    const char *preset, *densify, *base, *restore_with;
    int iters, refine_iters, adapt_steps, adapt, no_restore, resolution;
} explicit_flags;

/* defaults, the preset, then the flags given; one line on a bad or contradictory value. */
static int apply_settings(const explicit_flags *x, gv_reconstruct_options *o)
{
    if (x->preset && gv_reconstruct_preset(x->preset, o)) return -1;
    const char *mode = x->restore_with;
    if (x->no_restore && mode && strcmp(mode, "none"))
        return gv_fail("--no-restore and --restore-with %s: choose one", mode);
    if (x->adapt && mode && strcmp(mode, "adapted")) return gv_fail("--adapt and --restore-with %s: choose one", mode);
    if (x->adapt && x->no_restore) return gv_fail("--adapt and --no-restore: choose one");
    if (mode && (o->restore_with = gv_restore_with_parse(mode)) < 0)
        return gv_fail("--restore-with %s: expected " GV_RESTORE_WITH_NAMES, mode);
    if (x->no_restore) o->restore_with = GV_RESTORE_NONE;
    if (x->adapt) o->restore_with = GV_RESTORE_ADAPTED;
    if (x->densify && (o->densify = gv_splat_densify_mode_parse(x->densify)) < 0)
        return gv_fail("--densify %s: expected " GV_DENSIFY_MODE_NAMES, x->densify);
    if (x->base && (o->regularize = !strcmp(x->base, "3dgs") ? 0 : gv_splat_regularize_parse(x->base)) <= 0 &&
        strcmp(x->base, "3dgs"))
        return gv_fail("--base %s: expected 3dgs, corgs, fsgs, dropgaussian, segs, decay, binocular or a comma-separated list of the last six",
                       x->base);
    if (!x->base && o->densify == GV_DENSIFY_MCMC) o->regularize = gv_splat_regularize_default(o->densify);
    if (x->resolution != UNSET) {
        if (x->resolution != 1 && x->resolution != 2 && x->resolution != 4 && x->resolution != 8)
            return gv_fail("--resolution-schedule %d: expected 1 (full size throughout), 2, 4 or 8", x->resolution);
        o->resolution_start = x->resolution;
    }
    if (x->iters != UNSET) o->iters = x->iters;
    if (x->refine_iters != UNSET) o->refine_iters = x->refine_iters;
    if (x->adapt_steps != UNSET) {
        if (x->adapt_steps < 1) return gv_fail("--adapt-steps %d: must be positive", x->adapt_steps);
        o->adapt_options.train.steps = x->adapt_steps;
    }
    return 0;
}

/* The first line: the preset and the settings it resulted in. */
static void print_settings(const gv_reconstruct_options *o)
{
    char restore[512];
    if (o->restore_with == GV_RESTORE_NONE)
        snprintf(restore, sizeof restore, "no restoration (the sparse model only)");
    else if (o->restore_with == GV_RESTORE_CHECKPOINT)
        snprintf(restore, sizeof restore, "restoration with %s as it is (ungated), refinement %d iterations at weight %g",
                 o->ckpt, o->refine_iters, o->refine_weight);
    else
        snprintf(restore, sizeof restore, "%s adapted to the scene (%ld steps) where it has the views for it, its gate "
                 "deciding restoration and refinement (%d iterations at weight %g)", o->ckpt,
                 (long)o->adapt_options.train.steps, o->refine_iters, o->refine_weight);
    char base[64] = "3dgs", schedule[48] = "";
    if (o->regularize) gv_splat_regularize_name(o->regularize, base, sizeof base);
    if (o->resolution_start > 1) snprintf(schedule, sizeof schedule, ", from 1/%d of the size", o->resolution_start);
    printf("reconstruct, preset %s: %d sparse iterations (base %s, %s density control%s), %s\n", o->preset, o->iters,
           base, gv_splat_densify_mode_name(o->densify), schedule, restore);
    fflush(stdout);
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
    const char *intervals = NULL;
    int seed = 0, downscale = -1; /* -1: not given, chosen from the images' size */
    explicit_flags x = {NULL, NULL, NULL, NULL, UNSET, UNSET, UNSET, 0, 0, UNSET};
    const gv_flag flags[] = {
        {"scene", GV_FLAG_STRING, &o.scene_dir, "DIR", "the scene folder (images/ with sparse/0 or transforms.json; gaussvid scene colmap makes one from photos)", 1},
        {"interval", GV_FLAG_STRING, &intervals, "N[,N...|A:B:S]", "sparse views: frames 0, N, 2N, ... train, the held-out frames between them are restored (N >= 4); N = 1: every view trains and a smooth path between them is restored; a list or a range a:b:s runs each", 1},
        {"out", GV_FLAG_STRING, &o.out_dir, "DIR", "where everything goes: metrics.json and nN/ per interval (docs/RECONSTRUCT.md)", 1},
        {"preset", GV_FLAG_STRING, &x.preset, "NAME", "fast (lean density control, 3000 iterations, no restoration), default (8000 iterations, lean, the gated path) or best (15000 iterations, the reference control, the gated path); explicit flags override it (docs/RECONSTRUCT.md, \"Presets\")", 0},
        {"ckpt", GV_FLAG_STRING, &o.ckpt, "FILE", "the restorer (default " DEFAULT_CKPT_NAME ", found in $GAUSSVID_MODELS, else beside the program (../models: the source tree's " DEFAULT_CKPT "), else where make install put it (../share/gaussvid))", 0},
        {"restore-with", GV_FLAG_STRING, &x.restore_with, "MODE", "adapted (default: the checkpoint adapted to the scene, its gate deciding; where adaptation cannot run, the sparse model is kept), checkpoint (the checkpoint as it is, ungated) or none", 0},
        {"no-restore", GV_FLAG_BOOL, &x.no_restore, NULL, "the sparse model, its renders, evaluation, video and report only (--restore-with none)", 0},
        {"adapt", GV_FLAG_BOOL, &x.adapt, NULL, "--restore-with adapted (the default; kept for older scripts)", 0},
        {"iters", GV_FLAG_INT, &x.iters, "N", "sparse 3DGS iterations (default 8000; preset fast 3000, best 15000)", 0},
        {"base", GV_FLAG_STRING, &x.base, "NAME", "the sparse model, named as the paper's Table 1 names its bases: 3dgs (plain 3DGS), corgs (CoR-GS: two fields co-pruned and pulled together at cameras between the views; about 3x the time), fsgs (FSGS's unpooling, without its depth network), dropgaussian, segs (SE-GS: corgs's two fields and pseudo-view term without co-pruning, the second field perturbed where the model's pseudo views are uncertain), decay (Binocular3DGS's opacity decay), binocular (Binocular3DGS's consistency loss: the view shifted sideways, warped back with the model's depth, compared with the photo; decay,binocular is the release's method; two to three times the training's CPU, in no preset), or a comma-separated list of the last six (default: the preset's, dropgaussian,decay for fast and default, 3dgs for best and with --densify mcmc; docs/SPLAT_TRAINING.md)", 0},
        {"densify", GV_FLAG_STRING, &x.densify, "MODE", "its density control: lean (default: the reference's mean quality in half its time), reference (the paper's) or mcmc", 0},
        {"resolution-schedule", GV_FLAG_INT, &x.resolution, "K", "its first iterations at 1/K of the size, as splat train's: 1 (full size throughout; preset best), 2, 4 (default) or 8", 0},
        {"refine-iters", GV_FLAG_INT, &x.refine_iters, "N", "refinement iterations (default 1000)", 0},
        {"refine-weight", GV_FLAG_DOUBLE, &o.refine_weight, "W", "loss weight of the restored frames in the refinement, in (0, 1]; training views weigh 1 (default 0.3)", 0},
        {"adapt-steps", GV_FLAG_INT, &x.adapt_steps, "N", "the adaptation's fine-tuning steps (default 300)", 0},
        {"adapt-config", GV_FLAG_STRING, &o.adapt_options.config, "PRESET|FILE", "the network the checkpoint must be to adapt it (default small)", 0},
        {"lpips", GV_FLAG_STRING, &o.lpips, "FILE", "AlexNet-LPIPS weights (docs/LPIPS.md): add LPIPS to the evaluation", 0},
        {"fps", GV_FLAG_DOUBLE, &o.fps, "F", "frames per second of flythrough.mp4 (default 8)", 0},
        {"ffmpeg", GV_FLAG_STRING, &o.ffmpeg, "FILE", "the ffmpeg program (default: ffmpeg on the PATH)", 0},
        {"downscale", GV_FLAG_INT, &downscale, "K",
         "image downscale 1, 2, 4 or 8 (default: the smallest that brings the longer side to 512 pixels or less)", 0},
        {"seed", GV_FLAG_INT, &seed, "S", "seed of the 3DGS runs and of the restorer's noise (default 0)", 0},
        {"stop-after", GV_FLAG_STRING, &o.stop_after, "STAGE", "stop after this stage: train, render, adapt, restore, refine, evaluate or video (run again to continue)", 0},
    };
    const gv_command_spec spec = {
        "reconstruct", NULL, "sparse 3DGS, restored renders, a refined model, metrics and a video of a scene",
        "Per interval n, in DIR/nN: trains sparse 3DGS on frames 0, n, 2n, ... (sparse.ply,\n"
        "sparse.splat); renders the held-out frames between them (frames/render/, each named after\n"
        "its photo); adapts the restorer to the scene (gaussvid adapt), whose gate decides: open,\n"
        "every rendered frame is restored in 5-frame clips (clean anchors at the training views,\n"
        "three renders; frames/restored/) and the 3DGS refined on the training views and,\n"
        "down-weighted, the restored frames (refined.ply, refined.splat, frames/refined/); closed,\n"
        "or where the scene has too few training views to adapt, the renders and the sparse model\n"
        "are kept, each stage saying so in one line. Then scores sparse, restored and refined\n"
        "against the ground truth and their 3D consistency, and encodes flythrough.mp4 (ffmpeg): a\n"
        "fly-through along the training cameras (sparse | refined | nearest photo), then render |\n"
        "restored | ground truth, labelled. DIR/metrics.json has every number and decision and is\n"
        "rewritten after each stage; running the same command again skips the finished stages.\n"
        "See docs/RECONSTRUCT.md.",
        flags, sizeof flags / sizeof flags[0], 0, 0};
    int parsed = gv_args_parse(&spec, argc, argv, NULL, NULL);
    if (parsed != GV_ARGS_OK) return gv_args_exit_code(parsed);
    if (gv_interval_parse(intervals, GV_INTERVAL_RECONSTRUCT, o.intervals, GV_RECONSTRUCT_MAX_INTERVALS, &o.n_intervals) ||
        (seed < 0 && gv_fail("--seed %d: must not be negative", seed) != 0) || apply_settings(&x, &o) ||
        (downscale != -1 && downscale != 1 && downscale != 2 && downscale != 4 && downscale != 8 &&
         gv_fail("--downscale %d: expected 1, 2, 4 or 8", downscale) != 0)) {
        fprintf(stderr, "gaussvid reconstruct: %s (see 'gaussvid reconstruct --help')\n", gv_last_error());
        return 2;
    }
    if (downscale != -1) o.downscale = downscale;
    char found[4096];
    if (!o.ckpt) {
        if (default_ckpt(found, sizeof found)) return gv_report_failure();
        o.ckpt = found;
    }
    o.seed = (uint64_t)seed;
    o.on_stage = print_stage;
    o.adapt_options.train.seed = (uint64_t)seed;
    print_settings(&o);
    if (gv_reconstruct(&o)) return gv_report_failure();
    if (o.stop_after && strcmp(o.stop_after, "video")) return 0; /* stopped early: the summary is for a finished run */
    return gv_report_summary(o.out_dir, stdout) ? gv_report_failure() : 0;
}
