/* transforms.json writer in the nerfstudio convention (as in the shared scenes): OPENCV camera
 * model with zero distortion, intrinsics at the top level when every frame shares them, and
 * per frame a file_path and the OpenGL camera-to-world transform_matrix. */
#include <cjson/cJSON.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "gaussvid/core/core.h"
#include "gaussvid/io/transforms.h"

static int same_intrinsics(const gv_camera *a, const gv_camera *b)
{
    return a->width == b->width && a->height == b->height && a->fx == b->fx && a->fy == b->fy &&
           a->cx == b->cx && a->cy == b->cy;
}

/* Adds a number; *ok becomes 0 when cJSON runs out of memory. */
static void add_number(cJSON *obj, const char *key, double v, int *ok)
{
    if (!cJSON_AddNumberToObject(obj, key, v)) *ok = 0;
}

static void add_intrinsics(cJSON *obj, const gv_camera *cam, int *ok)
{
    add_number(obj, "fl_x", cam->fx, ok);
    add_number(obj, "fl_y", cam->fy, ok);
    add_number(obj, "cx", cam->cx, ok);
    add_number(obj, "cy", cam->cy, ok);
    add_number(obj, "w", cam->width, ok);
    add_number(obj, "h", cam->height, ok);
}

static cJSON *frame_object(const gv_camera *cam, const char *image_folder, int per_frame, int *ok)
{
    cJSON *frame = cJSON_CreateObject(), *rows = cJSON_CreateArray();
    char file_path[4096 + 256];
    snprintf(file_path, sizeof file_path, "%s%s%s", image_folder, image_folder[0] ? "/" : "", cam->name);
    if (!frame || !rows || !cJSON_AddStringToObject(frame, "file_path", file_path)) *ok = 0;
    if (per_frame) add_intrinsics(frame, cam, ok);
    double c2w[16];
    gv_pose_to_c2w_opengl(cam->R, cam->t, c2w);
    for (int i = 0; i < 4 && *ok; i++) {
        cJSON *row = cJSON_CreateDoubleArray(c2w + 4 * i, 4);
        if (!row || !rows || !cJSON_AddItemToArray(rows, row)) *ok = 0, cJSON_Delete(row);
    }
    if (frame && rows && cJSON_AddItemToObject(frame, "transform_matrix", rows)) rows = NULL;
    else *ok = 0;
    cJSON_Delete(rows);
    return frame;
}

static int check_cameras(const char *path, const gv_camera *cameras, int n)
{
    if (n < 1) return gv_fail("%s: no frames to write", path);
    for (int i = 0; i < n; i++) {
        const gv_camera *c = &cameras[i];
        int finite = isfinite(c->fx) && isfinite(c->fy) && isfinite(c->cx) && isfinite(c->cy);
        for (int k = 0; k < 9; k++) finite &= isfinite(c->R[k]) != 0;
        for (int k = 0; k < 3; k++) finite &= isfinite(c->t[k]) != 0;
        if (!finite || c->width < 1 || c->height < 1 || !c->name[0])
            return gv_fail("%s: frame %d (%s) has a non-finite value, no size or no name", path, i, c->name);
    }
    return 0;
}

static cJSON *build_document(const gv_camera *cameras, int n, const char *image_folder,
                             const char *ply_file_path, int *ok)
{
    static const char *distortion[4] = {"k1", "k2", "p1", "p2"};
    int shared = 1;
    for (int i = 1; i < n; i++) shared &= same_intrinsics(&cameras[0], &cameras[i]);
    cJSON *root = cJSON_CreateObject(), *frames = cJSON_CreateArray();
    if (!root || !frames || !cJSON_AddStringToObject(root, "camera_model", "OPENCV")) *ok = 0;
    if (shared && *ok) add_intrinsics(root, &cameras[0], ok);
    for (int k = 0; k < 4 && *ok; k++) add_number(root, distortion[k], 0.0, ok);
    for (int i = 0; i < n && *ok; i++) {
        cJSON *frame = frame_object(&cameras[i], image_folder, !shared, ok);
        if (!frame || !frames || !cJSON_AddItemToArray(frames, frame)) *ok = 0, cJSON_Delete(frame);
    }
    if (root && frames && cJSON_AddItemToObject(root, "frames", frames)) frames = NULL;
    else *ok = 0;
    cJSON_Delete(frames);
    if (ply_file_path && *ok && !cJSON_AddStringToObject(root, "ply_file_path", ply_file_path)) *ok = 0;
    return root;
}

int gv_transforms_write(const char *path, const gv_camera *cameras, int n,
                        const char *image_folder, const char *ply_file_path)
{
    if (check_cameras(path, cameras, n) != 0) return -1;
    int ok = 1;
    cJSON *root = build_document(cameras, n, image_folder ? image_folder : "", ply_file_path, &ok);
    char *text = ok ? cJSON_Print(root) : NULL;
    cJSON_Delete(root);
    if (!text) return gv_fail("%s: out of memory while building the JSON", path);
    gv_atomic_file af;
    if (gv_atomic_open(&af, path) != 0) {
        free(text);
        return -1;
    }
    fputs(text, af.f);
    fputc('\n', af.f);
    free(text);
    return gv_atomic_commit(&af);
}
