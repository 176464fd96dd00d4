/* gaussvid metrics consistency DIR [--json]: the 3D consistency of a reconstruct output
 * folder's sparse renders, restored frames and refined renders (docs/METRICS.md, "3D
 * consistency"; gv_reconstruct_consistency). */
#include <stdio.h>
#include <stdlib.h>

#include "cli/commands.h"
#include "gaussvid/core/core.h"
#include "gaussvid/pipeline/pipeline.h"

int cmd_metrics_consistency(int argc, char **argv)
{
    int json = 0;
    const gv_flag flags[] = {
        {"json", GV_FLAG_BOOL, &json, NULL, "print one JSON object on stdout (the summary lines go to stderr)", 0},
    };
    const gv_command_spec spec = {
        "metrics consistency", "DIR",
        "3D consistency of a reconstruct folder: each frame warped into its neighbours, masked PSNR",
        "DIR is a `gaussvid reconstruct` output folder (its metrics.json, the frames of each run,\n"
        "sparse.ply and refined.ply). For each run, the evaluated frames in path order: each frame\n"
        "is warped into the previous and the next one by the model's rendered depth (the sparse\n"
        "model for the sparse renders and the restored frames, the refined model for its renders;\n"
        "depth only where the accumulated opacity is at least 0.5) and compared with it on the\n"
        "pixels that land inside it and pass the occlusion test (depths agree within 5 %).\n"
        "PSNR = -10 log10(MSE over those pixels' values, v / 255), capped at 100 dB; a set's\n"
        "score is the mean over its pairs. Frames that agree with each other score high; a\n"
        "restorer that invents different detail in each frame scores low.\n"
        "Prints one line per run; with --json one object: {\"dir\", \"runs\": [{\"interval\",\n"
        "\"frames\", \"sparse\"|\"restored\"|\"refined\": {\"psnr\", \"coverage\", \"pairs\", \"scored\",\n"
        "\"depth\", \"per_pair\": [{\"from\", \"to\", \"psnr\", \"coverage\"}]}}]} (frame numbers as\n"
        "in metrics.json; null where no pixel is covered). docs/METRICS.md describes it.",
        flags, 1, 1, 1};
    char *positional[1];
    int n_positional = 0;
    int parsed = gv_args_parse(&spec, argc, argv, positional, &n_positional);
    if (parsed != GV_ARGS_OK) return gv_args_exit_code(parsed);
    char *text = NULL, summary[4096];
    if (gv_reconstruct_consistency(positional[0], &text, summary, sizeof summary)) return gv_report_failure();
    if (json) {
        printf("%s\n", text);
        fprintf(stderr, "%s\n", summary);
    } else {
        printf("%s\n", summary);
    }
    free(text);
    return 0;
}
