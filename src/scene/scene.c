/* Loading a scene folder (docs/SCENES.md): the description (sparse/0 binary, else text, else
 * transforms.json), the point cloud, the image folder for the requested downscale, and the
 * check that every frame's image exists. */
#include "gaussvid/scene/scene.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "gaussvid/io/colmap.h"
#include "gaussvid/core/core.h"
#include "gaussvid/io/ply.h"
#include "gaussvid/io/transforms.h"

#define MAX_DOWNSCALE 64

static int compare_names(const void *a, const void *b)
{
    return strcmp(((const gv_camera *)a)->name, ((const gv_camera *)b)->name);
}

static int from_colmap(gv_scene *s, const char *sparse, int binary)
{
    gv_colmap_model m;
    char cameras_path[4200];
    snprintf(cameras_path, sizeof cameras_path, "%s/cameras.%s", sparse, binary ? "bin" : "txt");
    if ((binary ? gv_colmap_read_bin : gv_colmap_read_text)(sparse, &m) != 0) return -1;
    int ok = 0;
    if (m.n_images == 0) ok = gv_fail("%s/images.%s: no registered images", sparse, binary ? "bin" : "txt");
    if (ok == 0 && !(s->cameras = calloc((size_t)m.n_images, sizeof *s->cameras)))
        ok = gv_fail("%s: out of memory", sparse);
    for (int i = 0; ok == 0 && i < m.n_images; i++, s->n_frames++) {
        const gv_colmap_image *im = &m.images[i];
        const gv_colmap_camera *c = m.cameras;
        while (c->id != im->camera_id) c++; /* exists: checked by the reader */
        gv_camera *cam = &s->cameras[i];
        ok = gv_colmap_camera_pinhole(c, cameras_path, &cam->fx, &cam->fy, &cam->cx, &cam->cy);
        cam->width = c->width, cam->height = c->height;
        gv_colmap_qvec_to_rotmat(im->qvec, cam->R);
        memcpy(cam->t, im->tvec, sizeof cam->t);
        snprintf(cam->name, sizeof cam->name, "%s", im->name);
    }
    if (ok == 0 && m.n_points > 0) {
        s->points = malloc((size_t)m.n_points * 3 * sizeof *s->points);
        s->colors = malloc((size_t)m.n_points * 3);
        if (!s->points || !s->colors) ok = gv_fail("%s: out of memory", sparse);
        for (int i = 0; ok == 0 && i < m.n_points; i++)
            for (int k = 0; k < 3; k++) {
                s->points[3 * i + k] = (float)m.points[i].xyz[k];
                s->colors[3 * i + k] = m.points[i].rgb[k];
            }
        if (ok == 0) s->n_points = m.n_points;
    }
    snprintf(s->image_dir, sizeof s->image_dir, "%s/images", s->dir);
    gv_colmap_free(&m);
    return ok;
}

/* When every file path starts with the same folder ("images/..."), that folder is the image
 * folder and is removed from the names; otherwise names stay relative to the scene folder. */
static void split_image_folder(gv_scene *s)
{
    const char *first = s->cameras[0].name, *slash = strchr(first, '/');
    size_t len = slash ? (size_t)(slash - first) + 1 : 0;
    for (int i = 1; i < s->n_frames && len; i++)
        if (strncmp(s->cameras[i].name, first, len) != 0) len = 0;
    if (len) snprintf(s->image_dir, sizeof s->image_dir, "%s/%.*s", s->dir, (int)(len - 1), first);
    else snprintf(s->image_dir, sizeof s->image_dir, "%s", s->dir);
    for (int i = 0; i < s->n_frames && len; i++)
        memmove(s->cameras[i].name, s->cameras[i].name + len, strlen(s->cameras[i].name + len) + 1);
}

static int load_points_ply(gv_scene *s, const char *path)
{
    return gv_points_read_ply(path, &s->n_points, &s->points, &s->colors);
}

static int from_transforms(gv_scene *s, const char *path)
{
    gv_transforms tf;
    if (gv_transforms_read(path, &tf) != 0) return -1;
    s->cameras = tf.cameras, s->n_frames = tf.n_frames;
    tf.cameras = NULL;
    split_image_folder(s);
    char ply[8300];
    if (tf.ply_file_path[0]) {
        snprintf(ply, sizeof ply, "%s/%s", s->dir, tf.ply_file_path);
        if (!gv_file_exists(ply))
            return gv_fail("%s: ply_file_path %s does not exist", path, tf.ply_file_path);
        return load_points_ply(s, ply);
    }
    snprintf(ply, sizeof ply, "%s/points3D.ply", s->dir);
    return gv_file_exists(ply) ? load_points_ply(s, ply) : 0;
}

/* Picks the description: sparse/0 binary, else text, else transforms.json. */
static int load_description(gv_scene *s, int prefer_transforms)
{
    char sparse[4200], bin[4300], txt[4300], json[4300];
    snprintf(sparse, sizeof sparse, "%s/sparse/0", s->dir);
    snprintf(bin, sizeof bin, "%s/cameras.bin", sparse);
    snprintf(txt, sizeof txt, "%s/cameras.txt", sparse);
    snprintf(json, sizeof json, "%s/transforms.json", s->dir);
    int has_json = gv_file_exists(json);
    if (prefer_transforms && has_json) {
        s->source = GV_SCENE_FROM_TRANSFORMS;
        return from_transforms(s, json);
    }
    if (gv_file_exists(bin)) {
        s->source = GV_SCENE_FROM_COLMAP_BIN;
        return from_colmap(s, sparse, 1);
    }
    if (gv_file_exists(txt)) {
        s->source = GV_SCENE_FROM_COLMAP_TEXT;
        return from_colmap(s, sparse, 0);
    }
    if (has_json) {
        s->source = GV_SCENE_FROM_TRANSFORMS;
        return from_transforms(s, json);
    }
    return gv_fail("%s: no scene description (expected sparse/0/cameras.bin, sparse/0/cameras.txt "
                   "or transforms.json)", s->dir);
}

/* Names must be safe relative paths, unique; frames are sorted by name. */
static int sort_and_check_names(gv_scene *s)
{
    for (int i = 0; i < s->n_frames; i++) {
        const char *n = s->cameras[i].name;
        if (!n[0] || n[0] == '/' || !strncmp(n, "../", 3) || strstr(n, "/../"))
            return gv_fail("%s: frame %d: image name '%s' is not a relative path inside %s",
                           s->dir, i, n, s->image_dir);
    }
    qsort(s->cameras, (size_t)s->n_frames, sizeof *s->cameras, compare_names);
    for (int i = 1; i < s->n_frames; i++)
        if (!strcmp(s->cameras[i].name, s->cameras[i - 1].name))
            return gv_fail("%s: image %s is used by two frames", s->dir, s->cameras[i].name);
    return 0;
}

int gv_downscaled_size(int size, int k)
{
    int r = (int)nearbyint((double)size / k); /* default rounding: half to even */
    return r < 1 ? 1 : r;
}

void gv_camera_rescale(gv_camera *cam, int width, int height)
{
    double sx = (double)width / cam->width, sy = (double)height / cam->height;
    cam->fx *= sx, cam->cx *= sx;
    cam->fy *= sy, cam->cy *= sy;
    cam->width = width, cam->height = height;
}

/* With images_<k>/: each camera takes the size of its downscaled image. The first image of
 * each distinct original size is read; it must be within a pixel of W/k x H/k. */
static int rescale_from_folder(gv_scene *s, int k)
{
    int from[64][2], to[64][2], n_sizes = 0;
    for (int i = 0; i < s->n_frames; i++) {
        gv_camera *cam = &s->cameras[i];
        int j = 0;
        while (j < n_sizes && (from[j][0] != cam->width || from[j][1] != cam->height)) j++;
        if (j == n_sizes) {
            char path[8400];
            gv_image img;
            if (n_sizes == 64) return gv_fail("%s: more than 64 different image sizes", s->dir);
            snprintf(path, sizeof path, "%s/%s", s->image_dir, cam->name);
            if (gv_image_read(path, &img) != 0) return -1;
            from[j][0] = cam->width, from[j][1] = cam->height;
            to[j][0] = img.width, to[j][1] = img.height;
            gv_image_free(&img);
            n_sizes++;
            if (fabs(to[j][0] - (double)cam->width / k) >= 1 || fabs(to[j][1] - (double)cam->height / k) >= 1)
                return gv_fail("%s: is %dx%d, which is not the camera's %dx%d downscaled by %d",
                               path, to[j][0], to[j][1], cam->width, cam->height, k);
        }
        gv_camera_rescale(cam, to[j][0], to[j][1]);
    }
    return 0;
}

/* images_<k>/ when it exists next to images/, else the full images downscaled in memory. */
static int choose_images(gv_scene *s, int k)
{
    s->downscale = k;
    s->memory_downscale = 1;
    if (k == 1) return 0;
    char base[4200], folder[4200];
    snprintf(base, sizeof base, "%s/images", s->dir);
    snprintf(folder, sizeof folder, "%s/images_%d", s->dir, k);
    if (!strcmp(s->image_dir, base) && gv_dir_exists(folder)) {
        snprintf(s->image_dir, sizeof s->image_dir, "%s", folder);
        return rescale_from_folder(s, k);
    }
    s->memory_downscale = k;
    for (int i = 0; i < s->n_frames; i++)
        gv_camera_rescale(&s->cameras[i], gv_downscaled_size(s->cameras[i].width, k),
                          gv_downscaled_size(s->cameras[i].height, k));
    return 0;
}

static int check_images_exist(const gv_scene *s)
{
    char path[8400];
    for (int i = 0; i < s->n_frames; i++) {
        snprintf(path, sizeof path, "%s/%s", s->image_dir, s->cameras[i].name);
        if (!gv_file_exists(path)) return gv_fail("%s: image of frame %d is missing", path, i);
    }
    return 0;
}

int gv_scene_load(const char *dir, const gv_scene_options *opt, gv_scene *out)
{
    gv_scene_options defaults = {.downscale = 1};
    if (!opt) opt = &defaults;
    memset(out, 0, sizeof *out);
    int k = opt->downscale ? opt->downscale : 1;
    if (k < 1 || k > MAX_DOWNSCALE)
        return gv_fail("%s: downscale %d is not in 1..%d", dir, k, MAX_DOWNSCALE);
    if (snprintf(out->dir, sizeof out->dir, "%s", dir) >= (int)sizeof out->dir - 64)
        return gv_fail("%s: path too long", dir);
    size_t len = strlen(out->dir);
    while (len > 1 && out->dir[len - 1] == '/') out->dir[--len] = '\0';
    if (!gv_dir_exists(out->dir)) return gv_fail("%s: no such scene folder", dir);
    out->white_background = opt->white_background;
    if (load_description(out, opt->prefer_transforms) || sort_and_check_names(out) ||
        choose_images(out, k) || check_images_exist(out)) {
        gv_scene_free(out);
        return -1;
    }
    return 0;
}

void gv_scene_free(gv_scene *scene)
{
    free(scene->cameras);
    free(scene->points);
    free(scene->colors);
    scene->cameras = NULL, scene->points = NULL, scene->colors = NULL;
    scene->n_frames = scene->n_points = 0;
}
