/* Files written atomically: a temporary beside the target, fsync, rename, fsync of the folder.
 * A reader (or a run killed half-way) sees the previous file or the new one, never a part.
 *
 * The path is looked at before anything is written, because rename() replaces whatever the
 * path names: run as root, `--out /dev/null` once turned the system's /dev/null into a
 * regular file. So: a symbolic link is followed to the file it names (that file is replaced,
 * the link stays); a device, FIFO or socket is written into directly; a directory is refused. */
#include "gaussvid/core/core.h"

#include <dirent.h>
#include <errno.h>
#include <fcntl.h>
#include <signal.h>
#include <stdatomic.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

enum { MAX_LINK_HOPS = 40 }; /* as the kernel's own limit (ELOOP) */

/* Copies into out the folder part of path ("." when there is none, "/" for the root). */
static void folder_of(const char *path, char *out, size_t size)
{
    const char *slash = strrchr(path, '/');
    if (!slash) snprintf(out, size, ".");
    else if (slash == path) snprintf(out, size, "/");
    else snprintf(out, size, "%.*s", (int)(slash - path), path);
}

int gv_path_follow_links(const char *path, char *out, size_t size)
{
    char current[4096], target[4096], folder[4096];
    if (snprintf(current, sizeof current, "%s", path) >= (int)sizeof current)
        return gv_fail("%s: path too long", path);
    for (int hop = 0; hop < MAX_LINK_HOPS; hop++) {
        struct stat st;
        if (lstat(current, &st) != 0 || !S_ISLNK(st.st_mode)) {
            if (snprintf(out, size, "%s", current) >= (int)size) return gv_fail("%s: path too long", path);
            return 0;
        }
        ssize_t n = readlink(current, target, sizeof target - 1);
        if (n < 0) return gv_fail("%s: cannot read the symbolic link: %s", path, strerror(errno));
        if (n >= (ssize_t)sizeof target - 1) return gv_fail("%s: symbolic link target too long", path);
        target[n] = '\0';
        if (target[0] == '/') {
            memcpy(current, target, (size_t)n + 1);
        } else {
            folder_of(current, folder, sizeof folder);
            if (snprintf(current, sizeof current, "%s/%s", folder, target) >= (int)sizeof current)
                return gv_fail("%s: path too long after following its links", path);
        }
    }
    return gv_fail("%s: too many levels of symbolic links", path);
}

/* fsync that accepts the files which cannot be synced (a FIFO, a terminal, /dev/null). */
static int sync_fd(int fd)
{
    if (fsync(fd) == 0 || errno == EINVAL || errno == EROFS || errno == ENOTSUP) return 0;
    return -1;
}

/* Makes the rename durable: the folder's entry is synced too. Best effort: some file systems
 * refuse fsync on a folder, and the file itself is already complete. */
static void sync_folder(const char *file)
{
    char folder[4096];
    folder_of(file, folder, sizeof folder);
    int fd = open(folder, O_RDONLY | O_DIRECTORY | O_CLOEXEC);
    if (fd < 0) return;
    (void)sync_fd(fd);
    close(fd);
}

/* The reason for an earlier failed fwrite, when errno still holds one a write gives. */
static int write_errno(void)
{
    int e = errno;
    return e == ENOSPC || e == EFBIG || e == EDQUOT || e == EIO || e == EROFS || e == EPIPE ? e : EIO;
}

static int open_temporary(gv_atomic_file *af, const struct stat *existing)
{
    static atomic_uint counter;
    for (int attempt = 0; attempt < 100; attempt++) {
        unsigned k = atomic_fetch_add(&counter, 1);
        if (snprintf(af->tmp_path, sizeof af->tmp_path, "%s.tmp.%ld.%u", af->target, (long)getpid(), k) >=
            (int)sizeof af->tmp_path)
            return gv_fail("%s: path too long", af->path);
        af->f = fopen(af->tmp_path, "wbx"); /* exclusive: never through a link planted there */
        if (af->f) break;
        if (errno != EEXIST) {
            af->tmp_path[0] = '\0';
            return gv_fail("%s: cannot write: %s", af->path, strerror(errno));
        }
    }
    if (!af->f) return gv_fail("%s: cannot create a temporary file beside it", af->path);
    if (existing) (void)fchmod(fileno(af->f), existing->st_mode & 07777); /* keep its permissions */
    return 0;
}

int gv_atomic_open(gv_atomic_file *af, const char *path)
{
    memset(af, 0, sizeof *af);
    if (snprintf(af->path, sizeof af->path, "%s", path) >= (int)sizeof af->path)
        return gv_fail("%s: path too long", path);
    if (gv_path_follow_links(path, af->target, sizeof af->target)) return -1;
    struct stat st;
    if (stat(af->target, &st) != 0) return open_temporary(af, NULL);
    if (S_ISREG(st.st_mode)) return open_temporary(af, &st);
    if (S_ISDIR(st.st_mode)) return gv_fail("%s: is a directory; give a file name", path);
    af->f = fopen(af->target, "wb"); /* a device or FIFO: write into it, never rename over it */
    if (!af->f) return gv_fail("%s: cannot write: %s", path, strerror(errno));
    af->direct = 1;
    return 0;
}

int gv_atomic_commit(gv_atomic_file *af)
{
    int err = 0;
    const char *what = "write error";
    if (ferror(af->f)) err = write_errno();
    if (fflush(af->f) != 0 && !err) err = errno;
    if (!err && sync_fd(fileno(af->f)) != 0) { err = errno; what = "cannot sync to disk"; }
    if (fclose(af->f) != 0 && !err) err = errno;
    af->f = NULL;
    if (err) {
        if (!af->direct) unlink(af->tmp_path);
        return gv_fail("%s: %s: %s", af->path, what, strerror(err));
    }
    if (af->direct) return 0;
    if (rename(af->tmp_path, af->target) != 0) {
        err = errno;
        unlink(af->tmp_path);
        return gv_fail("%s: cannot rename into place: %s", af->path, strerror(err));
    }
    sync_folder(af->target);
    return 0;
}

void gv_atomic_abort(gv_atomic_file *af)
{
    if (af->f) fclose(af->f);
    af->f = NULL;
    if (!af->direct && af->tmp_path[0]) unlink(af->tmp_path);
}

/* The writer's pid in a temporary's name NAME.tmp.PID or NAME.tmp.PID.K, or 0. */
static long temporary_pid(const char *name)
{
    const char *tmp = NULL;
    for (const char *p = strstr(name, ".tmp."); p; p = strstr(p + 1, ".tmp.")) tmp = p;
    if (!tmp) return 0;
    char *end;
    long pid = strtol(tmp + 5, &end, 10);
    if (end == tmp + 5 || pid <= 0) return 0;
    if (*end == '.') {
        const char *k = end + 1;
        strtol(k, &end, 10);
        if (end == k) return 0;
    }
    return *end ? 0 : pid;
}

int gv_atomic_sweep(const char *dir, const char *prefix)
{
    DIR *d = opendir(dir);
    if (!d) return 0;
    size_t n = prefix ? strlen(prefix) : 0;
    int removed = 0;
    for (struct dirent *e; (e = readdir(d));) {
        long pid = temporary_pid(e->d_name);
        if (!pid || pid == (long)getpid() || (n && strncmp(e->d_name, prefix, n))) continue;
        if (kill((pid_t)pid, 0) == 0 || errno == EPERM) continue; /* alive: it may be writing */
        char path[4096];
        if (gv_path_join(path, sizeof path, dir, e->d_name) == 0 && unlink(path) == 0) removed++;
    }
    closedir(d);
    return removed;
}

int gv_atomic_sweep_beside(const char *path)
{
    char folder[4096];
    folder_of(path, folder, sizeof folder);
    const char *slash = strrchr(path, '/');
    return gv_atomic_sweep(folder, slash ? slash + 1 : path);
}
