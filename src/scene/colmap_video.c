/* Frames of a video for `scene colmap --video` (colmap_internal.h): ffmpeg takes fps frames a
 * second (its `fps` filter) as JPEG (-q:v 2, its finest scale but one) into OUT/frames/
 * frame_00001.jpg ..., turned upright as ffmpeg does by default with a phone video's rotation;
 * OUT/frames/video.txt records the video and rate, so that a rerun keeps the frames (and
 * COLMAP's database of them). Written to OUT/frames.tmp and renamed when complete. */
#include <dirent.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

#include "colmap_internal.h"

/* Removes the files of a folder (no subfolders there) and the folder. */
static void remove_flat_dir(const char *dir)
{
    DIR *d = opendir(dir);
    if (!d) return;
    struct dirent *e;
    while ((e = readdir(d))) {
        if (!strcmp(e->d_name, ".") || !strcmp(e->d_name, "..")) continue;
        char path[COLMAP_PATH + 300];
        snprintf(path, sizeof path, "%s/%s", dir, e->d_name);
        remove(path);
    }
    closedir(d);
    rmdir(dir);
}

int colmap_video_frames(const gv_colmap_run_options *o, char *frames_dir, size_t size, double *seconds)
{
    *seconds = 0;
    struct stat st;
    if (stat(o->video, &st) || !S_ISREG(st.st_mode)) return gv_fail("%s: no such video file", o->video);
    char ffmpeg[COLMAP_PATH], record[COLMAP_PATH + 16], tmp[COLMAP_PATH], pattern[COLMAP_PATH + 32], vf[64];
    char log[COLMAP_PATH + 32], stamp[COLMAP_PATH + 128];
    if (gv_find_program(o->ffmpeg ? o->ffmpeg : "ffmpeg", ffmpeg, sizeof ffmpeg))
        return gv_fail("ffmpeg is not installed: --video needs it to take the frames (scripts/setup.sh installs it)");
    snprintf(frames_dir, size, "%s/frames", o->out_dir);
    snprintf(record, sizeof record, "%s/video.txt", frames_dir);
    snprintf(stamp, sizeof stamp, "%s %lld %lld fps=%g", o->video, (long long)st.st_size, (long long)st.st_mtime, o->fps);
    char *old = NULL;
    size_t old_size;
    if (gv_file_exists(record) && gv_read_file(record, &old, &old_size) == 0) {
        int same = !strncmp(old, stamp, strlen(stamp)) && old[strlen(stamp)] == '\n';
        free(old);
        if (same) {
            gv_info("the frames of %s at %g a second are in %s already", o->video, o->fps, frames_dir);
            return 0;
        }
    }
    snprintf(tmp, sizeof tmp, "%s/frames.tmp", o->out_dir);
    snprintf(pattern, sizeof pattern, "%s/frame_%%05d.jpg", tmp);
    snprintf(vf, sizeof vf, "fps=%g", o->fps);
    snprintf(log, sizeof log, "%s/frames.log", o->out_dir);
    remove_flat_dir(tmp);
    if (gv_mkdirs(tmp)) return -1;
    gv_info("ffmpeg: the frames of %s at %g a second (log: %s)", o->video, o->fps, log);
    const char *argv[] = {ffmpeg, "-nostdin", "-y", "-i", o->video, "-vf", vf, "-q:v", "2", "-start_number", "1",
                          pattern, NULL};
    double start = gv_now();
    int status = gv_run_logged(argv, log);
    *seconds = gv_now() - start;
    if (status < 0) return -1;
    if (status) return gv_fail("%s: ffmpeg could not take its frames (exit %d); its messages are in %s", o->video,
                               status, log);
    snprintf(pattern, sizeof pattern, "%s/video.txt", tmp);
    if (gv_write_text_atomic(pattern, stamp)) return -1;
    remove_flat_dir(frames_dir);
    if (rename(tmp, frames_dir)) return gv_fail("%s: cannot rename to %s", tmp, frames_dir);
    remove(log);
    return 0;
}
