/* The scene API: the split, the extent, downscaling (intrinsics and images), write/load round
 * trips through both descriptions, and bad folders (the shared scenes: test_shared_scenes.c). */
#include "check.h"
#include "gaussvid/io/colmap.h"
#include "gaussvid/core/core.h"
#include "gaussvid/io/image.h"
#include "gaussvid/scene/scene.h"

static const char *tmp;

static void test_split(void)
{
    int train[160], held[160], nt, nh;
    CHECK(gv_scene_split(10, 3, train, &nt, held, &nh) == 0);
    const int t3[4] = {0, 3, 6, 9}, h3[6] = {1, 2, 4, 5, 7, 8};
    CHECK(nt == 4 && nh == 6 && !memcmp(train, t3, sizeof t3) && !memcmp(held, h3, sizeof h3));
    CHECK(gv_scene_is_train(0, 3) && gv_scene_is_train(9, 3) && !gv_scene_is_train(4, 3) && gv_scene_is_train(7, 1));
    CHECK(gv_scene_split(10, 1, train, &nt, held, &nh) == 0 && nt == 10 && nh == 0);
    CHECK(gv_scene_split(10, 9, train, &nt, held, &nh) == 0 && nt == 2 && train[1] == 9 && nh == 8);
    CHECK(gv_scene_split(160, 8, train, &nt, held, &nh) == 0 && nt == 20 && nh == 140);
    CHECK(train[19] == 152 && held[0] == 1 && held[139] == 159);
    int ok = 1; /* train and held out partition 0..159, both increasing */
    for (int i = 0, a = 0, b = 0; i < 160; i++) {
        if (a < nt && train[a] == i) a++;
        else if (b < nh && held[b] == i) b++;
        else ok = 0;
    }
    CHECK(ok);
    CHECK_FAILS_WITH(gv_scene_split(10, 10, train, &nt, held, &nh), "interval 10 leaves 1 training frame of the scene's 10 frames (frames 0, n, 2n, ...); at least 2 are needed: a split takes 1 <= n <= 9 on this scene");
    CHECK_FAILS_WITH(gv_scene_split(10, 0, train, &nt, held, &nh), "interval 0: a split takes 1 <= n <= 9 on this scene");
    CHECK_FAILS_WITH(gv_scene_split(1, 1, train, &nt, held, &nh), "the scene has 1 frame(s)");
}

/* A camera at `centre` looking along +y (R rows x, down, forward), so t = -R C. */
static void place(gv_camera *cam, double x, double y, double z)
{
    static const double R[9] = {1, 0, 0, 0, 0, -1, 0, 1, 0};
    memcpy(cam->R, R, sizeof R);
    cam->t[0] = -x, cam->t[1] = z, cam->t[2] = -y;
}

static void test_extent(void)
{
    gv_camera cams[4];
    memset(cams, 0, sizeof cams);
    place(&cams[0], 0, 0, 0), place(&cams[1], 2, 0, 0), place(&cams[2], 0, 2, 0), place(&cams[3], 0, 0, 2);
    double c[3];
    gv_camera_center(&cams[1], c);
    CHECK(c[0] == 2 && c[1] == 0 && c[2] == 0);
    gv_scene s = {.n_frames = 4, .cameras = cams};
    /* Mean (0.5, 0.5, 0.5); the farthest centre is (2, 0, 0) at sqrt(2.25 + 0.25 + 0.25). */
    CHECK_NEAR(gv_scene_extent(&s, NULL, 0), 1.1 * sqrt(2.75), 1e-15);
    const int pair[2] = {1, 2}; /* mean (1, 1, 0), both at sqrt(2) */
    CHECK_NEAR(gv_scene_extent(&s, pair, 2), 1.1 * sqrt(2.0), 1e-15);
    CHECK(gv_scene_extent(&s, pair, 1) == 0);
}

/* ---- Scenes on disk ------------------------------------------------------------------- */

/* Pixel value of frame f at (x, y, channel k): distinct per frame and position. */
static uint8_t pattern(int f, int x, int y, int k)
{
    return (uint8_t)(17 * f + 29 * x + 53 * y + 71 * k);
}

static void write_image(const char *path, int f, int w, int h, int channels)
{
    gv_image img;
    if (gv_image_alloc(&img, w, h, channels) != 0) exit(1);
    for (int y = 0; y < h; y++)
        for (int x = 0; x < w; x++)
            for (int k = 0; k < channels; k++) img.pixels[(y * w + x) * channels + k] = pattern(f, x, y, k);
    if (gv_image_write_png(path, &img) != 0) { fprintf(stderr, "%s\n", gv_last_error()); exit(1); }
    gv_image_free(&img);
}

/* A scene of n frames of w x h around a circle, with two points, written with its images. */
static void make_scene(const char *dir, int n, int w, int h, gv_scene *s)
{
    memset(s, 0, sizeof *s);
    s->n_frames = n;
    s->cameras = calloc((size_t)n, sizeof *s->cameras);
    for (int i = 0; i < n; i++) {
        gv_camera *c = &s->cameras[i];
        double a = 2 * M_PI * i / n;
        c->width = w, c->height = h, c->fx = 0.9 * w, c->fy = 0.95 * w, c->cx = w / 2.0 + 0.25, c->cy = h / 2.0;
        /* Looking at the origin from radius 3, z up: forward f = -(cos a, sin a, 0). */
        const double R[9] = {-sin(a), cos(a), 0, 0, 0, -1, -cos(a), -sin(a), 0};
        memcpy(c->R, R, sizeof R);
        c->t[0] = 0, c->t[1] = 0.5, c->t[2] = 3; /* C = (3 cos a, 3 sin a, 0.5) */
        snprintf(c->name, sizeof c->name, "frame_%05d.png", n - 1 - i); /* reverse name order */
    }
    static float points[6] = {0.1f, 0.2f, 0.3f, -1.5f, 2.25f, 1e-3f};
    static uint8_t colors[6] = {1, 2, 3, 250, 128, 0};
    s->n_points = 2, s->points = points, s->colors = colors;
    char path[4200];
    snprintf(path, sizeof path, "%s/images", dir);
    CHECK(gv_mkdirs(path) == 0);
    for (int i = 0; i < n; i++) {
        snprintf(path, sizeof path, "%s/images/%s", dir, s->cameras[i].name);
        write_image(path, n - 1 - i, w, h, 3);
    }
    CHECK(gv_scene_write(dir, s) == 0);
}

static void compare_cameras(const gv_camera *a, const gv_camera *b, double tol, const char *what)
{
    double worst = 0;
    for (int k = 0; k < 9; k++) worst = fmax(worst, fabs(a->R[k] - b->R[k]));
    for (int k = 0; k < 3; k++) worst = fmax(worst, fabs(a->t[k] - b->t[k]));
    worst = fmax(worst, fmax(fabs(a->fx - b->fx), fabs(a->fy - b->fy)));
    worst = fmax(worst, fmax(fabs(a->cx - b->cx), fabs(a->cy - b->cy)));
    if (worst > tol) printf("%s: %s differs by %.3g\n", what, a->name, worst);
    CHECK(worst <= tol);
    CHECK(a->width == b->width && a->height == b->height && !strcmp(a->name, b->name));
}

static void test_round_trip(void)
{
    char dir[4200];
    snprintf(dir, sizeof dir, "%s/round_trip", tmp);
    gv_scene written;
    make_scene(dir, 6, 16, 12, &written);
    for (int from_json = 0; from_json < 2; from_json++) {
        gv_scene_options opt = {.downscale = 1, .prefer_transforms = from_json};
        gv_scene s;
        REQUIRE(gv_scene_load(dir, &opt, &s) == 0);
        CHECK(s.source == (from_json ? GV_SCENE_FROM_TRANSFORMS : GV_SCENE_FROM_COLMAP_TEXT));
        REQUIRE(s.n_frames == 6 && s.n_points == 2);
        /* Sorted by name: frame i of the loaded scene is camera 5 - i of the written one. */
        for (int i = 0; i < s.n_frames; i++)
            compare_cameras(&s.cameras[i], &written.cameras[5 - i], 1e-14, from_json ? "json" : "colmap");
        CHECK(s.n_points == 2 && !memcmp(s.points, written.points, 6 * sizeof(float)) &&
              !memcmp(s.colors, written.colors, 6));
        gv_image img;
        CHECK(gv_scene_load_image(&s, 2, &img) == 0);
        CHECK(img.width == 16 && img.height == 12 && img.channels == 3);
        CHECK(img.pixels && img.pixels[3 * (12 * 16 - 1) + 2] == pattern(2, 15, 11, 2));
        gv_image_free(&img);
        CHECK_FAILS_WITH(gv_scene_load_image(&s, 6, &img), "frame 6 out of range");
        gv_scene_free(&s);
    }
    /* A binary model in sparse/0 wins over the text one. */
    gv_colmap_model m;
    char sparse[4300];
    snprintf(sparse, sizeof sparse, "%s/sparse/0", dir);
    CHECK(gv_colmap_read_text(sparse, &m) == 0);
    m.images[0].tvec[0] += 1;
    CHECK(gv_colmap_write_bin(sparse, &m) == 0);
    gv_scene s;
    CHECK(gv_scene_load(dir, NULL, &s) == 0 && s.source == GV_SCENE_FROM_COLMAP_BIN);
    if (s.n_frames == 6) CHECK(s.cameras[5].t[0] == written.cameras[0].t[0] + 1);
    gv_scene_free(&s);
    gv_colmap_free(&m);
    free(written.cameras);
}

/* Area average of the k x k block at output pixel (x, y) of the pattern, rounded half up. */
static int block_mean(int f, int x, int y, int c, int k)
{
    int sum = 0;
    for (int j = 0; j < k; j++)
        for (int i = 0; i < k; i++) sum += pattern(f, k * x + i, k * y + j, c);
    return (2 * sum + k * k) / (2 * k * k);
}

static void test_downscale(void)
{
    char dir[4200], path[4300];
    snprintf(dir, sizeof dir, "%s/downscale", tmp);
    gv_scene written;
    make_scene(dir, 3, 10, 6, &written);
    const gv_camera *w0 = &written.cameras[2]; /* frame_00000 */
    /* k = 4 in memory: 10 x 6 -> (round(2.5), round(1.5)) = (2, 2), half to even; fx, cx
     * scale by 2/10 and fy, cy by 2/6. */
    gv_scene_options opt = {.downscale = 4};
    gv_scene s;
    REQUIRE(gv_scene_load(dir, &opt, &s) == 0);
    CHECK(s.downscale == 4 && s.memory_downscale == 4);
    const gv_camera *c = &s.cameras[0];
    CHECK(c->width == 2 && c->height == 2);
    CHECK_NEAR(c->fx, w0->fx * 0.2, 1e-14);
    CHECK_NEAR(c->cx, w0->cx * 0.2, 1e-14);
    CHECK_NEAR(c->fy, w0->fy / 3, 1e-14);
    CHECK_NEAR(c->cy, w0->cy / 3, 1e-14);
    gv_image img;
    CHECK(gv_scene_load_image(&s, 0, &img) == 0 && img.width == 2 && img.height == 2);
    gv_image_free(&img);
    gv_scene_free(&s);
    CHECK(gv_downscaled_size(10, 4) == 2 && gv_downscaled_size(14, 4) == 4 && gv_downscaled_size(3, 8) == 1);

    /* k = 2 divides 10 x 6: each pixel is the mean of a 2 x 2 block. */
    opt.downscale = 2;
    REQUIRE(gv_scene_load(dir, &opt, &s) == 0 && s.memory_downscale == 2);
    REQUIRE(gv_scene_load_image(&s, 1, &img) == 0 && img.width == 5 && img.height == 3);
    int same = 1;
    for (int y = 0; y < 3; y++)
        for (int x = 0; x < 5; x++)
            for (int k = 0; k < 3; k++) same &= img.pixels[(y * 5 + x) * 3 + k] == block_mean(1, x, y, k, 2);
    CHECK(same);
    gv_image_free(&img);
    gv_scene_free(&s);

    /* With images_2/ present its files are used as they are (here: other content). */
    snprintf(path, sizeof path, "%s/images_2", dir);
    CHECK(gv_mkdirs(path) == 0);
    for (int f = 0; f < 3; f++) {
        snprintf(path, sizeof path, "%s/images_2/frame_%05d.png", dir, f);
        write_image(path, f + 40, 5, 3, 3);
    }
    REQUIRE(gv_scene_load(dir, &opt, &s) == 0 && s.memory_downscale == 1);
    CHECK(strstr(s.image_dir, "images_2") != NULL);
    CHECK_NEAR(s.cameras[0].fx, w0->fx / 2, 1e-14);
    CHECK_NEAR(s.cameras[0].cy, w0->cy / 2, 1e-14);
    CHECK(gv_scene_load_image(&s, 1, &img) == 0 && img.width == 5 && img.height == 3);
    CHECK(img.pixels && img.pixels[0] == pattern(41, 0, 0, 0));
    gv_image_free(&img);
    gv_scene_free(&s);
    /* A file of the wrong size in images_2/ fails, naming it. */
    snprintf(path, sizeof path, "%s/images_2/frame_00000.png", dir);
    write_image(path, 0, 3, 3, 3);
    CHECK_FAILS_WITH(gv_scene_load(dir, &opt, &s), "images_2/frame_00000.png: is 3x3, which is not the camera's 10x6 downscaled by 2");
    write_image(path, 0, 5, 3, 3);
    snprintf(path, sizeof path, "%s/images_2/frame_00002.png", dir);
    write_image(path, 0, 4, 3, 3); /* right size for the folder's first image only */
    CHECK(gv_scene_load(dir, &opt, &s) == 0);
    CHECK_FAILS_WITH(gv_scene_load_image(&s, 2, &img), "images_2/frame_00002.png: is 4x3 but the camera is 5x3");
    gv_scene_free(&s);
    free(written.cameras);
}

/* RGBA images are composited on the background. */
static void test_alpha(void)
{
    char dir[4200], path[4300];
    snprintf(dir, sizeof dir, "%s/alpha", tmp);
    gv_scene written;
    make_scene(dir, 2, 4, 4, &written);
    snprintf(path, sizeof path, "%s/images/frame_00000.png", dir);
    write_image(path, 0, 4, 4, 4);
    for (int white = 0; white < 2; white++) {
        gv_scene_options opt = {.downscale = 1, .white_background = white};
        gv_scene s;
        gv_image img;
        REQUIRE(gv_scene_load(dir, &opt, &s) == 0 && gv_scene_load_image(&s, 0, &img) == 0);
        int same = 1;
        for (int y = 0; y < 4; y++)
            for (int x = 0; x < 4; x++)
                for (int k = 0; k < 3; k++) {
                    int v = pattern(0, x, y, k), a = pattern(0, x, y, 3);
                    int expected = (v * a + (white ? 255 : 0) * (255 - a) + 127) / 255;
                    same &= img.pixels[(y * 4 + x) * 3 + k] == expected;
                }
        CHECK(same);
        gv_image_free(&img);
        gv_scene_free(&s);
    }
    free(written.cameras);
}

static void test_bad_scenes(void)
{
    char dir[4200], path[4300];
    gv_scene s;
    snprintf(dir, sizeof dir, "%s/does_not_exist", tmp);
    CHECK_FAILS_WITH(gv_scene_load(dir, NULL, &s), "does_not_exist: no such scene folder");
    snprintf(dir, sizeof dir, "%s/empty", tmp);
    CHECK(gv_mkdirs(dir) == 0);
    CHECK_FAILS_WITH(gv_scene_load(dir, NULL, &s), "empty: no scene description");
    gv_scene_options bad = {.downscale = 0 - 3};
    CHECK_FAILS_WITH(gv_scene_load(dir, &bad, &s), "downscale -3 is not in 1..64");

    snprintf(dir, sizeof dir, "%s/broken", tmp);
    gv_scene written;
    make_scene(dir, 3, 8, 8, &written);
    snprintf(path, sizeof path, "%s/images/frame_00001.png", dir);
    remove(path);
    CHECK_FAILS_WITH(gv_scene_load(dir, NULL, &s), "images/frame_00001.png: image of frame 1 is missing");
    gv_scene_options json = {.prefer_transforms = 1};
    CHECK_FAILS_WITH(gv_scene_load(dir, &json, &s), "images/frame_00001.png: image of frame 1 is missing");
    write_image(path, 1, 8, 8, 3);
    snprintf(path, sizeof path, "%s/points3D.ply", dir);
    remove(path);
    CHECK_FAILS_WITH(gv_scene_load(dir, &json, &s), "transforms.json: ply_file_path points3D.ply does not exist");
    snprintf(path, sizeof path, "%s/sparse/0/points3D.txt", dir);
    remove(path);
    CHECK_FAILS_WITH(gv_scene_load(dir, NULL, &s), "points3D.txt: cannot open");
    /* Two frames naming the same image. */
    strcpy(written.cameras[1].name, written.cameras[0].name);
    CHECK(gv_scene_write(dir, &written) == 0);
    CHECK_FAILS_WITH(gv_scene_load(dir, NULL, &s), "image frame_00002.png is used by two frames");
    free(written.cameras);
}

int main(void)
{
    tmp = check_tmp_dir();
    test_split();
    test_extent();
    test_round_trip();
    test_downscale();
    test_alpha();
    test_bad_scenes();
    return check_summary();
}
