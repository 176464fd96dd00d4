/* gaussvid splat: the 3D Gaussian Splatting command group. */
#include "cli/commands.h"

static const gv_subcommand splat_commands[] = {
    {"export", cmd_splat_export, "convert a 3DGS .ply model to the 32-byte .splat format"},
    {"train", cmd_splat_train, "train 3D Gaussian Splatting on the sparse split of a scene"},
    {"render", cmd_splat_render, "render a model from a scene's cameras (or a path) to PNGs"},
    {"eval", cmd_splat_eval, "PSNR and SSIM of a model on held-out and training views"},
    {"coverage", cmd_splat_coverage, "how much of each held-out view its anchors see, and the error there"},
};

int cmd_splat(int argc, char **argv)
{
    return gv_run_subcommand("splat", splat_commands,
                             sizeof splat_commands / sizeof splat_commands[0], argc, argv);
}
