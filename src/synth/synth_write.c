/* Writing a synthesised scene folder: everything goes into a fresh temporary sibling
 * (DIR.partial-XXXXXX) that is renamed to DIR only when complete, so an interrupted run never
 * leaves a folder that looks like a scene. A previous synthesised scene at DIR (it has a
 * synth.txt) is replaced; any other non-empty DIR is refused. */
#include "synth/synth_internal.h"

#include <dirent.h>
#include <errno.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

static const char *const scene_files[] = {
    "transforms.json", "points3D.ply", "synth.txt", "sparse/0/cameras.txt", "sparse/0/images.txt",
    "sparse/0/points3D.txt",
};
static const char *const scene_dirs[] = {"sparse/0", "sparse", "images"};

static int dir_is_empty(const char *path)
{
    DIR *d = opendir(path);
    if (!d) return 0;
    struct dirent *e;
    int empty = 1;
    while (empty && (e = readdir(d)))
        if (strcmp(e->d_name, ".") && strcmp(e->d_name, "..")) empty = 0;
    closedir(d);
    return empty;
}

/* Removes what a synthesised scene consists of (and nothing else) and the folders if they
 * are then empty; returns 0 when the folder itself is gone. */
static int remove_scene_files(const char *dir)
{
    char path[4200];
    snprintf(path, sizeof path, "%s/images", dir);
    DIR *d = opendir(path);
    if (d) {
        struct dirent *e;
        while ((e = readdir(d))) {
            size_t len = strlen(e->d_name);
            if (!strncmp(e->d_name, "frame_", 6) && len > 4 && !strcmp(e->d_name + len - 4, ".png")) {
                snprintf(path, sizeof path, "%s/images/%s", dir, e->d_name);
                unlink(path);
            }
        }
        closedir(d);
    }
    for (size_t i = 0; i < sizeof scene_files / sizeof *scene_files; i++) {
        snprintf(path, sizeof path, "%s/%s", dir, scene_files[i]);
        unlink(path);
    }
    for (size_t i = 0; i < sizeof scene_dirs / sizeof *scene_dirs; i++) {
        snprintf(path, sizeof path, "%s/%s", dir, scene_dirs[i]);
        rmdir(path);
    }
    return rmdir(dir);
}

/* Frames are rendered in parallel, one per thread (no barriers inside a frame, which matters
 * on a busy machine); each is written by the thread that rendered it. */
static int render_frames(const gv_synth_world *w, const char *tmp)
{
    char dir[4200], message[1024] = "";
    snprintf(dir, sizeof dir, "%s/images", tmp);
    if (gv_mkdirs(dir)) return -1;
    gv_progress bar;
    gv_progress_start(&bar, "scene synth", w->params.n_frames);
    int failed = 0;
    long done = 0;
    #pragma omp parallel for schedule(dynamic, 1)
    for (int f = 0; f < w->params.n_frames; f++) {
        int stop;
        #pragma omp atomic read
        stop = failed;
        if (stop) continue;
        gv_image img;
        char path[4400];
        int rc = gv_synth_render(w, f, &img);
        if (!rc) {
            snprintf(path, sizeof path, "%s/%s", dir, w->cameras[f].name);
            rc = gv_image_write_png(path, &img);
            gv_image_free(&img);
        }
        #pragma omp critical(synth_frames)
        {
            if (rc && !failed) { /* keep the first failure's message */
                snprintf(message, sizeof message, "%s", gv_last_error());
                #pragma omp atomic write
                failed = 1;
            }
            gv_progress_update(&bar, ++done, NULL);
        }
    }
    if (failed) return gv_fail("%s", message);
    gv_progress_finish(&bar);
    return 0;
}

static int write_description(const gv_synth_world *w, const char *tmp)
{
    char text[2048], path[4200];
    if (gv_synth_describe(w, text, sizeof text)) return -1;
    snprintf(path, sizeof path, "%s/synth.txt", tmp);
    gv_atomic_file af;
    if (gv_atomic_open(&af, path)) return -1;
    fprintf(af.f, "Procedural scene made by 'gaussvid scene synth' (see docs/SYNTH.md)\n%s", text);
    return gv_atomic_commit(&af);
}

/* Renders, samples the points and writes every file of the scene into tmp. */
static int write_scene(const gv_synth_world *w, const char *tmp)
{
    if (render_frames(w, tmp)) return -1;
    gv_scene scene;
    memset(&scene, 0, sizeof scene);
    snprintf(scene.dir, sizeof scene.dir, "%s", tmp);
    snprintf(scene.image_dir, sizeof scene.image_dir, "%s/images", tmp);
    scene.downscale = 1;
    scene.memory_downscale = 1;
    scene.n_frames = w->params.n_frames;
    scene.cameras = w->cameras;
    if (gv_synth_points(w, &scene.points, &scene.colors, &scene.n_points)) return -1;
    int rc = gv_scene_write(tmp, &scene);
    if (!rc) gv_info("scene synth: %d points", scene.n_points);
    free(scene.points);
    free(scene.colors);
    return rc ? -1 : write_description(w, tmp);
}

/* Moves the finished tmp folder to dir, replacing a previous synthesised scene. */
static int move_into_place(const char *tmp, const char *dir)
{
    char old[4200] = "";
    if (gv_dir_exists(dir)) {
        if (dir_is_empty(dir)) {
            if (rmdir(dir)) return gv_fail("%s: cannot replace: %s", dir, strerror(errno));
        } else {
            snprintf(old, sizeof old, "%s.old-XXXXXX", dir);
            if (!mkdtemp(old)) return gv_fail("%s: cannot make a folder beside it: %s", dir, strerror(errno));
            if (rename(dir, old)) return gv_fail("%s: cannot move aside: %s", dir, strerror(errno));
        }
    }
    if (rename(tmp, dir)) {
        int err = errno;
        if (old[0]) rename(old, dir); /* put the previous scene back */
        return gv_fail("%s: cannot rename %s to it: %s", dir, tmp, strerror(err));
    }
    if (old[0] && remove_scene_files(old))
        gv_warn("scene synth: the previous scene's other files were kept in %s", old);
    return 0;
}

static int check_destination(const char *dir)
{
    char marker[4200];
    if (!gv_dir_exists(dir)) {
        if (gv_file_exists(dir)) return gv_fail("%s: exists and is not a folder", dir);
        return 0;
    }
    snprintf(marker, sizeof marker, "%s/synth.txt", dir);
    if (!dir_is_empty(dir) && !gv_file_exists(marker))
        return gv_fail("%s: exists and is not a synthesised scene (no synth.txt): choose another --out or remove it", dir);
    return 0;
}

int gv_synth_write(const gv_synth_params *p, const char *dir_in)
{
    char dir[4096], tmp[4200];
    if (gv_synth_check_params(p)) return -1;
    size_t len = strlen(dir_in);
    while (len > 1 && dir_in[len - 1] == '/') len--;
    if (len == 0 || len >= sizeof dir - 32) return gv_fail("scene synth: bad output folder '%s'", dir_in);
    memcpy(tmp, dir_in, len);
    tmp[len] = '\0';
    /* A link to a folder: the scene replaces the folder it names, never the link. */
    if (gv_path_follow_links(tmp, dir, sizeof dir - 32)) return -1;
    for (len = strlen(dir); len > 1 && dir[len - 1] == '/'; len--) dir[len - 1] = '\0';
    if (check_destination(dir)) return -1;
    snprintf(tmp, sizeof tmp, "%s", dir);
    char *slash = strrchr(tmp, '/');
    if (slash && slash != tmp) {
        *slash = '\0';
        if (gv_mkdirs(tmp)) return -1;
    }
    snprintf(tmp, sizeof tmp, "%s.partial-XXXXXX", dir);
    if (!mkdtemp(tmp)) return gv_fail("%s: cannot create a temporary folder beside it: %s", dir, strerror(errno));
    mode_t mask = umask(0); /* mkdtemp makes it private; the scene gets the usual permissions */
    umask(mask);
    chmod(tmp, 0777 & ~mask);

    double start = gv_now();
    gv_synth_world *w;
    int rc = gv_synth_build(p, &w);
    if (!rc) {
        gv_info("scene synth: built the scene in %.1f s (%d primitives, %ld lightmap texels)", gv_now() - start,
                w->n_prims, w->n_texels);
        rc = write_scene(w, tmp);
        gv_synth_free(w);
    }
    if (!rc) rc = move_into_place(tmp, dir);
    if (rc) {
        if (remove_scene_files(tmp) && gv_dir_exists(tmp)) gv_warn("scene synth: could not remove %s", tmp);
        return -1;
    }
    gv_info("scene synth: wrote %s in %.1f s", dir, gv_now() - start);
    return 0;
}
