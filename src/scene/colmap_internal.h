/* The pieces of `scene colmap` (scene_colmap.h): the photos and their order
 * (colmap_photos.c), frames from a video (colmap_video.c), the pairs to match
 * (colmap_match.c), COLMAP's steps with progress (colmap_run.c) and the scene written from
 * the model (colmap_output.c). */
#ifndef GAUSSVID_SCENE_COLMAP_INTERNAL_H
#define GAUSSVID_SCENE_COLMAP_INTERNAL_H

#include "gaussvid/io/colmap.h"
#include "gaussvid/core/core.h"
#include "gaussvid/scene/scene_colmap.h"

#define COLMAP_PATH 4400

typedef struct {
    char name[GV_COLMAP_MAX_NAME];
    int orientation;       /* its EXIF tag, 1..8 (1 for PNG) */
    long long bytes, mtime; /* recorded so that a rerun knows the photo unchanged */
} colmap_photo;

typedef struct {
    int n;
    colmap_photo *photo;   /* in capture order: by number when ordered, else by name */
    int ordered;           /* names are one prefix and a number (IMG_0001.JPG ...), or video frames */
    int width, height;     /* as stored (before EXIF orientation), when one size */
} colmap_photos;

/* The paths of one run, all under OUT/colmap/ but the photos. */
typedef struct {
    const char *images;    /* the photos' folder (the user's, or OUT/frames for a video) */
    char colmap[COLMAP_PATH], work[COLMAP_PATH], db[COLMAP_PATH], log[COLMAP_PATH], list[COLMAP_PATH];
    char sparse[COLMAP_PATH], undistorted[COLMAP_PATH], manifest[COLMAP_PATH], threads[16];
} colmap_paths;

/* The photo files of the folder in capture order (names only; ordered decided). */
int colmap_list_photos(const char *dir, colmap_photos *p);
/* Decodes each photo once (an unreadable one fails naming it), records its EXIF orientation
 * and, with one camera, checks that all share a stored size. */
int colmap_read_photos(const char *dir, int single_camera, colmap_photos *p);
/* Keeps the database of an earlier run when the manifest says it was made from these photos
 * (none changed or removed) with the same camera options, else starts a new one; writes the
 * manifest and the image list. *resumed says which. */
int colmap_prepare_database(const colmap_paths *paths, const gv_colmap_run_options *o, const colmap_photos *p,
                            int *resumed);
void colmap_photos_free(colmap_photos *p);

/* The frames of o->video at o->fps into OUT/frames/frame_00001.jpg ... (kept when an earlier
 * run extracted them from the same video at the same rate). */
int colmap_video_frames(const gv_colmap_run_options *o, char *frames_dir, size_t size, double *seconds);

/* The matcher for these photos (o->matcher, else chosen by the input), its line of
 * explanation into why. */
int colmap_choose_matcher(const gv_colmap_run_options *o, const colmap_photos *p, char *matcher, size_t size,
                          char *why, size_t why_size, long *pairs);
/* Matches the pairs of the chosen matcher, with progress (pairs matched of their total). */
int colmap_match(const colmap_paths *paths, const gv_colmap_run_options *o, const colmap_photos *p,
                 const char *matcher);

/* One COLMAP step run with its output in the log, each line also given to on_line (may be
 * NULL); fails naming the step and the log. */
int colmap_step(const char *const argv[], const char *log, gv_line_fn on_line, void *ctx);

/* Removes the mapper's models (sparse/0, sparse/1, ...: the files COLMAP writes there): an
 * earlier run's before mapping, so that the largest is this run's; the kept one once the
 * scene no longer needs it. */
void colmap_remove_models(const char *sparse);

/* The scene from the model sparse/<best>: the photos undistorted in small batches, turned
 * upright, written once as images/ and images_K/, the model turned to match and written. */
int colmap_write_scene(const colmap_paths *paths, const gv_colmap_run_options *o, const colmap_photos *p,
                       int best, gv_colmap_run_result *r);

#endif
