/* The video stage of `reconstruct`: the frames of video_frames.c (a fly-through along the
 * training cameras, then the evaluated frames side by side, labelled) encoded to
 * nN/flythrough.mp4 by Debian's ffmpeg program (H.264 in MP4, yuv420p, the size padded to even
 * numbers), fed raw RGB through a pipe. It writes to a temporary beside the video and renames on success (the
 * atomic writer's naming, so gv_atomic_sweep removes a killed run's leftover); ffmpeg's own
 * messages go to nN/flythrough.log. */
#include <errno.h>
#include <fcntl.h>
#include <signal.h>
#include <stdlib.h>
#include <string.h>
#include <sys/wait.h>
#include <unistd.h>

#include "gaussvid/core/core.h"
#include "pipeline/pipeline_internal.h"

int pipeline_find_ffmpeg(const gv_reconstruct_options *o, char *out, size_t size)
{
    if (gv_find_program(o->ffmpeg ? o->ffmpeg : "ffmpeg", out, size) == 0) return 0;
    if (o->ffmpeg) return gv_fail("%s: not an executable ffmpeg program", o->ffmpeg);
    return gv_fail("ffmpeg is not installed: the video stage needs Debian's ffmpeg (scripts/setup.sh installs it; "
                   "or stop earlier with --stop-after evaluate)");
}

/* Starts ffmpeg reading W x H RGB frames on a pipe; *to_ffmpeg is its stdin. */
static pid_t start_ffmpeg(const char *ffmpeg, int W, int H, double fps, const char *tmp, const char *log, int *to_ffmpeg)
{
    char size[32], rate[32];
    snprintf(size, sizeof size, "%dx%d", W, H);
    snprintf(rate, sizeof rate, "%g", fps);
    int fd[2];
    if (pipe(fd)) return -1;
    pid_t pid = fork();
    if (pid == 0) {
        int lf = open(log, O_WRONLY | O_CREAT | O_TRUNC, 0644);
        dup2(fd[0], 0);
        if (lf >= 0) dup2(lf, 1), dup2(lf, 2);
        close(fd[0]), close(fd[1]);
        execl(ffmpeg, ffmpeg, "-nostdin", "-hide_banner", "-loglevel", "error", "-y", "-f", "rawvideo", "-pix_fmt",
              "rgb24", "-s", size, "-r", rate, "-i", "pipe:0", "-pix_fmt", "yuv420p", "-movflags", "+faststart", "-f",
              "mp4", tmp, (char *)NULL);
        _exit(127);
    }
    close(fd[0]);
    if (pid < 0) {
        close(fd[1]);
        return -1;
    }
    *to_ffmpeg = fd[1];
    return pid;
}

static int write_all(int fd, const uint8_t *p, size_t n)
{
    while (n > 0) {
        ssize_t k = write(fd, p, n);
        if (k < 0 && errno == EINTR) continue;
        if (k <= 0) return -1;
        p += k, n -= (size_t)k;
    }
    return 0;
}

int pipeline_video(pipeline_run *r)
{
    char ffmpeg[4200], video[4200], tmp[4300], log[4200];
    if (pipeline_find_ffmpeg(r->opt, ffmpeg, sizeof ffmpeg) || pipeline_file(r, "flythrough.mp4", video, sizeof video) ||
        pipeline_file(r, "flythrough.log", log, sizeof log))
        return -1;
    snprintf(tmp, sizeof tmp, "%s.tmp.%ld", video, (long)getpid());
    pipeline_video_frames v;
    if (pipeline_video_open(&v, r)) return -1;
    int W = v.W, H = v.H;
    uint8_t *frame = calloc((size_t)W * H * 3, 1);
    if (!frame) {
        pipeline_video_close(&v);
        return gv_fail("out of memory for a %dx%d video frame", W, H);
    }
    int to_ffmpeg = -1, rc = 0;
    void (*old_pipe)(int) = signal(SIGPIPE, SIG_IGN); /* ffmpeg failing must not kill us */
    pid_t pid = start_ffmpeg(ffmpeg, W, H, r->opt->fps, tmp, log, &to_ffmpeg);
    if (pid < 0) rc = gv_fail("%s: cannot start: %s", ffmpeg, strerror(errno));
    gv_progress bar;
    char label[48];
    snprintf(label, sizeof label, "video n=%d", r->interval);
    gv_progress_start(&bar, label, v.n_total);
    for (int i = 0; i < v.n_total && rc == 0; i++) {
        rc = pipeline_video_frame(&v, i, frame);
        if (rc == 0 && write_all(to_ffmpeg, frame, (size_t)W * H * 3))
            rc = gv_fail("%s: ffmpeg stopped reading frames (its messages: %s)", video, log);
        gv_progress_update(&bar, i + 1, NULL);
    }
    gv_progress_finish(&bar);
    if (to_ffmpeg >= 0) close(to_ffmpeg);
    int status = 0;
    if (pid > 0 && waitpid(pid, &status, 0) == pid && rc == 0 && (!WIFEXITED(status) || WEXITSTATUS(status)))
        rc = gv_fail("%s: ffmpeg failed (exit %d; its messages: %s)", video,
                     WIFEXITED(status) ? WEXITSTATUS(status) : -1, log);
    signal(SIGPIPE, old_pipe);
    if (rc == 0 && rename(tmp, video)) rc = gv_fail("%s: cannot rename the video into place: %s", video, strerror(errno));
    if (rc) unlink(tmp);
    free(frame);
    if (rc == 0)
        snprintf(r->summary, sizeof r->summary,
                 "%s: %d frames at %g fps: a fly-through of %d frames through the %d training views (sparse%s%s), "
                 "then the %d %s frames (render%s%s)",
                 video, v.n_total, r->opt->fps, v.n_flight, r->n_train, v.restoring ? " | refined" : "",
                 v.truth ? " | nearest photo" : "", r->n_frames, r->smooth_path ? "path" : "held-out",
                 v.restoring ? " | restored" : "", v.truth ? " | ground truth" : "");
    pipeline_video_close(&v);
    return rc;
}
