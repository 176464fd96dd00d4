/* COLMAP models: the camera model table, the pinhole check, quaternions, and the readers and
 * writers of a whole sparse/0 folder. The per-file formats are in colmap_bin.c and
 * colmap_text.c. */
#include "gaussvid/io/colmap.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "gaussvid/core/core.h"

/* Reference 18.4: model id, name and parameter count, in id order. */
static const struct {
    const char *name;
    int n_params;
} colmap_models[GV_COLMAP_N_MODELS] = {
    {"SIMPLE_PINHOLE", 3}, {"PINHOLE", 4},          {"SIMPLE_RADIAL", 4},
    {"RADIAL", 5},         {"OPENCV", 8},           {"OPENCV_FISHEYE", 8},
    {"FULL_OPENCV", 12},   {"FOV", 5},              {"SIMPLE_RADIAL_FISHEYE", 4},
    {"RADIAL_FISHEYE", 5}, {"THIN_PRISM_FISHEYE", 12}, {"RAD_TAN_THIN_PRISM_FISHEYE", 16},
};

const char *gv_colmap_model_name(int model)
{
    return model >= 0 && model < GV_COLMAP_N_MODELS ? colmap_models[model].name : NULL;
}

int gv_colmap_model_id(const char *name)
{
    for (int i = 0; i < GV_COLMAP_N_MODELS; i++)
        if (!strcmp(name, colmap_models[i].name)) return i;
    return -1;
}

int gv_colmap_model_n_params(int model)
{
    return model >= 0 && model < GV_COLMAP_N_MODELS ? colmap_models[model].n_params : -1;
}

int gv_colmap_camera_pinhole(const gv_colmap_camera *cam, const char *path, double *fx,
                             double *fy, double *cx, double *cy)
{
    const char *name = gv_colmap_model_name(cam->model);
    if (!name) return gv_fail("%s: camera %d: unknown camera model id %d", path, cam->id, cam->model);
    const double *p = cam->params;
    int first_distortion; /* index of the first distortion coefficient */
    switch (cam->model) {
    case GV_COLMAP_SIMPLE_PINHOLE:
    case GV_COLMAP_SIMPLE_RADIAL:
    case GV_COLMAP_RADIAL:
        *fx = *fy = p[0], *cx = p[1], *cy = p[2];
        first_distortion = 3;
        break;
    case GV_COLMAP_PINHOLE:
    case GV_COLMAP_OPENCV:
    case GV_COLMAP_FULL_OPENCV:
        *fx = p[0], *fy = p[1], *cx = p[2], *cy = p[3];
        first_distortion = 4;
        break;
    default:
        return gv_fail("%s: camera %d: model %s is not supported (only pinhole cameras; "
                       "gaussvid does not undistort images)", path, cam->id, name);
    }
    for (int i = first_distortion; i < colmap_models[cam->model].n_params; i++)
        if (p[i] != 0)
            return gv_fail("%s: camera %d: model %s has non-zero distortion (parameter %d = %g); "
                           "gaussvid does not undistort: undistort the images first "
                           "(e.g. colmap image_undistorter)", path, cam->id, name, i, p[i]);
    for (int i = 0; i < first_distortion; i++)
        if (!isfinite(p[i])) return gv_fail("%s: camera %d: parameter %d is not finite", path, cam->id, i);
    if (!(*fx > 0) || !(*fy > 0))
        return gv_fail("%s: camera %d: focal length must be positive", path, cam->id);
    return 0;
}

void gv_colmap_qvec_to_rotmat(const double q[4], double R[9])
{
    double n = sqrt(q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3]);
    double w = q[0] / n, x = q[1] / n, y = q[2] / n, z = q[3] / n;
    R[0] = 1 - 2 * (y * y + z * z), R[1] = 2 * (x * y - w * z), R[2] = 2 * (x * z + w * y);
    R[3] = 2 * (x * y + w * z), R[4] = 1 - 2 * (x * x + z * z), R[5] = 2 * (y * z - w * x);
    R[6] = 2 * (x * z - w * y), R[7] = 2 * (y * z + w * x), R[8] = 1 - 2 * (x * x + y * y);
}

void gv_colmap_rotmat_to_qvec(const double R[9], double q[4])
{
    /* Shepperd's method: divide by the largest of 4w^2, 4x^2, 4y^2, 4z^2 for stability. */
    double trace = R[0] + R[4] + R[8];
    double w, x, y, z;
    if (trace >= R[0] && trace >= R[4] && trace >= R[8]) {
        double s = 2 * sqrt(1 + trace);
        w = s / 4, x = (R[7] - R[5]) / s, y = (R[2] - R[6]) / s, z = (R[3] - R[1]) / s;
    } else if (R[0] >= R[4] && R[0] >= R[8]) {
        double s = 2 * sqrt(1 + R[0] - R[4] - R[8]);
        w = (R[7] - R[5]) / s, x = s / 4, y = (R[1] + R[3]) / s, z = (R[2] + R[6]) / s;
    } else if (R[4] >= R[8]) {
        double s = 2 * sqrt(1 + R[4] - R[0] - R[8]);
        w = (R[2] - R[6]) / s, x = (R[1] + R[3]) / s, y = s / 4, z = (R[5] + R[7]) / s;
    } else {
        double s = 2 * sqrt(1 + R[8] - R[0] - R[4]);
        w = (R[3] - R[1]) / s, x = (R[2] + R[6]) / s, y = (R[5] + R[7]) / s, z = s / 4;
    }
    double n = sqrt(w * w + x * x + y * y + z * z) * (w < 0 ? -1 : 1);
    q[0] = w / n, q[1] = x / n, q[2] = y / n, q[3] = z / n;
}

void gv_colmap_free(gv_colmap_model *model)
{
    free(model->cameras);
    free(model->images);
    free(model->points);
    memset(model, 0, sizeof *model);
}

/* Every image must name a defined camera; ids must be unique. */
static int check_references(const char *images_path, const gv_colmap_model *m)
{
    for (int i = 0; i < m->n_cameras; i++)
        for (int j = 0; j < i; j++)
            if (m->cameras[i].id == m->cameras[j].id)
                return gv_fail("%s: camera id %d defined twice", images_path, m->cameras[i].id);
    for (int i = 0; i < m->n_images; i++) {
        int found = 0;
        for (int j = 0; j < m->n_cameras && !found; j++) found = m->cameras[j].id == m->images[i].camera_id;
        if (!found)
            return gv_fail("%s: image %d (%s) refers to camera %d, which is not defined",
                           images_path, m->images[i].id, m->images[i].name, m->images[i].camera_id);
    }
    return 0;
}

typedef int (*colmap_file_fn)(const char *path, gv_colmap_model *model);
typedef int (*colmap_write_fn)(const char *path, const gv_colmap_model *model);

static int read_dir(const char *dir, const char *ext, const colmap_file_fn readers[3],
                    gv_colmap_model *model)
{
    static const char *stems[3] = {"cameras", "images", "points3D"};
    memset(model, 0, sizeof *model);
    char path[4096], images_path[4096] = "";
    for (int i = 0; i < 3; i++) {
        char file[32];
        snprintf(file, sizeof file, "%s.%s", stems[i], ext);
        if (gv_path_join(path, sizeof path, dir, file) != 0) goto fail;
        if (i == 1) snprintf(images_path, sizeof images_path, "%s", path);
        if (readers[i](path, model) != 0) goto fail;
    }
    if (check_references(images_path, model) != 0) goto fail;
    return 0;
fail:
    gv_colmap_free(model);
    return -1;
}

static int write_dir(const char *dir, const char *ext, const colmap_write_fn writers[3],
                     const gv_colmap_model *model)
{
    static const char *stems[3] = {"cameras", "images", "points3D"};
    char path[4096];
    for (int i = 0; i < 3; i++) {
        char file[32];
        snprintf(file, sizeof file, "%s.%s", stems[i], ext);
        if (gv_path_join(path, sizeof path, dir, file) != 0) return -1;
        if (writers[i](path, model) != 0) return -1;
    }
    return 0;
}

int gv_colmap_read_bin(const char *dir, gv_colmap_model *model)
{
    const colmap_file_fn readers[3] = {gv_colmap_read_cameras_bin, gv_colmap_read_images_bin,
                                       gv_colmap_read_points3d_bin};
    return read_dir(dir, "bin", readers, model);
}

int gv_colmap_read_text(const char *dir, gv_colmap_model *model)
{
    const colmap_file_fn readers[3] = {gv_colmap_read_cameras_text, gv_colmap_read_images_text,
                                       gv_colmap_read_points3d_text};
    return read_dir(dir, "txt", readers, model);
}

int gv_colmap_write_bin(const char *dir, const gv_colmap_model *model)
{
    const colmap_write_fn writers[3] = {gv_colmap_write_cameras_bin, gv_colmap_write_images_bin,
                                        gv_colmap_write_points3d_bin};
    return write_dir(dir, "bin", writers, model);
}

int gv_colmap_write_text(const char *dir, const gv_colmap_model *model)
{
    const colmap_write_fn writers[3] = {gv_colmap_write_cameras_text, gv_colmap_write_images_text,
                                        gv_colmap_write_points3d_text};
    return write_dir(dir, "txt", writers, model);
}
