/* Procedural scenes: a seeded, ray-traced, textured room with furniture, lit by area lights,
 * lamps and sun through its openings, seen along a smooth hand-held-like camera path, written
 * in the shared scene folder format (images/, transforms.json, sparse/0 text, points3D.ply).
 *
 * Shading is diffuse only (view-independent): a surface point has the same colour in every
 * frame, so the sparse points' colours agree with every image. The same parameters give
 * byte-identical files whatever the thread count. See docs/SYNTH.md. */
#ifndef GAUSSVID_SYNTH_H
#define GAUSSVID_SYNTH_H

#include <stddef.h>
#include <stdint.h>

#include "gaussvid/io/image.h"
#include "gaussvid/scene/scene.h"

typedef struct {
    uint64_t seed;
    int n_frames;      /* 2 .. GV_SYNTH_MAX_FRAMES */
    int width, height; /* 16 .. GV_SYNTH_MAX_SIZE each */
    int samples;       /* K: pixels on edges get a K x K stratified grid (1 .. 8) */
    double texture_detail; /* 0 .. 1: non-repeating noise at several scales on every surface's
                              albedo, so that feature matching (COLMAP) finds unique points;
                              0 (the default) leaves the rooms as they always were */
} gv_synth_params;

#define GV_SYNTH_MAX_FRAMES 100000
#define GV_SYNTH_MAX_SIZE 4096

typedef struct gv_synth_world gv_synth_world;

/* The defaults: seed 1, 160 frames, 256x144, samples 3, no texture detail. */
void gv_synth_default_params(gv_synth_params *p);
/* Fails with a message naming the bad parameter. */
int gv_synth_check_params(const gv_synth_params *p);

/* Builds the scene: room, objects, lights, camera path, baked lighting, exposure. */
int gv_synth_build(const gv_synth_params *p, gv_synth_world **out);
void gv_synth_free(gv_synth_world *w);
/* Camera of a frame (OpenCV convention of scene.h, name "frame_%05d.png"); fails when the
 * frame is not in [0, n_frames). */
int gv_synth_camera(const gv_synth_world *w, int frame, gv_camera *out);
/* Renders a frame into a newly allocated 3-channel image (same check). */
int gv_synth_render(const gv_synth_world *w, int frame, gv_image *out);
/* The sparse point cloud: first hits of rays through a pixel grid of some frames, coloured
 * with their shaded colour, one per voxel. Arrays are newly allocated (n * 3 each). */
int gv_synth_points(const gv_synth_world *w, float **xyz, uint8_t **rgb, int *n);
/* One line per scene property (room, objects, lights, path), for a README in the output. */
int gv_synth_describe(const gv_synth_world *w, char *out, size_t size);

/* Makes the whole scene folder at dir: renders under a temporary sibling folder and renames
 * it into place at the end. An existing dir is replaced only when it holds a previous
 * synthesised scene (its synth.txt), and refused when it holds anything else. */
int gv_synth_write(const gv_synth_params *p, const char *dir);

#endif
