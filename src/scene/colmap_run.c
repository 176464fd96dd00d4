/* `gaussvid scene colmap` (scene_colmap.h): COLMAP's four steps on a folder of photos, then the
 * undistorted result written as a scene folder. COLMAP runs headless (QT_QPA_PLATFORM=offscreen,
 * no GPU: --SiftExtraction.use_gpu 0, --SiftMatching.use_gpu 0); its messages go to
 * OUT/colmap/colmap.log. */
#include <dirent.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>
#include <strings.h>
#include <unistd.h>

#include "gaussvid/colmap.h"
#include "gaussvid/core.h"
#include "gaussvid/image.h"
#include "gaussvid/scene.h"
#include "gaussvid/scene_colmap.h"

typedef struct {
    int n;
    char (*names)[GV_COLMAP_MAX_NAME];
} photo_list;

void gv_colmap_run_defaults(gv_colmap_run_options *o)
{
    memset(o, 0, sizeof *o);
    o->camera_model = "SIMPLE_RADIAL";
    o->single_camera = 1;
    o->matcher = "exhaustive";
    o->min_registered = 0.5;
}

static int is_photo(const char *name)
{
    const char *dot = strrchr(name, '.');
    return dot && (!strcasecmp(dot, ".png") || !strcasecmp(dot, ".jpg") || !strcasecmp(dot, ".jpeg"));
}

static int by_name(const void *a, const void *b) { return strcmp(a, b); }

/* The photos of the folder, sorted by name, each decoded once (an unreadable one fails here,
 * naming it, rather than being skipped by COLMAP); with one camera they must share a size. */
static int list_photos(const gv_colmap_run_options *o, photo_list *p)
{
    DIR *d = opendir(o->images_dir);
    if (!d) return gv_fail("%s: no such folder of photos", o->images_dir);
    int cap = 0;
    struct dirent *e;
    while ((e = readdir(d))) {
        if (e->d_name[0] == '.' || !is_photo(e->d_name)) continue;
        if (strlen(e->d_name) >= GV_COLMAP_MAX_NAME) {
            closedir(d);
            return gv_fail("%s/%s: name longer than %d bytes", o->images_dir, e->d_name, GV_COLMAP_MAX_NAME - 1);
        }
        if (p->n == cap) {
            cap = cap ? 2 * cap : 64;
            void *grown = realloc(p->names, (size_t)cap * sizeof *p->names);
            if (!grown) {
                closedir(d);
                return gv_fail("out of memory for %d photo names", cap);
            }
            p->names = grown;
        }
        snprintf(p->names[p->n++], GV_COLMAP_MAX_NAME, "%s", e->d_name);
    }
    closedir(d);
    if (p->n < 3) return gv_fail("%s: %d photos (.png, .jpg, .jpeg); COLMAP needs at least 3", o->images_dir, p->n);
    qsort(p->names, (size_t)p->n, sizeof *p->names, by_name);
    gv_progress bar;
    gv_progress_start(&bar, "read photos", p->n);
    int w = 0, h = 0, rc = 0;
    for (int i = 0; i < p->n && rc == 0; i++) {
        char path[4400];
        gv_image img = {0};
        snprintf(path, sizeof path, "%s/%s", o->images_dir, p->names[i]);
        if (gv_image_read(path, &img)) rc = -1; /* the reader's line names the file */
        else if (i == 0) w = img.width, h = img.height;
        else if (o->single_camera && (img.width != w || img.height != h))
            rc = gv_fail("%s: %dx%d, but %s is %dx%d: photos of one camera share a size", path, img.width, img.height,
                         p->names[0], w, h);
        gv_image_free(&img);
        gv_progress_update(&bar, i + 1, NULL);
    }
    gv_progress_finish(&bar);
    return rc;
}

/* Removes the models of an earlier run (sparse/0, sparse/1, ...: the files COLMAP writes
 * there), so that the largest model is this run's. */
static void remove_old_models(const char *sparse)
{
    static const char *const files[] = {"cameras.bin", "images.bin", "points3D.bin", "project.ini", "frames.bin",
                                        "rigs.bin"};
    for (int k = 0;; k++) {
        char dir[4200], path[4300];
        snprintf(dir, sizeof dir, "%s/%d", sparse, k);
        if (!gv_dir_exists(dir)) break;
        for (size_t i = 0; i < sizeof files / sizeof files[0]; i++) {
            snprintf(path, sizeof path, "%s/%s", dir, files[i]);
            remove(path);
        }
        rmdir(dir);
    }
}

/* One COLMAP step; fails naming it and the log. */
static int colmap_step(const char *const argv[], const char *log, double *seconds)
{
    double start = gv_now();
    gv_info("colmap %s (log: %s)", argv[1], log);
    int status = gv_run_logged(argv, log);
    *seconds = gv_now() - start;
    if (status < 0) return -1;
    if (status) return gv_fail("colmap %s failed (exit %d); its messages are in %s", argv[1], status, log);
    return 0;
}

/* The mapper's largest model (sparse/0, sparse/1, ...): its index and image count. */
static int largest_model(const char *sparse, gv_colmap_run_result *r, int *best)
{
    *best = -1;
    r->registered = r->models = 0;
    for (int k = 0;; k++) {
        char dir[4200];
        snprintf(dir, sizeof dir, "%s/%d", sparse, k);
        if (!gv_dir_exists(dir)) break;
        gv_colmap_model m;
        memset(&m, 0, sizeof m);
        char images[4300];
        snprintf(images, sizeof images, "%s/images.bin", dir); /* its cameras are still distorted */
        if (gv_colmap_read_images_bin(images, &m)) return gv_fail_context("the model COLMAP mapped");
        r->models++;
        if (m.n_images > r->registered) r->registered = m.n_images, *best = k;
        gv_colmap_free(&m);
    }
    return 0;
}

static int copy_file(const char *from, const char *to)
{
    FILE *in = fopen(from, "rb");
    if (!in) return gv_fail("%s: cannot open", from);
    gv_atomic_file af;
    if (gv_atomic_open(&af, to)) {
        fclose(in);
        return -1;
    }
    char buf[65536];
    size_t n;
    while ((n = fread(buf, 1, sizeof buf, in)) > 0)
        if (fwrite(buf, 1, n, af.f) != n) break;
    int bad = ferror(in) || !feof(in);
    fclose(in);
    if (bad) {
        gv_atomic_abort(&af);
        return gv_fail("%s: read error", from);
    }
    return gv_atomic_commit(&af);
}

/* The undistorted model as the scene folder: images/ copied, sparse/0 as text, then the
 * scene loaded (every check of gv_scene_load) and its transforms.json and points3D.ply. */
static int write_scene(const gv_colmap_run_options *o, const char *undistorted, gv_colmap_run_result *r)
{
    char sparse[4200], dir[4200], from[4600], to[4600];
    gv_colmap_model m;
    memset(&m, 0, sizeof m);
    snprintf(sparse, sizeof sparse, "%s/sparse", undistorted);
    if (gv_colmap_read_bin(sparse, &m)) return gv_fail_context("the undistorted model");
    r->points = m.n_points;
    int rc = 0;
    for (int i = 0; i < m.n_images && rc == 0; i++) {
        snprintf(from, sizeof from, "%s/images/%s", undistorted, m.images[i].name);
        snprintf(to, sizeof to, "%s/images/%s", o->out_dir, m.images[i].name);
        char *slash = strrchr(to, '/');
        *slash = 0;
        rc = gv_mkdirs(to);
        *slash = '/';
        if (rc == 0) rc = copy_file(from, to);
    }
    snprintf(dir, sizeof dir, "%s/sparse/0", o->out_dir);
    if (rc == 0) rc = gv_mkdirs(dir) || gv_colmap_write_text(dir, &m);
    gv_colmap_free(&m);
    gv_scene scene;
    if (rc == 0 && (rc = gv_scene_load(o->out_dir, NULL, &scene)) == 0) {
        rc = gv_scene_write(o->out_dir, &scene);
        gv_scene_free(&scene);
    }
    return rc;
}

int gv_scene_colmap(const gv_colmap_run_options *o, gv_colmap_run_result *r)
{
    memset(r, 0, sizeof *r);
    char colmap[4200];
    if (gv_find_program(o->colmap ? o->colmap : "colmap", colmap, sizeof colmap))
        return o->colmap ? gv_fail("%s: not an executable COLMAP program", o->colmap)
                         : gv_fail("colmap is not installed: scene colmap needs Debian's colmap package "
                                   "(scripts/setup.sh installs it)");
    if (strcmp(o->matcher, "exhaustive") && strcmp(o->matcher, "sequential"))
        return gv_fail("matcher %s: expected exhaustive or sequential", o->matcher);
    photo_list photos = {0};
    int rc = list_photos(o, &photos);
    r->images = photos.n;
    char work[4200], db[4300], list[4300], log[4300], sparse[4300], undistorted[4300], matcher[64], threads[16];
    snprintf(work, sizeof work, "%s/colmap", o->out_dir);
    snprintf(db, sizeof db, "%s/database.db", work);
    snprintf(list, sizeof list, "%s/image_list.txt", work);
    snprintf(log, sizeof log, "%s/colmap.log", work);
    snprintf(sparse, sizeof sparse, "%s/sparse", work);
    snprintf(undistorted, sizeof undistorted, "%s/undistorted", work);
    snprintf(matcher, sizeof matcher, "%s_matcher", o->matcher);
    snprintf(threads, sizeof threads, "%d", o->threads > 0 ? o->threads : -1);
    if (rc == 0) rc = gv_mkdirs(work) || gv_mkdirs(sparse);
    if (rc == 0) { /* a fresh database and no old models: COLMAP would add to an old database */
        remove(db);
        remove_old_models(sparse);
        size_t size = (size_t)photos.n * GV_COLMAP_MAX_NAME + 1, len = 0;
        char *text = malloc(size);
        if (!text) rc = gv_fail("out of memory");
        for (int i = 0; text && i < photos.n; i++) len += (size_t)snprintf(text + len, size - len, "%s\n", photos.names[i]);
        if (text && len) text[len - 1] = 0; /* gv_write_text_atomic adds the last newline */
        if (rc == 0) rc = gv_write_text_atomic(list, text);
        free(text);
    }
    free(photos.names);
    setenv("QT_QPA_PLATFORM", "offscreen", 1); /* no display: COLMAP's Qt must not look for one */
    const char *extract[] = {colmap, "feature_extractor", "--database_path", db, "--image_path", o->images_dir,
                             "--image_list_path", list, "--ImageReader.camera_model", o->camera_model,
                             "--ImageReader.single_camera", o->single_camera ? "1" : "0", "--SiftExtraction.use_gpu",
                             "0", "--SiftExtraction.num_threads", threads, NULL};
    const char *match[] = {colmap, matcher, "--database_path", db, "--SiftMatching.use_gpu", "0",
                           "--SiftMatching.num_threads", threads, NULL};
    const char *map[] = {colmap, "mapper", "--database_path", db, "--image_path", o->images_dir, "--output_path", sparse,
                         "--Mapper.num_threads", threads, NULL};
    if (rc == 0) rc = colmap_step(extract, log, &r->seconds[0]);
    if (rc == 0) rc = colmap_step(match, log, &r->seconds[1]);
    /* The mapper fails when it finds no initial pair: that is "0 registered", said below. */
    if (rc == 0 && colmap_step(map, log, &r->seconds[2])) gv_info("%s", gv_last_error());
    int best = -1;
    if (rc == 0) rc = largest_model(sparse, r, &best);
    int needed = (int)ceil(o->min_registered * photos.n);
    if (needed < 3) needed = 3;
    if (rc == 0 && r->registered < needed)
        rc = gv_fail("%s: COLMAP registered %d of %d photos (at least %d needed): the photos may overlap too little "
                     "or lack texture; its messages are in %s", o->images_dir, r->registered, photos.n, needed, log);
    char model[4400];
    snprintf(model, sizeof model, "%s/%d", sparse, best);
    const char *undistort[] = {colmap, "image_undistorter", "--image_path", o->images_dir, "--input_path", model,
                               "--output_path", undistorted, "--output_type", "COLMAP", NULL};
    if (rc == 0) rc = colmap_step(undistort, log, &r->seconds[3]);
    if (rc == 0) rc = write_scene(o, undistorted, r);
    return rc;
}
