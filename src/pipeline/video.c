/* The video stage of `reconstruct`: the evaluated frames in path order, render | restored |
 * ground truth (when the frame has it; no restored panel with --no-restore) side by side, encoded to nN/flythrough.mp4 by Debian's
 * ffmpeg program (H.264 in MP4, yuv420p, the size padded to even numbers), fed raw RGB
 * through a pipe. It writes to a temporary beside the video and renames on success (the
 * atomic writer's naming, so gv_atomic_sweep removes a killed run's leftover); ffmpeg's own
 * messages go to nN/flythrough.log. */
#include <errno.h>
#include <fcntl.h>
#include <signal.h>
#include <stdlib.h>
#include <string.h>
#include <sys/wait.h>
#include <unistd.h>

#include "gaussvid/core.h"
#include "pipeline/pipeline_internal.h"

int pipeline_find_ffmpeg(const gv_reconstruct_options *o, char *out, size_t size)
{
    if (gv_find_program(o->ffmpeg ? o->ffmpeg : "ffmpeg", out, size) == 0) return 0;
    if (o->ffmpeg) return gv_fail("%s: not an executable ffmpeg program", o->ffmpeg);
    return gv_fail("ffmpeg is not installed: the video stage needs Debian's ffmpeg (scripts/setup.sh installs it; "
                   "or stop earlier with --stop-after evaluate)");
}

/* The panels of a frame, left to right: "render", "restored" (unless --no-restore) and
 * "truth" (when the frames have ground truth). */
static int panel_list(const pipeline_run *r, const char *panels[3])
{
    int n = 0;
    panels[n++] = "render";
    if (r->opt->restore_with != GV_RESTORE_NONE) panels[n++] = "restored";
    if (r->frames[0].truth >= 0) panels[n++] = "truth";
    return n;
}

/* One side-by-side frame: the panels of frame i, each w x h, into out (W x H, W, H even). */
static int compose(pipeline_run *r, int i, const char *const *names, int panels, int w, int h, int W, uint8_t *out)
{
    const pipeline_frame *f = &r->frames[i];
    memset(out, 0, (size_t)W * h * 3 + (size_t)W * 3 * (size_t)(h & 1));
    for (int p = 0; p < panels; p++) {
        gv_image img = {0};
        char path[4200];
        int rc = strcmp(names[p], "truth") ? pipeline_frame_path(r, names[p], f->index, path, sizeof path) ||
                                                 gv_image_read_rgb(path, &img)
                                           : gv_scene_load_image(r->scene, f->truth, &img);
        if (rc == 0 && (img.width != w || img.height != h))
            rc = gv_fail("%s: frame %d is %dx%d, not %dx%d", r->dir, f->index, img.width, img.height, w, h);
        for (int y = 0; rc == 0 && y < h; y++)
            memcpy(out + ((size_t)y * W + (size_t)p * w) * 3, img.pixels + (size_t)y * w * 3, (size_t)w * 3);
        gv_image_free(&img);
        if (rc) return -1;
    }
    return 0;
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
    const char *names[3];
    int w = r->frames[0].camera.width, h = r->frames[0].camera.height, panels = panel_list(r, names);
    int W = (panels * w + 1) & ~1, H = (h + 1) & ~1;
    uint8_t *frame = calloc((size_t)W * H * 3, 1);
    if (!frame) return gv_fail("out of memory for a %dx%d video frame", W, H);
    int to_ffmpeg = -1, rc = 0;
    void (*old_pipe)(int) = signal(SIGPIPE, SIG_IGN); /* ffmpeg failing must not kill us */
    pid_t pid = start_ffmpeg(ffmpeg, W, H, r->opt->fps, tmp, log, &to_ffmpeg);
    if (pid < 0) rc = gv_fail("%s: cannot start: %s", ffmpeg, strerror(errno));
    gv_progress bar;
    char label[48];
    snprintf(label, sizeof label, "video n=%d", r->n);
    gv_progress_start(&bar, label, r->n_frames);
    for (int i = 0; i < r->n_frames && rc == 0; i++) {
        rc = compose(r, i, names, panels, w, h, W, frame);
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
    if (rc == 0) {
        char layout[64] = "";
        for (int p = 0; p < panels; p++)
            snprintf(layout + strlen(layout), sizeof layout - strlen(layout), "%s%s", p ? " | " : "",
                     strcmp(names[p], "truth") ? names[p] : "ground truth");
        snprintf(r->summary, sizeof r->summary, "%s: %d frames at %g fps, %s%s", video, r->n_frames, r->opt->fps, layout,
                 panels > 1 ? " side by side" : "");
    }
    return rc;
}
