/* gaussvid splat train --scene DIR --out model.ply: sparse-view 3DGS training on frames
 * 0, n, 2n, ... of a scene (docs/SPLAT_TRAINING.md). */
#include <stdio.h>

#include "cli/commands.h"
#include "gaussvid/core.h"
#include "gaussvid/ply.h"
#include "gaussvid/scene.h"
#include "gaussvid/splat_train.h"

int cmd_splat_train(int argc, char **argv)
{
    const char *scene_dir = NULL, *out = NULL;
    int interval = 1, iterations = 30000, downscale = 1, sh_degree = 3, seed = 0;
    int white_bg = 0, random_bg = 0, sparse_adam = 0;
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
         "Adam on the Gaussians visible in the view only (default: all, as the reference)", 0},
    };
    const gv_command_spec spec = {
        "splat train", NULL, "train 3D Gaussian Splatting on the sparse split of a scene",
        "Trains on frames 0, N, 2N, ... (N = --interval) with the reference 3DGS recipe:\n"
        "initialisation from the scene's points, Adam with the reference learning rates,\n"
        "clone/split/prune from iteration 500 to 15000 every 100, opacity reset every 3000,\n"
        "one more SH degree every 1000 iterations, loss 0.8 L1 + 0.2 (1 - SSIM).\n"
        "--iters N stops the reference schedule early (nothing is rescaled).\n"
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

    gv_splat_train_options opt;
    gv_splat_train_defaults(&opt);
    opt.iterations = iterations;
    opt.sh_degree = sh_degree;
    opt.seed = (uint64_t)seed;
    opt.background = white_bg ? GV_BG_WHITE : random_bg ? GV_BG_RANDOM : GV_BG_BLACK;
    opt.sparse_adam = sparse_adam;
    opt.progress_label = "train";
    gv_scene_options so = {.downscale = downscale, .white_background = white_bg};
    gv_scene scene;
    if (gv_scene_load(scene_dir, &so, &scene) != 0) return gv_report_failure();
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
        printf("%s: %d Gaussians, SH degree %d, %d iterations in %.1f s\n", out, model.n,
               model.sh_degree, iterations, gv_now() - start);
    gv_gaussians_free(&model);
    return written == 0 ? 0 : gv_report_failure();
}
