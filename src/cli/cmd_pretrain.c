/* gaussvid pretrain --clips DIR --config small --vae V --out base.safetensors: the base
 * first-last-frame video model (standing in for the pretrained Wan2.1-VACE): standard flow
 * matching on the clean training clips, the anchors as VACE context (docs/TRAINING.md). */
#include <stdio.h>
#include <string.h>

#include "cli/cmd_train.h"
#include "cli/commands.h"

int cmd_pretrain(int argc, char **argv)
{
    gv_train_options o;
    gv_train_defaults(&o, GV_OBJECTIVE_PRETRAIN);
    gv_run_cli run = {NULL, NULL, (int)o.steps, o.batch, (int)o.warmup, 0, (int)o.checkpoint_every, 0, 0, o.lr, {""}};
    const char *clips = NULL, *config = "small", *vae = NULL, *variant = NULL, *crop = NULL;
    const gv_flag own[] = {
        {"clips", GV_FLAG_STRING, &clips, "DIR", "dataset folder (manifest.json); its train split is used", 1},
        {"config", GV_FLAG_STRING, &config, "PRESET|FILE", "model config (default small)", 0},
        {"vae", GV_FLAG_STRING, &vae, "FILE", "the trained VAE (.safetensors with latent statistics)", 1},
        {"variant", GV_FLAG_STRING, &variant, "V", GV_VARIANT_HELP, 0},
        {"min-lr", GV_FLAG_DOUBLE, &o.min_lr, "LR", "end of the cosine decay (default 3e-5)", 0},
        {"shift", GV_FLAG_DOUBLE, &o.shift, "S", "shift of the timestep grid (default 5, as the reference; 1 = none)", 0},
        {"render-context", GV_FLAG_DOUBLE, &o.render_context, "P",
         "share of samples whose VACE context also holds the clip's renders (default 0)", 0},
        {"crop", GV_FLAG_STRING, &crop, "RxC", "train each sample on a random window of R x C tokens of its clip (default: the whole clip)", 0},
    };
    gv_flag flags[sizeof own / sizeof own[0] + GV_RUN_CLI_FLAGS];
    int n_flags = gv_run_cli_flags(&run, "the base checkpoint; FILE.ckpt holds the resumable state", own,
                                   sizeof own / sizeof own[0], flags);
    const gv_command_spec spec = {
        "pretrain", NULL, "pretrain the base first-last-frame video model on clean clips",
        "Standard flow matching (docs/reference/wan-vace-gaussvid.md 5.5):\n"
        "x_t = (1 - t) z0 + t eps on the clean clip latent z0, target v = eps - z0, t drawn\n"
        "uniformly from the 1000-point grid shifted by --shift and the loss weighted by the\n"
        "reference's bell around t = 500.\n"
        "The VACE context holds the anchors only (the reactive latents are zeroed): the base\n"
        "generates the intermediate frames from the first and last frame, and from the cameras\n"
        "when the variant has them. With --render-context P a share P of the samples keeps the\n"
        "clip's corrupted renders as reactive context (a control video, as VACE is trained),\n"
        "so that the base learns to read that stream; the target stays the clean clip.\n"
        "Every tensor is trained (no LoRA). The clips are encoded once by --vae and cached in\n"
        "the dataset folder. The base keeps the config's LoRA rank in its metadata for\n"
        "`gaussvid train`. See docs/TRAINING.md.",
        flags, n_flags, 0, 0};
    int parsed = gv_args_parse(&spec, argc, argv, NULL, NULL);
    if (parsed != GV_ARGS_OK) return gv_args_exit_code(parsed);
    if (gv_run_cli_check(&run, "pretrain")) return 2;
    if (crop && gv_parse_crop("pretrain", crop, &o.crop_h, &o.crop_w)) return 2;
    if (!(o.render_context >= 0 && o.render_context <= 1)) {
        fprintf(stderr, "gaussvid pretrain: --render-context is a share of the samples, in [0, 1]\n");
        return 2;
    }
    gv_run_cli_apply(&run, &o);

    gv_model_config cfg;
    if (gv_model_config_load(&cfg, config)) return gv_report_failure();
    if (variant && gv_model_config_set_variant(&cfg, variant, "--variant")) {
        fprintf(stderr, "gaussvid pretrain: %s\n", gv_last_error());
        return 2;
    }
    gv_train_state meta;
    memset(&meta, 0, sizeof meta);
    gv_latent_set set;
    if (gv_train_load_data(clips, vae, NULL, &cfg, &set, &meta)) return gv_report_failure();
    gv_dit m;
    int rc = gv_train_model(&cfg, GV_OBJECTIVE_PRETRAIN, NULL, 0, o.seed, &m, &meta);
    gv_train_report r;
    if (rc == 0)
        gv_info("pretrain: %s (camera %s, anchors %s), %d clips, %.2f M parameters, %ld steps of %d clips", cfg.name,
                gv_camera_variant_name(cfg.variant.camera), gv_anchors_name(cfg.variant.anchors), set.count,
                gv_params_count(&m.params, 1) / 1e6, o.steps, o.batch);
    if (rc == 0) rc = gv_train_run(&m, &cfg, &set, &o, &meta, &r);
    gv_dit_free(&m);
    gv_latent_set_free(&set);
    if (rc) return gv_report_failure();
    if (r.end_step < o.steps)
        printf("%s.ckpt: pretrained to step %ld of %ld (%.1f clips/s, %.1f s this run); continue with --resume\n", o.out,
               r.end_step, o.steps, r.clips_per_second, r.seconds);
    else
        printf("%s: base %s pretrained for %ld steps (%ld clips, %.1f clips/s, %.1f s this run, loss %.4f)\n", o.out,
               cfg.name, o.steps, r.clips_used, r.clips_per_second, r.seconds, r.last_loss);
    return 0;
}
