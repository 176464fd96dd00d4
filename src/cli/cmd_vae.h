/* Shared by the vae subcommands (src/cli/cmd_vae*.c). */
#ifndef GAUSSVID_CLI_CMD_VAE_H
#define GAUSSVID_CLI_CMD_VAE_H

enum { VAE_MAX_SCENES = 256 };

/* gaussvid vae residual (src/cli/cmd_vae_residual.c; the others are in cli/commands.h). */
int cmd_vae_residual(int argc, char **argv);

/* Takes every "--NAME A B ..." (values up to the next option) and "--NAME=A" out of argv
 * before the flags are parsed, so the flag may name several folders and be repeated.
 * Returns 0, or 2 after printing a usage message. */
int vae_take_list(const char *command, const char *name, int *argc, char **argv, const char **values, int *n);

#endif
