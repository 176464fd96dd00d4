/* A scene folder from a user's photos or video (`gaussvid scene colmap`, docs/SCENES.md "From
 * photos"): Debian's COLMAP program, run headless on the CPU, finds and matches SIFT features
 * (the pairs chosen by the capture: sequential for ordered names and videos, exhaustive for
 * unordered sets, a vocabulary tree when one is given), maps the cameras and points and
 * undistorts the photos to PINHOLE cameras; the result is written upright (EXIF orientation)
 * in the shared scene format (images/, images_2/... downscaled copies, sparse/0 as text,
 * transforms.json, points3D.ply). The database in OUT/colmap/ is kept: a rerun continues. */
#ifndef GAUSSVID_SCENE_COLMAP_H
#define GAUSSVID_SCENE_COLMAP_H

#define GV_COLMAP_MAX_DOWNSCALES 8

typedef struct {
    const char *images_dir;      /* the photos: PNG or JPEG files (.png, .jpg, .jpeg); or NULL with video */
    const char *video;           /* a video: its frames (fps a second, by ffmpeg) are the photos */
    double fps;                  /* frames a second taken from the video (default 2) */
    const char *out_dir;         /* the scene folder; OUT/colmap/ keeps COLMAP's work and log */
    const char *colmap;          /* the program (NULL: colmap on the PATH) */
    const char *ffmpeg;          /* the program for video (NULL: ffmpeg on the PATH) */
    const char *camera_model;    /* the model COLMAP fits (default SIMPLE_RADIAL) */
    int single_camera;           /* 1: one camera shared by every photo (the same size needed) */
    const char *matcher;         /* NULL: chosen by the input; "exhaustive", "sequential", "vocab_tree" */
    const char *vocab_tree;      /* a COLMAP vocabulary tree file (NULL: none) */
    int downscales[GV_COLMAP_MAX_DOWNSCALES]; /* images_K/ written for each (default 2, 4, 8) */
    int n_downscales;
    double min_registered;       /* fail when COLMAP registers fewer than this share (0.5) */
    int threads;                 /* COLMAP's threads (0: its own choice) */
} gv_colmap_run_options;

typedef struct {
    int images, registered;      /* photos given, photos the chosen model holds */
    int models;                  /* models the mapper made (the largest is kept) */
    int points;
    int resumed;                 /* 1 when an earlier run's database was reused */
    char matcher[16];            /* "exhaustive", "sequential" or "vocab_tree" */
    long pairs;                  /* image pairs listed for matching (0 for the vocabulary tree's own) */
    double seconds[5];           /* frames from video, features, matching, mapping, undistortion */
} gv_colmap_run_result;

void gv_colmap_run_defaults(gv_colmap_run_options *o);
/* Runs COLMAP on the photos and writes the scene. Fails with one line: COLMAP (or ffmpeg for
 * a video) not installed, a photo unreadable (naming it), photos of different sizes with
 * single_camera, a COLMAP step failing (naming its log), fewer registered photos than asked
 * (how many of how many). */
int gv_scene_colmap(const gv_colmap_run_options *o, gv_colmap_run_result *r);

#endif
