/* gaussvid dataset: the paired clip dataset (build, stats, show; docs/FORMATS-DATASET.md). */
#include "cli/commands.h"

static const gv_subcommand dataset_commands[] = {
    {"build", cmd_dataset_build, "simulate sparse-view artifacts and sample clean-corrupted-clean clips"},
    {"stats", cmd_dataset_stats, "clips per n and split, baseline PSNR/SSIM of the corrupted frames"},
    {"show", cmd_dataset_show, "contact sheet of a clip: inputs above, targets below"},
};

int cmd_dataset(int argc, char **argv)
{
    return gv_run_subcommand("dataset", dataset_commands, 3, argc, argv);
}
