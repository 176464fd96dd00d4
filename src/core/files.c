/* Whole-file reads, directories and paths (files written atomically: atomic_file.c). */
#include "gaussvid/core/core.h"

#include <errno.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

int gv_read_file(const char *path, char **data, size_t *size)
{
    *data = NULL;
    if (size) *size = 0;
    FILE *f = fopen(path, "rb");
    if (!f) return gv_fail("%s: cannot open: %s", path, strerror(errno));
    if (fseek(f, 0, SEEK_END) != 0) { fclose(f); return gv_fail("%s: cannot seek", path); }
    long length = ftell(f);
    if (length < 0) { fclose(f); return gv_fail("%s: not a regular file", path); }
    rewind(f);
    char *buffer = malloc((size_t)length + 1);
    if (!buffer) { fclose(f); return gv_fail("%s: out of memory (%ld bytes)", path, length); }
    size_t got = fread(buffer, 1, (size_t)length, f);
    fclose(f);
    if (got != (size_t)length) { free(buffer); return gv_fail("%s: read error", path); }
    buffer[length] = '\0';
    *data = buffer;
    if (size) *size = (size_t)length;
    return 0;
}

int gv_file_exists(const char *path)
{
    struct stat st;
    return stat(path, &st) == 0 && S_ISREG(st.st_mode);
}

int gv_dir_exists(const char *path)
{
    struct stat st;
    return stat(path, &st) == 0 && S_ISDIR(st.st_mode);
}

int gv_mkdirs(const char *path)
{
    char buffer[4096];
    if (snprintf(buffer, sizeof buffer, "%s", path) >= (int)sizeof buffer)
        return gv_fail("%s: path too long", path);
    for (char *p = buffer + 1; ; p++) {
        if (*p == '/' || *p == '\0') {
            char saved = *p;
            *p = '\0';
            if (mkdir(buffer, 0777) != 0 && errno != EEXIST)
                return gv_fail("%s: cannot create directory: %s", buffer, strerror(errno));
            if (!gv_dir_exists(buffer)) return gv_fail("%s: exists and is not a directory", buffer);
            *p = saved;
            if (saved == '\0') break;
        }
    }
    return 0;
}

int gv_path_join(char *out, size_t size, const char *a, const char *b)
{
    size_t la = strlen(a);
    int need_slash = la > 0 && a[la - 1] != '/';
    int n = snprintf(out, size, "%s%s%s", a, need_slash ? "/" : "", b);
    if (n < 0 || (size_t)n >= size) return gv_fail("%s/%s: path too long", a, b);
    return 0;
}

int gv_write_text_atomic(const char *path, const char *text)
{
    gv_atomic_file af;
    if (gv_atomic_open(&af, path) != 0) return -1;
    fputs(text, af.f);
    fputc('\n', af.f);
    return gv_atomic_commit(&af);
}
