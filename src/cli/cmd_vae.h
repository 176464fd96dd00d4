/* Shared by the vae subcommands (src/cli/cmd_vae*.c). */
#ifndef GAUSSVID_CLI_CMD_VAE_H
#define GAUSSVID_CLI_CMD_VAE_H

/* gaussvid vae residual (src/cli/cmd_vae_residual.c; the others are in cli/commands.h). */
int cmd_vae_residual(int argc, char **argv);

#endif
