/* COLMAP sparse models: binary and text files written here byte by byte with known values
 * are read back exactly; text and binary agree; the writers round-trip; quaternions; and
 * every malformed file fails with a message naming the file and the problem. */
#include <stdint.h>
#include <time.h>

#include "check.h"
#include "gaussvid/io/colmap.h"
#include "gaussvid/core/core.h"

static const char *tmp;

/* ---- The known model ------------------------------------------------------------------ */

static const gv_colmap_camera known_cameras[3] = {
    {1, GV_COLMAP_PINHOLE, 640, 480, {500.5, 501.25, 320.125, 240.0625}},
    {7, GV_COLMAP_SIMPLE_PINHOLE, 100, 50, {80, 50.5, 25}},
    {3, GV_COLMAP_OPENCV, 320, 240, {300, 310, 160, 120, 0, 0, 0, 0}},
};
static const gv_colmap_image known_images[2] = {
    {4, {0.5, 0.5, -0.5, 0.5}, {1, -2, 3.5}, 1, "a.png"},
    {2, {1, 0, 0, 0}, {0.25, 0.125, -0.75}, 7, "sub/b.jpg"},
};
static const gv_colmap_point known_points[2] = {
    {5, {1.5, -2.25, 3.125}, {10, 20, 30}, 0.75},
    {9, {0, 0, 0}, {255, 0, 128}, 0},
};

/* ---- Little-endian bytes, written independently of the library ------------------------ */

typedef struct {
    unsigned char data[4096];
    size_t n;
} bytes;

static void b_u64(bytes *b, uint64_t v)
{
    for (int i = 0; i < 8; i++) b->data[b->n++] = (unsigned char)(v >> (8 * i));
}
static void b_i32(bytes *b, int32_t v)
{
    for (int i = 0; i < 4; i++) b->data[b->n++] = (unsigned char)((uint32_t)v >> (8 * i));
}
static void b_f64(bytes *b, double v)
{
    uint64_t u;
    memcpy(&u, &v, 8);
    b_u64(b, u);
}
static void b_str(bytes *b, const char *s)
{
    memcpy(b->data + b->n, s, strlen(s) + 1);
    b->n += strlen(s) + 1;
}

static void put_u64_at(bytes *b, size_t offset, uint64_t v)
{
    for (int i = 0; i < 8; i++) b->data[offset + i] = (unsigned char)(v >> (8 * i));
}

static void write_file(const char *path, const void *data, size_t n)
{
    FILE *f = fopen(path, "wb");
    if (!f || fwrite(data, 1, n, f) != n) { fprintf(stderr, "cannot write %s\n", path); exit(1); }
    fclose(f);
}

static void path_in(char *out, const char *dir, const char *name)
{
    snprintf(out, 4200, "%s/%s", dir, name);
}

static void make_dir(char *out, const char *name)
{
    path_in(out, tmp, name);
    if (gv_mkdirs(out) != 0) { fprintf(stderr, "%s\n", gv_last_error()); exit(1); }
}

static bytes cameras_bin(void)
{
    static const int n_params[3] = {4, 3, 8};
    bytes b = {.n = 0};
    b_u64(&b, 3);
    for (int i = 0; i < 3; i++) {
        b_i32(&b, known_cameras[i].id);
        b_i32(&b, known_cameras[i].model);
        b_u64(&b, (uint64_t)known_cameras[i].width);
        b_u64(&b, (uint64_t)known_cameras[i].height);
        for (int k = 0; k < n_params[i]; k++) b_f64(&b, known_cameras[i].params[k]);
    }
    return b;
}

static bytes images_bin(void)
{
    bytes b = {.n = 0};
    b_u64(&b, 2);
    for (int i = 0; i < 2; i++) {
        const gv_colmap_image *im = &known_images[i];
        b_i32(&b, im->id);
        for (int k = 0; k < 4; k++) b_f64(&b, im->qvec[k]);
        for (int k = 0; k < 3; k++) b_f64(&b, im->tvec[k]);
        b_i32(&b, im->camera_id);
        b_str(&b, im->name);
        b_u64(&b, i == 0 ? 2 : 0); /* the first image has two 2D points */
        for (int p = 0; i == 0 && p < 2; p++) {
            b_f64(&b, 10.5 + p), b_f64(&b, 20.5), b_u64(&b, p == 0 ? 5 : (uint64_t)-1);
        }
    }
    return b;
}

static bytes points_bin(void)
{
    bytes b = {.n = 0};
    b_u64(&b, 2);
    for (int i = 0; i < 2; i++) {
        const gv_colmap_point *p = &known_points[i];
        b_u64(&b, p->id);
        for (int k = 0; k < 3; k++) b_f64(&b, p->xyz[k]);
        for (int k = 0; k < 3; k++) b.data[b.n++] = p->rgb[k];
        b_f64(&b, p->error);
        b_u64(&b, i == 0 ? 2 : 0); /* the first point has a track of two */
        for (int t = 0; i == 0 && t < 2; t++) b_i32(&b, 4), b_i32(&b, t);
    }
    return b;
}

static const char *cameras_txt =
    "# Camera list with one line of data per camera:\n"
    "#   CAMERA_ID, MODEL, WIDTH, HEIGHT, PARAMS[]\n"
    "1 PINHOLE 640 480 500.5 501.25 320.125 240.0625\n"
    "\n"
    "7 SIMPLE_PINHOLE 100 50 80 50.5 25\r\n"
    "3 OPENCV 320 240 300 310 160 120 0 0 0.0 -0\n";
static const char *images_txt =
    "# Image list with two lines of data per image:\n"
    "4 0.5 0.5 -0.5 0.5 1 -2 3.5 1 a.png\n"
    "10.5 20.5 5 11.5 20.5 -1\n"
    "2 1 0 0 0 0.25 0.125 -0.75 7 sub/b.jpg\n"
    "\n";
static const char *points_txt =
    "# 3D point list\n"
    "5 1.5 -2.25 3.125 10 20 30 0.75 4 0 4 1\n"
    "9 0 0 0 255 0 128 0\n";

/* ---- Comparisons ---------------------------------------------------------------------- */

static int cameras_equal(const gv_colmap_camera *a, const gv_colmap_camera *b)
{
    int n = gv_colmap_model_n_params(a->model);
    int same = a->id == b->id && a->model == b->model && a->width == b->width &&
               a->height == b->height && n > 0;
    for (int i = 0; i < n; i++) same &= a->params[i] == b->params[i]; /* -0 == 0 in text */
    return same;
}

static int images_equal(const gv_colmap_image *a, const gv_colmap_image *b)
{
    return a->id == b->id && !memcmp(a->qvec, b->qvec, sizeof a->qvec) &&
           !memcmp(a->tvec, b->tvec, sizeof a->tvec) && a->camera_id == b->camera_id &&
           !strcmp(a->name, b->name);
}

static int points_equal(const gv_colmap_point *a, const gv_colmap_point *b)
{
    return a->id == b->id && !memcmp(a->xyz, b->xyz, sizeof a->xyz) &&
           !memcmp(a->rgb, b->rgb, 3) && a->error == b->error;
}

static void check_model(const gv_colmap_model *m, const gv_colmap_camera *cams, int nc,
                        const gv_colmap_image *ims, int ni, const gv_colmap_point *pts, int np)
{
    CHECK(m->n_cameras == nc && m->n_images == ni && m->n_points == np);
    for (int i = 0; i < nc && i < m->n_cameras; i++) CHECK(cameras_equal(&m->cameras[i], &cams[i]));
    for (int i = 0; i < ni && i < m->n_images; i++) CHECK(images_equal(&m->images[i], &ims[i]));
    for (int i = 0; i < np && i < m->n_points; i++) CHECK(points_equal(&m->points[i], &pts[i]));
}

static void write_known(const char *dir)
{
    char path[4200];
    bytes b = cameras_bin();
    path_in(path, dir, "cameras.bin"), write_file(path, b.data, b.n);
    b = images_bin();
    path_in(path, dir, "images.bin"), write_file(path, b.data, b.n);
    b = points_bin();
    path_in(path, dir, "points3D.bin"), write_file(path, b.data, b.n);
    path_in(path, dir, "cameras.txt"), write_file(path, cameras_txt, strlen(cameras_txt));
    path_in(path, dir, "images.txt"), write_file(path, images_txt, strlen(images_txt));
    path_in(path, dir, "points3D.txt"), write_file(path, points_txt, strlen(points_txt));
}

/* ---- Tests ------------------------------------------------------------------------------ */

static void test_read_known(void)
{
    char dir[4200];
    make_dir(dir, "known");
    write_known(dir);
    gv_colmap_model bin, txt;
    CHECK(gv_colmap_read_bin(dir, &bin) == 0);
    check_model(&bin, known_cameras, 3, known_images, 2, known_points, 2);
    CHECK(gv_colmap_read_text(dir, &txt) == 0);
    check_model(&txt, known_cameras, 3, known_images, 2, known_points, 2);
    /* Text and binary agree with each other, field by field. */
    check_model(&txt, bin.cameras, bin.n_cameras, bin.images, bin.n_images, bin.points, bin.n_points);
    gv_colmap_free(&bin);
    gv_colmap_free(&txt);
}

static void test_writers_round_trip(void)
{
    char dir[4200], path[4200];
    make_dir(dir, "written");
    /* Values that need 17 significant digits in text. */
    gv_colmap_image images[2] = {known_images[0], known_images[1]};
    images[0].tvec[0] = 1.0 / 3.0, images[1].qvec[1] = 0.1, images[1].tvec[2] = -2e-300;
    gv_colmap_point points[2] = {known_points[0], known_points[1]};
    points[1].xyz[1] = 123456.789012345678, points[0].id = 12345678901234ull;
    gv_colmap_model m = {3, 2, 2, (gv_colmap_camera *)known_cameras, images, points};
    CHECK(gv_colmap_write_bin(dir, &m) == 0);
    CHECK(gv_colmap_write_text(dir, &m) == 0);
    gv_colmap_model bin, txt;
    CHECK(gv_colmap_read_bin(dir, &bin) == 0);
    check_model(&bin, known_cameras, 3, images, 2, points, 2);
    CHECK(gv_colmap_read_text(dir, &txt) == 0);
    check_model(&txt, known_cameras, 3, images, 2, points, 2);
    gv_colmap_free(&bin);
    gv_colmap_free(&txt);
    /* cameras.bin carries no optional data: the writer's bytes are the hand-written ones. */
    bytes expected = cameras_bin();
    char *data;
    size_t size;
    path_in(path, dir, "cameras.bin");
    CHECK(gv_read_file(path, &data, &size) == 0);
    CHECK(size == expected.n && !memcmp(data, expected.data, size));
    free(data);
}

static void test_quaternions(void)
{
    double R[9], q[4];
    const double q120[4] = {1, 1, 1, 1}; /* unnormalised: 120 degrees about (1, 1, 1) */
    const double expected[9] = {0, 0, 1, 1, 0, 0, 0, 1, 0};
    gv_colmap_qvec_to_rotmat(q120, R);
    for (int i = 0; i < 9; i++) CHECK_NEAR(R[i], expected[i], 1e-15);
    gv_colmap_rotmat_to_qvec(R, q);
    for (int i = 0; i < 4; i++) CHECK_NEAR(q[i], 0.5, 1e-15);
    const double half_turn[4] = {0, 0, 3, 0}; /* 180 degrees about y: diag(-1, 1, -1) */
    gv_colmap_qvec_to_rotmat(half_turn, R);
    CHECK(R[0] == -1 && R[4] == 1 && R[8] == -1 && R[1] == 0 && R[2] == 0 && R[5] == 0);
    gv_colmap_rotmat_to_qvec(R, q);
    CHECK_NEAR(q[0], 0, 1e-15);
    CHECK_NEAR(q[2], 1, 1e-15);
    /* Random rotations: q -> R -> q gives q up to sign, with w >= 0. */
    double worst = 0;
    int w_positive = 1;
    for (int t = 0; t < 1000; t++) {
        double r[4], n = 0;
        for (int k = 0; k < 4; k++) r[k] = gv_normal_at(11, (uint64_t)(4 * t + k)), n += r[k] * r[k];
        gv_colmap_qvec_to_rotmat(r, R);
        gv_colmap_rotmat_to_qvec(R, q);
        double s = r[0] < 0 ? -1 : 1;
        for (int k = 0; k < 4; k++) worst = fmax(worst, fabs(q[k] - s * r[k] / sqrt(n)));
        w_positive &= q[0] >= 0;
    }
    CHECK(w_positive);
    printf("quaternion round trip: max error %.3g over 1000 rotations\n", worst);
    CHECK(worst < 1e-14);
}

static void test_model_table(void)
{
    CHECK(gv_colmap_model_id("PINHOLE") == 1 && gv_colmap_model_id("FULL_OPENCV") == 6);
    CHECK(gv_colmap_model_id("NOPE") == -1 && gv_colmap_model_name(12) == NULL);
    CHECK(gv_colmap_model_n_params(GV_COLMAP_THIN_PRISM_FISHEYE) == 12);
    CHECK(gv_colmap_model_n_params(GV_COLMAP_RAD_TAN_THIN_PRISM_FISHEYE) == 16);
}

/* Truncating the good cameras.bin anywhere fails; so does a longer file. */
static void test_bad_binary(void)
{
    char dir[4200], path[4200];
    gv_colmap_model m = {0};
    make_dir(dir, "bad_bin");
    path_in(path, dir, "cameras.bin");
    bytes b = cameras_bin();
    int all_failed = 1;
    for (size_t cut = 0; cut < b.n; cut++) { /* short counts or short records */
        write_file(path, b.data, cut);
        gv_clear_error();
        const char *e = gv_colmap_read_cameras_bin(path, &m) == 0 ? "" : gv_last_error();
        if (!strstr(e, "cameras.bin: truncated") && !strstr(e, "cameras.bin: header says")) {
            all_failed = 0;
            fprintf(stderr, "cut at %zu: '%s'\n", cut, e);
        }
    }
    CHECK(all_failed);
    write_file(path, b.data, b.n - 1);
    CHECK_FAILS_WITH(gv_colmap_read_cameras_bin(path, &m), "cameras.bin: truncated");
    b.data[b.n++] = 0;
    write_file(path, b.data, b.n);
    CHECK_FAILS_WITH(gv_colmap_read_cameras_bin(path, &m), "unexpected bytes");

    /* An absurd count fails at once, before any allocation (a 2^60-record calloc would
     * abort under ASan). */
    path_in(path, dir, "images.bin");
    b = images_bin();
    for (int i = 0; i < 8; i++) b.data[i] = i == 7 ? 0x10 : 0;
    write_file(path, b.data, b.n);
    double start = gv_now();
    CHECK_FAILS_WITH(gv_colmap_read_images_bin(path, &m), "images.bin: header says 1152921504606846976 images");
    CHECK(gv_now() - start < 1.0);
    b = images_bin();
    b.data[0] = 3; /* three images where there are two */
    write_file(path, b.data, b.n);
    CHECK_FAILS_WITH(gv_colmap_read_images_bin(path, &m), "images.bin: header says 3 images, but the file has room for at most 2");
    b = images_bin();
    put_u64_at(&b, 8 + 64 + 6, 1ull << 40); /* the first image's num_points2D */
    write_file(path, b.data, b.n);
    CHECK_FAILS_WITH(gv_colmap_read_images_bin(path, &m), "images.bin: image 4: says 1099511627776 2D points");
    b = images_bin();
    write_file(path, b.data, b.n - 3); /* ends inside the last num_points2D */
    CHECK_FAILS_WITH(gv_colmap_read_images_bin(path, &m), "images.bin: truncated: 8 bytes needed at offset 208");
    b.data[0] = 1;
    write_file(path, b.data, 8 + 64 + 3); /* one image, ending inside its name */
    CHECK_FAILS_WITH(gv_colmap_read_images_bin(path, &m), "images.bin: header says 1 images");

    path_in(path, dir, "points3D.bin");
    b = points_bin();
    put_u64_at(&b, 8 + 43, (1ull << 62) + 2); /* the first point's track length */
    write_file(path, b.data, b.n);
    CHECK_FAILS_WITH(gv_colmap_read_points3d_bin(path, &m), "track length 4611686018427387906");
    path_in(path, dir, "missing.bin");
    CHECK_FAILS_WITH(gv_colmap_read_points3d_bin(path, &m), "missing.bin: cannot open");
    gv_colmap_free(&m);
}

/* Distortion, unknown or unsupported models: refused by both readers, naming the camera. */
static void test_bad_models(void)
{
    char dir[4200], path[4200];
    gv_colmap_model m = {0};
    make_dir(dir, "bad_models");
    gv_colmap_camera cam = known_cameras[2]; /* OPENCV */
    cam.params[5] = -0.05;                   /* k2 */
    gv_colmap_model one = {.n_cameras = 1, .cameras = &cam};
    CHECK(gv_colmap_write_bin(dir, &one) == 0 && gv_colmap_write_text(dir, &one) == 0);
    path_in(path, dir, "cameras.bin");
    CHECK_FAILS_WITH(gv_colmap_read_cameras_bin(path, &m), "cameras.bin: camera 3: model OPENCV has non-zero distortion");
    path_in(path, dir, "cameras.txt");
    CHECK_FAILS_WITH(gv_colmap_read_cameras_text(path, &m), "cameras.txt: camera 3: model OPENCV has non-zero distortion");
    CHECK_FAILS_WITH(gv_colmap_read_bin(dir, &m), "does not undistort");

    cam = (gv_colmap_camera){9, GV_COLMAP_OPENCV_FISHEYE, 10, 10, {5, 5, 5, 5, 0, 0, 0, 0}};
    CHECK(gv_colmap_write_bin(dir, &one) == 0);
    path_in(path, dir, "cameras.bin");
    CHECK_FAILS_WITH(gv_colmap_read_cameras_bin(path, &m), "camera 9: model OPENCV_FISHEYE is not supported");
    cam = (gv_colmap_camera){2, GV_COLMAP_SIMPLE_RADIAL, 10, 10, {5, 5, 5, 0}};
    CHECK(gv_colmap_write_bin(dir, &one) == 0);
    CHECK(gv_colmap_read_cameras_bin(path, &m) == 0 && m.n_cameras == 1); /* zero k: accepted */

    bytes b = {.n = 0};
    b_u64(&b, 1), b_i32(&b, 6), b_i32(&b, 42), b_u64(&b, 10), b_u64(&b, 10);
    write_file(path, b.data, b.n);
    CHECK_FAILS_WITH(gv_colmap_read_cameras_bin(path, &m), "cameras.bin: camera 6: unknown camera model id 42");
    path_in(path, dir, "cameras.txt");
    const char *unknown = "1 PINHOLE 10 10 5 5 5 5\n2 FISHEYE_X 10 10 5 5 5\n";
    write_file(path, unknown, strlen(unknown));
    CHECK_FAILS_WITH(gv_colmap_read_cameras_text(path, &m), "cameras.txt:2: camera 2: unknown camera model 'FISHEYE_X'");
    const char *few = "1 PINHOLE 10 10 5 5 5\n";
    write_file(path, few, strlen(few));
    CHECK_FAILS_WITH(gv_colmap_read_cameras_text(path, &m), "cameras.txt:1: missing camera parameter");
    const char *many = "1 PINHOLE 10 10 5 5 5 5 5\n";
    write_file(path, many, strlen(many));
    CHECK_FAILS_WITH(gv_colmap_read_cameras_text(path, &m), "cameras.txt:1: unexpected '5'");
    const char *zero_size = "1 PINHOLE 0 10 5 5 5 5\n";
    write_file(path, zero_size, strlen(zero_size));
    CHECK_FAILS_WITH(gv_colmap_read_cameras_text(path, &m), "cameras.txt:1: WIDTH '0'");
    gv_colmap_free(&m);
}

static void test_bad_text(void)
{
    char dir[4200], path[4200];
    gv_colmap_model m = {0};
    make_dir(dir, "bad_text");
    path_in(path, dir, "images.txt");
    const char *nan = "1 1 0 0 0 nan 0 0 1 a.png\n\n";
    write_file(path, nan, strlen(nan));
    CHECK_FAILS_WITH(gv_colmap_read_images_text(path, &m), "images.txt:1: TX 'nan' is not a finite number");
    const char *bad2d = "1 1 0 0 0 0 0 0 1 a.png\n1.5 2.5\n";
    write_file(path, bad2d, strlen(bad2d));
    CHECK_FAILS_WITH(gv_colmap_read_images_text(path, &m), "images.txt:2: missing POINT3D_ID");
    const char *noname = "1 1 0 0 0 0 0 0 1\n\n";
    write_file(path, noname, strlen(noname));
    CHECK_FAILS_WITH(gv_colmap_read_images_text(path, &m), "images.txt:1: missing NAME");
    const char *zero_q = "1 0 0 0 0 0 0 0 1 a.png\n\n";
    write_file(path, zero_q, strlen(zero_q));
    CHECK_FAILS_WITH(gv_colmap_read_images_text(path, &m), "images.txt:1: image 1: quaternion is zero");
    path_in(path, dir, "points3D.txt");
    const char *colour = "1 0 0 0 256 0 0 0\n";
    write_file(path, colour, strlen(colour));
    CHECK_FAILS_WITH(gv_colmap_read_points3d_text(path, &m), "points3D.txt:1: R '256'");
    const char *track = "1 0 0 0 1 2 3 0 4\n";
    write_file(path, track, strlen(track));
    CHECK_FAILS_WITH(gv_colmap_read_points3d_text(path, &m), "points3D.txt:1: missing track POINT2D_IDX");

    /* A whole model whose image names an undefined camera. */
    write_known(dir);
    path_in(path, dir, "images.txt");
    const char *orphan = "4 1 0 0 0 0 0 0 8 a.png\n\n";
    write_file(path, orphan, strlen(orphan));
    CHECK_FAILS_WITH(gv_colmap_read_text(dir, &m), "images.txt: image 4 (a.png) refers to camera 8");
    CHECK(m.n_cameras == 0 && m.cameras == NULL);
    gv_colmap_free(&m);
}

/* Mutation fuzzing: random bytes of each known file replaced (seeded, so repeatable). Every
 * read must return 0 or fail with a message naming the file; under ASan nothing may go out of
 * bounds. */
typedef int (*reader_fn)(const char *path, gv_colmap_model *model);

static void test_mutations(void)
{
    char dir[4200], path[4200];
    make_dir(dir, "fuzz");
    bytes files[3] = {cameras_bin(), images_bin(), points_bin()};
    const char *texts[3] = {cameras_txt, images_txt, points_txt};
    const char *names[6] = {"cameras.bin", "images.bin", "points3D.bin", "cameras.txt",
                            "images.txt", "points3D.txt"};
    const reader_fn readers[6] = {gv_colmap_read_cameras_bin, gv_colmap_read_images_bin,
                                  gv_colmap_read_points3d_bin, gv_colmap_read_cameras_text,
                                  gv_colmap_read_images_text, gv_colmap_read_points3d_text};
    static const unsigned char specials[6] = {0, 0xff, 0x7f, '\n', ' ', '#'};
    int named = 1, failures = 0;
    uint64_t draw = 0;
    for (int f = 0; f < 6; f++) {
        path_in(path, dir, names[f]);
        for (int trial = 0; trial < 200; trial++) {
            bytes b;
            if (f < 3) b = files[f];
            else b.n = strlen(texts[f - 3]), memcpy(b.data, texts[f - 3], b.n);
            int n_changes = 1 + (int)(gv_uniform_at(99, draw++) * 3);
            for (int c = 0; c < n_changes; c++) {
                size_t at = (size_t)(gv_uniform_at(99, draw++) * b.n);
                double kind = gv_uniform_at(99, draw++);
                b.data[at] = kind < 0.5 ? (unsigned char)(gv_uniform_at(99, draw++) * 256)
                                        : specials[(int)(gv_uniform_at(99, draw++) * 6)];
            }
            if (gv_uniform_at(99, draw++) < 0.2) b.n = (size_t)(gv_uniform_at(99, draw++) * b.n);
            write_file(path, b.data, b.n);
            gv_colmap_model m = {0};
            gv_clear_error();
            if (readers[f](path, &m) != 0) {
                failures++;
                if (!strstr(gv_last_error(), names[f])) {
                    named = 0;
                    fprintf(stderr, "unnamed failure: %s\n", gv_last_error());
                }
            }
            gv_colmap_free(&m);
        }
    }
    printf("mutations: %d of 1200 mutated files refused, each naming its file\n", failures);
    CHECK(named);
    CHECK(failures > 300);
}

int main(void)
{
    tmp = check_tmp_dir();
    test_read_known();
    test_writers_round_trip();
    test_quaternions();
    test_model_table();
    test_bad_binary();
    test_bad_models();
    test_bad_text();
    test_mutations();
    return check_summary();
}
