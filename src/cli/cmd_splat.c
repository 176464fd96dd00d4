/* gaussvid splat: the 3D Gaussian Splatting command group. */
#include "cli/commands.h"

static const gv_subcommand splat_commands[] = {
    {"export", cmd_splat_export, "convert a 3DGS .ply model to the 32-byte .splat format"},
};

int cmd_splat(int argc, char **argv)
{
    return gv_run_subcommand("splat", splat_commands, 1, argc, argv);
}
