/* gaussvid adapt --scene DIR --interval n --base CKPT --out SCENE_CKPT: adapts the restorer to
 * one scene from the scene's own internal pairs, keeping the best step and deciding by the
 * held-back pairs whether to restore at all (the gate). docs/ADAPT.md. */
#include <stdio.h>
#include <string.h>

#include "cli/commands.h"
#include "gaussvid/restore/adapt.h"
#include "gaussvid/core/core.h"
#include "gaussvid/splat/splat_train.h"

/* Why the gate is closed, when it is. */
static const char *closed_because(const gv_scene_adaptation *a)
{
    if (gv_scene_gate_change(a) <= a->gate_margin_db) return "the held-back pairs do not gain";
    if (a->gate_frames < a->gate_min_frames) return "too few held-back frames to trust (at least --gate-min-frames)";
    return "the restorer harms nearly clean renders (the do-no-harm clips, --harm-max-loss)";
}

static void print_summary(const char *out, const gv_adapt_report *r)
{
    const gv_scene_adaptation *a = &r->adaptation;
    printf("%s: %s n=%d: %d internal clips trained on, %d held back; step %ld kept (held-back %s %+.3f dB)\n",
           out, a->scene, a->interval, a->train_clips, a->held_back, a->best_step,
           a->best_by[0] ? a->best_by : "latent gain", a->val_gain_db);
    printf("held-back pairs: %.2f dB / %.4f as rendered, %.2f dB / %.4f restored (%+.2f dB over %d frames, margin "
           "%+.2f dB)\n", a->gate_psnr_base, a->gate_ssim_base, a->gate_psnr_restored, a->gate_ssim_restored,
           gv_scene_gate_change(a), a->gate_frames, a->gate_margin_db);
    if (a->harm_frames > 0 && gv_scene_harm_rules(a))
        printf("their do-no-harm clips: %.2f dB / %.4f as rendered, %.2f dB / %.4f restored (%+.2f dB over %d frames, "
               "at most -%.2f dB allowed)\n", a->harm_psnr_base, a->harm_ssim_base, a->harm_psnr_restored,
               a->harm_ssim_restored, gv_scene_harm_change(a), a->harm_frames, a->harm_max_loss_db);
    else if (a->harm_frames > 0)
        printf("their do-no-harm clips: %.2f dB / %.4f as rendered, %.2f dB / %.4f restored (%+.2f dB over %d frames; "
               "not a test of the unseen composition, which changes only pixels no anchor sees)\n", a->harm_psnr_base,
               a->harm_ssim_base, a->harm_psnr_restored, a->harm_ssim_restored, gv_scene_harm_change(a), a->harm_frames);
    if (a->gate_open) printf("gate open: restore and eval will restore this scene's renders\n");
    else printf("gate closed: %s; restore and eval will leave this scene's renders unchanged\n", closed_because(a));
    if (!r->already)
        printf("seconds: pairs %.1f, latents %.1f, fine-tuning %.1f, gate %.1f\n", a->seconds_pairs, a->seconds_latents,
               a->seconds_train, a->seconds_gate);
}

int cmd_adapt(int argc, char **argv)
{
    gv_adapt_options o;
    gv_adapt_defaults(&o);
    const char *schedule = gv_lr_kind_name(o.train.lr_schedule), *crop = NULL, *sampler = GV_SAMPLER_DEFAULT,
               *compose = gv_compose_name(o.compose), *early_stop = NULL, *densify = NULL;
    int steps = (int)o.train.steps, val_every = (int)o.train.val_every, stop_after = 0, seed = 0;
    const gv_flag flags[] = {
        {"scene", GV_FLAG_STRING, &o.scene_dir, "DIR", "the scene folder (COLMAP sparse/0 or transforms.json)", 1},
        {"interval", GV_FLAG_INT, &o.interval, "N", "its training views are frames 0, N, 2N, ...: the renders to restore are of this n (n >= 2)", 1},
        {"base", GV_FLAG_STRING, &o.base, "FILE", "the cross-scene checkpoint to adapt (e.g. models/gaussvid-small.safetensors)", 1},
        {"out", GV_FLAG_STRING, &o.out, "FILE", "the scene checkpoint (adapters and gate); FILE.work keeps the work", 1},
        {"work", GV_FLAG_STRING, &o.work_dir, "DIR", "the work folder (default FILE.work): internal pairs, latents, resumable training", 0},
        {"config", GV_FLAG_STRING, &o.config, "PRESET|FILE", "the network the base must be (default small)", 0},
        {"variant", GV_FLAG_STRING, &o.variant, "V",
         "a variant over the base's: residual,coverage (default: the output relearned from zero, so the adaptation "
         "starts at the identity, and the anchors' coverage in VACE's mask), residual, or base (the base's own "
         "output); docs/TRAINING.md", 0},
        {"fresh-camera", GV_FLAG_BOOL, &o.fresh_camera, NULL, "start the camera encoder from its initialisation, not the base's", 0},
        {"iters", GV_FLAG_INT, &o.iters, "N", "3DGS iterations of each internal subset model (default 8000, as dataset build)", 0},
        {"subsets", GV_FLAG_INT, &o.subsets, "K",
         "subsets of the training views for the internal pairs, each leaving out every K-th view: 2 (default, two "
         "3DGS runs) leaves every other view out; K at least the training views (e.g. 99) leaves each interior view out "
         "alone (a run per view)", 0},
        {"densify", GV_FLAG_STRING, &densify, "MODE",
         "their density control, as the scene's sparse model was trained: reference (default), lean or mcmc", 0},
        {"downscale", GV_FLAG_INT, &o.downscale, "K", "image downscale 1, 2, 4 or 8 (default 1)", 0},
        {"hold-every", GV_FLAG_INT, &o.hold_every, "K", "hold back internal clips 1, 1 + K, 1 + 2K, ... for validation (default 3)", 0},
        {"steps", GV_FLAG_INT, &steps, "N", "fine-tuning steps (default 300)", 0},
        {"batch", GV_FLAG_INT, &o.train.batch, "B", "clips per step (default 2)", 0},
        {"lr", GV_FLAG_DOUBLE, &o.train.lr, "LR", "AdamW learning rate at the start (default 1e-3)", 0},
        {"lr-schedule", GV_FLAG_STRING, &schedule, "NAME", "linear (default) or cosine decay to 0, or constant", 0},
        {"t-max", GV_FLAG_DOUBLE, &o.train.t_max, "T", "timesteps t ~ U[0, T] (default 0.1)", 0},
        {"crop", GV_FLAG_STRING, &crop, "RxC", "train on random windows of R x C tokens (default: whole clips)", 0},
        {"val-every", GV_FLAG_INT, &val_every, "K", "validate on the held-back clips every K steps (default 50)", 0},
        {"gate-margin", GV_FLAG_DOUBLE, &o.gate_margin_db, "DB", "restore only when the held-back PSNR gains more than DB (default 0)", 0},
        {"gate-min-frames", GV_FLAG_INT, &o.gate_min_frames, "K",
         "... measured on at least K held-back frames (default 2; fewer is too little evidence)", 0},
        {"harm-train", GV_FLAG_BOOL, &o.harm_train, NULL,
         "fine-tune and validate on the do-no-harm clips too (nearly clean renders the adapters must leave alone)", 0},
        {"harm-max-loss", GV_FLAG_DOUBLE, &o.harm_max_loss_db, "DB",
         "... and the do-no-harm clips (nearly clean renders) lose less than DB (default 0.05)", 0},
        {"sampler", GV_FLAG_STRING, &sampler, "NAME", "the sampler the gate restores with (default " GV_SAMPLER_DEFAULT ", restore's)", 0},
        {"early-stop", GV_FLAG_STRING, &early_stop, "BY",
         "choose the step by the held-back pairs' latent gain (latent) or their PSNR change restored as the gate "
         "restores (psnr; a gate pass per validation); default latent", 0},
        {"compose", GV_FLAG_STRING, &compose, "MODE",
         "the composition the gate restores with, recorded for restore: unseen (default), residual or decoded", 0},
        {"seed", GV_FLAG_INT, &seed, "S", "seed of the internal 3DGS runs and the fine-tuning (default 0)", 0},
        {"stop-after", GV_FLAG_INT, &stop_after, "N", "stop the fine-tuning after step N (run again to continue)", 0},
    };
    const gv_command_spec spec = {
        "adapt", NULL, "adapt the restorer to one scene from its own training views",
        "Builds the scene's internal pairs (sparse 3DGS on every other training view, rendered at\n"
        "the views it left out: corrupted frames with known ground truth, docs/FORMATS-DATASET.md),\n"
        "holds back a third of them, fine-tunes the base's adapters (LoRA, camera encoder) on the\n"
        "rest with a learning rate decaying to 0, keeps the step the held-back pairs liked best,\n"
        "then restores the held-back pairs as 'restore' would: the gate opens only when they gain\n"
        "and when the same views rendered by the model of every training view (nearly clean: the\n"
        "do-no-harm clips) do not get worse.\n"
        "The scene checkpoint holds the adapters and the gate; 'restore' and 'eval' use it with\n"
        "--ckpt and leave the renders unchanged when the gate is closed. Run again to resume.\n"
        "See docs/ADAPT.md.",
        flags, sizeof flags / sizeof flags[0], 0, 0};
    int parsed = gv_args_parse(&spec, argc, argv, NULL, NULL);
    if (parsed != GV_ARGS_OK) return gv_args_exit_code(parsed);
    if (steps < 1 || o.train.batch < 1 || val_every < 1 || stop_after < 0 || seed < 0 ||
        o.iters < 1 || o.subsets < 2 || o.hold_every < 2 || o.gate_min_frames < 1 || !(o.train.lr > 0) || !(o.train.t_max > 0 && o.train.t_max <= 1) ||
        !(o.harm_max_loss_db >= 0)) {
        fprintf(stderr, "gaussvid adapt: --subsets and --hold-every K >= 2; --steps, --batch, --iters, "
                        "--val-every, --gate-min-frames and --lr must be positive, --t-max in (0, 1], --seed, --stop-after and "
                        "--harm-max-loss not negative\n");
        return 2;
    }
    if (gv_interval_check(o.interval, 0, GV_INTERVAL_CLIPS)) {
        fprintf(stderr, "gaussvid adapt: --interval: %s\n", gv_last_error());
        return 2;
    }
    if (gv_lr_kind_from_name(schedule, &o.train.lr_schedule) ||
        gv_sampler_configure(sampler, 0, 0, 0, 0, 0, 0, &o.sampler) || gv_compose_from_name(compose, &o.compose)) {
        fprintf(stderr, "gaussvid adapt: %s\n", gv_last_error());
        return 2;
    }
    if (early_stop && strcmp(early_stop, "latent") && strcmp(early_stop, "psnr")) {
        fprintf(stderr, "gaussvid adapt: --early-stop %s: expected latent or psnr\n", early_stop);
        return 2;
    }
    if (early_stop) o.early_stop_psnr = !strcmp(early_stop, "psnr");
    if (densify && (o.densify = gv_splat_densify_mode_parse(densify)) < 0) {
        fprintf(stderr, "gaussvid adapt: --densify %s: expected " GV_DENSIFY_MODE_NAMES "\n", densify);
        return 2;
    }
    if (crop && gv_parse_crop("adapt", crop, &o.train.crop_h, &o.train.crop_w)) return 2;
    o.train.steps = steps, o.train.val_every = val_every, o.train.stop_after = stop_after;
    o.train.seed = (uint64_t)seed;
    o.train.fresh_camera = o.fresh_camera; /* recorded in the training options */
    o.train.min_lr = o.train.lr_schedule == GV_LR_CONSTANT ? o.train.lr : 0.0;

    gv_adapt_report r;
    if (gv_adapt_scene(&o, &r)) return gv_report_failure();
    if (!r.done) {
        printf("%s: fine-tuning stopped at step %ld of %ld; run the same command to continue (work in %s)\n", o.out,
               r.train.end_step, o.train.steps, r.work_dir);
        return 0;
    }
    if (r.already) printf("%s: already adapted (remove it to adapt again; the work in %s is reused)\n", o.out, r.work_dir);
    print_summary(o.out, &r);
    return 0;
}
