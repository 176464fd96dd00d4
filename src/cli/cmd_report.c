/* gaussvid report DIR: rebuilds DIR/report.html and DIR/nN/viewer.html from the folder that
 * `gaussvid reconstruct` wrote (docs/REPORT.md). */
#include <stdio.h>

#include "cli/commands.h"
#include "gaussvid/core/core.h"
#include "gaussvid/report/report.h"

int cmd_report(int argc, char **argv)
{
    const gv_command_spec spec = {
        "report", "DIR", "write the HTML report and the viewers of a reconstruction folder",
        "Reads DIR/metrics.json and the images it names and writes DIR/report.html: one\n"
        "self-contained page (no network) with the per-n table of PSNR / SSIM (LPIPS when\n"
        "measured) of the sparse, restored and refined frames, a per-frame PSNR plot, image\n"
        "strips with error maps for the worst and best frames, the restorer and its gate, and\n"
        "the time of each stage. Next to each model it writes nN/viewer.html, which flies\n"
        "through the refined (else the sparse) model along the scene's cameras in a browser,\n"
        "from file:// (three.js + Spark, vendored by scripts/setup.sh). See docs/REPORT.md.",
        NULL, 0, 1, 1};
    char *positional[1];
    int n_positional = 0;
    int parsed = gv_args_parse(&spec, argc, argv, positional, &n_positional);
    if (parsed != GV_ARGS_OK) return gv_args_exit_code(parsed);
    if (gv_report_write(positional[0]) != 0) return gv_report_failure();
    char path[8192];
    if (gv_path_join(path, sizeof path, positional[0], "report.html") != 0) return gv_report_failure();
    printf("%s\n", path);
    return 0;
}
