/* COLMAP binary model files (little-endian; docs/reference/gaussian-splatting.md 18.4):
 *   cameras.bin   u64 n; n x (i32 id, i32 model, u64 width, u64 height, f64 params[])
 *   images.bin    u64 n; n x (i32 id, f64 qw qx qy qz, f64 tx ty tz, i32 camera_id,
 *                 NUL-terminated name, u64 n2d, n2d x (f64 x, f64 y, i64 point3D_id))
 *   points3D.bin  u64 n; n x (u64 id, f64 x y z, u8 r g b, f64 error, u64 track_length,
 *                 track_length x (i32 image_id, i32 point2D_idx))
 * The file is streamed; every count is checked against the bytes left in the file before
 * anything is allocated, so a corrupt count fails at once. */
#include <errno.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>

#include "gaussvid/io/colmap.h"
#include "gaussvid/core/core.h"

/* Fixed part of each record, used to bound counts by the file size. */
enum { CAMERA_MIN_BYTES = 24, IMAGE_MIN_BYTES = 64 + 1 + 8, POINT2D_BYTES = 24,
       POINT_MIN_BYTES = 43 + 8, TRACK_ELEMENT_BYTES = 8 };
#define MAX_IMAGE_SIDE 1000000

typedef struct {
    FILE *f;
    const char *path;
    uint64_t left;    /* bytes not yet read */
    uint64_t offset;
} bin_reader;

static int reader_open(bin_reader *r, const char *path)
{
    memset(r, 0, sizeof *r);
    r->path = path;
    r->f = fopen(path, "rb");
    if (!r->f) return gv_fail("%s: cannot open: %s", path, strerror(errno));
    struct stat st;
    if (fstat(fileno(r->f), &st) != 0 || !S_ISREG(st.st_mode)) {
        fclose(r->f);
        return gv_fail("%s: not a regular file", path);
    }
    r->left = (uint64_t)st.st_size;
    return 0;
}

static int reader_bytes(bin_reader *r, void *out, uint64_t n)
{
    if (n > r->left || fread(out, 1, (size_t)n, r->f) != n)
        return gv_fail("%s: truncated: %llu bytes needed at offset %llu, file ends there",
                       r->path, (unsigned long long)n, (unsigned long long)r->offset);
    r->left -= n;
    r->offset += n;
    return 0;
}

static int reader_skip(bin_reader *r, uint64_t n)
{
    if (n > r->left || fseeko(r->f, (off_t)n, SEEK_CUR) != 0)
        return gv_fail("%s: truncated: %llu bytes needed at offset %llu, file ends there",
                       r->path, (unsigned long long)n, (unsigned long long)r->offset);
    r->left -= n;
    r->offset += n;
    return 0;
}

/* Little-endian decoding that does not depend on the host's byte order. */
static uint64_t le64(const unsigned char *b)
{
    uint64_t v = 0;
    for (int i = 7; i >= 0; i--) v = v << 8 | b[i];
    return v;
}

static int read_u64(bin_reader *r, uint64_t *v)
{
    unsigned char b[8];
    if (reader_bytes(r, b, 8) != 0) return -1;
    *v = le64(b);
    return 0;
}

static int read_i32(bin_reader *r, int *v)
{
    unsigned char b[4];
    if (reader_bytes(r, b, 4) != 0) return -1;
    *v = (int)(int32_t)((uint32_t)b[0] | (uint32_t)b[1] << 8 | (uint32_t)b[2] << 16 |
                        (uint32_t)b[3] << 24);
    return 0;
}

static int read_f64(bin_reader *r, double *v)
{
    uint64_t bits;
    if (read_u64(r, &bits) != 0) return -1;
    memcpy(v, &bits, 8);
    return 0;
}

/* Reads the leading count and checks that `min_bytes` per record fit in the rest. */
static int read_count(bin_reader *r, uint64_t min_bytes, const char *what, int *count)
{
    uint64_t n;
    if (read_u64(r, &n) != 0) return -1;
    if (n > r->left / min_bytes || n > INT32_MAX)
        return gv_fail("%s: header says %llu %s, but the file has room for at most %llu",
                       r->path, (unsigned long long)n, what,
                       (unsigned long long)(r->left / min_bytes));
    *count = (int)n;
    return 0;
}

static int reader_finish(bin_reader *r, int ok)
{
    if (ok == 0 && r->left != 0)
        ok = gv_fail("%s: %llu unexpected bytes after the last record", r->path,
                     (unsigned long long)r->left);
    fclose(r->f);
    return ok;
}

static int read_camera(bin_reader *r, gv_colmap_camera *c)
{
    uint64_t width, height;
    memset(c, 0, sizeof *c);
    if (read_i32(r, &c->id) || read_i32(r, &c->model) || read_u64(r, &width) || read_u64(r, &height))
        return -1;
    int n_params = gv_colmap_model_n_params(c->model);
    if (n_params < 0) return gv_fail("%s: camera %d: unknown camera model id %d", r->path, c->id, c->model);
    if (width < 1 || height < 1 || width > MAX_IMAGE_SIDE || height > MAX_IMAGE_SIDE)
        return gv_fail("%s: camera %d: bad image size %llux%llu", r->path, c->id,
                       (unsigned long long)width, (unsigned long long)height);
    c->width = (int)width, c->height = (int)height;
    for (int i = 0; i < n_params; i++)
        if (read_f64(r, &c->params[i]) != 0) return -1;
    double fx, fy, cx, cy;
    return gv_colmap_camera_pinhole(c, r->path, &fx, &fy, &cx, &cy);
}

int gv_colmap_read_cameras_bin(const char *path, gv_colmap_model *model)
{
    bin_reader r;
    if (reader_open(&r, path) != 0) return -1;
    free(model->cameras);
    model->cameras = NULL, model->n_cameras = 0;
    int n, ok = read_count(&r, CAMERA_MIN_BYTES, "cameras", &n);
    if (ok == 0 && n > 0 && !(model->cameras = calloc((size_t)n, sizeof *model->cameras)))
        ok = gv_fail("%s: out of memory", path);
    for (int i = 0; ok == 0 && i < n; i++, model->n_cameras++)
        ok = read_camera(&r, &model->cameras[i]);
    if (reader_finish(&r, ok) == 0) return 0;
    free(model->cameras); /* a failed read leaves nothing behind */
    model->cameras = NULL, model->n_cameras = 0;
    return -1;
}

static int read_image(bin_reader *r, gv_colmap_image *im)
{
    memset(im, 0, sizeof *im);
    if (read_i32(r, &im->id)) return -1;
    for (int i = 0; i < 4; i++) if (read_f64(r, &im->qvec[i])) return -1;
    for (int i = 0; i < 3; i++) if (read_f64(r, &im->tvec[i])) return -1;
    if (read_i32(r, &im->camera_id)) return -1;
    for (int i = 0; ; i++) {
        if (i == GV_COLMAP_MAX_NAME)
            return gv_fail("%s: image %d: name longer than %d bytes or not NUL-terminated",
                           r->path, im->id, GV_COLMAP_MAX_NAME - 1);
        if (reader_bytes(r, &im->name[i], 1) != 0) return -1;
        if (im->name[i] == '\0') break;
    }
    if (!im->name[0]) return gv_fail("%s: image %d: empty name", r->path, im->id);
    double qn = 0;
    for (int i = 0; i < 4; i++) qn += im->qvec[i] * im->qvec[i];
    for (int i = 0; i < 3; i++)
        if (!isfinite(im->tvec[i])) return gv_fail("%s: image %d: translation is not finite", r->path, im->id);
    if (!isfinite(qn) || qn < 1e-12)
        return gv_fail("%s: image %d: quaternion is zero or not finite", r->path, im->id);
    uint64_t n2d;
    if (read_u64(r, &n2d) != 0) return -1;
    if (n2d > r->left / POINT2D_BYTES)
        return gv_fail("%s: image %d: says %llu 2D points, but the file has room for at most %llu",
                       r->path, im->id, (unsigned long long)n2d,
                       (unsigned long long)(r->left / POINT2D_BYTES));
    return reader_skip(r, n2d * POINT2D_BYTES);
}

int gv_colmap_read_images_bin(const char *path, gv_colmap_model *model)
{
    bin_reader r;
    if (reader_open(&r, path) != 0) return -1;
    free(model->images);
    model->images = NULL, model->n_images = 0;
    int n, ok = read_count(&r, IMAGE_MIN_BYTES, "images", &n);
    if (ok == 0 && n > 0 && !(model->images = calloc((size_t)n, sizeof *model->images)))
        ok = gv_fail("%s: out of memory", path);
    for (int i = 0; ok == 0 && i < n; i++, model->n_images++)
        ok = read_image(&r, &model->images[i]);
    if (reader_finish(&r, ok) == 0) return 0;
    free(model->images); /* a failed read leaves nothing behind */
    model->images = NULL, model->n_images = 0;
    return -1;
}

static int read_point(bin_reader *r, gv_colmap_point *p)
{
    memset(p, 0, sizeof *p);
    if (read_u64(r, &p->id)) return -1;
    for (int i = 0; i < 3; i++) {
        if (read_f64(r, &p->xyz[i])) return -1;
        if (!isfinite(p->xyz[i]))
            return gv_fail("%s: point %llu: coordinate is not finite", r->path, (unsigned long long)p->id);
    }
    if (reader_bytes(r, p->rgb, 3) || read_f64(r, &p->error)) return -1;
    uint64_t track;
    if (read_u64(r, &track) != 0) return -1;
    if (track > r->left / TRACK_ELEMENT_BYTES)
        return gv_fail("%s: point %llu: says track length %llu, but the file has room for at most %llu",
                       r->path, (unsigned long long)p->id, (unsigned long long)track,
                       (unsigned long long)(r->left / TRACK_ELEMENT_BYTES));
    return reader_skip(r, track * TRACK_ELEMENT_BYTES);
}

int gv_colmap_read_points3d_bin(const char *path, gv_colmap_model *model)
{
    bin_reader r;
    if (reader_open(&r, path) != 0) return -1;
    free(model->points);
    model->points = NULL, model->n_points = 0;
    int n, ok = read_count(&r, POINT_MIN_BYTES, "points", &n);
    if (ok == 0 && n > 0 && !(model->points = calloc((size_t)n, sizeof *model->points)))
        ok = gv_fail("%s: out of memory", path);
    for (int i = 0; ok == 0 && i < n; i++, model->n_points++)
        ok = read_point(&r, &model->points[i]);
    if (reader_finish(&r, ok) == 0) return 0;
    free(model->points); /* a failed read leaves nothing behind */
    model->points = NULL, model->n_points = 0;
    return -1;
}

/* ---- Writers ------------------------------------------------------------------------ */

static void put_u64(FILE *f, uint64_t v)
{
    unsigned char b[8];
    for (int i = 0; i < 8; i++) b[i] = (unsigned char)(v >> (8 * i));
    fwrite(b, 1, 8, f);
}

static void put_i32(FILE *f, int v)
{
    uint32_t u = (uint32_t)v;
    unsigned char b[4] = {(unsigned char)u, (unsigned char)(u >> 8), (unsigned char)(u >> 16),
                          (unsigned char)(u >> 24)};
    fwrite(b, 1, 4, f);
}

static void put_f64(FILE *f, double v)
{
    uint64_t bits;
    memcpy(&bits, &v, 8);
    put_u64(f, bits);
}

int gv_colmap_write_cameras_bin(const char *path, const gv_colmap_model *model)
{
    gv_atomic_file af;
    for (int i = 0; i < model->n_cameras; i++)
        if (gv_colmap_model_n_params(model->cameras[i].model) < 0)
            return gv_fail("%s: camera %d: unknown camera model id %d", path,
                           model->cameras[i].id, model->cameras[i].model);
    if (gv_atomic_open(&af, path) != 0) return -1;
    put_u64(af.f, (uint64_t)model->n_cameras);
    for (int i = 0; i < model->n_cameras; i++) {
        const gv_colmap_camera *c = &model->cameras[i];
        put_i32(af.f, c->id);
        put_i32(af.f, c->model);
        put_u64(af.f, (uint64_t)c->width);
        put_u64(af.f, (uint64_t)c->height);
        for (int k = 0; k < gv_colmap_model_n_params(c->model); k++) put_f64(af.f, c->params[k]);
    }
    return gv_atomic_commit(&af);
}

int gv_colmap_write_images_bin(const char *path, const gv_colmap_model *model)
{
    gv_atomic_file af;
    if (gv_atomic_open(&af, path) != 0) return -1;
    put_u64(af.f, (uint64_t)model->n_images);
    for (int i = 0; i < model->n_images; i++) {
        const gv_colmap_image *im = &model->images[i];
        put_i32(af.f, im->id);
        for (int k = 0; k < 4; k++) put_f64(af.f, im->qvec[k]);
        for (int k = 0; k < 3; k++) put_f64(af.f, im->tvec[k]);
        put_i32(af.f, im->camera_id);
        fwrite(im->name, 1, strnlen(im->name, GV_COLMAP_MAX_NAME - 1), af.f);
        fputc('\0', af.f);
        put_u64(af.f, 0); /* no 2D points */
    }
    return gv_atomic_commit(&af);
}

int gv_colmap_write_points3d_bin(const char *path, const gv_colmap_model *model)
{
    gv_atomic_file af;
    if (gv_atomic_open(&af, path) != 0) return -1;
    put_u64(af.f, (uint64_t)model->n_points);
    for (int i = 0; i < model->n_points; i++) {
        const gv_colmap_point *p = &model->points[i];
        put_u64(af.f, p->id);
        for (int k = 0; k < 3; k++) put_f64(af.f, p->xyz[k]);
        fwrite(p->rgb, 1, 3, af.f);
        put_f64(af.f, p->error);
        put_u64(af.f, 0); /* empty track */
    }
    return gv_atomic_commit(&af);
}
