/* transforms.json scene descriptions (docs/reference/gaussian-splatting.md 18.5), read in the
 * nerfstudio / instant-ngp and the NeRF-synthetic (Blender) conventions, written in the
 * nerfstudio convention. Poses in the file are camera-to-world in OpenGL camera axes
 * (x right, y up, looking along -z); they are converted to the library's OpenCV
 * world-to-camera R, t (camera.h): negate the 2nd and 3rd columns of the rotation, invert.
 *
 * Intrinsics (pixels of the images the file_paths name) are looked up per frame first, then
 * at the top level: fl_x (else camera_angle_x: fx = w / (2 tan(camera_angle_x / 2))),
 * fl_y (else camera_angle_y likewise, else fy = fx), cx (else w / 2), cy (else h / 2), w and
 * h (else the size of the first frame's image, read from disk). Distortion keys (k1..k6,
 * p1, p2) must be zero, camera_model (when present) a pinhole-compatible model: we do not
 * undistort. A file_path whose last component has no extension gets ".png" (NeRF-synthetic).
 * Rotations must be orthonormal within 1e-3 (max |R^T R - I|) with determinant +1; they are
 * then projected exactly onto the nearest rotation. */
#ifndef GAUSSVID_TRANSFORMS_H
#define GAUSSVID_TRANSFORMS_H

#include "gaussvid/core/camera.h"

#define GV_TRANSFORMS_ROTATION_TOLERANCE 1e-3

typedef struct {
    int n_frames;
    gv_camera *cameras;       /* file order; name = file_path relative to the file's folder,
                               * "./" removed, ".png" added when it has no extension */
    char ply_file_path[4096]; /* relative to the file's folder; "" when absent */
} gv_transforms;

/* Reads and converts a transforms.json; every failure names the file and the frame/key. */
int gv_transforms_read(const char *path, gv_transforms *out);
void gv_transforms_free(gv_transforms *t);

/* Writes a nerfstudio transforms.json atomically: shared intrinsics at the top level (per
 * frame when cameras differ), camera_model OPENCV with zero distortion, file_path =
 * image_folder/name, transform_matrix = OpenGL camera-to-world, and ply_file_path when
 * ply_file_path is not NULL. */
int gv_transforms_write(const char *path, const gv_camera *cameras, int n,
                        const char *image_folder, const char *ply_file_path);

/* OpenGL camera-to-world 4x4 (row-major) of an OpenCV world-to-camera pose, and back. */
void gv_pose_to_c2w_opengl(const double R[9], const double t[3], double c2w[16]);
void gv_pose_from_c2w_opengl(const double c2w[16], double R[9], double t[3]);

#endif
