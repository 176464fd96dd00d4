/* A scene: the cameras (camera.h) and images of a multi-view capture, its sparse point
 * cloud, and the sparse split into training frames 0, n, 2n, ... and held-out frames. */
#ifndef GAUSSVID_SCENE_H
#define GAUSSVID_SCENE_H

#include <stdint.h>

#include "gaussvid/camera.h"
#include "gaussvid/image.h"

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
 * Fills the arrays (each n_frames long) and counts; fails when n < 1 or when fewer than two
 * training frames result. */
int gv_scene_split(int n_frames, int interval, int *train, int *n_train, int *held_out,
                   int *n_held_out);

/* Writes the scene's description (not its images) in the shared folder format:
 * transforms.json (nerfstudio, OpenGL c2w), sparse/0/{cameras,images,points3D}.txt
 * (PINHOLE) and points3D.ply. Image names are those of the cameras under images/. */
int gv_scene_write(const char *dir, const gv_scene *scene);

#endif
