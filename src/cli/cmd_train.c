/* gaussvid train --clips DIR --base base.safetensors --out ckpt.safetensors: GaussVid
 * fine-tuning (paper 3.4; docs/ARCHITECTURE.md 7): flow matching anchored at the corrupted latent, the
 * progressive latent loss and the difficulty curriculum; LoRA and the full camera encoder
 * trained, the base frozen. Flags switch each part off for the ablations (docs/TRAINING.md). */
#include <stdio.h>
#include <string.h>

#include "cli/cmd_train.h"
#include "cli/commands.h"

int gv_run_cli_flags(gv_run_cli *r, const char *out_help, const gv_flag *own, int n_own, gv_flag *f)
{
    snprintf(r->help[0], sizeof r->help[0], "optimiser steps (default %d)", r->steps);
    snprintf(r->help[1], sizeof r->help[1], "clips per step (default %d)", r->batch);
    snprintf(r->help[2], sizeof r->help[2], "AdamW learning rate, the peak when it decays (default %g)", r->lr);
    snprintf(r->help[3], sizeof r->help[3], "linear learning-rate warm-up steps (default %d)", r->warmup);
    snprintf(r->help[4], sizeof r->help[4], "steps between checkpoints FILE.ckpt (default %d)", r->checkpoint_every);
    const gv_flag flags[GV_RUN_CLI_FLAGS] = {
        {"out", GV_FLAG_STRING, &r->out, "FILE", out_help, 1},
        {"steps", GV_FLAG_INT, &r->steps, "N", r->help[0], 0},
        {"batch", GV_FLAG_INT, &r->batch, "B", r->help[1], 0},
        {"lr", GV_FLAG_DOUBLE, &r->lr, "LR", r->help[2], 0},
        {"warmup", GV_FLAG_INT, &r->warmup, "N", r->help[3], 0},
        {"seed", GV_FLAG_INT, &r->seed, "S", "random seed of every draw of the run (default 0)", 0},
        {"checkpoint-every", GV_FLAG_INT, &r->checkpoint_every, "K", r->help[4], 0},
        {"resume", GV_FLAG_BOOL, &r->resume, NULL, "continue from FILE.ckpt when it exists (bit-exact)", 0},
        {"stop-after", GV_FLAG_INT, &r->stop_after, "N", "end this run after step N (continue later with --resume)", 0},
        {"log", GV_FLAG_STRING, &r->log, "FILE", "tab-separated log, a line per step", 0},
    };
    memcpy(f, own, (size_t)n_own * sizeof *own);
    memcpy(f + n_own, flags, sizeof flags);
    return n_own + GV_RUN_CLI_FLAGS;
}

int gv_run_cli_check(const gv_run_cli *r, const char *command)
{
    if (r->steps >= 1 && r->batch >= 1 && r->checkpoint_every >= 1 && r->warmup >= 0 && r->seed >= 0 && r->stop_after >= 0)
        return 0;
    fprintf(stderr, "gaussvid %s: --steps, --batch and --checkpoint-every must be positive; --warmup, --seed and "
                    "--stop-after not negative\n", command);
    return 2;
}

void gv_run_cli_apply(const gv_run_cli *r, gv_train_options *o)
{
    o->steps = r->steps, o->batch = r->batch, o->lr = r->lr, o->warmup = r->warmup, o->seed = (uint64_t)r->seed;
    o->checkpoint_every = r->checkpoint_every, o->stop_after = r->stop_after, o->resume = r->resume;
    o->out = r->out, o->log_path = r->log;
}

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

int cmd_train(int argc, char **argv)
{
    gv_train_options o;
    gv_train_defaults(&o, GV_OBJECTIVE_FINETUNE);
    gv_run_cli run = {NULL, NULL, (int)o.steps, o.batch, (int)o.warmup, 0, (int)o.checkpoint_every, 0, 0, o.lr, {""}};
    const char *clips = NULL, *base = NULL, *config = NULL, *vae = NULL, *variant = NULL;
    const char *val_clips = NULL, *val_log = NULL, *crop = NULL, *schedule = "constant";
    int s_w = 0, val_every = 0, no_curriculum = 0, no_progressive = 0;
    const gv_flag own[] = {
        {"clips", GV_FLAG_STRING, &clips, "DIR", "dataset folder (manifest.json); its train split is used", 1},
        {"base", GV_FLAG_STRING, &base, "FILE", "the base checkpoint (gaussvid pretrain)", 1},
        {"config", GV_FLAG_STRING, &config, "PRESET|FILE", "check the base against this config and take its variant and LoRA", 0},
        {"vae", GV_FLAG_STRING, &vae, "FILE", "the VAE (default: the one the base names; must be the same)", 0},
        {"variant", GV_FLAG_STRING, &variant, "V", GV_VARIANT_HELP, 0},
        {"lr-schedule", GV_FLAG_STRING, &schedule, "NAME",
         "after the warm-up: constant (default, the paper's), linear or cosine (both decay to 0 at step S)", 0},
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
        {"val-clips", GV_FLAG_STRING, &val_clips, "DIR", "validate on the eval split of this dataset folder", 0},
        {"val-every", GV_FLAG_INT, &val_every, "K", "steps between validations (default: the checkpoint interval)", 0},
        {"val-log", GV_FLAG_STRING, &val_log, "FILE", "tab-separated validation log: step, n, clips, loss, identity", 0},
    };
    gv_flag flags[sizeof own / sizeof own[0] + GV_RUN_CLI_FLAGS];
    int n_flags = gv_run_cli_flags(&run, "the fine-tuned checkpoint; FILE.ckpt holds the resumable state", own,
                                   sizeof own / sizeof own[0], flags);
    const gv_command_spec spec = {
        "train", NULL, "GaussVid fine-tuning of a base model (LoRA + camera encoder)",
        "Objective (paper 3.4): x_t = (1 - t) z-hat + t eps from the corrupted clip's latent,\n"
        "target v = eps - z0*, t ~ U[0, 0.48]; plus the progressive latent loss\n"
        "L1(x_t - t v, z0*) weighted 0.1 clamp((s - S_w)/S_w, 0, 1) max(0, 1 - t/0.3); the\n"
        "curriculum skips clips with delta(n) = (n - 6)/20 above delta_max(s) (warm-up 0.05 S)\n"
        "and weights the others 1 - 0.4 delta/delta_max. The base (and its VAE) is frozen;\n"
        "LoRA and the Plücker camera encoder train (AdamW at a constant rate, the paper's 1e-4).\n"
        "The output holds the base weights too, so it loads alone. With --val-clips the loss on\n"
        "unseen clips (fixed draws) is shown beside the identity's, the loss of leaving the\n"
        "renders unchanged: below it, the network restores. See docs/TRAINING.md.",
        flags, n_flags, 0, 0};
    int parsed = gv_args_parse(&spec, argc, argv, NULL, NULL);
    if (parsed != GV_ARGS_OK) return gv_args_exit_code(parsed);
    if (gv_run_cli_check(&run, "train")) return 2;
    if (s_w < 0 || val_every < 0) {
        fprintf(stderr, "gaussvid train: --latent-warmup and --val-every must not be negative\n");
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
    gv_run_cli_apply(&run, &o);
    o.latent_warmup = s_w, o.curriculum = !no_curriculum, o.progressive = !no_progressive;
    o.min_lr = o.lr_schedule == GV_LR_CONSTANT ? o.lr : 0.0;
    o.val_every = val_every ? val_every : run.checkpoint_every, o.val_log = val_log;

    gv_model_config cfg;
    gv_train_state base_state, meta;
    int rc = run_config(base, config, variant, &cfg, &base_state);
    if (rc) return rc == 2 ? 2 : gv_report_failure();
    char vae_path[4200];
    if (vae) snprintf(vae_path, sizeof vae_path, "%s", vae);
    else if (gv_checkpoint_vae_path(base, &base_state, vae_path, sizeof vae_path)) return gv_report_failure();
    memset(&meta, 0, sizeof meta);
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
    rc = gv_train_model(&cfg, GV_OBJECTIVE_FINETUNE, base, o.fresh_camera, o.seed, &m, &meta);
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
        printf("%s.ckpt: fine-tuned to step %ld of %ld (%.1f clips/s, %.1f s this run); continue with --resume\n", o.out,
               r.end_step, o.steps, r.clips_per_second, r.seconds);
    else
        printf("%s: %s fine-tuned for %ld steps (%ld clips used, %ld skipped by the curriculum, %.1f clips/s, %.1f s "
               "this run, loss %.4f)\n",
               o.out, cfg.name, o.steps, r.clips_used, r.clips_skipped, r.clips_per_second, r.seconds, r.last_loss);
    return 0;
}
