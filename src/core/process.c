/* Running the external programs gaussvid uses (COLMAP for `scene colmap`, ffmpeg for the
 * video of `reconstruct`): finding them on the PATH and running one with its output in a log. */
#include <errno.h>
#include <fcntl.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/wait.h>
#include <unistd.h>

#include "gaussvid/core/core.h"

int gv_find_program(const char *name, char *out, size_t size)
{
    if (strchr(name, '/')) {
        snprintf(out, size, "%s", name);
        return access(out, X_OK) ? -1 : 0;
    }
    const char *path = getenv("PATH");
    char dirs[8192];
    snprintf(dirs, sizeof dirs, "%s", path ? path : "/usr/bin:/bin");
    for (char *save = NULL, *d = strtok_r(dirs, ":", &save); d; d = strtok_r(NULL, ":", &save)) {
        snprintf(out, size, "%s/%s", d, name);
        if (!access(out, X_OK)) return 0;
    }
    return -1;
}

int gv_run_logged(const char *const argv[], const char *log)
{
    int lf = open(log, O_WRONLY | O_CREAT | O_APPEND, 0644);
    if (lf < 0) return gv_fail("%s: cannot open: %s", log, strerror(errno));
    fflush(stdout), fflush(stderr);
    pid_t pid = fork();
    if (pid == 0) {
        int null = open("/dev/null", O_RDONLY);
        if (null >= 0) dup2(null, 0);
        dup2(lf, 1), dup2(lf, 2);
        execv(argv[0], (char *const *)argv);
        _exit(127);
    }
    close(lf);
    if (pid < 0) return gv_fail("%s: cannot start: %s", argv[0], strerror(errno));
    int status;
    while (waitpid(pid, &status, 0) < 0)
        if (errno != EINTR) return gv_fail("%s: lost: %s", argv[0], strerror(errno));
    if (WIFEXITED(status)) return WEXITSTATUS(status);
    return 128 + (WIFSIGNALED(status) ? WTERMSIG(status) : 0);
}

/* Splits the bytes read into lines for the caller (a line longer than the buffer is cut). */
typedef struct {
    char line[1024];
    size_t len;
    gv_line_fn on_line;
    void *ctx;
} line_splitter;

static void split_lines(line_splitter *s, const char *data, size_t n)
{
    for (size_t i = 0; i < n; i++) {
        char c = data[i];
        if (c == '\n' || c == '\r' || s->len == sizeof s->line - 1) {
            s->line[s->len] = 0;
            if (s->len) s->on_line(s->line, s->ctx);
            s->len = 0;
            if (c == '\n' || c == '\r') continue;
        }
        s->line[s->len++] = c;
    }
}

int gv_run_watched(const char *const argv[], const char *log, gv_line_fn on_line, void *ctx)
{
    int lf = open(log, O_WRONLY | O_CREAT | O_APPEND, 0644);
    if (lf < 0) return gv_fail("%s: cannot open: %s", log, strerror(errno));
    int fds[2];
    if (pipe(fds)) {
        close(lf);
        return gv_fail("%s: cannot make a pipe: %s", argv[0], strerror(errno));
    }
    fflush(stdout), fflush(stderr);
    pid_t pid = fork();
    if (pid == 0) {
        int null = open("/dev/null", O_RDONLY);
        if (null >= 0) dup2(null, 0);
        dup2(fds[1], 1), dup2(fds[1], 2);
        close(fds[0]), close(fds[1]), close(lf);
        execv(argv[0], (char *const *)argv);
        _exit(127);
    }
    close(fds[1]);
    if (pid < 0) {
        close(fds[0]), close(lf);
        return gv_fail("%s: cannot start: %s", argv[0], strerror(errno));
    }
    line_splitter s = {.len = 0, .on_line = on_line, .ctx = ctx};
    char buf[4096];
    for (;;) {
        ssize_t n = read(fds[0], buf, sizeof buf);
        if (n < 0 && errno == EINTR) continue;
        if (n <= 0) break;
        ssize_t written = write(lf, buf, (size_t)n); /* the log is a record; a full disk does not stop the run */
        (void)written;
        split_lines(&s, buf, (size_t)n);
    }
    split_lines(&s, "\n", 1);
    close(fds[0]), close(lf);
    int status;
    while (waitpid(pid, &status, 0) < 0)
        if (errno != EINTR) return gv_fail("%s: lost: %s", argv[0], strerror(errno));
    if (WIFEXITED(status)) return WEXITSTATUS(status);
    return 128 + (WIFSIGNALED(status) ? WTERMSIG(status) : 0);
}
