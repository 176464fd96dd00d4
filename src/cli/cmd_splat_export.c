/* gaussvid splat export MODEL.ply --out FILE.splat: a 3DGS model to the 32-byte .splat
 * format read by web splat viewers (docs/PLY.md). */
#include <stdio.h>

#include "cli/commands.h"
#include "gaussvid/core/core.h"
#include "gaussvid/io/ply.h"

int cmd_splat_export(int argc, char **argv)
{
    const char *out = NULL;
    const gv_flag flags[] = {
        {"out", GV_FLAG_STRING, &out, "FILE.splat", "the .splat file to write", 1},
    };
    const gv_command_spec spec = {
        "splat export", "MODEL.ply", "convert a 3DGS .ply model to the 32-byte .splat format",
        "Each Gaussian becomes 32 bytes: position, exp(scale), RGBA from the DC colour and\n"
        "sigmoid(opacity), and the normalised quaternion, sorted by descending volume x\n"
        "opacity. Higher SH coefficients are dropped. See docs/PLY.md.",
        flags, 1, 1, 1};
    char *positional[1];
    int n_positional = 0;
    int parsed = gv_args_parse(&spec, argc, argv, positional, &n_positional);
    if (parsed != GV_ARGS_OK) return gv_args_exit_code(parsed);

    gv_gaussians g;
    if (gv_gaussians_read_ply(positional[0], &g) != 0) return gv_report_failure();
    if (gv_gaussians_write_splat(out, &g) != 0) {
        gv_gaussians_free(&g);
        return gv_report_failure();
    }
    printf("%s: %d Gaussians, SH degree %d -> %s (%ld bytes; only the DC colour is kept)\n",
           positional[0], g.n, g.sh_degree, out, 32L * g.n);
    gv_gaussians_free(&g);
    return 0;
}
