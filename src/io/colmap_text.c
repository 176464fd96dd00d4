/* COLMAP text model files (docs/reference/gaussian-splatting.md 18.4); '#' lines are comments:
 *   cameras.txt   CAMERA_ID MODEL WIDTH HEIGHT PARAMS...
 *   images.txt    IMAGE_ID QW QX QY QZ TX TY TZ CAMERA_ID NAME, then one line of
 *                 (X Y POINT3D_ID) triples, which may be empty
 *   points3D.txt  POINT3D_ID X Y Z R G B ERROR (IMAGE_ID POINT2D_IDX)...
 * Every number is checked (whole token, finite); errors name the file and the line. */
#include <errno.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "gaussvid/io/colmap.h"
#include "gaussvid/core/core.h"

#define MAX_IMAGE_SIDE 1000000

typedef struct {
    FILE *f;
    const char *path;
    char *line;
    size_t capacity;
    int number;       /* 1-based line number of `line` */
    char *cursor;     /* next token of `line` */
} text_reader;

static int text_open(text_reader *r, const char *path)
{
    memset(r, 0, sizeof *r);
    r->path = path;
    r->f = fopen(path, "r");
    if (!r->f) return gv_fail("%s: cannot open: %s", path, strerror(errno));
    return 0;
}

static int text_close(text_reader *r, int ok)
{
    if (ok == 0 && ferror(r->f)) ok = gv_fail("%s: read error", r->path);
    fclose(r->f);
    free(r->line);
    return ok;
}

/* Next line (trailing newline and CR removed); 0 at end of file. */
static int next_line(text_reader *r)
{
    if (getline(&r->line, &r->capacity, r->f) < 0) return 0;
    r->number++;
    size_t n = strlen(r->line);
    while (n > 0 && (r->line[n - 1] == '\n' || r->line[n - 1] == '\r')) r->line[--n] = '\0';
    r->cursor = r->line;
    return 1;
}

/* Next non-empty line that is not a comment; 0 at end of file. */
static int next_record(text_reader *r)
{
    while (next_line(r)) {
        const char *p = r->line + strspn(r->line, " \t");
        if (*p && *p != '#') return 1;
    }
    return 0;
}

/* Next whitespace-separated token of the line, or NULL at its end. */
static char *next_token(text_reader *r)
{
    char *p = r->cursor + strspn(r->cursor, " \t");
    if (!*p) return r->cursor = p, NULL;
    char *end = p + strcspn(p, " \t");
    if (*end) *end++ = '\0';
    r->cursor = end;
    return p;
}

static int missing(text_reader *r, const char *what)
{
    return gv_fail("%s:%d: missing %s", r->path, r->number, what);
}

static int token_double(text_reader *r, const char *what, double *v)
{
    char *t = next_token(r), *end;
    if (!t) return missing(r, what);
    errno = 0;
    *v = strtod(t, &end);
    if (*end || end == t || !isfinite(*v))
        return gv_fail("%s:%d: %s '%s' is not a finite number", r->path, r->number, what, t);
    return 0;
}

static int token_long(text_reader *r, const char *what, long long lo, long long hi, long long *v)
{
    char *t = next_token(r), *end;
    if (!t) return missing(r, what);
    errno = 0;
    *v = strtoll(t, &end, 10);
    if (*end || end == t || errno == ERANGE || *v < lo || *v > hi)
        return gv_fail("%s:%d: %s '%s' is not an integer in [%lld, %lld]", r->path, r->number,
                       what, t, lo, hi);
    return 0;
}

static int token_int(text_reader *r, const char *what, int lo, int hi, int *v)
{
    long long x;
    if (token_long(r, what, lo, hi, &x) != 0) return -1;
    *v = (int)x;
    return 0;
}

static int end_of_line(text_reader *r)
{
    char *t = next_token(r);
    if (t) return gv_fail("%s:%d: unexpected '%s' at the end of the line", r->path, r->number, t);
    return 0;
}

/* Grows *array (of `size`-byte elements) so that index n fits. */
static int grow(text_reader *r, void **array, int n, int *capacity, size_t size)
{
    if (n < *capacity) return 0;
    if (n >= INT32_MAX / 2) return gv_fail("%s: too many records", r->path);
    int want = *capacity ? 2 * *capacity : 64;
    void *p = realloc(*array, (size_t)want * size);
    if (!p) return gv_fail("%s: out of memory", r->path);
    *array = p;
    *capacity = want;
    return 0;
}

static int parse_camera(text_reader *r, gv_colmap_camera *c)
{
    memset(c, 0, sizeof *c);
    if (token_int(r, "CAMERA_ID", INT32_MIN, INT32_MAX, &c->id)) return -1;
    char *model = next_token(r);
    if (!model) return missing(r, "MODEL");
    c->model = gv_colmap_model_id(model);
    if (c->model < 0) return gv_fail("%s:%d: camera %d: unknown camera model '%s'", r->path, r->number, c->id, model);
    if (token_int(r, "WIDTH", 1, MAX_IMAGE_SIDE, &c->width) ||
        token_int(r, "HEIGHT", 1, MAX_IMAGE_SIDE, &c->height))
        return -1;
    int n_params = gv_colmap_model_n_params(c->model);
    for (int i = 0; i < n_params; i++)
        if (token_double(r, "camera parameter", &c->params[i])) return -1;
    if (end_of_line(r)) return -1;
    double fx, fy, cx, cy;
    return gv_colmap_camera_pinhole(c, r->path, &fx, &fy, &cx, &cy);
}

int gv_colmap_read_cameras_text(const char *path, gv_colmap_model *model)
{
    text_reader r;
    if (text_open(&r, path) != 0) return -1;
    free(model->cameras);
    model->cameras = NULL, model->n_cameras = 0;
    int capacity = 0, ok = 0;
    while (ok == 0 && next_record(&r)) {
        ok = grow(&r, (void **)&model->cameras, model->n_cameras, &capacity, sizeof *model->cameras);
        if (ok == 0) ok = parse_camera(&r, &model->cameras[model->n_cameras++]);
    }
    if (text_close(&r, ok) == 0) return 0;
    free(model->cameras); /* a failed read leaves nothing behind */
    model->cameras = NULL, model->n_cameras = 0;
    return -1;
}

static int parse_image(text_reader *r, gv_colmap_image *im)
{
    static const char *q_names[4] = {"QW", "QX", "QY", "QZ"}, *t_names[3] = {"TX", "TY", "TZ"};
    memset(im, 0, sizeof *im);
    if (token_int(r, "IMAGE_ID", INT32_MIN, INT32_MAX, &im->id)) return -1;
    for (int i = 0; i < 4; i++) if (token_double(r, q_names[i], &im->qvec[i])) return -1;
    for (int i = 0; i < 3; i++) if (token_double(r, t_names[i], &im->tvec[i])) return -1;
    if (token_int(r, "CAMERA_ID", INT32_MIN, INT32_MAX, &im->camera_id)) return -1;
    char *name = next_token(r);
    if (!name) return missing(r, "NAME");
    if (strlen(name) >= GV_COLMAP_MAX_NAME)
        return gv_fail("%s:%d: image name longer than %d bytes", r->path, r->number, GV_COLMAP_MAX_NAME - 1);
    strcpy(im->name, name);
    if (end_of_line(r)) return -1;
    double qn = 0;
    for (int i = 0; i < 4; i++) qn += im->qvec[i] * im->qvec[i];
    if (qn < 1e-12) return gv_fail("%s:%d: image %d: quaternion is zero", r->path, r->number, im->id);
    return 0;
}

/* The line after an image line: (X Y POINT3D_ID) triples, possibly none. */
static int parse_points2d(text_reader *r)
{
    double x;
    long long id;
    while (*(r->cursor + strspn(r->cursor, " \t"))) {
        if (token_double(r, "2D point X", &x) || token_double(r, "2D point Y", &x) ||
            token_long(r, "POINT3D_ID", -1, INT64_MAX, &id))
            return -1;
    }
    return 0;
}

int gv_colmap_read_images_text(const char *path, gv_colmap_model *model)
{
    text_reader r;
    if (text_open(&r, path) != 0) return -1;
    free(model->images);
    model->images = NULL, model->n_images = 0;
    int capacity = 0, ok = 0;
    while (ok == 0 && next_record(&r)) {
        ok = grow(&r, (void **)&model->images, model->n_images, &capacity, sizeof *model->images);
        if (ok == 0) ok = parse_image(&r, &model->images[model->n_images++]);
        /* COLMAP always writes the 2D-point line; a file that ends right after the last
         * image line is accepted as having none. */
        if (ok == 0 && next_line(&r)) ok = parse_points2d(&r);
    }
    if (text_close(&r, ok) == 0) return 0;
    free(model->images); /* a failed read leaves nothing behind */
    model->images = NULL, model->n_images = 0;
    return -1;
}

static int parse_point(text_reader *r, gv_colmap_point *p)
{
    static const char *xyz_names[3] = {"X", "Y", "Z"}, *rgb_names[3] = {"R", "G", "B"};
    long long id;
    memset(p, 0, sizeof *p);
    if (token_long(r, "POINT3D_ID", 0, INT64_MAX, &id)) return -1;
    p->id = (uint64_t)id;
    for (int i = 0; i < 3; i++) if (token_double(r, xyz_names[i], &p->xyz[i])) return -1;
    for (int i = 0; i < 3; i++) {
        int c;
        if (token_int(r, rgb_names[i], 0, 255, &c)) return -1;
        p->rgb[i] = (uint8_t)c;
    }
    if (token_double(r, "ERROR", &p->error)) return -1;
    while (*(r->cursor + strspn(r->cursor, " \t"))) {
        long long image_id, point2d;
        if (token_long(r, "track IMAGE_ID", INT32_MIN, INT32_MAX, &image_id)) return -1;
        if (token_long(r, "track POINT2D_IDX", 0, INT32_MAX, &point2d)) return -1;
    }
    return 0;
}

int gv_colmap_read_points3d_text(const char *path, gv_colmap_model *model)
{
    text_reader r;
    if (text_open(&r, path) != 0) return -1;
    free(model->points);
    model->points = NULL, model->n_points = 0;
    int capacity = 0, ok = 0;
    while (ok == 0 && next_record(&r)) {
        ok = grow(&r, (void **)&model->points, model->n_points, &capacity, sizeof *model->points);
        if (ok == 0) ok = parse_point(&r, &model->points[model->n_points++]);
    }
    if (text_close(&r, ok) == 0) return 0;
    free(model->points); /* a failed read leaves nothing behind */
    model->points = NULL, model->n_points = 0;
    return -1;
}

/* ---- Writers ------------------------------------------------------------------------ */

/* The shortest %g form (15 to 17 digits) that reads back to exactly v. */
static void put_double(FILE *f, double v)
{
    char buffer[40];
    for (int digits = 15; digits <= 17; digits++) {
        snprintf(buffer, sizeof buffer, "%.*g", digits, v);
        if (strtod(buffer, NULL) == v) break;
    }
    fprintf(f, " %s", buffer);
}

int gv_colmap_write_cameras_text(const char *path, const gv_colmap_model *model)
{
    for (int i = 0; i < model->n_cameras; i++)
        if (!gv_colmap_model_name(model->cameras[i].model))
            return gv_fail("%s: camera %d: unknown camera model id %d", path,
                           model->cameras[i].id, model->cameras[i].model);
    gv_atomic_file af;
    if (gv_atomic_open(&af, path) != 0) return -1;
    fprintf(af.f, "# Camera list with one line of data per camera:\n"
                  "#   CAMERA_ID, MODEL, WIDTH, HEIGHT, PARAMS[]\n"
                  "# Number of cameras: %d\n", model->n_cameras);
    for (int i = 0; i < model->n_cameras; i++) {
        const gv_colmap_camera *c = &model->cameras[i];
        fprintf(af.f, "%d %s %d %d", c->id, gv_colmap_model_name(c->model), c->width, c->height);
        for (int k = 0; k < gv_colmap_model_n_params(c->model); k++) put_double(af.f, c->params[k]);
        fputc('\n', af.f);
    }
    return gv_atomic_commit(&af);
}

int gv_colmap_write_images_text(const char *path, const gv_colmap_model *model)
{
    for (int i = 0; i < model->n_images; i++) {
        const char *name = model->images[i].name;
        if (!name[0] || strpbrk(name, " \t\r\n"))
            return gv_fail("%s: image %d: name '%s' is empty or contains white space, which the "
                           "text format cannot hold", path, model->images[i].id, name);
    }
    gv_atomic_file af;
    if (gv_atomic_open(&af, path) != 0) return -1;
    fprintf(af.f, "# Image list with two lines of data per image:\n"
                  "#   IMAGE_ID, QW, QX, QY, QZ, TX, TY, TZ, CAMERA_ID, NAME\n"
                  "#   POINTS2D[] as (X, Y, POINT3D_ID)\n"
                  "# Number of images: %d, mean observations per image: 0\n", model->n_images);
    for (int i = 0; i < model->n_images; i++) {
        const gv_colmap_image *im = &model->images[i];
        fprintf(af.f, "%d", im->id);
        for (int k = 0; k < 4; k++) put_double(af.f, im->qvec[k]);
        for (int k = 0; k < 3; k++) put_double(af.f, im->tvec[k]);
        fprintf(af.f, " %d %s\n\n", im->camera_id, im->name);
    }
    return gv_atomic_commit(&af);
}

int gv_colmap_write_points3d_text(const char *path, const gv_colmap_model *model)
{
    gv_atomic_file af;
    if (gv_atomic_open(&af, path) != 0) return -1;
    fprintf(af.f, "# 3D point list with one line of data per point:\n"
                  "#   POINT3D_ID, X, Y, Z, R, G, B, ERROR, TRACK[] as (IMAGE_ID, POINT2D_IDX)\n"
                  "# Number of points: %d, mean track length: 0\n", model->n_points);
    for (int i = 0; i < model->n_points; i++) {
        const gv_colmap_point *p = &model->points[i];
        fprintf(af.f, "%llu", (unsigned long long)p->id);
        for (int k = 0; k < 3; k++) put_double(af.f, p->xyz[k]);
        fprintf(af.f, " %d %d %d", p->rgb[0], p->rgb[1], p->rgb[2]);
        put_double(af.f, p->error);
        fputc('\n', af.f);
    }
    return gv_atomic_commit(&af);
}
