/* Where the released models are found (core.h): $GAUSSVID_MODELS, beside the program, and
 * where `make install` puts them, so the default restorer loads whatever the working folder
 * (docs/RECONSTRUCT.md, "Where the models are found"). */
#include <limits.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "gaussvid/core/core.h"

#ifndef GV_INSTALL_DATADIR
#define GV_INSTALL_DATADIR "/usr/local/share/gaussvid"
#endif

/* The folder of the running program (/proc/self/exe, symbolic links resolved); 0 when unknown. */
static int program_dir(char *out, size_t size)
{
    char exe[PATH_MAX];
    ssize_t n = readlink("/proc/self/exe", exe, sizeof exe - 1);
    if (n <= 0) return 0;
    exe[n] = 0;
    char *slash = strrchr(exe, '/');
    if (!slash) return 0;
    *slash = 0;
    snprintf(out, size, "%s", exe[0] ? exe : "/");
    return 1;
}

/* Adds dir (made absolute and free of '..' when it exists) unless listed already. */
static void add_dir(gv_model_dirs *d, const char *dir, const char *why)
{
    if (d->count == GV_MODEL_DIRS_MAX || !dir[0]) return;
    char real[PATH_MAX];
    const char *path = realpath(dir, real) ? real : dir;
    for (int i = 0; i < d->count; i++)
        if (!strcmp(d->dir[i], path)) return;
    snprintf(d->dir[d->count], sizeof d->dir[0], "%s", path);
    snprintf(d->why[d->count], sizeof d->why[0], "%s", why);
    d->count++;
}

void gv_model_dirs_list(gv_model_dirs *d)
{
    memset(d, 0, sizeof *d);
    const char *env = getenv("GAUSSVID_MODELS");
    d->env_set = env && *env;
    if (d->env_set) { /* a list like PATH's, first first */
        char list[8192];
        snprintf(list, sizeof list, "%s", env);
        for (char *save = NULL, *p = strtok_r(list, ":", &save); p; p = strtok_r(NULL, ":", &save))
            add_dir(d, p, "GAUSSVID_MODELS");
    }
    char prog[PATH_MAX], up[PATH_MAX + 8], parent[PATH_MAX], dir[PATH_MAX + 32];
    if (program_dir(prog, sizeof prog)) {
        snprintf(up, sizeof up, "%s/..", prog);
        if (!realpath(up, parent)) snprintf(parent, sizeof parent, "%s", up);
        snprintf(dir, sizeof dir, "%s/models", parent); /* the source tree: build/gaussvid, models/ */
        add_dir(d, dir, "beside the program");
        snprintf(dir, sizeof dir, "%s/share/gaussvid", parent); /* installed: PREFIX/bin, PREFIX/share/gaussvid */
        add_dir(d, dir, "installed");
    }
    add_dir(d, GV_INSTALL_DATADIR, "the install prefix");
}

int gv_find_model(const char *name, char *out, size_t size)
{
    gv_model_dirs d;
    gv_model_dirs_list(&d);
    for (int i = 0; i < d.count; i++)
        if (gv_path_join(out, size, d.dir[i], name) == 0 && gv_file_exists(out)) return 1;
    return 0;
}

void gv_model_dirs_describe(const gv_model_dirs *d, char *out, size_t size)
{
    size_t used = 0;
    out[0] = 0;
    if (!d->env_set) used += (size_t)snprintf(out, size, "GAUSSVID_MODELS (not set)");
    for (int i = 0; i < d->count && used < size; i++)
        used += (size_t)snprintf(out + used, size - used, "%s%s (%s)", used ? ", " : "", d->dir[i], d->why[i]);
}
