/* `gaussvid scene colmap` (scene_colmap.h): COLMAP's steps on a folder of photos (or a video's
 * frames), each with a progress bar that follows COLMAP's own output, then the scene written
 * (colmap_output.c). COLMAP runs headless (QT_QPA_PLATFORM=offscreen, no GPU:
 * --SiftExtraction.use_gpu 0, --SiftMatching.use_gpu 0); its messages go to
 * OUT/colmap/colmap.log. Its output is read only for the bars: a line it words differently
 * leaves a bar behind, never the run wrong. */
#include <math.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "colmap_internal.h"

void gv_colmap_run_defaults(gv_colmap_run_options *o)
{
    memset(o, 0, sizeof *o);
    o->camera_model = "SIMPLE_RADIAL";
    o->single_camera = 1;
    o->fps = 2;
    o->downscales[0] = 2, o->downscales[1] = 4, o->downscales[2] = 8;
    o->n_downscales = 3;
    o->min_registered = 0.5;
}

void colmap_remove_models(const char *sparse)
{
    static const char *const files[] = {"cameras.bin", "images.bin", "points3D.bin", "project.ini", "frames.bin",
                                        "rigs.bin"};
    for (int k = 0;; k++) {
        char dir[COLMAP_PATH + 16], path[COLMAP_PATH + 64];
        snprintf(dir, sizeof dir, "%s/%d", sparse, k);
        if (!gv_dir_exists(dir)) break;
        for (size_t i = 0; i < sizeof files / sizeof files[0]; i++) {
            snprintf(path, sizeof path, "%s/%s", dir, files[i]);
            remove(path);
        }
        rmdir(dir);
    }
}

int colmap_step(const char *const argv[], const char *log, gv_line_fn on_line, void *ctx)
{
    gv_debug("colmap %s (log: %s)", argv[1], log);
    int status = on_line ? gv_run_watched(argv, log, on_line, ctx) : gv_run_logged(argv, log);
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
        char dir[COLMAP_PATH + 16], images[COLMAP_PATH + 32];
        snprintf(dir, sizeof dir, "%s/%d", sparse, k);
        if (!gv_dir_exists(dir)) break;
        gv_colmap_model m;
        memset(&m, 0, sizeof m);
        snprintf(images, sizeof images, "%s/images.bin", dir); /* its cameras are still distorted */
        if (gv_colmap_read_images_bin(images, &m)) return gv_fail_context("the model COLMAP mapped");
        r->models++;
        if (m.n_images > r->registered) r->registered = m.n_images, *best = k;
        gv_colmap_free(&m);
    }
    return 0;
}

/* Feature extraction as COLMAP reports it: "Processed file [i/N]", then "Features: K" or
 * "SKIP: Features for image already extracted." per photo. */
typedef struct {
    gv_progress bar;
    int done, skipped, extracted, fewest, most;
} feature_watch;

static void on_feature_line(const char *line, void *ctx)
{
    feature_watch *w = ctx;
    int i, n, k;
    while (*line == ' ') line++;
    if (sscanf(line, "Processed file [%d/%d]", &i, &n) == 2) w->done++;
    else if (!strncmp(line, "SKIP: Features for image already extracted", 42)) w->skipped++;
    else if (sscanf(line, "Features: %d", &k) == 1) {
        if (!w->extracted++ || k < w->fewest) w->fewest = k;
        if (k > w->most) w->most = k;
        gv_progress_update(&w->bar, w->done, "%d features", k);
        return;
    } else return;
    gv_progress_update(&w->bar, w->done, NULL);
}

static int extract_features(const colmap_paths *paths, const gv_colmap_run_options *o, int n)
{
    const char *argv[] = {paths->colmap, "feature_extractor", "--database_path", paths->db, "--image_path",
                          paths->images, "--image_list_path", paths->list, "--ImageReader.camera_model",
                          o->camera_model, "--ImageReader.single_camera", o->single_camera ? "1" : "0",
                          "--SiftExtraction.use_gpu", "0", "--SiftExtraction.num_threads", paths->threads, NULL};
    feature_watch w = {0};
    gv_progress_start(&w.bar, "features", n);
    int rc = colmap_step(argv, paths->log, on_feature_line, &w);
    gv_progress_finish(&w.bar);
    if (rc == 0 && w.extracted)
        gv_info("features: %d photos extracted, %d to %d features each", w.extracted, w.fewest, w.most);
    if (rc == 0 && w.skipped) gv_info("features: %d photos already in the database (skipped)", w.skipped);
    return rc;
}

/* The mapper: "Initializing with image pair" (2 registered), "Registering image #id (K)". */
static void on_mapper_line(const char *line, void *ctx)
{
    int id, k;
    if (!strncmp(line, "Initializing with image pair", 28)) gv_progress_update(ctx, 2, "registered");
    else if (sscanf(line, "Registering image #%d (%d)", &id, &k) == 2) gv_progress_update(ctx, k, "registered");
}

static int map_cameras(const colmap_paths *paths, int n, gv_colmap_run_result *r, int *best)
{
    const char *argv[] = {paths->colmap, "mapper", "--database_path", paths->db, "--image_path", paths->images,
                          "--output_path", paths->sparse, "--image_list_path", paths->list, "--Mapper.num_threads",
                          paths->threads, NULL};
    colmap_remove_models(paths->sparse);
    gv_progress bar;
    gv_progress_start(&bar, "map", n);
    /* The mapper fails when it finds no initial pair: that is "0 registered", said after. */
    if (colmap_step(argv, paths->log, on_mapper_line, &bar)) gv_info("%s", gv_last_error());
    gv_progress_finish(&bar);
    return largest_model(paths->sparse, r, best);
}

static int set_paths(const gv_colmap_run_options *o, const char *images, colmap_paths *paths)
{
    memset(paths, 0, sizeof *paths);
    paths->images = images;
    if (gv_find_program(o->colmap ? o->colmap : "colmap", paths->colmap, sizeof paths->colmap))
        return o->colmap ? gv_fail("%s: not an executable COLMAP program", o->colmap)
                         : gv_fail("colmap is not installed: scene colmap needs Debian's colmap package "
                                   "(scripts/setup.sh installs it)");
    if (o->vocab_tree && access(o->vocab_tree, R_OK)) return gv_fail("%s: no such vocabulary tree file", o->vocab_tree);
    if (strlen(o->out_dir) > COLMAP_PATH - 64) return gv_fail("%s: path too long", o->out_dir);
    snprintf(paths->work, sizeof paths->work, "%s/colmap", o->out_dir);
#define UNDER_WORK(field, name) snprintf(paths->field, sizeof paths->field, "%s/" name, paths->work)
    UNDER_WORK(db, "database.db");
    UNDER_WORK(log, "colmap.log");
    UNDER_WORK(list, "image_list.txt");
    UNDER_WORK(sparse, "sparse");
    UNDER_WORK(undistorted, "undistorted");
    UNDER_WORK(manifest, "photos.txt");
#undef UNDER_WORK
    snprintf(paths->threads, sizeof paths->threads, "%d", o->threads > 0 ? o->threads : -1);
    return 0;
}

/* COLMAP's steps on the listed photos: database, features, matching, mapping, the scene. */
static int run_steps(const colmap_paths *paths, const gv_colmap_run_options *o, colmap_photos *p,
                     const char *matcher, gv_colmap_run_result *r)
{
    double t = gv_now();
    if (colmap_read_photos(paths->images, o->single_camera, p) || gv_mkdirs(paths->work) || gv_mkdirs(paths->sparse) ||
        colmap_prepare_database(paths, o, p, &r->resumed))
        return -1;
    setenv("QT_QPA_PLATFORM", "offscreen", 1); /* no display: COLMAP's Qt must not look for one */
    if (extract_features(paths, o, p->n)) return -1;
    r->seconds[1] = gv_now() - t, t = gv_now();
    if (colmap_match(paths, o, p, matcher)) return -1;
    r->seconds[2] = gv_now() - t, t = gv_now();
    int best = -1;
    if (map_cameras(paths, p->n, r, &best)) return -1;
    r->seconds[3] = gv_now() - t, t = gv_now();
    int needed = (int)ceil(o->min_registered * p->n);
    if (needed < 3) needed = 3;
    if (r->registered < needed)
        return gv_fail("%s: COLMAP registered %d of %d photos (at least %d needed): the photos may overlap too little "
                       "or lack texture; its messages are in %s", paths->images, r->registered, p->n, needed, paths->log);
    gv_info("map: %d of %d photos registered (%d model%s, the largest kept)", r->registered, p->n, r->models,
            r->models == 1 ? "" : "s");
    int rc = colmap_write_scene(paths, o, p, best, r);
    r->seconds[4] = gv_now() - t;
    return rc;
}

int gv_scene_colmap(const gv_colmap_run_options *o, gv_colmap_run_result *r)
{
    memset(r, 0, sizeof *r);
    if (!o->images_dir == !o->video) return gv_fail("scene colmap: give either a folder of photos or a video");
    if (o->video && !(o->fps > 0 && o->fps <= 1000)) return gv_fail("scene colmap: --fps %g is not in (0, 1000]", o->fps);
    for (int k = 0; k < o->n_downscales; k++)
        if (o->downscales[k] < 2 || o->downscales[k] > 64)
            return gv_fail("scene colmap: downscale %d is not in 2..64", o->downscales[k]);
    char frames[COLMAP_PATH], why[1024];
    colmap_paths paths;
    if (set_paths(o, o->video ? frames : o->images_dir, &paths)) return -1;
    if (o->video) {
        if (access(o->video, R_OK)) return gv_fail("%s: no such video file", o->video);
        gv_info("scene colmap: the frames of %s at %g a second, matched in sequence (video frames)", o->video, o->fps);
        if (colmap_video_frames(o, frames, sizeof frames, &r->seconds[0])) return -1;
    }
    colmap_photos p;
    int rc = colmap_list_photos(paths.images, &p);
    if (o->video) p.ordered = 1; /* frame_00001.jpg ...: in time order */
    if (rc == 0) rc = colmap_choose_matcher(o, &p, r->matcher, sizeof r->matcher, why, sizeof why, &r->pairs);
    r->images = p.n;
    if (rc == 0) {
        gv_info("%s: %d photos; %s", paths.images, p.n, why);
        rc = run_steps(&paths, o, &p, r->matcher, r);
    }
    colmap_photos_free(&p);
    return rc;
}
