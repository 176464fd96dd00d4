/* gaussvid eval --ckpt C --clips DIR [--split eval] [--json F]: PSNR and SSIM of the corrupted
 * (baseline) and restored intermediate frames of a dataset's clips, per interval n and mean,
 * as a Markdown table like the paper's and as JSON. docs/RESTORATION.md. */
#include <stdio.h>
#include <string.h>

#include "cli/cmd_restore.h"
#include "cli/commands.h"
#include "gaussvid/core/core.h"

int cmd_eval(int argc, char **argv)
{
    gv_restore_cli c = {0};
    const char *clips = NULL, *json = NULL, *metric = "3dgs";
    int identity = 0;
    gv_flag flags[GV_RESTORE_CLI_FLAGS + 4];
    gv_restore_cli_flags(&c, flags, "train, eval or all (default eval)");
    const gv_flag more[4] = {
        {"metric", GV_FLAG_STRING, &metric, "3dgs|release",
         "3dgs: PSNR and SSIM as the 3DGS evaluation (default); release: as the GaussVid release measures "
         "(scikit-image: SSIM with a 7x7 uniform window, docs/GAUSSVID_RELEASE.md)", 0},
        {"clips", GV_FLAG_STRING, &clips, "DIR", "the dataset folder (manifest.json)", 1},
        {"json", GV_FLAG_STRING, &json, "FILE", "also write the table as JSON", 0},
        {"identity", GV_FLAG_BOOL, &identity, NULL,
         "check the pipeline: the sampler returns the input latent, so with residual composition the "
         "restored numbers must equal the baseline's exactly (exit 1 otherwise)", 0},
    };
    memcpy(flags + GV_RESTORE_CLI_FLAGS, more, sizeof more);
    const gv_command_spec spec = {
        "eval", NULL, "PSNR and SSIM of baseline and restored frames, per interval n",
        "Restores every clip of the split (as 'gaussvid restore') and measures the three\n"
        "intermediate frames against the ground truth, as the 3DGS evaluation computes PSNR and\n"
        "SSIM (docs/METRICS.md), and LPIPS with --lpips: the corrupted inputs (baseline) and the\n"
        "restored frames, averaged over frames per n and overall. JSON: {\"baseline\": {\"psnr\", \"ssim\", \"clips\"},\n"
        "\"restored\": {...}, \"per_n\": [...], \"checkpoint\", \"sampler\", \"compose\", \"split\",\n"
        "\"scene\" (with --scene or a scene checkpoint), \"gate\" (a scene checkpoint)}. A scene\n"
        "checkpoint (gaussvid adapt) restores only the clips of its scene at its interval.",
        flags, GV_RESTORE_CLI_FLAGS + 4, 0, 0};
    int parsed = gv_args_parse(&spec, argc, argv, NULL, NULL);
    if (parsed != GV_ARGS_OK) return gv_args_exit_code(parsed);
    if (!c.split) c.split = "eval";
    if (strcmp(metric, "3dgs") && strcmp(metric, "release"))
        return gv_restore_cli_usage("eval", "--metric is 3dgs or release");
    if (identity) {
        if (strcmp(c.sampler, GV_SAMPLER_DEFAULT) || (c.compose && strcmp(c.compose, GV_COMPOSE_DEFAULT)))
            return gv_restore_cli_usage("eval", "--identity sets the sampler and the composition");
        c.sampler = "identity", c.compose = "residual";
    }
    gv_restore_options o;
    if (gv_restore_cli_options(&c, &o)) return gv_restore_cli_usage("eval", gv_last_error());

    gv_restore_session s = {0}; /* ended below even when the input check fails before start */
    int rc = gv_restore_cli_check_input(clips, NULL) || gv_restore_cli_start(&c, &o, &s) ||
                     gv_restore_cli_warn_seen(&s.r, c.ckpt, clips, NULL, &o)
                 ? -1
                 : 0;
    s.table.release_metric = !strcmp(metric, "release");
    if (rc == 0) rc = gv_restore_dataset(&s.r, clips, &o);
    gv_eval_table *table = &s.table;
    char text[256];
    gv_sampler_describe(&o.sampler, text, sizeof text);
    if (rc == 0) {
        gv_eval_finish(table);
        printf("%s (%s split): %d clips, checkpoint %s, %s, %s composition, %s metric\n\n", clips, c.split,
               table->mean.clips, c.ckpt, text, gv_compose_name(o.compose), metric);
        gv_eval_print_markdown(table, stdout);
    }
    if (rc == 0 && json) {
        const char *keys[8] = {"checkpoint", "sampler", "compose", "split", "clips_dir", "metric", "scene", "gate"};
        const char *values[8] = {c.ckpt, text, gv_compose_name(o.compose), c.split, clips, metric, o.scene, s.gate};
        int count = 6;
        for (int i = 6; i < 8; i++) /* the scene and the gate only when there is one */
            if (values[i]) keys[count] = keys[i], values[count++] = values[i];
        rc = gv_eval_write_json(table, json, keys, values, count);
    }
    if (rc == 0 && identity) {
        /* restore.h: the identity sampler with residual composition reproduces the inputs */
        int same = table->mean.psnr_rest == table->mean.psnr_base && table->mean.ssim_rest == table->mean.ssim_base;
        for (int i = 0; i < table->n_rows; i++)
            same = same && table->rows[i].psnr_rest == table->rows[i].psnr_base &&
                   table->rows[i].ssim_rest == table->rows[i].ssim_base;
        if (!same) rc = gv_fail("%s: identity check failed: restored numbers differ from the baseline", clips);
        else printf("\nidentity check passed: restored = baseline for every n\n");
    }
    gv_restore_cli_end(&s);
    return rc == 0 ? 0 : gv_report_failure();
}
