/* gaussvid train --clips DIR --base base.safetensors --out ckpt.safetensors: GaussVid
 * fine-tuning (paper 3.4; DESIGN 7): flow matching anchored at the corrupted latent, the
 * progressive latent loss and the difficulty curriculum; LoRA and the full camera encoder
 * trained, the base frozen. Flags switch each part off for the ablations (docs/TRAINING.md). */
#include <stdio.h>
#include <string.h>

#include "cli/commands.h"
#include "gaussvid/core.h"
#include "gaussvid/train.h"

/* The run's config: the base's, or --config (which must build the same network), then
 * --variant. Returns 0, 1 (failure, message set) or 2 (usage). */
static int run_config(const char *base, const char *config, const char *variant, gv_model_config *cfg,
                      gv_train_state *base_state)
{
    gv_model_config base_cfg;
    if (gv_checkpoint_read_info(base, &base_cfg, base_state)) return 1;
    *cfg = base_cfg;
    if (config) {
        char have[160], want[160];
        if (gv_model_config_load(cfg, config)) return 1;
        if (!gv_config_same_network(&base_cfg, cfg)) {
            gv_config_describe(&base_cfg, have, sizeof have);
            gv_config_describe(cfg, want, sizeof want);
            gv_fail("%s: the base is another network (%s) than --config %s (%s)", base, have, config, want);
            return 1;
        }
    }
    if (variant && gv_model_config_set_variant(cfg, variant, "--variant")) {
        fprintf(stderr, "gaussvid train: %s\n", gv_last_error());
        return 2;
    }
    return 0;
}

/* The network to fine-tune: fresh adapters and camera encoder, the base's weights loaded. */
static int build_model(const char *base, const gv_model_config *cfg, uint64_t seed, int fresh_camera, gv_dit *m)
{
    int camera_loaded = 0;
    if (gv_dit_init(m, cfg, seed) || gv_checkpoint_load_base(base, m, !fresh_camera, &camera_loaded) ||
        gv_dit_set_train_mode(m, GV_DIT_FINETUNE))
        return -1;
    if (gv_params_count(&m->params, 1) == 0)
        return gv_fail("%s: nothing to train in this variant (no LoRA adapters, no camera encoder)", cfg->name);
    if (cfg->variant.camera != GV_CAMERA_NONE)
        gv_info("train: camera encoder %s", camera_loaded ? "continued from the base" : "trained from its fresh start");
    return 0;
}

int cmd_train(int argc, char **argv)
{
    gv_train_options o;
    gv_train_defaults(&o, GV_OBJECTIVE_FINETUNE);
    const char *clips = NULL, *base = NULL, *config = NULL, *vae = NULL, *variant = NULL, *out = NULL, *log = NULL;
    const char *val_clips = NULL, *val_log = NULL, *crop = NULL, *schedule = "constant";
    int steps = (int)o.steps, warmup = 0, seed = 0, ckpt = (int)o.checkpoint_every, stop_after = 0, s_w = 0;
    int val_every = 0;
    int no_curriculum = 0, no_progressive = 0;
    const gv_flag flags[] = {
        {"clips", GV_FLAG_STRING, &clips, "DIR", "dataset folder (manifest.json); its train split is used", 1},
        {"base", GV_FLAG_STRING, &base, "FILE", "the base checkpoint (gaussvid pretrain)", 1},
        {"out", GV_FLAG_STRING, &out, "FILE", "the fine-tuned checkpoint; FILE.ckpt holds the resumable state", 1},
        {"config", GV_FLAG_STRING, &config, "PRESET|FILE", "check the base against this config and take its variant and LoRA", 0},
        {"vae", GV_FLAG_STRING, &vae, "FILE", "the VAE (default: the one the base names; must be the same)", 0},
        {"variant", GV_FLAG_STRING, &variant, "V", "ablation: camera=none|early|monolithic|decomposed, anchors=none|first|both, per-frame, lora=R", 0},
        {"steps", GV_FLAG_INT, &steps, "N", "optimiser steps S (default 5000)", 0},
        {"batch", GV_FLAG_INT, &o.batch, "B", "clips per step (default 2)", 0},
        {"lr", GV_FLAG_DOUBLE, &o.lr, "LR", "AdamW learning rate after the warm-up (default 1e-4, the paper's)", 0},
        {"warmup", GV_FLAG_INT, &warmup, "N", "linear learning-rate warm-up steps (default 0)", 0},
        {"lr-schedule", GV_FLAG_STRING, &schedule, "NAME",
         "after the warm-up: constant (default, the paper's), linear or cosine (both decay to 0 at step S)", 0},
        {"seed", GV_FLAG_INT, &seed, "S", "random seed: adapters, data order, timesteps, noise (default 0)", 0},
        {"no-curriculum", GV_FLAG_BOOL, &no_curriculum, NULL, "ablation: shuffled clips, all weighted 1", 0},
        {"no-progressive-loss", GV_FLAG_BOOL, &no_progressive, NULL, "ablation: flow matching loss only", 0},
        {"fresh-camera", GV_FLAG_BOOL, &o.fresh_camera, NULL, "start the camera encoder from its initialisation, not the base's (the paper trains it from scratch)", 0},
        {"t-max", GV_FLAG_DOUBLE, &o.t_max, "T", "timesteps t ~ U[0, T] (default 0.48)", 0},
        {"relative-loss", GV_FLAG_BOOL, &o.relative_loss, NULL, "weight each clip's loss by 1 / its identity loss (the loss of leaving its renders unchanged), mean weight 1", 0},
        {"crop", GV_FLAG_STRING, &crop, "RxC", "train each sample on a random window of R x C tokens of its clip (default: the whole clip)", 0},
        {"latent-warmup", GV_FLAG_INT, &s_w, "N", "S_w of the progressive loss (default S/20)", 0},
        {"p-w", GV_FLAG_DOUBLE, &o.p_w, "P", "curriculum warm-up fraction (default 0.05)", 0},
        {"n-min", GV_FLAG_INT, &o.n_min, "N", "interval of difficulty 0 (default 6)", 0},
        {"n-max", GV_FLAG_INT, &o.n_max, "N", "interval of difficulty 1, reached by delta_max only at step S (default 26)", 0},
        {"checkpoint-every", GV_FLAG_INT, &ckpt, "K", "steps between checkpoints FILE.ckpt (default 250)", 0},
        {"resume", GV_FLAG_BOOL, &o.resume, NULL, "continue from FILE.ckpt when it exists (bit-exact)", 0},
        {"stop-after", GV_FLAG_INT, &stop_after, "N", "end this run after step N (continue later with --resume)", 0},
        {"log", GV_FLAG_STRING, &log, "FILE", "tab-separated log: step, seconds, lr, losses, curriculum threshold", 0},
        {"val-clips", GV_FLAG_STRING, &val_clips, "DIR", "validate on the eval split of this dataset folder", 0},
        {"val-every", GV_FLAG_INT, &val_every, "K", "steps between validations (default: the checkpoint interval)", 0},
        {"val-log", GV_FLAG_STRING, &val_log, "FILE", "tab-separated validation log: step, n, clips, loss, identity", 0},
    };
    const gv_command_spec spec = {
        "train", NULL, "GaussVid fine-tuning of a base model (LoRA + camera encoder)",
        "Objective (paper 3.4): x_t = (1 - t) z-hat + t eps from the corrupted clip's latent,\n"
        "target v = eps - z0*, t ~ U[0, 0.48]; plus the progressive latent loss\n"
        "L1(x_t - t v, z0*) weighted 0.1 clamp((s - S_w)/S_w, 0, 1) max(0, 1 - t/0.3); the\n"
        "curriculum skips clips with delta(n) = (n - 6)/20 above delta_max(s) (warm-up 0.05 S)\n"
        "and weights the others 1 - 0.4 delta/delta_max. The base (and its VAE) is frozen;\n"
        "LoRA and the Plücker camera encoder train (AdamW). The output holds the base weights\n"
        "too, so it loads alone. With --val-clips the loss on unseen clips (fixed draws) is\n"
        "shown beside the identity's, the loss of leaving the renders unchanged: below it, the\n"
        "network restores. See docs/TRAINING.md.",
        flags, sizeof flags / sizeof flags[0], 0, 0};
    int parsed = gv_args_parse(&spec, argc, argv, NULL, NULL);
    if (parsed != GV_ARGS_OK) return gv_args_exit_code(parsed);
    if (steps < 1 || o.batch < 1 || warmup < 0 || seed < 0 || ckpt < 1 || stop_after < 0 || s_w < 0 || val_every < 0) {
        fprintf(stderr, "gaussvid train: --steps, --batch and --checkpoint-every must be positive; --warmup, --seed, "
                        "--stop-after, --latent-warmup and --val-every not negative\n");
        return 2;
    }
    if (crop && gv_parse_crop("train", crop, &o.crop_h, &o.crop_w)) return 2;
    if (gv_lr_kind_from_name(schedule, &o.lr_schedule)) {
        fprintf(stderr, "gaussvid train: --lr-schedule: %s\n", gv_last_error());
        return 2;
    }
    if ((val_every || val_log) && !val_clips) {
        fprintf(stderr, "gaussvid train: --val-every and --val-log need --val-clips\n");
        return 2;
    }
    o.steps = steps, o.warmup = warmup, o.seed = (uint64_t)seed, o.checkpoint_every = ckpt, o.stop_after = stop_after;
    o.latent_warmup = s_w, o.curriculum = !no_curriculum, o.progressive = !no_progressive;
    o.min_lr = o.lr_schedule == GV_LR_CONSTANT ? o.lr : 0.0, o.out = out, o.log_path = log;
    o.val_every = val_every ? val_every : ckpt, o.val_log = val_log;

    gv_model_config cfg;
    gv_train_state base_state, meta;
    int rc = run_config(base, config, variant, &cfg, &base_state);
    if (rc) return rc == 2 ? 2 : gv_report_failure();
    char vae_path[4200];
    if (vae) snprintf(vae_path, sizeof vae_path, "%s", vae);
    else if (gv_checkpoint_vae_path(base, &base_state, vae_path, sizeof vae_path)) return gv_report_failure();
    memset(&meta, 0, sizeof meta);
    snprintf(meta.kind, sizeof meta.kind, "finetune");
    snprintf(meta.base, sizeof meta.base, "%s", base);
    gv_latent_set set, val;
    memset(&val, 0, sizeof val);
    if (gv_train_load_data(clips, vae_path, base_state.vae_checksum, &cfg, &set, &meta)) return gv_report_failure();
    if (val_clips && gv_train_load_val(val_clips, vae_path, &cfg, &val)) {
        gv_latent_set_free(&set);
        return gv_report_failure();
    }
    o.val = val_clips ? &val : NULL;
    gv_dit m;
    gv_train_report r;
    rc = build_model(base, &cfg, o.seed, o.fresh_camera, &m);
    char window[64] = "";
    if (crop) snprintf(window, sizeof window, ", random windows of %dx%d tokens", o.crop_h, o.crop_w);
    if (rc == 0)
        gv_info("train: %s (camera %s, anchors %s%s), %d clips, %.1f K trainable parameters, %ld steps of %d clips, "
                "curriculum %s, progressive loss %s (S_w %ld)%s",
                cfg.name, gv_camera_variant_name(cfg.variant.camera), gv_anchors_name(cfg.variant.anchors),
                cfg.variant.per_frame ? ", per-frame" : "", set.count, gv_params_count(&m.params, 1) / 1e3, o.steps,
                o.batch, o.curriculum ? "on" : "off", o.progressive ? "on" : "off", gv_train_latent_warmup(&o),
                window);
    if (rc == 0) rc = gv_train_run(&m, &cfg, &set, &o, &meta, &r);
    gv_dit_free(&m);
    gv_latent_set_free(&set);
    gv_latent_set_free(&val);
    if (rc) return gv_report_failure();
    if (r.end_step < o.steps)
        printf("%s.ckpt: fine-tuned to step %ld of %ld (%.1f clips/s, %.1f s this run); continue with --resume\n", out,
               r.end_step, o.steps, r.clips_per_second, r.seconds);
    else
        printf("%s: %s fine-tuned for %ld steps (%ld clips used, %ld skipped by the curriculum, %.1f clips/s, %.1f s "
               "this run, loss %.4f)\n",
               out, cfg.name, o.steps, r.clips_used, r.clips_skipped, r.clips_per_second, r.seconds, r.last_loss);
    return 0;
}
