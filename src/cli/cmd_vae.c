/* gaussvid vae: the restoration network's VAE, trained on scene frames (docs/VAE.md). */
#include <stdio.h>
#include <string.h>

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

int vae_take_list(const char *command, const char *name, int *argc, char **argv, const char **values, int *n)
{
    size_t len = strlen(name);
    int kept = 1;
    for (int i = 1; i < *argc; i++) {
        const char *a = argv[i];
        int bare = !strncmp(a, "--", 2) && !strcmp(a + 2, name);
        int with_value = !strncmp(a, "--", 2) && !strncmp(a + 2, name, len) && a[2 + len] == '=';
        if (!bare && !with_value) {
            argv[kept++] = argv[i];
            continue;
        }
        int before = *n;
        if (with_value && a[3 + len]) {
            if (*n == VAE_MAX_SCENES) goto too_many;
            values[(*n)++] = a + 3 + len;
        }
        while (bare && i + 1 < *argc && strncmp(argv[i + 1], "--", 2)) {
            if (*n == VAE_MAX_SCENES) goto too_many;
            values[(*n)++] = argv[++i];
        }
        if (*n == before) {
            fprintf(stderr, "gaussvid %s: --%s needs at least one folder\n", command, name);
            return 2;
        }
    }
    *argc = kept;
    return 0;
too_many:
    fprintf(stderr, "gaussvid %s: more than %d folders for --%s\n", command, VAE_MAX_SCENES, name);
    return 2;
}
