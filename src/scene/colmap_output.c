/* The scene folder from COLMAP's model (colmap_internal.h, docs/SCENES.md "From photos"):
 * image_undistorter runs on BATCH photos at a time (its full-size JPEGs, at quality 100, are
 * four times the photos: a batch at a time keeps them out of the peak); each undistorted photo
 * is turned upright by its EXIF orientation, written once as images/NAME and downscaled as
 * images_K/NAME (JPEG at quality 95 for a .jpg photo, PNG for a .png), and COLMAP's copy
 * removed. The undistorter reads a slim copy of the mapper's model (slim_model). The model is
 * turned the same way (per orientation a camera, the poses rotated about the optical axis) and
 * written as sparse/0, transforms.json and points3D.ply. */
#define _XOPEN_SOURCE 700
#include <ftw.h>
#include <stdlib.h>
#include <string.h>
#include <strings.h>

#include "colmap_internal.h"
#include "gaussvid/io/image.h"
#include "gaussvid/scene/scene.h"

#define BATCH 8
#define JPEG_QUALITY 95

/* A mirrored tag (a front camera's) is turned upright without the mirror: a mirror image has
 * no camera. 2 -> 1, 4 -> 3, 5 -> 6, 7 -> 8 (each the rotation before the left-right mirror). */
static int rotation_of(int orientation)
{
    static const int rotation[9] = {1, 1, 1, 3, 3, 6, 6, 8, 8};
    return orientation >= 1 && orientation <= 8 ? rotation[orientation] : 1;
}

static int orientation_of(const colmap_photos *p, const char *name)
{
    for (int i = 0; i < p->n; i++)
        if (!strcmp(p->photo[i].name, name)) return rotation_of(p->photo[i].orientation);
    return 1;
}

static int remove_entry(const char *path, const struct stat *st, int flag, struct FTW *ftw)
{
    (void)st, (void)flag, (void)ftw;
    remove(path);
    return 0;
}

/* One undistorted photo: upright, written at full size and at each downscale; COLMAP's copy removed. */
static int write_photo(const colmap_paths *paths, const gv_colmap_run_options *o, const char *name, int rotation)
{
    char from[COLMAP_PATH + 300], to[COLMAP_PATH + 300];
    gv_image stored, up;
    int tag;
    snprintf(from, sizeof from, "%s/images/%s", paths->undistorted, name);
    if (gv_image_read_stored(from, &stored, &tag)) return -1;
    int rc = gv_image_orient(&stored, rotation, &up);
    gv_image_free(&stored);
    const char *dot = strrchr(name, '.');
    int png = dot && !strcasecmp(dot, ".png");
    for (int k = 0; rc == 0 && k <= o->n_downscales; k++) {
        int factor = k ? o->downscales[k - 1] : 1;
        gv_image small;
        if (factor == 1) snprintf(to, sizeof to, "%s/images", o->out_dir);
        else snprintf(to, sizeof to, "%s/images_%d", o->out_dir, factor);
        if ((rc = gv_mkdirs(to))) break;
        snprintf(to + strlen(to), sizeof to - strlen(to), "/%s", name);
        const gv_image *out = &up;
        if (factor > 1 && (rc = gv_image_downscale(&up, factor, &small))) break;
        if (factor > 1) out = &small;
        rc = png ? gv_image_write_png(to, out) : gv_image_write_jpeg(to, out, JPEG_QUALITY);
        if (factor > 1) gv_image_free(&small);
    }
    gv_image_free(&up);
    if (rc == 0) remove(from);
    return rc;
}

/* COLMAP's undistorter on names [from, to) of the model, then each photo written. */
static int undistort_batch(const colmap_paths *paths, const gv_colmap_run_options *o, const colmap_photos *p,
                           const gv_colmap_model *m, const char *model, int from, int to)
{
    char list[COLMAP_PATH + 32], text[BATCH * (GV_COLMAP_MAX_NAME + 1) + 1];
    size_t len = 0;
    text[0] = 0;
    for (int i = from; i < to; i++) len += (size_t)snprintf(text + len, sizeof text - len, "%s%s", i > from ? "\n" : "", m->images[i].name);
    snprintf(list, sizeof list, "%s/undistort_list.txt", paths->work);
    if (gv_write_text_atomic(list, text)) return -1;
    const char *argv[] = {paths->colmap, "image_undistorter", "--image_path", paths->images, "--input_path", model,
                          "--output_path", paths->undistorted, "--output_type", "COLMAP", "--image_list_path", list,
                          NULL};
    if (colmap_step(argv, paths->log, NULL, NULL)) return -1;
    for (int i = from; i < to; i++)
        if (write_photo(paths, o, m->images[i].name, orientation_of(p, m->images[i].name))) return -1;
    return 0;
}

/* A photo shown turned by rotation 3, 6 or 8 (stored W x H): its pixel (x, y) shows at
 * (W - x, H - y), (H - y, x) or (y, W - x) (continuous coordinates), so the intrinsics move
 * with the pixels and the camera frame turns by M: x' = M x in the camera's coordinates. */
static void turn_matrix(int rotation, double M[9])
{
    static const double m3[9] = {-1, 0, 0, 0, -1, 0, 0, 0, 1}, m6[9] = {0, -1, 0, 1, 0, 0, 0, 0, 1},
                        m8[9] = {0, 1, 0, -1, 0, 0, 0, 0, 1};
    memcpy(M, rotation == 3 ? m3 : rotation == 6 ? m6 : m8, 9 * sizeof *M);
}

static void turn_intrinsics(int rotation, gv_colmap_camera *c)
{
    double fx = c->params[0], fy = c->params[1], cx = c->params[2], cy = c->params[3];
    int W = c->width, H = c->height;
    if (rotation == 3) {
        c->params[2] = W - cx, c->params[3] = H - cy;
        return;
    }
    c->width = H, c->height = W;
    c->params[0] = fy, c->params[1] = fx;
    c->params[2] = rotation == 6 ? H - cy : cy;
    c->params[3] = rotation == 6 ? cx : W - cx;
}

/* World-to-camera R' = M R, t' = M t. */
static void turn_pose(int rotation, gv_colmap_image *im)
{
    double M[9], R[9], R2[9], t[3];
    turn_matrix(rotation, M);
    gv_colmap_qvec_to_rotmat(im->qvec, R);
    for (int i = 0; i < 3; i++) {
        t[i] = 0;
        for (int k = 0; k < 3; k++) t[i] += M[3 * i + k] * im->tvec[k];
        for (int j = 0; j < 3; j++) {
            R2[3 * i + j] = 0;
            for (int k = 0; k < 3; k++) R2[3 * i + j] += M[3 * i + k] * R[3 * k + j];
        }
    }
    gv_colmap_rotmat_to_qvec(R2, im->qvec);
    memcpy(im->tvec, t, sizeof t);
}

/* Each image's camera turned by its photo's orientation: one camera per (camera, rotation). */
static int turn_model(gv_colmap_model *m, const colmap_photos *p)
{
    int cap = 4 * m->n_cameras, n = 0, *source = malloc((size_t)cap * sizeof *source);
    gv_colmap_camera *cams = calloc((size_t)cap, sizeof *cams);
    if (!cams || !source) {
        free(cams), free(source);
        return gv_fail("out of memory for %d cameras", cap);
    }
    for (int i = 0; i < m->n_images; i++) {
        gv_colmap_image *im = &m->images[i];
        int rot = orientation_of(p, im->name), j = 0;
        const gv_colmap_camera *c = m->cameras;
        while (c->id != im->camera_id) c++; /* exists: checked by the reader */
        while (j < n && source[j] != c->id * 10 + rot) j++;
        if (j == n) {
            cams[n] = *c, cams[n].id = n + 1, source[n] = c->id * 10 + rot;
            if (rot != 1) turn_intrinsics(rot, &cams[n]);
            n++;
        }
        if (rot != 1) turn_pose(rot, im);
        im->camera_id = j + 1;
    }
    free(m->cameras), free(source);
    m->cameras = cams, m->n_cameras = n;
    return 0;
}

static int copy_file(const char *from, const char *to)
{
    FILE *in = fopen(from, "rb");
    if (!in) return gv_fail("%s: cannot open", from);
    gv_atomic_file af;
    if (gv_atomic_open(&af, to)) {
        fclose(in);
        return -1;
    }
    char buf[65536];
    size_t n;
    while ((n = fread(buf, 1, sizeof buf, in)) > 0)
        if (fwrite(buf, 1, n, af.f) != n) break;
    int bad = ferror(in) || !feof(in);
    fclose(in);
    if (bad) {
        gv_atomic_abort(&af);
        return gv_fail("%s: read error", from);
    }
    return gv_atomic_commit(&af);
}

/* The mapper's model read (m: the images' names and poses, the points), then written slim into
 * OUT/colmap/model: its 2D points and tracks, 24 and 8 bytes per feature seen and most of its
 * size (half the photos' at 540x960), are left out (the undistorter needs neither and would
 * copy them again), cameras.bin copied as it is (gaussvid reads no distorted camera); the
 * mapper's models are then removed, so they are not on disk beside the scene's images. */
static int slim_model(const colmap_paths *paths, int best, gv_colmap_model *m, char *slim, size_t size)
{
    char dir[COLMAP_PATH + 16], from[COLMAP_PATH + 32], to[COLMAP_PATH + 32];
    snprintf(dir, sizeof dir, "%s/%d", paths->sparse, best);
    snprintf(slim, size, "%s/model", paths->work);
    memset(m, 0, sizeof *m);
    snprintf(from, sizeof from, "%s/images.bin", dir);
    if (gv_colmap_read_images_bin(from, m)) return gv_fail_context("the model COLMAP mapped");
    snprintf(from, sizeof from, "%s/points3D.bin", dir);
    if (gv_colmap_read_points3d_bin(from, m)) return gv_fail_context("the model COLMAP mapped");
    gv_colmap_model no_points = *m;
    no_points.n_points = 0;
    snprintf(from, sizeof from, "%s/cameras.bin", dir);
    snprintf(to, sizeof to, "%s/cameras.bin", slim);
    if (gv_mkdirs(slim) || copy_file(from, to)) return -1;
    snprintf(to, sizeof to, "%s/images.bin", slim);
    if (gv_colmap_write_images_bin(to, m)) return -1;
    snprintf(to, sizeof to, "%s/points3D.bin", slim);
    if (gv_colmap_write_points3d_bin(to, &no_points)) return -1;
    colmap_remove_models(paths->sparse);
    return 0;
}

int colmap_write_scene(const colmap_paths *paths, const gv_colmap_run_options *o, const colmap_photos *p,
                       int best, gv_colmap_run_result *r)
{
    char model[COLMAP_PATH + 16], sparse[COLMAP_PATH + 16], dir[COLMAP_PATH + 16];
    gv_colmap_model m, u;
    memset(&u, 0, sizeof u);
    if (slim_model(paths, best, &m, model, sizeof model)) {
        gv_colmap_free(&m);
        return -1;
    }
    nftw(paths->undistorted, remove_entry, 16, FTW_DEPTH | FTW_PHYS); /* an earlier run's */
    gv_progress bar;
    gv_progress_start(&bar, "undistort", m.n_images);
    int rc = 0;
    for (int i = 0; i < m.n_images && rc == 0; i += BATCH) {
        int to = i + BATCH < m.n_images ? i + BATCH : m.n_images;
        rc = undistort_batch(paths, o, p, &m, model, i, to);
        gv_progress_update(&bar, to, NULL);
    }
    gv_progress_finish(&bar);
    snprintf(sparse, sizeof sparse, "%s/sparse", paths->undistorted);
    if (rc == 0 && gv_colmap_read_bin(sparse, &u)) rc = gv_fail_context("the undistorted model");
    if (rc == 0) { /* the points are the mapper's: undistortion moves no 3D point */
        free(u.points);
        u.points = m.points, u.n_points = m.n_points;
        m.points = NULL, m.n_points = 0;
        rc = turn_model(&u, p);
    }
    gv_colmap_free(&m);
    r->points = u.n_points;
    snprintf(dir, sizeof dir, "%s/sparse/0", o->out_dir);
    if (rc == 0) rc = gv_mkdirs(dir) || gv_colmap_write_text(dir, &u);
    gv_colmap_free(&u);
    gv_scene scene;
    if (rc == 0 && (rc = gv_scene_load(o->out_dir, NULL, &scene)) == 0) {
        rc = gv_scene_write(o->out_dir, &scene);
        gv_scene_free(&scene);
    }
    if (rc == 0) nftw(paths->undistorted, remove_entry, 16, FTW_DEPTH | FTW_PHYS);
    return rc;
}
