/* transforms.json reader (nerfstudio / instant-ngp / NeRF-synthetic) and writer (nerfstudio);
 * conventions in include/gaussvid/io/transforms.h and docs/reference/gaussian-splatting.md 18.5. */
#include "gaussvid/io/transforms.h"

#include <cjson/cJSON.h>
#include <ctype.h>
#include <float.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "gaussvid/core/core.h"
#include "gaussvid/io/image.h"
#include "gaussvid/io/json.h"

#define MAX_IMAGE_SIDE 1000000

/* What a lookup is about: the file, the parsed document and the current frame. */
typedef struct {
    const char *path;
    char dir[4096];          /* folder of the file, for image paths */
    const cJSON *root, *frame;
    int index;               /* frame index in the file */
    int image_w, image_h;    /* size of the first frame's image, once read */
} reader_ctx;

/* A key of the frame, else of the top level; *where gets "frames[i]." or "". */
static const cJSON *lookup(reader_ctx *c, const char *key, char *where, size_t size)
{
    const cJSON *item = cJSON_GetObjectItemCaseSensitive(c->frame, key);
    snprintf(where, size, "frames[%d].", c->index);
    if (!item) {
        item = cJSON_GetObjectItemCaseSensitive(c->root, key);
        where[0] = '\0';
    }
    return item;
}

/* A finite number under `key`; *found = 0 when the key is absent (not an error). */
static int get_number(reader_ctx *c, const char *key, double *v, int *found)
{
    char where[64];
    const cJSON *item = lookup(c, key, where, sizeof where);
    *found = item != NULL;
    if (!item || gv_json_number(where[0] ? c->frame : c->root, key, -DBL_MAX, DBL_MAX, 0, v) == 0) return 0;
    if (!cJSON_IsNumber(item)) return gv_fail("%s: %s%s is not a number", c->path, where, key);
    return gv_fail("%s: %s%s is not finite (%g)", c->path, where, key, item->valuedouble);
}

static int missing_key(reader_ctx *c, const char *key)
{
    return gv_fail("%s: frames[%d]: missing key %s", c->path, c->index, key);
}

/* Width and height of the first frame's image that needs them, read once (NeRF-synthetic
 * files give no size: docs/reference/gaussian-splatting.md 18.5 takes it from the image). */
static int image_size(reader_ctx *c, const char *name, int *w, int *h)
{
    if (!c->image_w) {
        char path[8192];
        gv_image img;
        if (gv_path_join(path, sizeof path, c->dir, name) != 0) return -1;
        if (gv_image_read(path, &img) != 0)
            return gv_fail_context("%s: frames[%d] gives no w/h and its image cannot be read", c->path, c->index);
        c->image_w = img.width, c->image_h = img.height;
        gv_image_free(&img);
    }
    *w = c->image_w, *h = c->image_h;
    return 0;
}

static int get_size(reader_ctx *c, gv_camera *cam)
{
    double w, h;
    int has_w, has_h;
    if (get_number(c, "w", &w, &has_w) || get_number(c, "h", &h, &has_h)) return -1;
    if (!has_w || !has_h) return image_size(c, cam->name, &cam->width, &cam->height);
    if (w != floor(w) || h != floor(h) || w < 1 || h < 1 || w > MAX_IMAGE_SIDE || h > MAX_IMAGE_SIDE)
        return gv_fail("%s: frames[%d]: image size w=%g h=%g is not a positive integer size",
                       c->path, c->index, w, h);
    cam->width = (int)w, cam->height = (int)h;
    return 0;
}

/* Focal length from fl_x (fl_y) or a field of view: f = size / (2 tan(angle / 2)). */
static int get_focal(reader_ctx *c, const char *fl_key, const char *angle_key, int size,
                     double *f, int *found)
{
    double angle;
    int has_angle;
    if (get_number(c, fl_key, f, found) != 0) return -1;
    if (*found) return 0;
    if (get_number(c, angle_key, &angle, &has_angle) != 0) return -1;
    if (!has_angle) return 0;
    if (!(angle > 0 && angle < M_PI))
        return gv_fail("%s: %s = %g is not an angle in (0, pi) radians", c->path, angle_key, angle);
    *f = size / (2 * tan(angle / 2));
    *found = 1;
    return 0;
}

/* We do not undistort: the camera model must be pinhole-compatible, distortion zero. */
static int check_distortion(reader_ctx *c)
{
    static const char *models[] = {"OPENCV", "PINHOLE", "SIMPLE_PINHOLE", "SIMPLE_RADIAL",
                                   "RADIAL", "FULL_OPENCV"};
    static const char *keys[] = {"k1", "k2", "k3", "k4", "k5", "k6", "p1", "p2"};
    char where[64];
    const cJSON *model = lookup(c, "camera_model", where, sizeof where);
    if (model) {
        if (!cJSON_IsString(model)) return gv_fail("%s: %scamera_model is not a string", c->path, where);
        int ok = 0;
        for (size_t i = 0; i < sizeof models / sizeof *models; i++) ok |= !strcmp(model->valuestring, models[i]);
        if (!ok)
            return gv_fail("%s: %scamera_model %s is not supported (pinhole cameras only; gaussvid "
                           "does not undistort images)", c->path, where, model->valuestring);
    }
    for (size_t i = 0; i < sizeof keys / sizeof *keys; i++) {
        double v;
        int found;
        if (get_number(c, keys[i], &v, &found) != 0) return -1;
        if (found && v != 0) {
            lookup(c, keys[i], where, sizeof where);
            return gv_fail("%s: %s%s = %g: non-zero distortion is not supported (gaussvid does not "
                           "undistort: undistort the images first)", c->path, where, keys[i], v);
        }
    }
    return 0;
}

static int get_intrinsics(reader_ctx *c, gv_camera *cam)
{
    int found;
    if (check_distortion(c) || get_size(c, cam)) return -1;
    if (get_focal(c, "fl_x", "camera_angle_x", cam->width, &cam->fx, &found)) return -1;
    if (!found) return missing_key(c, "fl_x (or camera_angle_x)");
    if (get_focal(c, "fl_y", "camera_angle_y", cam->height, &cam->fy, &found)) return -1;
    if (!found) cam->fy = cam->fx;
    if (get_number(c, "cx", &cam->cx, &found)) return -1;
    if (!found) cam->cx = cam->width / 2.0;
    if (get_number(c, "cy", &cam->cy, &found)) return -1;
    if (!found) cam->cy = cam->height / 2.0;
    if (!(cam->fx > 0) || !(cam->fy > 0))
        return gv_fail("%s: frames[%d]: focal length must be positive (fx=%g fy=%g)", c->path,
                       c->index, cam->fx, cam->fy);
    return 0;
}

static int get_file_path(reader_ctx *c, gv_camera *cam)
{
    const cJSON *item = cJSON_GetObjectItemCaseSensitive(c->frame, "file_path");
    if (!item) return missing_key(c, "file_path");
    if (!cJSON_IsString(item) || !item->valuestring[0])
        return gv_fail("%s: frames[%d].file_path is not a non-empty string", c->path, c->index);
    const char *p = item->valuestring;
    while (p[0] == '.' && p[1] == '/') p += 2;
    if (p[0] == '/') return gv_fail("%s: frames[%d].file_path %s must be relative", c->path, c->index, p);
    const char *base = strrchr(p, '/');
    int has_extension = strchr(base ? base + 1 : p, '.') != NULL;
    if (snprintf(cam->name, sizeof cam->name, "%s%s", p, has_extension ? "" : ".png") >=
        (int)sizeof cam->name)
        return gv_fail("%s: frames[%d].file_path is longer than %zu bytes", c->path, c->index,
                       sizeof cam->name - 1);
    return 0;
}

/* 4x4 (or 3x4) array of finite numbers; the missing last row is (0, 0, 0, 1). */
static int get_matrix(reader_ctx *c, double m[16])
{
    const cJSON *rows = cJSON_GetObjectItemCaseSensitive(c->frame, "transform_matrix");
    if (!rows) return missing_key(c, "transform_matrix");
    int n_rows = cJSON_IsArray(rows) ? cJSON_GetArraySize(rows) : -1;
    if (n_rows != 3 && n_rows != 4)
        return gv_fail("%s: frames[%d].transform_matrix is not a 4x4 (or 3x4) array", c->path, c->index);
    static const double last_row[4] = {0, 0, 0, 1};
    memcpy(m + 12, last_row, sizeof last_row);
    for (int i = 0; i < n_rows; i++) {
        const cJSON *row = cJSON_GetArrayItem(rows, i);
        if (!cJSON_IsArray(row) || cJSON_GetArraySize(row) != 4)
            return gv_fail("%s: frames[%d].transform_matrix row %d does not have 4 entries",
                           c->path, c->index, i);
        for (int j = 0; j < 4; j++) {
            const cJSON *v = cJSON_GetArrayItem(row, j);
            if (!cJSON_IsNumber(v) || !isfinite(v->valuedouble))
                return gv_fail("%s: frames[%d].transform_matrix[%d][%d] is not a finite number",
                               c->path, c->index, i, j);
            m[4 * i + j] = v->valuedouble;
        }
    }
    for (int j = 0; j < 4; j++)
        if (fabs(m[12 + j] - last_row[j]) > 1e-6)
            return gv_fail("%s: frames[%d].transform_matrix: last row is not (0, 0, 0, 1)", c->path, c->index);
    return 0;
}

static double det3(const double a[9])
{
    return a[0] * (a[4] * a[8] - a[5] * a[7]) - a[1] * (a[3] * a[8] - a[5] * a[6]) +
           a[2] * (a[3] * a[7] - a[4] * a[6]);
}

/* Nearest rotation (orthogonal polar factor) by Newton's iteration A <- (A + A^-T) / 2,
 * which converges quadratically from a nearly orthonormal start. */
static void project_to_rotation(double a[9])
{
    for (int iter = 0; iter < 4; iter++) {
        double d = det3(a), cof[9];
        cof[0] = a[4] * a[8] - a[5] * a[7], cof[1] = a[5] * a[6] - a[3] * a[8], cof[2] = a[3] * a[7] - a[4] * a[6];
        cof[3] = a[2] * a[7] - a[1] * a[8], cof[4] = a[0] * a[8] - a[2] * a[6], cof[5] = a[1] * a[6] - a[0] * a[7];
        cof[6] = a[1] * a[5] - a[2] * a[4], cof[7] = a[2] * a[3] - a[0] * a[5], cof[8] = a[0] * a[4] - a[1] * a[3];
        for (int i = 0; i < 9; i++) a[i] = 0.5 * (a[i] + cof[i] / d); /* A^-T = cof(A) / det */
    }
}

static int matrix_to_pose(reader_ctx *c, double m[16], gv_camera *cam)
{
    double r[9], worst = 0;
    for (int i = 0; i < 3; i++)
        for (int j = 0; j < 3; j++) r[3 * i + j] = m[4 * i + j];
    for (int i = 0; i < 3; i++)
        for (int j = 0; j < 3; j++) {
            double dot = r[i] * r[j] + r[3 + i] * r[3 + j] + r[6 + i] * r[6 + j];
            worst = fmax(worst, fabs(dot - (i == j)));
        }
    if (worst > GV_TRANSFORMS_ROTATION_TOLERANCE || det3(r) <= 0)
        return gv_fail("%s: frames[%d].transform_matrix: rotation is not orthonormal with "
                       "determinant +1 (max |R^T R - I| = %.3g, det = %.6g)", c->path, c->index,
                       worst, det3(r));
    project_to_rotation(r);
    for (int i = 0; i < 3; i++)
        for (int j = 0; j < 3; j++) m[4 * i + j] = r[3 * i + j];
    gv_pose_from_c2w_opengl(m, cam->R, cam->t);
    return 0;
}

static int read_frame(reader_ctx *c, gv_camera *cam)
{
    double m[16];
    memset(cam, 0, sizeof *cam);
    if (!cJSON_IsObject(c->frame)) return gv_fail("%s: frames[%d] is not an object", c->path, c->index);
    if (get_file_path(c, cam) || get_intrinsics(c, cam) || get_matrix(c, m)) return -1;
    return matrix_to_pose(c, m, cam);
}

/* The key of the nearest `"key":` before `at`, to name the value a parse error is in. */
static void preceding_key(const char *data, const char *at, char *key, size_t size)
{
    key[0] = '\0';
    for (const char *p = at; p > data; p--) {
        if (*p != ':') continue;
        const char *q = p - 1;
        while (q > data && isspace((unsigned char)*q)) q--;
        if (*q != '"' || q == data) continue; /* the key's closing quote, with room for its opening one */
        const char *s = q - 1;
        while (s > data && *s != '"') s--;
        if (*s == '"') snprintf(key, size, "%.*s", (int)(q - s - 1), s + 1);
        return;
    }
}

/* One line for a parse error: where it is, and a hint for NaN/Infinity, which JSON lacks. */
static int parse_error(const char *path, const char *data, const char *at)
{
    int line = 1;
    for (const char *p = data; p < at; p++) line += *p == '\n';
    char key[128];
    preceding_key(data, at, key, sizeof key);
    int non_finite = !strncmp(at, "NaN", 3) || !strncmp(at, "Infinity", 8) ||
                     !strncmp(at, "-Infinity", 9) || !strncmp(at, "nan", 3) || !strncmp(at, "inf", 3);
    return gv_fail("%s: line %d%s%s: %s", path, line, key[0] ? ", key " : "", key,
                   non_finite ? "NaN/Infinity is not a number (not valid JSON)" : "invalid JSON");
}

static int read_document(reader_ctx *c, cJSON *root, gv_transforms *out)
{
    c->root = root;
    if (!cJSON_IsObject(root)) return gv_fail("%s: top level is not a JSON object", c->path);
    const cJSON *frames = cJSON_GetObjectItemCaseSensitive(root, "frames");
    if (!frames) return gv_fail("%s: missing key frames", c->path);
    int n = cJSON_IsArray(frames) ? cJSON_GetArraySize(frames) : 0;
    if (n == 0) return gv_fail("%s: frames is not a non-empty array", c->path);
    const cJSON *ply = cJSON_GetObjectItemCaseSensitive(root, "ply_file_path");
    if (ply && (!cJSON_IsString(ply) || !ply->valuestring[0] ||
                snprintf(out->ply_file_path, sizeof out->ply_file_path, "%s", ply->valuestring) >=
                    (int)sizeof out->ply_file_path))
        return gv_fail("%s: ply_file_path is not a string of a usable length", c->path);
    if (!(out->cameras = calloc((size_t)n, sizeof *out->cameras))) return gv_fail("%s: out of memory", c->path);
    for (int i = 0; i < n; i++, out->n_frames++) {
        c->index = i;
        c->frame = cJSON_GetArrayItem(frames, i);
        if (read_frame(c, &out->cameras[i]) != 0) return -1;
    }
    return 0;
}

int gv_transforms_read(const char *path, gv_transforms *out)
{
    memset(out, 0, sizeof *out);
    reader_ctx c = {.path = path};
    snprintf(c.dir, sizeof c.dir, "%s", path);
    char *slash = strrchr(c.dir, '/');
    if (slash) *slash = '\0';
    else strcpy(c.dir, ".");
    char *data;
    size_t size;
    if (gv_read_file(path, &data, &size) != 0) return -1;
    const char *end = NULL;
    cJSON *root = cJSON_ParseWithLengthOpts(data, size, &end, 0);
    int ok = root ? read_document(&c, root, out) : parse_error(path, data, end ? end : data);
    cJSON_Delete(root);
    free(data);
    if (ok != 0) gv_transforms_free(out);
    return ok;
}

void gv_transforms_free(gv_transforms *t)
{
    free(t->cameras);
    memset(t, 0, sizeof *t);
}

void gv_pose_from_c2w_opengl(const double c2w[16], double R[9], double t[3])
{
    /* c2w_cv = c2w_gl diag(1, -1, -1, 1); R = (rotation of c2w_cv)^T; t = -R C. */
    static const double flip[3] = {1, -1, -1};
    const double C[3] = {c2w[3], c2w[7], c2w[11]};
    for (int i = 0; i < 3; i++)
        for (int j = 0; j < 3; j++) R[3 * j + i] = c2w[4 * i + j] * flip[j];
    for (int i = 0; i < 3; i++) t[i] = -(R[3 * i] * C[0] + R[3 * i + 1] * C[1] + R[3 * i + 2] * C[2]);
}

void gv_pose_to_c2w_opengl(const double R[9], const double t[3], double c2w[16])
{
    /* c2w_cv = [R^T | -R^T t]; the OpenGL axes negate its 2nd and 3rd columns. */
    static const double flip[3] = {1, -1, -1};
    for (int i = 0; i < 3; i++) {
        for (int j = 0; j < 3; j++) c2w[4 * i + j] = R[3 * j + i] * flip[j];
        c2w[4 * i + 3] = -(R[i] * t[0] + R[3 + i] * t[1] + R[6 + i] * t[2]);
    }
    c2w[12] = c2w[13] = c2w[14] = 0, c2w[15] = 1;
}
