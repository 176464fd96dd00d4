/* gaussvid restore --ckpt C (--clips DIR | --clip FILE) --out DIR: restores the intermediate
 * frames of clips with a trained checkpoint and writes them as PNGs (and clip files); also the
 * flags and loading that `gaussvid eval` shares (cmd_restore.h). docs/RESTORATION.md. */
#include <stdio.h>
#include <string.h>

#include "cli/cmd_restore.h"
#include "cli/commands.h"
#include "gaussvid/core/core.h"
#include "gaussvid/data/dataset.h"
#include "gaussvid/restore/adapt.h"
#include "gaussvid/train/scene_adapt.h"

void gv_restore_cli_flags(gv_restore_cli *c, gv_flag *f, const char *split_help)
{
    const gv_flag flags[GV_RESTORE_CLI_FLAGS] = {
        {"ckpt", GV_FLAG_STRING, &c->ckpt, "FILE", "the trained checkpoint (gaussvid train)", 1},
        {"split", GV_FLAG_STRING, &c->split, "S", split_help, 0},
        {"sampler", GV_FLAG_STRING, &c->sampler, "NAME",
         "onestep, iterate, euler, released (euler as the authors run it) or identity (the input "
         "through the same pipeline); default " GV_SAMPLER_DEFAULT, 0},
        {"t0", GV_FLAG_DOUBLE, &c->t0, "T", "the first time the network sees, in (0, 1) (default: the sampler's)", 0},
        {"steps", GV_FLAG_INT, &c->steps, "N", "network evaluations in time (iterate, euler)", 0},
        {"shift", GV_FLAG_DOUBLE, &c->shift, "S", "shift of the time grid (default: the sampler's)", 0},
        {"samples", GV_FLAG_INT, &c->samples, "K", "noise draws averaged per evaluation (onestep, iterate; default 8 for onestep, 1 for iterate)", 0},
        {"blend", GV_FLAG_DOUBLE, &c->blend, "B",
         "fraction of the correction applied, in (0, 1]: z = z-hat + B (estimate - z-hat) (onestep, iterate; default 1)", 0},
        {"seed", GV_FLAG_INT, &c->seed, "S", "noise seed (default 0); each clip's stream also depends on its file name", 0},
        {"compose", GV_FLAG_STRING, &c->compose, "MODE",
         "residual (render + D(z) - D(z-hat)), decoded (D(z)), or unseen (residual where no anchor sees the pixel, "
         "the render elsewhere; clips with a coverage plane); default " GV_COMPOSE_DEFAULT, 0},
        {"no-cache", GV_FLAG_BOOL, &c->no_cache, NULL, "encode every clip instead of using the dataset's latent cache", 0},
        {"lpips", GV_FLAG_STRING, &c->lpips, "FILE", "AlexNet-LPIPS weights (safetensors, docs/LPIPS.md): add LPIPS", 0},
        {"scene", GV_FLAG_STRING, &c->scene, "NAME",
         "only clips of this scene (folder name); a scene checkpoint sets its own", 0},
        {"interval", GV_FLAG_INT, &c->interval, "N", "only clips of interval n; a scene checkpoint sets its own", 0},
    };
    memcpy(f, flags, sizeof flags);
    c->sampler = GV_SAMPLER_DEFAULT, c->compose = NULL; /* NULL: the default, or a scene checkpoint's */
}

int gv_restore_cli_start(const gv_restore_cli *c, gv_restore_options *o, gv_restore_session *s)
{
    memset(s, 0, sizeof *s);
    if (gv_restorer_load(c->ckpt, &s->r)) return -1;
    gv_info("%s: %s checkpoint of %s, step %ld of %ld", c->ckpt, s->r.state.kind, s->r.cfg.name, s->r.state.step,
            s->r.state.steps);
    char gate_line[1024];
    if (gv_restore_cli_gate(c->ckpt, c->compose != NULL, o, gate_line, sizeof gate_line, s)) return -1;
    fputs(gate_line, stdout);
    /* the release's tiled VAE (docs/GAUSSVID_RELEASE.md); cached latents were encoded whole */
    if (o->sampler.release) s->r.vae.tiling = &GV_VAE_TILING_RELEASE;
    if (c->lpips && gv_lpips_load(&s->lpips, c->lpips)) return -1;
    gv_eval_init(&s->table, c->lpips ? &s->lpips : NULL);
    o->each = gv_eval_add_restored, o->each_ctx = &s->table;
    return 0;
}

int gv_restore_cli_check_input(const char *clips_dir, const char *clip_file)
{
    if (clip_file) {
        gv_clip_info info;
        return gv_clip_read_info(clip_file, &info);
    }
    gv_manifest m;
    int rc = gv_manifest_read_dataset(clips_dir, &m);
    gv_manifest_free(&m);
    return rc;
}

int gv_restore_cli_warn_seen(const gv_restorer *r, const char *ckpt, const char *clips_dir, const char *clip_file,
                             const gv_restore_options *o)
{
    if (clip_file) {
        gv_clip_info info;
        if (gv_clip_read_info(clip_file, &info)) return -1;
        if ((o->scene && strcmp(info.id.scene, o->scene)) || (o->interval && info.id.interval != o->interval))
            return 0; /* a clip outside a scene checkpoint's scope: refused next, not restored */
        return gv_warn_if_trained_on(r, ckpt, info.id.scene);
    }
    gv_manifest m;
    if (gv_manifest_read_dataset(clips_dir, &m)) return -1;
    char seen[GV_CHECKPOINT_SCENES] = "";
    int rc = 0;
    for (int i = 0; rc == 0 && i < m.n_clips; i++) { /* each scene of the clips restore will take, once */
        const gv_run_id *id = &m.clips[i].id;
        if ((o->split && strcmp(id->split, o->split)) || (o->scene && strcmp(id->scene, o->scene)) ||
            (o->interval && id->interval != o->interval) || gv_scene_list_has(seen, id->scene))
            continue;
        size_t len = strlen(seen);
        if (len + strlen(id->scene) + 2 < sizeof seen) snprintf(seen + len, sizeof seen - len, ",%s", id->scene);
        rc = gv_warn_if_trained_on(r, ckpt, id->scene);
    }
    gv_manifest_free(&m);
    return rc;
}

void gv_restore_cli_end(gv_restore_session *s)
{
    gv_lpips_free(&s->lpips);
    gv_restorer_free(&s->r);
}

int gv_restore_cli_usage(const char *command, const char *message)
{
    fprintf(stderr, "gaussvid %s: %s (see 'gaussvid %s --help')\n", command, message, command);
    return 2;
}

int gv_restore_cli_options(const gv_restore_cli *c, gv_restore_options *o)
{
    memset(o, 0, sizeof *o);
    if (c->seed < 0) return gv_fail("--seed %d: must be non-negative", c->seed);
    if (c->t0 < 0 || c->steps < 0 || c->shift < 0 || c->samples < 0 || c->blend < 0)
        return gv_fail("--t0, --steps, --shift, --samples and --blend must be positive");
    if (gv_sampler_configure(c->sampler, c->t0, c->steps, c->shift, c->samples, c->blend, (uint64_t)c->seed,
                             &o->sampler) ||
        gv_compose_from_name(c->compose ? c->compose : GV_COMPOSE_DEFAULT, &o->compose))
        return -1;
    if (c->split && strcmp(c->split, "all") && strcmp(c->split, "train") && strcmp(c->split, "eval"))
        return gv_fail("--split %s: expected train, eval or all", c->split);
    o->split = c->split && strcmp(c->split, "all") ? c->split : NULL;
    if (c->interval < 0) return gv_fail("--interval %d: must be positive", c->interval);
    o->scene = c->scene, o->interval = c->interval;
    o->use_cache = !c->no_cache;
    return 0;
}

int gv_restore_cli_gate(const char *ckpt, int compose_given, gv_restore_options *o, char *line, size_t size,
                        gv_restore_session *s)
{
    line[0] = '\0';
    s->gate = NULL;
    if (!s->r.scene) return 0;
    const gv_scene_adaptation a = s->r.adaptation;
    /* adapters fitted to one scene at one sparsity restore only that scene's renders at it */
    if ((o->scene && strcmp(o->scene, a.scene)) || (o->interval && o->interval != a.interval))
        return gv_fail("%s: adapted to %s at n = %d, not to %s at n = %d", ckpt, a.scene, a.interval,
                       o->scene ? o->scene : a.scene, o->interval ? o->interval : a.interval);
    /* the gate's evidence is for the composition it measured: restore composes the same way */
    gv_compose gate_compose;
    if (gv_adapt_gate_compose(&a, &gate_compose)) return gv_fail_context("%s", ckpt);
    if (compose_given && gate_compose != o->compose)
        return gv_fail("%s: its gate measured the %s composition, so restore composes that way: drop --compose %s, or "
                       "adapt again with --compose %s",
                       ckpt, gv_compose_name(gate_compose), gv_compose_name(o->compose), gv_compose_name(o->compose));
    o->compose = gate_compose;
    snprintf(s->scene, sizeof s->scene, "%s", a.scene);
    o->scene = s->scene, o->interval = a.interval;
    o->keep_renders = !a.gate_open;
    s->gate = a.gate_open ? "open" : "closed";
    snprintf(line, size,
             "%s: adapted to %s at n = %d; gate %s: its held-back pairs %+.2f dB when restored (margin %+.2f dB, %s "
             "composition), so the renders are %s\n",
             ckpt, a.scene, a.interval, s->gate, gv_scene_gate_change(&a), a.gate_margin_db,
             gv_compose_name(gate_compose), a.gate_open ? "restored" : "left unchanged");
    return 0;
}

int cmd_restore(int argc, char **argv)
{
    gv_restore_cli c = {0};
    const char *clips = NULL, *clip = NULL, *out = NULL;
    int save_clips = 0;
    gv_flag flags[GV_RESTORE_CLI_FLAGS + 4];
    gv_restore_cli_flags(&c, flags, "with --clips: train, eval or all (default all)");
    const gv_flag more[4] = {
        {"clips", GV_FLAG_STRING, &clips, "DIR", "a dataset folder (manifest.json): restore its clips", 0},
        {"clip", GV_FLAG_STRING, &clip, "FILE", "one clip file", 0},
        {"out", GV_FLAG_STRING, &out, "DIR", "where <clip>/f0.png .. f4.png go", 1},
        {"save-clips", GV_FLAG_BOOL, &save_clips, NULL,
         "also write <out>/<clip>.safetensors: the clip with the restored frames as its inputs", 0},
    };
    memcpy(flags + GV_RESTORE_CLI_FLAGS, more, sizeof more);
    const gv_command_spec spec = {
        "restore", NULL, "restore the intermediate frames of clips with a trained checkpoint",
        "Restores the three corrupted intermediate frames of 5-frame clips (clean anchor, 3 renders,\n"
        "clean anchor; docs/FORMATS-DATASET.md) and writes the restored clip's 5 frames as PNGs\n"
        "(the anchors are the input's). Prints the PSNR and SSIM of the input and restored\n"
        "intermediates against the clips' ground truth. Samplers and compositions are described in\n"
        "docs/RESTORATION.md; the same seed and clip give the same result.",
        flags, GV_RESTORE_CLI_FLAGS + 4, 0, 0};
    int parsed = gv_args_parse(&spec, argc, argv, NULL, NULL);
    if (parsed != GV_ARGS_OK) return gv_args_exit_code(parsed);
    if (!clips == !clip) return gv_restore_cli_usage("restore", "give exactly one of --clips DIR and --clip FILE");
    gv_restore_options o;
    if (gv_restore_cli_options(&c, &o)) return gv_restore_cli_usage("restore", gv_last_error());
    if (clip && c.split) return gv_restore_cli_usage("restore", "--split goes with --clips");

    o.out_dir = out, o.save_clips = save_clips;
    gv_restore_session s = {0}; /* ended below even when the input check fails before start */
    int rc = gv_restore_cli_check_input(clips, clip) || gv_restore_cli_start(&c, &o, &s) ||
                     gv_restore_cli_warn_seen(&s.r, c.ckpt, clips, clip, &o) ? -1 : gv_mkdirs(out);
    if (rc == 0) {
        const char *paths[1] = {clip};
        rc = clip ? gv_restore_files(&s.r, paths, 1, &o) : gv_restore_dataset(&s.r, clips, &o);
    }
    if (rc == 0) {
        char text[256];
        gv_sampler_describe(&o.sampler, text, sizeof text);
        gv_eval_finish(&s.table);
        printf("%s: %d clips restored (%s, %s composition)\n\n", out, s.table.mean.clips, text, gv_compose_name(o.compose));
        gv_eval_print_markdown(&s.table, stdout);
    }
    gv_restore_cli_end(&s);
    return rc == 0 ? 0 : gv_report_failure();
}
