/* A scene: the cameras (camera.h) and images of a multi-view capture, its sparse point
 * cloud, and the sparse split into training frames 0, n, 2n, ... and held-out frames. */
#ifndef GAUSSVID_SCENE_H
#define GAUSSVID_SCENE_H

#include <stddef.h>
#include <stdint.h>

#include "gaussvid/core/camera.h"
#include "gaussvid/io/image.h"

typedef enum { GV_SCENE_FROM_COLMAP_BIN, GV_SCENE_FROM_COLMAP_TEXT, GV_SCENE_FROM_TRANSFORMS } gv_scene_source;

typedef struct {
    char dir[4096];
    char image_dir[4096]; /* images/ or images_<k>/ when downscaled (the scene folder itself
                           * when the file paths of a transforms.json share no folder) */
    gv_scene_source source;
    int downscale;        /* 1, 2, 4, 8: intrinsics already scaled to it */
    int memory_downscale; /* factor still applied in memory when an image is loaded: 1 when
                           * image_dir holds images of the cameras' size, else downscale */
    int white_background; /* alpha is composited on white (else black) when loading */
    int n_frames;
    gv_camera *cameras;   /* n_frames, sorted by image name */
    int n_points;
    float *points;        /* n_points * 3, world coordinates */
    uint8_t *colors;      /* n_points * 3, RGB */
} gv_scene;

typedef struct {
    int downscale;        /* 1 (default), 2, 4, 8: read images_<k>/ when present, else
                           * downscale images in memory by area averaging */
    int prefer_transforms; /* read transforms.json even when sparse/0 exists */
    int white_background;  /* composite images with alpha on white instead of black */
} gv_scene_options;

/* Loads cameras and points: sparse/0 (binary, else text) when present, else transforms.json.
 * Every camera's image must exist. opt may be NULL for the defaults. */
int gv_scene_load(const char *dir, const gv_scene_options *opt, gv_scene *out);
void gv_scene_free(gv_scene *scene);
/* Reads frame i's image as RGB (alpha composited on the background, downscaled in memory
 * when needed), checking its size against the camera. */
int gv_scene_load_image(const gv_scene *scene, int frame, gv_image *out);
/* Camera centre in world coordinates: C = -R^T t. */
void gv_camera_center(const gv_camera *cam, double center[3]);
/* The 3DGS scene extent (getNerfppNorm): 1.1 x the largest distance of a camera centre
 * from their mean, over the given frames (all frames when frames is NULL). */
double gv_scene_extent(const gv_scene *scene, const int *frames, int n_frames);

/* Scales a camera's intrinsics to an image of width x height: fx, cx by width / W and
 * fy, cy by height / H (pixel centres at +0.5, so the image's edges map onto each other). */
void gv_camera_rescale(gv_camera *cam, int width, int height);
/* Size of an image downscaled by k in memory: round(W / k), half to even, at least 1
 * (the gv_image_downscale rule, as 3DGS loadCam). */
int gv_downscaled_size(int size, int k);

/* The sparse split's rule: frame i is a training view at interval n when i is a multiple of n. */
int gv_scene_is_train(int frame, int interval);
/* Sparse split for interval n: training frames 0, n, 2n, ...; every other frame held out.
 * Fills the arrays (each n_frames long) and counts; fails when the scene has fewer than two
 * frames or n fails gv_interval_check(n, n_frames, GV_INTERVAL_SPLIT). */
int gv_scene_split(int n_frames, int interval, int *train, int *n_train, int *held_out,
                   int *n_held_out);

/* ---- the interval rule (split.c) --------------------------------------------------------
 * Every command that takes an interval n checks it here. A scene of F frames needs two
 * training views, so n <= F - 1, and n <= GV_INTERVAL_MAX. Below that each use takes what
 * the frames between two training views must hold:
 *   GV_INTERVAL_SPLIT        n >= 1: a sparse 3DGS, its renders and their scores (splat
 *                            train/render/eval/coverage, scene info).
 *   GV_INTERVAL_CLIPS        n >= 2: clips of a dataset (dataset build) and of adapt's
 *                            scene-internal pairs. Their anchors may lie several training views
 *                            apart (anchor gap G; 2n for internal pairs), so n = 2 can hold the
 *                            3 held-out frames a clip needs; n = 1 holds none. Whether a clip
 *                            fits at a given gap is gv_clip_check_interval's (dataset.h).
 *   GV_INTERVAL_RECONSTRUCT  n = 1 or n >= 4: reconstruct restores the held-out frames between
 *                            neighbouring training views with clips of 3 held-out frames, so
 *                            n - 1 >= 3; at n = 1 every view trains and a smooth path between
 *                            the views is restored. */
typedef enum { GV_INTERVAL_SPLIT, GV_INTERVAL_CLIPS, GV_INTERVAL_RECONSTRUCT } gv_interval_use;
#define GV_INTERVAL_MAX 100000
#define GV_INTERVAL_CLIP_HELD_OUT 3 /* held-out frames a clip restores (paper section 3.2) */
/* The intervals the use takes, as text ("n = 1 or 4 <= n <= 100000"); on a scene of n_frames
 * frames (> 0) only those that leave two training views ("n = 1", "no n"). */
void gv_interval_range(gv_interval_use use, int n_frames, char *out, size_t size);
/* Whether the use takes interval n, and (n_frames > 0) whether a scene of n_frames frames
 * has two training views at n. Fails with one line that gives the range: "interval 3:
 * reconstruct takes n = 1 or 4 <= n <= 100000 (why)", or the n the use takes on the scene. */
int gv_interval_check(int n, int n_frames, gv_interval_use use);
/* Parses an interval list: comma-separated items, each "n", "a:b" (a to b inclusive) or
 * "a:b:s" (step s; "6:26:2" is the paper's 6, 8, ..., 26), in the order given. Every value
 * passes gv_interval_check(n, 0, use); a value listed twice (also by overlapping ranges) and
 * more than max values fail. */
int gv_interval_parse(const char *text, gv_interval_use use, int *intervals, int max, int *count);

/* Writes the scene's description (not its images) in the shared folder format:
 * transforms.json (nerfstudio, OpenGL c2w), sparse/0/{cameras,images,points3D}.txt
 * (PINHOLE) and points3D.ply. Image names are those of the cameras under images/. */
int gv_scene_write(const char *dir, const gv_scene *scene);

#endif
