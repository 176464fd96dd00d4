/* gaussvid splat train --scene DIR --out model.ply: sparse-view 3DGS training on frames
 * 0, n, 2n, ... of a scene (docs/SPLAT_TRAINING.md). */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>

#include "cli/commands.h"
#include "gaussvid/core/core.h"
#include "gaussvid/io/ply.h"
#include "gaussvid/scene/scene.h"
#include "gaussvid/splat/splat_train.h"

/* Pixels of the training views (frames 0, n, 2n, ...); 0 when the split fails (training
 * then reports why). */
static long training_pixels(const gv_scene *scene, int interval)
{
    int n = scene->n_frames, n_train = 0, n_held_out = 0;
    int *train = malloc((size_t)(n > 0 ? n : 1) * sizeof(int));
    int *held_out = malloc((size_t)(n > 0 ? n : 1) * sizeof(int));
    long pixels = 0;
    if (train && held_out && gv_scene_split(n, interval, train, &n_train, held_out, &n_held_out) == 0)
        for (int i = 0; i < n_train; i++)
            pixels += (long)scene->cameras[train[i]].width * scene->cameras[train[i]].height;
    free(train), free(held_out);
    return pixels;
}

int cmd_splat_train(int argc, char **argv)
{
    const char *scene_dir = NULL, *out = NULL;
    int interval = 1, iterations = 30000, downscale = 1, sh_degree = 3, seed = 0;
    double grad_threshold = 0, per_pixel = 0, regularizer = 0.01, fsgs_distance = 0.1,
           corgs_distance = 0.05, corgs_pseudo = 1.0;
    const char *densify = "lean", *regularize = NULL; /* NULL: the user's, GV_REGULARIZE_USER */
    gv_splat_train_options opt;
    gv_splat_train_defaults(&opt);
    int white_bg = 0, random_bg = 0, sparse_adam = 0, max_gaussians = 0, segs_interval = 500,
        resolution_start = 0; /* 0: not given, GV_RESOLUTION_USER as the views allow */
    double resolution_full_at = 0; /* 0: not given (the schedule's 0.5) */
    double binocular_from = NAN, binocular_baseline = NAN; /* NAN: not given */
    const gv_flag flags[] = {
        {"scene", GV_FLAG_STRING, &scene_dir, "DIR", "scene folder (COLMAP sparse/0 or transforms.json)", 1},
        {"out", GV_FLAG_STRING, &out, "FILE.ply", "the trained model (3DGS .ply)", 1},
        {"interval", GV_FLAG_INT, &interval, "N", "train on frames 0, N, 2N, ... (default 1: all)", 0},
        {"iters", GV_FLAG_INT, &iterations, "N", "iterations (default 30000; 8000 = the early stop)", 0},
        {"downscale", GV_FLAG_INT, &downscale, "K", "image downscale 1, 2, 4 or 8 (default 1)", 0},
        {"sh-degree", GV_FLAG_INT, &sh_degree, "D", "largest SH degree 0..3 (default 3)", 0},
        {"seed", GV_FLAG_INT, &seed, "S", "random seed (default 0)", 0},
        {"white-bg", GV_FLAG_BOOL, &white_bg, NULL, "white background (default black)", 0},
        {"random-bg", GV_FLAG_BOOL, &random_bg, NULL, "a random background colour per iteration", 0},
        {"sparse-adam", GV_FLAG_BOOL, &sparse_adam, NULL,
         "lean and reference: Adam on the visible Gaussians only (default: all; mcmc steps all)", 0},
        {"densify", GV_FLAG_STRING, &densify, "MODE", "lean (default), reference or mcmc", 0},
        {"regularize", GV_FLAG_STRING, &regularize, "NAME[,NAME]", "sparse-view regularisers: dropgaussian,decay (default), none (plain 3DGS), fsgs, corgs, segs, binocular", 0},
        {"corgs-distance", GV_FLAG_DOUBLE, &corgs_distance, "X", "corgs: co-prune Gaussians without a counterpart within X x the scene extent (default 0.05)", 0},
        {"corgs-pseudo", GV_FLAG_DOUBLE, &corgs_pseudo, "W", "corgs, segs: weight of the two fields' pseudo-view term (default 1; 0: off)", 0},
        {"segs-interval", GV_FLAG_INT, &segs_interval, "N", "segs: iterations between the pseudo-view renders that decide the perturbation (default 500)", 0},
        {"decay-factor", GV_FLAG_DOUBLE, &opt.decay_factor, "F", "decay: the opacities' factor per iteration (default 0.995)", 0},
        {"decay-until", GV_FLAG_DOUBLE, &opt.decay_until, "S", "decay: only up to this share of the iterations, in (0, 1] (default 0.5; 1: to the end)", 0},
        {"drop-rate", GV_FLAG_DOUBLE, &opt.drop_rate, "R", "dropgaussian: the share left out at the last iteration, in [0, 1) (default 0.1)", 0},
        {"binocular-from", GV_FLAG_DOUBLE, &binocular_from, "S", "binocular: the consistency loss after this share of the iterations, in [0, 1) (default 0.667: the release's 20000 of 30000)", 0},
        {"binocular-baseline", GV_FLAG_DOUBLE, &binocular_baseline, "X", "binocular: the largest sideways shift of the camera, X x the initial Gaussians' median depth in the training views (default 0.015)", 0},
        {"fsgs-distance", GV_FLAG_DOUBLE, &fsgs_distance, "X", "fsgs: unpool where the proximity score exceeds X x the scene extent (default 0.1)", 0},
        {"max-gaussians", GV_FLAG_INT, &max_gaussians, "N", "mcmc: the budget (default: --per-pixel x training pixels)", 0},
        {"per-pixel", GV_FLAG_DOUBLE, &per_pixel, "X", "mcmc: budget per training pixel (default 0.02)", 0},
        {"regularizer", GV_FLAG_DOUBLE, &regularizer, "X", "mcmc: weight of the opacity and scale L1 terms (default 0.01)", 0},
        {"grad-threshold", GV_FLAG_DOUBLE, &grad_threshold, "X", "lean and reference: densify threshold (default 0.0004 and 0.0002)", 0},
        {"resolution-schedule", GV_FLAG_INT, &resolution_start, "K", "train the first iterations at 1/K of the size, K = 2, 4 or 8, doubling to full; 1: full size throughout (default 4)", 0},
        {"resolution-full-at", GV_FLAG_DOUBLE, &resolution_full_at, "F", "with --resolution-schedule: full resolution from this share of the iterations (default 0.5)", 0},
    };
    const gv_command_spec spec = {
        "splat train", NULL, "train 3D Gaussian Splatting on the sparse split of a scene",
        "Trains on frames 0, N, 2N, ... (N = --interval): initialisation from the scene's\n"
        "points, Adam with the reference learning rates, one more SH degree every 1000\n"
        "iterations, loss 0.8 L1 + 0.2 (1 - SSIM). Density control (--densify):\n"
        "  lean       (default) the reference's at twice its gradient threshold: a third\n"
        "             of the Gaussians at 256x144, 1.9x faster; the same held-out PSNR on\n"
        "             average, 0.001 lower SSIM\n"
        "  reference  the paper's: clone/split/prune from iteration 500 to 15000 every\n"
        "             100, opacity reset every 3000 (what `dataset build` trains)\n"
        "  mcmc       a budget of --per-pixel Gaussians per training pixel; transparent\n"
        "             Gaussians are relocated onto opaque ones, the count grows by 5 % every\n"
        "             100 iterations from 500 until the budget (3DGS as MCMC): about 2.6x\n"
        "             faster, better held out on some scenes, worse on others\n"
        "Sparse-view regularisers (--regularize; none = plain 3DGS). The default,\n"
        "dropgaussian,decay, with the default resolution schedule, gave at 8000 iterations\n"
        "+0.57 dB held-out PSNR over plain 3DGS on average over 15 scenes and sparsities,\n"
        "+0.98 dB at n = 26, no cell more than 0.08 dB below (docs/RESULTS.md); with\n"
        "--densify mcmc the default is none:\n"
        "  decay      Binocular3DGS's opacity decay: from iteration 500 to --decay-until\n"
        "             x N (default half the run) every opacity is multiplied by\n"
        "             --decay-factor each iteration, the density control runs to the\n"
        "             end, with no opacity reset and no screen-size pruning (lean,\n"
        "             reference)\n"
        "  dropgaussian  each training render leaves out a random share of the Gaussians\n"
        "             (0 growing linearly to --drop-rate, default 0.1, at the last\n"
        "             iteration) and scales the opacity of the others by 1 / (1 - share);\n"
        "             renders are unchanged\n"
        "  fsgs       FSGS's unpooling: at each densification step, a Gaussian whose 3\n"
        "             nearest are far (root mean square distance > --fsgs-distance x\n"
        "             extent, up to 10 times that) gets a new one at the midpoint to each\n"
        "             (lean, reference)\n"
        "  corgs      CoR-GS's co-pruning: a second field trains alongside (twice the\n"
        "             time); at each densification step the Gaussians of either with no\n"
        "             counterpart in the other within --corgs-distance x extent are\n"
        "             pruned (lean, reference); the first field is the model; from\n"
        "             iteration 500 the two fields' renders at a camera between two\n"
        "             training views are pulled together (--corgs-pseudo)\n"
        "  segs       SE-GS's self-ensembling: the same second field and pseudo-view\n"
        "             term (twice to four times the time); every --segs-interval\n"
        "             iterations the model is rendered at 24 pseudo views near the\n"
        "             training cameras, and the second field's Gaussians covering the\n"
        "             pixels where its last 3 renders disagree most get random noise\n"
        "             (position, opacity, scale, rotation; ratio 0.08 down to 0.02), so\n"
        "             the model is pulled towards an ensemble of perturbed fields; with\n"
        "             corgs too, co-pruning as well (the SE-GS release's configuration)\n"
        "  binocular  Binocular3DGS's consistency loss: after --binocular-from x N\n"
        "             iterations, each training view is also rendered from the camera\n"
        "             moved sideways by a random baseline (up to --binocular-baseline x\n"
        "             the initial median depth), warped back with the disparity of the\n"
        "             model's own depth, and compared with the photo (L1, plus 0.05 x an\n"
        "             edge-aware smoothness of the disparity); the gradient reaches the\n"
        "             shifted render and the depth. decay,binocular is the release's full\n"
        "             method. About three times the time per iteration while it runs.\n"
        "             Not in the default; measured only as decay,binocular at full size:\n"
        "             0.18 and 0.37 dB below the default on courtyard n = 26 and\n"
        "             livingroom n = 6 (one seed each)\n"
        "--iters N stops the schedule early (nothing is rescaled; the drop share\n"
        "follows --iters).\n"
        "Resolution scheduling (--resolution-schedule K, after DashGaussian): iterations\n"
        "up to F x N (F = --resolution-full-at, default 0.5) render the training views at\n"
        "1/K, 1/(K/2), ... in equal steps (cameras with the intrinsics divided, targets\n"
        "box-filtered), then at full size: K = 4 (the default), 8000 iterations: 1/4 to\n"
        "2000, 1/2 to 4000, full after; about a third less time at the same held-out\n"
        "quality with the default regularisers. --resolution-schedule 1: full size\n"
        "throughout.\n"
        "The last line gives the Gaussian count and the Gaussians per training pixel.\n"
        "Same seed, inputs and --threads give the same model. See docs/SPLAT_TRAINING.md.",
        flags, sizeof flags / sizeof flags[0], 0, 0};
    int parsed = gv_args_parse(&spec, argc, argv, NULL, NULL);
    if (parsed != GV_ARGS_OK) return gv_args_exit_code(parsed);
    if (white_bg && random_bg) {
        fprintf(stderr, "gaussvid splat train: --white-bg and --random-bg exclude each other\n");
        return 2;
    }
    if (seed < 0) {
        fprintf(stderr, "gaussvid splat train: --seed must be non-negative\n");
        return 2;
    }

    opt.iterations = iterations;
    opt.sh_degree = sh_degree;
    opt.seed = (uint64_t)seed;
    opt.background = white_bg ? GV_BG_WHITE : random_bg ? GV_BG_RANDOM : GV_BG_BLACK;
    opt.sparse_adam = sparse_adam;
    int mode = gv_splat_densify_mode_parse(densify);
    if (mode < 0) {
        fprintf(stderr, "gaussvid splat train: --densify %s: expected " GV_DENSIFY_MODE_NAMES "\n", densify);
        return 2;
    }
    if (!(corgs_pseudo >= 0)) {
        fprintf(stderr, "gaussvid splat train: --corgs-pseudo must be 0 or more\n");
        return 2;
    }
    if (segs_interval < 1) {
        fprintf(stderr, "gaussvid splat train: --segs-interval must be at least 1\n");
        return 2;
    }
    if (!(opt.decay_factor > 0 && opt.decay_factor < 1) || !(opt.decay_until > 0 && opt.decay_until <= 1)) {
        fprintf(stderr, "gaussvid splat train: --decay-factor must be in (0, 1) and --decay-until in (0, 1]\n");
        return 2;
    }
    if (!(opt.drop_rate >= 0 && opt.drop_rate < 1)) {
        fprintf(stderr, "gaussvid splat train: --drop-rate must be in [0, 1)\n");
        return 2;
    }
    if (!isnan(binocular_from)) opt.binocular_from = binocular_from;
    if (!isnan(binocular_baseline)) opt.binocular_baseline = binocular_baseline;
    if (!(opt.binocular_from >= 0 && opt.binocular_from < 1) || !(opt.binocular_baseline > 0 && opt.binocular_baseline < 1)) {
        fprintf(stderr, "gaussvid splat train: --binocular-from must be in [0, 1) and --binocular-baseline in (0, 1)\n");
        return 2;
    }
    if (!(fsgs_distance > 0) || !(corgs_distance > 0)) {
        fprintf(stderr, "gaussvid splat train: --fsgs-distance and --corgs-distance must be positive\n");
        return 2;
    }
    if (max_gaussians < 0 || per_pixel < 0 || regularizer < 0 || grad_threshold < 0) {
        fprintf(stderr, "gaussvid splat train: --max-gaussians, --per-pixel, --regularizer and --grad-threshold "
                        "must be non-negative\n");
        return 2;
    }
    if (resolution_full_at != 0 && resolution_start == 1) {
        fprintf(stderr, "gaussvid splat train: --resolution-full-at needs a resolution schedule, not "
                        "--resolution-schedule 1\n");
        return 2;
    }
    if (resolution_full_at == 0) resolution_full_at = 0.5;
    if ((resolution_start != 0 && resolution_start != 1 && resolution_start != 2 && resolution_start != 4 && resolution_start != 8) ||
        !(resolution_full_at > 0 && resolution_full_at <= 1)) {
        fprintf(stderr, "gaussvid splat train: --resolution-schedule takes 1 (off), 2, 4 or 8 and "
                        "--resolution-full-at a share in (0, 1]\n");
        return 2;
    }
    opt.resolution_start = resolution_start;
    opt.resolution_full_at = resolution_full_at;
    opt.densify_mode = (gv_splat_densify_mode)mode;
    opt.regularize = regularize ? gv_splat_regularize_parse(regularize) : gv_splat_regularize_default(opt.densify_mode);
    if (opt.regularize < 0) {
        fprintf(stderr, "gaussvid splat train: --regularize %s: expected " GV_REGULARIZE_NAMES "\n", regularize);
        return 2;
    }
    if ((!isnan(binocular_from) || !isnan(binocular_baseline)) && !(opt.regularize & GV_REGULARIZE_BINOCULAR)) {
        fprintf(stderr, "gaussvid splat train: --binocular-from and --binocular-baseline need binocular in --regularize\n");
        return 2;
    }
    opt.mcmc.cap = max_gaussians;
    opt.mcmc.opacity_reg = opt.mcmc.scale_reg = regularizer;
    if (per_pixel > 0) opt.gaussians_per_pixel = per_pixel;
    opt.densify.grad_threshold = grad_threshold; /* 0: the mode's */
    opt.fsgs_distance = fsgs_distance;
    opt.corgs_distance = corgs_distance;
    opt.corgs_pseudo_weight = corgs_pseudo;
    opt.segs_interval = segs_interval;
    opt.progress_label = "train";
    gv_scene_options so = {.downscale = downscale, .white_background = white_bg};
    gv_scene scene;
    if (gv_scene_load(scene_dir, &so, &scene) != 0) return gv_report_failure();
    if (resolution_start == 0)
        opt.resolution_start = gv_splat_resolution_fit(GV_RESOLUTION_USER, scene.cameras, scene.n_frames);
    long pixels = training_pixels(&scene, interval);
    gv_gaussians model;
    double start = gv_now();
    gv_atomic_sweep_beside(out); /* a killed run's temporary (the run starts again) */
    if (gv_splat_train(&scene, interval, &opt, &model) != 0) {
        gv_scene_free(&scene);
        return gv_report_failure();
    }
    gv_scene_free(&scene);
    int written = gv_gaussians_write_ply(out, &model);
    if (written == 0)
        printf("%s: %d Gaussians, SH degree %d, %d iterations in %.1f s, %.3f Gaussians per "
               "training pixel\n", out, model.n, model.sh_degree, iterations, gv_now() - start,
               pixels > 0 ? model.n / (double)pixels : 0.0);
    gv_gaussians_free(&model);
    return written == 0 ? 0 : gv_report_failure();
}
