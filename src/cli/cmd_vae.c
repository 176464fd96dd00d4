/* gaussvid vae: the restoration network's VAE, trained on scene frames (docs/VAE.md). */
#include "cli/cmd_vae.h"
#include "cli/commands.h"

static const gv_subcommand vae_commands[] = {
    {"train", cmd_vae_train, "train the VAE of a config (the small preset's) on scene frames"},
    {"eval", cmd_vae_eval, "reconstruction PSNR and SSIM of VAE weights on scene frames"},
    {"residual", cmd_vae_residual, "what the VAE costs the restorer on dataset clips (residual decoding)"},
};

int cmd_vae(int argc, char **argv)
{
    return gv_run_subcommand("vae", vae_commands, (int)(sizeof vae_commands / sizeof vae_commands[0]), argc, argv);
}
