/* gaussvid vae train --scenes DIR... --out vae.safetensors: trains a config's VAE from scratch
 * on scene frames (docs/VAE.md). */
#include <stdio.h>
#include <string.h>

#include "cli/cmd_train.h"
#include "cli/cmd_vae.h"
#include "cli/commands.h"
#include "gaussvid/eval/eval.h"

/* "HxW" with both positive. */
static int parse_size(const char *text, int *h, int *w)
{
    char tail;
    return text && sscanf(text, "%dx%d%c", h, w, &tail) == 2 && *h > 0 && *w > 0 ? 0 : -1;
}

int cmd_vae_train(int argc, char **argv)
{
    gv_flag_list scenes = {.n = 0}, eval_scenes = {.n = 0};
    gv_vae_train_options o;
    gv_vae_train_defaults(&o);
    gv_run_cli run = {NULL, NULL, (int)o.steps, o.batch, (int)o.warmup, 0, (int)o.checkpoint_every, 0, 0, o.lr, {""}};
    const char *config = "small", *crop = "64x64";
    int downscale = 1, eval_every = 0;
    const gv_flag own[] = {
        {"scenes", GV_FLAG_LIST, &scenes, "DIR...", "scene folders to train on (COLMAP sparse/0 or transforms.json)", 1},
        {"eval-scenes", GV_FLAG_LIST, &eval_scenes, "DIR...", "scene folders of the held-out evaluation (at the last step, and every --eval-every)", 0},
        {"config", GV_FLAG_STRING, &config, "PRESET|FILE", "model config whose VAE is trained (default small)", 0},
        {"crop", GV_FLAG_STRING, &crop, "HxW", "training crop, multiples of the spatial factor (default 64x64)", 0},
        {"frames", GV_FLAG_INT, &o.frames, "N", "frames per clip, 1 + k x temporal factor (default 5)", 0},
        {"max-stride", GV_FLAG_INT, &o.max_stride, "N", "frame spacing drawn from 1..N (default 3)", 0},
        {"image-every", GV_FLAG_INT, &o.image_every, "K", "every K-th step trains on single frames (default 4; 0 never)", 0},
        {"min-lr", GV_FLAG_DOUBLE, &o.min_lr, "LR", "end of the cosine decay (default 1e-5)", 0},
        {"weight-decay", GV_FLAG_DOUBLE, &o.weight_decay, "W", "AdamW weight decay (default 0)", 0},
        {"l2-weight", GV_FLAG_DOUBLE, &o.l2_weight, "W", "weight of the squared error beside L1 (default 1)", 0},
        {"kl-weight", GV_FLAG_DOUBLE, &o.kl_weight, "W", "weight of the KL term (default 1e-6; 0: no sampling)", 0},
        {"eval-every", GV_FLAG_INT, &eval_every, "N", "steps between held-out evaluations (needs --eval-scenes)", 0},
        {"eval-clips", GV_FLAG_INT, &o.eval_clips, "N", "held-out clips per scene and evaluation (default 4)", 0},
        {"stats-clips", GV_FLAG_INT, &o.stats_clips, "N", "clips for the latent mean/std (default 64)", 0},
        {"downscale", GV_FLAG_INT, &downscale, "K", "image downscale 1, 2, 4 or 8 (default 1)", 0},
    };
    gv_flag flags[sizeof own / sizeof own[0] + GV_RUN_CLI_FLAGS];
    int n_flags = gv_run_cli_flags(&run, "the weights (.safetensors); the checkpoint is FILE.ckpt", own,
                                   sizeof own / sizeof own[0], flags);
    const gv_command_spec spec = {
        "vae train", NULL, "train the VAE of a config on scene frames",
        "Each step draws random crops of clips (frame spacing 1..--max-stride, mirrored and\n"
        "reversed at random); loss = L1 + l2-weight * L2 on pixels + kl-weight * KL (sum over\n"
        "latent values per pixel value). AdamW, warm-up then cosine decay, gradient norm clipped\n"
        "to 1. The weights and the checkpoint FILE.ckpt are written every --checkpoint-every\n"
        "steps; --resume continues from the checkpoint (same options give the same steps). At the\n"
        "end the latent per-channel mean and std are computed on training clips and stored in the\n"
        "weights' metadata. Single-threaded runs are often faster on a busy machine\n"
        "(--threads 1). See docs/VAE.md.",
        flags, n_flags, 0, 0};
    int parsed = gv_args_parse(&spec, argc, argv, NULL, NULL);
    if (parsed != GV_ARGS_OK) return gv_args_exit_code(parsed);
    if (gv_run_cli_check(&run, "vae train")) return 2;
    if (parse_size(crop, &o.crop_h, &o.crop_w) || eval_every < 0) {
        fprintf(stderr, "gaussvid vae train: --crop needs HxW; --eval-every must not be negative\n");
        return 2;
    }
    if (eval_every > 0 && eval_scenes.n == 0) {
        fprintf(stderr, "gaussvid vae train: --eval-every needs --eval-scenes\n");
        return 2;
    }
    o.steps = run.steps, o.batch = run.batch, o.lr = run.lr, o.warmup = run.warmup, o.seed = (uint64_t)run.seed;
    o.checkpoint_every = run.checkpoint_every, o.stop_after = run.stop_after, o.resume = run.resume;
    o.out = run.out, o.log_path = run.log, o.config_spec = config;
    o.eval_every = eval_every, o.evaluate = gv_vae_evaluate;

    gv_model_config c;
    if (gv_model_config_load(&c, config)) return gv_report_failure();
    gv_vae_frames train, eval;
    memset(&eval, 0, sizeof eval);
    if (gv_vae_frames_load(&train, scenes.items, scenes.n, downscale)) return gv_report_failure();
    if (eval_scenes.n && gv_vae_frames_load(&eval, eval_scenes.items, eval_scenes.n, downscale)) {
        gv_vae_frames_free(&train);
        return gv_report_failure();
    }
    gv_info("vae train: %s VAE, %lld frames of %d scene(s), %ld steps of %d x %d-frame %dx%d crops", c.name,
            (long long)train.total_frames, train.n, o.steps, o.batch, o.frames, o.crop_w, o.crop_h);
    double start = gv_now();
    int rc = gv_vae_train(&c, &train, eval_scenes.n ? &eval : NULL, &o);
    gv_vae_frames_free(&train);
    gv_vae_frames_free(&eval);
    if (rc) return gv_report_failure();
    if (o.stop_after > 0 && o.stop_after < o.steps)
        printf("%s: %s VAE trained to step %ld of %ld (%.1f s this run); continue with --resume\n", o.out, c.name,
               o.stop_after, o.steps, gv_now() - start);
    else
        printf("%s: %s VAE trained for %ld steps (%.1f s this run), latent statistics stored\n", o.out, c.name, o.steps,
               gv_now() - start);
    return 0;
}
