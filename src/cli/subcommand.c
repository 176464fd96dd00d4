/* Dispatch of command groups ("scene info", "splat train", ...) and the --crop flag. */
#include <stdio.h>
#include <string.h>

#include "cli/commands.h"
#include "gaussvid/core/core.h"

int gv_run_subcommand(const char *group, const gv_subcommand *table, int n, int argc, char **argv)
{
    int wants_help = argc < 2 || !strcmp(argv[1], "--help") || !strcmp(argv[1], "help");
    if (!wants_help) {
        for (int i = 0; i < n; i++)
            if (!strcmp(argv[1], table[i].name)) return table[i].run(argc - 1, argv + 1);
        fprintf(stderr, "gaussvid %s: unknown subcommand '%s' (see 'gaussvid %s --help')\n",
                group, argv[1], group);
        return 2;
    }
    FILE *out = argc < 2 ? stderr : stdout;
    fprintf(out, "usage: gaussvid %s SUBCOMMAND [options]\n\nsubcommands:\n", group);
    for (int i = 0; i < n; i++) fprintf(out, "  %-8s %s\n", table[i].name, table[i].summary);
    fprintf(out, "\n'gaussvid %s SUBCOMMAND --help' describes one.\n", group);
    return argc < 2 ? 2 : 0;
}

int gv_parse_crop(const char *command, const char *text, int *rows, int *cols)
{
    char tail;
    if (sscanf(text, "%dx%d%c", rows, cols, &tail) == 2 && *rows >= 1 && *cols >= 1) return 0;
    fprintf(stderr, "gaussvid %s: --crop %s: expected rows x columns of tokens, e.g. 6x8\n", command, text);
    return 2;
}
