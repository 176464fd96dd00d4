/* A scene folder from a user's photos (`gaussvid scene colmap`, docs/SCENES.md "From photos"):
 * Debian's COLMAP program, run headless on the CPU, finds and matches SIFT features, maps the
 * cameras and points and undistorts the photos to PINHOLE cameras; the result is written in
 * the shared scene format (images/, sparse/0 as text, transforms.json, points3D.ply). */
#ifndef GAUSSVID_SCENE_COLMAP_H
#define GAUSSVID_SCENE_COLMAP_H

typedef struct {
    const char *images_dir;      /* the photos: PNG or JPEG files (.png, .jpg, .jpeg) */
    const char *out_dir;         /* the scene folder; OUT/colmap/ keeps COLMAP's work and log */
    const char *colmap;          /* the program (NULL: colmap on the PATH) */
    const char *camera_model;    /* the model COLMAP fits (default SIMPLE_RADIAL) */
    int single_camera;           /* 1: one camera shared by every photo (the same size needed) */
    const char *matcher;         /* "exhaustive" (default) or "sequential" (video frames) */
    double min_registered;       /* fail when COLMAP registers fewer than this share (0.5) */
    int threads;                 /* COLMAP's threads (0: its own choice) */
} gv_colmap_run_options;

typedef struct {
    int images, registered;      /* photos given, photos the chosen model holds */
    int models;                  /* models the mapper made (the largest is kept) */
    int points;
    double seconds[4];           /* features, matching, mapping, undistortion */
} gv_colmap_run_result;

void gv_colmap_run_defaults(gv_colmap_run_options *o);
/* Runs COLMAP on the photos and writes the scene. Fails with one line: COLMAP not installed,
 * a photo unreadable (naming it), photos of different sizes with single_camera, a COLMAP step
 * failing (naming its log), fewer registered photos than asked (how many of how many). */
int gv_scene_colmap(const gv_colmap_run_options *o, gv_colmap_run_result *r);

#endif
