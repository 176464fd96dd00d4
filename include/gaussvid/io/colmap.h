/* COLMAP sparse models (sparse/0/{cameras,images,points3D}.{bin,txt}), read and written in
 * both the binary and the text format (docs/reference/gaussian-splatting.md section 18.4).
 *
 * What is kept: cameras (id, model, size, parameters), registered images (id, world-to-camera
 * quaternion w,x,y,z and translation, camera id, name) and 3D points (id, xyz, rgb, error).
 * The 2D observations of the images and the tracks of the points are parsed and validated
 * but not kept; the writers write them empty.
 *
 * Camera models: we do not undistort. Reading accepts SIMPLE_PINHOLE and PINHOLE, and
 * SIMPLE_RADIAL, RADIAL, OPENCV and FULL_OPENCV only when every distortion coefficient is
 * exactly zero; every other model (fisheye models, FOV, ...) and any non-zero distortion
 * is refused with a message naming the file, the camera id and the model. Unknown model ids
 * or names are refused. */
#ifndef GAUSSVID_COLMAP_H
#define GAUSSVID_COLMAP_H

#include <stdint.h>

/* COLMAP's model ids (src/colmap/sensor/models.h; docs/reference/gaussian-splatting.md 18.4). */
enum {
    GV_COLMAP_SIMPLE_PINHOLE = 0,
    GV_COLMAP_PINHOLE = 1,
    GV_COLMAP_SIMPLE_RADIAL = 2,
    GV_COLMAP_RADIAL = 3,
    GV_COLMAP_OPENCV = 4,
    GV_COLMAP_OPENCV_FISHEYE = 5,
    GV_COLMAP_FULL_OPENCV = 6,
    GV_COLMAP_FOV = 7,
    GV_COLMAP_SIMPLE_RADIAL_FISHEYE = 8,
    GV_COLMAP_RADIAL_FISHEYE = 9,
    GV_COLMAP_THIN_PRISM_FISHEYE = 10,
    GV_COLMAP_RAD_TAN_THIN_PRISM_FISHEYE = 11,
    GV_COLMAP_N_MODELS = 12
};
#define GV_COLMAP_MAX_PARAMS 16
#define GV_COLMAP_MAX_NAME 256 /* image names, NUL included */

typedef struct {
    int id;
    int model;            /* GV_COLMAP_* */
    int width, height;
    double params[GV_COLMAP_MAX_PARAMS]; /* gv_colmap_model_n_params(model) are used */
} gv_colmap_camera;

typedef struct {
    int id;
    double qvec[4];       /* world-to-camera rotation as w, x, y, z */
    double tvec[3];       /* world-to-camera translation */
    int camera_id;
    char name[GV_COLMAP_MAX_NAME];
} gv_colmap_image;

typedef struct {
    uint64_t id;
    double xyz[3];
    uint8_t rgb[3];
    double error;
} gv_colmap_point;

typedef struct {
    int n_cameras, n_images, n_points;
    gv_colmap_camera *cameras;
    gv_colmap_image *images;
    gv_colmap_point *points;
} gv_colmap_model;

/* Model name ("PINHOLE") of an id, or NULL when the id is unknown. */
const char *gv_colmap_model_name(int model);
/* Model id of a name, or -1 when the name is unknown. */
int gv_colmap_model_id(const char *name);
/* Number of parameters of a model, or -1 when the id is unknown. */
int gv_colmap_model_n_params(int model);
/* Pinhole intrinsics of a camera; fails (naming `path`, the camera id and the model) for a
 * model we do not accept or a non-zero distortion coefficient. */
int gv_colmap_camera_pinhole(const gv_colmap_camera *cam, const char *path, double *fx,
                             double *fy, double *cx, double *cy);

/* Rotation matrix (row-major) of a quaternion w, x, y, z, normalised first. */
void gv_colmap_qvec_to_rotmat(const double q[4], double R[9]);
/* Unit quaternion w, x, y, z (w >= 0) of a rotation matrix (row-major). */
void gv_colmap_rotmat_to_qvec(const double R[9], double q[4]);

/* Each reader replaces its part of `model` (which must be zero-initialised or hold an
 * earlier read; the arrays are malloc'ed, free with gv_colmap_free) and leaves that part
 * empty on failure. Every count is checked against the file size before allocating. */
int gv_colmap_read_cameras_bin(const char *path, gv_colmap_model *model);
int gv_colmap_read_images_bin(const char *path, gv_colmap_model *model);
int gv_colmap_read_points3d_bin(const char *path, gv_colmap_model *model);
int gv_colmap_read_cameras_text(const char *path, gv_colmap_model *model);
int gv_colmap_read_images_text(const char *path, gv_colmap_model *model);
int gv_colmap_read_points3d_text(const char *path, gv_colmap_model *model);
/* Reads dir/{cameras,images,points3D}.bin (or .txt) into a fresh model (its previous
 * contents are not freed); checks that camera ids are unique and every image's camera id
 * is defined. On failure the model is empty. */
int gv_colmap_read_bin(const char *dir, gv_colmap_model *model);
int gv_colmap_read_text(const char *dir, gv_colmap_model *model);

/* Writers: each file atomically; 2D points and tracks are written empty. The text writer
 * prints every double in the shortest form that reads back to the same value. */
int gv_colmap_write_cameras_bin(const char *path, const gv_colmap_model *model);
int gv_colmap_write_images_bin(const char *path, const gv_colmap_model *model);
int gv_colmap_write_points3d_bin(const char *path, const gv_colmap_model *model);
int gv_colmap_write_cameras_text(const char *path, const gv_colmap_model *model);
int gv_colmap_write_images_text(const char *path, const gv_colmap_model *model);
int gv_colmap_write_points3d_text(const char *path, const gv_colmap_model *model);
/* Writes dir/{cameras,images,points3D}.bin (or .txt); dir must exist. */
int gv_colmap_write_bin(const char *dir, const gv_colmap_model *model);
int gv_colmap_write_text(const char *dir, const gv_colmap_model *model);

void gv_colmap_free(gv_colmap_model *model);

#endif
