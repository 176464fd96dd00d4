/* transforms.json: cameras derived by hand (OpenGL camera-to-world -> OpenCV world-to-camera),
 * the NeRF-synthetic convention, the writer's round trip, and malformed files, each failing
 * with one line naming the file and the frame or key. */
#include "check.h"
#include "gaussvid/core/core.h"
#include "gaussvid/io/image.h"
#include "gaussvid/scene/scene.h"
#include "gaussvid/io/transforms.h"

static const char *tmp;

static const char *write_text(const char *name, const char *text)
{
    static char path[8][4200];
    static int next;
    char *p = path[next++ % 8];
    snprintf(p, 4200, "%s/%s", tmp, name);
    FILE *f = fopen(p, "w");
    if (!f || fputs(text, f) < 0) { fprintf(stderr, "cannot write %s\n", p); exit(1); }
    fclose(f);
    return p;
}

static void check_matrix(const double *got, const double *expected, int n, double tol)
{
    double worst = 0;
    for (int i = 0; i < n; i++) worst = fmax(worst, fabs(got[i] - expected[i]));
    CHECK_NEAR(worst, 0, tol);
}

/* Frame a: camera at C = (1, 2, 3) looking along world +y with world +z up. In OpenGL axes
 * its columns are x = (1,0,0), up = (0,0,1), back = (0,-1,0). In OpenCV axes the rows of R are
 * x = (1,0,0), down = (0,0,-1), forward = (0,1,0); t = -R C = -(1, -3, 2).
 * Frame b: camera at C = (4, 5, 6) looking along world -x, +z up: OpenGL columns x = (0,1,0),
 * up = (0,0,1), back = (1,0,0); R rows (0,1,0), (0,0,-1), (-1,0,0); t = -R C = -(5, -6, -4).
 * Frame c: frame a as a 3x4 matrix with float32-rounded entries (not exactly orthonormal). */
static const char *hand_json =
    "{\"camera_model\": \"OPENCV\", \"fl_x\": 100, \"fl_y\": 110, \"cx\": 64.5, \"cy\": 48.25,\n"
    " \"w\": 128, \"h\": 96, \"k1\": 0, \"k2\": 0.0, \"p1\": 0, \"p2\": -0.0,\n"
    " \"ply_file_path\": \"sparse_pc.ply\",\n"
    " \"frames\": [\n"
    "  {\"file_path\": \"images/a.png\", \"transform_matrix\": [[1,0,0,1],[0,0,-1,2],[0,1,0,3],[0,0,0,1]]},\n"
    "  {\"file_path\": \"./images/b.jpg\", \"fl_x\": 200, \"cx\": 60, \"w\": 120,\n"
    "   \"transform_matrix\": [[0,0,1,4],[1,0,0,5],[0,1,0,6],[0,0,0,1]]},\n"
    "  {\"file_path\": \"images/c.png\", \"transform_matrix\": [[0.99999994,0,0,1],"
    "[0,0.00000003,-1.0000001,2],[0,0.99999994,0,3]]}\n"
    " ]}\n";

static void test_hand_computed(void)
{
    gv_transforms tf;
    CHECK(gv_transforms_read(write_text("hand.json", hand_json), &tf) == 0);
    CHECK(tf.n_frames == 3);
    if (tf.n_frames != 3) return;
    CHECK(!strcmp(tf.ply_file_path, "sparse_pc.ply"));
    const gv_camera *a = &tf.cameras[0], *b = &tf.cameras[1], *c = &tf.cameras[2];
    CHECK(!strcmp(a->name, "images/a.png") && !strcmp(b->name, "images/b.jpg"));
    CHECK(a->width == 128 && a->height == 96 && a->fx == 100 && a->fy == 110 && a->cx == 64.5 &&
          a->cy == 48.25);
    /* Per-frame keys override the top level; the rest is inherited. */
    CHECK(b->width == 120 && b->height == 96 && b->fx == 200 && b->fy == 110 && b->cx == 60 &&
          b->cy == 48.25);
    const double Ra[9] = {1, 0, 0, 0, 0, -1, 0, 1, 0}, ta[3] = {-1, 3, -2};
    const double Rb[9] = {0, 1, 0, 0, 0, -1, -1, 0, 0}, tb[3] = {-5, 6, 4};
    check_matrix(a->R, Ra, 9, 0), check_matrix(a->t, ta, 3, 0);
    check_matrix(b->R, Rb, 9, 0), check_matrix(b->t, tb, 3, 0);
    check_matrix(c->R, Ra, 9, 1e-7), check_matrix(c->t, ta, 3, 1e-6);
    /* c's rotation was projected onto an exact rotation. */
    double worst = 0;
    for (int i = 0; i < 3; i++)
        for (int j = 0; j < 3; j++) {
            double dot = 0;
            for (int k = 0; k < 3; k++) dot += c->R[3 * i + k] * c->R[3 * j + k];
            worst = fmax(worst, fabs(dot - (i == j)));
        }
    CHECK(worst < 1e-15);
    /* A point 5 m ahead of camera a projects to the principal point; 1 m above it, to
     * 110 / 5 = 22 pixels above (y down). */
    const double ahead[3] = {1, 7, 3}, above[3] = {1, 7, 4};
    double p[3], q[3];
    for (int i = 0; i < 3; i++) {
        p[i] = a->R[3 * i] * ahead[0] + a->R[3 * i + 1] * ahead[1] + a->R[3 * i + 2] * ahead[2] + a->t[i];
        q[i] = a->R[3 * i] * above[0] + a->R[3 * i + 1] * above[1] + a->R[3 * i + 2] * above[2] + a->t[i];
    }
    CHECK(p[0] == 0 && p[1] == 0 && p[2] == 5);
    CHECK_NEAR(a->fy * q[1] / q[2] + a->cy, 48.25 - 22, 1e-12);
    double centre[3];
    gv_camera_center(b, centre);
    CHECK(centre[0] == 4 && centre[1] == 5 && centre[2] == 6);
    gv_transforms_free(&tf);
}

/* NeRF-synthetic: camera_angle_x = 2 atan(1/2) gives fx = W / (2 * 1/2) = W; fy = fx; the
 * principal point is the centre; the size comes from the image; ".png" is appended. */
static void test_nerf_synthetic(void)
{
    char dir[4200];
    snprintf(dir, sizeof dir, "%s/train", tmp);
    CHECK(gv_mkdirs(dir) == 0);
    gv_image img;
    CHECK(gv_image_alloc(&img, 40, 30, 4) == 0);
    snprintf(dir, sizeof dir, "%s/train/r_0.png", tmp);
    CHECK(gv_image_write_png(dir, &img) == 0);
    gv_image_free(&img);
    char json[512];
    snprintf(json, sizeof json,
             "{\"camera_angle_x\": %.17g, \"frames\": [{\"file_path\": \"./train/r_0\", "
             "\"rotation\": 0.1, \"transform_matrix\": [[1,0,0,0],[0,1,0,0],[0,0,1,4],[0,0,0,1]]}]}",
             2 * atan(0.5));
    gv_transforms tf;
    CHECK(gv_transforms_read(write_text("transforms_ns.json", json), &tf) == 0);
    if (tf.n_frames != 1) { CHECK(0); return; }
    const gv_camera *c = &tf.cameras[0];
    CHECK(!strcmp(c->name, "train/r_0.png"));
    CHECK(c->width == 40 && c->height == 30);
    CHECK_NEAR(c->fx, 40, 1e-12);
    CHECK_NEAR(c->fy, 40, 1e-12);
    CHECK(c->cx == 20 && c->cy == 15);
    /* Identity OpenGL rotation: the camera looks along world -z with y up, so in OpenCV axes
     * R = diag(1, -1, -1) and t = -R (0, 0, 4) = (0, 0, 4). */
    const double R[9] = {1, 0, 0, 0, -1, 0, 0, 0, -1}, t[3] = {0, 0, 4};
    check_matrix(c->R, R, 9, 0), check_matrix(c->t, t, 3, 0);
    gv_transforms_free(&tf);
    /* camera_angle_y sets fy from the height: 2 atan(3/4) -> fy = 30 / (2 * 3/4) = 20. */
    snprintf(json, sizeof json,
             "{\"camera_angle_x\": %.17g, \"camera_angle_y\": %.17g, \"frames\": [{\"file_path\": "
             "\"train/r_0\", \"transform_matrix\": [[1,0,0,0],[0,1,0,0],[0,0,1,4],[0,0,0,1]]}]}",
             2 * atan(0.5), 2 * atan(0.75));
    CHECK(gv_transforms_read(write_text("transforms_ns.json", json), &tf) == 0);
    if (tf.n_frames == 1) CHECK_NEAR(tf.cameras[0].fy, 20, 1e-12);
    gv_transforms_free(&tf);
    const char *no_image = "{\"camera_angle_x\": 0.5, \"frames\": [{\"file_path\": \"train/r_9\", "
                           "\"transform_matrix\": [[1,0,0,0],[0,1,0,0],[0,0,1,4],[0,0,0,1]]}]}";
    CHECK_FAILS_WITH(gv_transforms_read(write_text("no_image.json", no_image), &tf),
                     "no_image.json: frames[0] gives no w/h and its image cannot be read");
}

static void random_rotation(uint64_t seed, double R[9])
{
    double q[4], n = 0;
    for (int k = 0; k < 4; k++) q[k] = gv_normal_at(seed, (uint64_t)k), n += q[k] * q[k];
    n = sqrt(n);
    double w = q[0] / n, x = q[1] / n, y = q[2] / n, z = q[3] / n;
    const double r[9] = {1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y),
                         2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x),
                         2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)};
    memcpy(R, r, sizeof r);
}

static void test_writer_round_trip(void)
{
    gv_camera cams[3];
    memset(cams, 0, sizeof cams);
    for (int i = 0; i < 3; i++) {
        gv_camera *c = &cams[i];
        *c = (gv_camera){.width = 256, .height = 144, .fx = 199.11111111111111, .fy = 199.11111111111111,
                         .cx = 128, .cy = 72};
        random_rotation(100 + i, c->R);
        for (int k = 0; k < 3; k++) c->t[k] = gv_normal_at(7, (uint64_t)(3 * i + k)) * 3;
        snprintf(c->name, sizeof c->name, "frame_%05d.png", i);
    }
    char path[4200];
    snprintf(path, sizeof path, "%s/written.json", tmp);
    for (int per_frame = 0; per_frame < 2; per_frame++) {
        if (per_frame) cams[2].cx = 127.5, cams[1].width = 250;
        CHECK(gv_transforms_write(path, cams, 3, "images", "points3D.ply") == 0);
        gv_transforms tf;
        CHECK(gv_transforms_read(path, &tf) == 0);
        CHECK(tf.n_frames == 3 && !strcmp(tf.ply_file_path, "points3D.ply"));
        for (int i = 0; i < tf.n_frames && i < 3; i++) {
            const gv_camera *a = &cams[i], *b = &tf.cameras[i];
            char expected[300];
            snprintf(expected, sizeof expected, "images/%s", a->name);
            CHECK(!strcmp(b->name, expected));
            CHECK(a->width == b->width && a->height == b->height && a->fx == b->fx &&
                  a->fy == b->fy && a->cx == b->cx && a->cy == b->cy);
            check_matrix(b->R, a->R, 9, 1e-14);
            check_matrix(b->t, a->t, 3, 1e-13);
        }
        gv_transforms_free(&tf);
    }
    char *text;
    CHECK(gv_read_file(path, &text, NULL) == 0);
    CHECK(strstr(text, "\"fl_x\"") && strstr(text, "\"camera_model\":\t\"OPENCV\""));
    free(text);
    cams[0].t[1] = NAN;
    CHECK_FAILS_WITH(gv_transforms_write(path, cams, 3, "images", NULL), "written.json: frame 0");
}

static void test_pose_conversion(void)
{
    double worst = 0;
    for (int i = 0; i < 100; i++) {
        double R[9], t[3], c2w[16], R2[9], t2[3];
        random_rotation(500 + i, R);
        for (int k = 0; k < 3; k++) t[k] = gv_normal_at(9, (uint64_t)(3 * i + k));
        gv_pose_to_c2w_opengl(R, t, c2w);
        gv_pose_from_c2w_opengl(c2w, R2, t2);
        for (int k = 0; k < 9; k++) worst = fmax(worst, fabs(R[k] - R2[k]));
        for (int k = 0; k < 3; k++) worst = fmax(worst, fabs(t[k] - t2[k]));
        /* The OpenGL camera looks along -z: column 2 of c2w is minus the forward axis, which is
         * row 2 of R. */
        for (int k = 0; k < 3; k++) worst = fmax(worst, fabs(c2w[4 * k + 2] + R[6 + k]));
    }
    CHECK(worst < 1e-14);
}

#define FRAME_A "{\"file_path\": \"images/a.png\", \"transform_matrix\": [[1,0,0,1],[0,0,-1,2],[0,1,0,3],[0,0,0,1]]}"
#define TOP "\"fl_x\": 100, \"w\": 128, \"h\": 96"

static void test_bad_files(void)
{
    static const struct {
        const char *name, *text, *needle;
    } cases[] = {
        {"missing_fl.json", "{\"w\": 8, \"h\": 8, \"frames\": [" FRAME_A "]}",
         "missing_fl.json: frames[0]: missing key fl_x (or camera_angle_x)"},
        {"nan.json", "{\"fl_x\": NaN, \"w\": 8, \"h\": 8, \"frames\": [" FRAME_A "]}",
         "nan.json: line 1, key fl_x: NaN/Infinity is not a number"},
        {"inf.json", "{\"fl_x\": 100, \"w\": 8, \"h\": 8,\n \"cy\": 1e999, \"frames\": [" FRAME_A "]}",
         "inf.json: cy is not finite"},
        {"string.json", "{" TOP ", \"frames\": [{\"cx\": \"64\", \"file_path\": \"a.png\", "
         "\"transform_matrix\": [[1,0,0,1],[0,1,0,2],[0,0,1,3],[0,0,0,1]]}]}",
         "string.json: frames[0].cx is not a number"},
        {"nan_matrix.json", "{" TOP ", \"frames\": [" FRAME_A ",\n{\"file_path\": \"b.png\", "
         "\"transform_matrix\": [[1,0,0,NaN],[0,1,0,2],[0,0,1,3],[0,0,0,1]]}]}",
         "nan_matrix.json: line 2, key transform_matrix: NaN/Infinity"},
        {"shape.json", "{" TOP ", \"frames\": [" FRAME_A ", {\"file_path\": \"b.png\", "
         "\"transform_matrix\": [[1,0,0],[0,1,0],[0,0,1]]}]}",
         "shape.json: frames[1].transform_matrix row 0 does not have 4 entries"},
        {"rows.json", "{" TOP ", \"frames\": [{\"file_path\": \"b.png\", "
         "\"transform_matrix\": [[1,0,0,0],[0,1,0,0]]}]}",
         "rows.json: frames[0].transform_matrix is not a 4x4 (or 3x4) array"},
        {"entry.json", "{" TOP ", \"frames\": [{\"file_path\": \"b.png\", "
         "\"transform_matrix\": [[1,0,0,0],[0,1,\"x\",0],[0,0,1,0]]}]}",
         "entry.json: frames[0].transform_matrix[1][2] is not a finite number"},
        {"scaled.json", "{" TOP ", \"frames\": [{\"file_path\": \"b.png\", "
         "\"transform_matrix\": [[2,0,0,0],[0,2,0,0],[0,0,2,0],[0,0,0,1]]}]}",
         "scaled.json: frames[0].transform_matrix: rotation is not orthonormal"},
        {"mirror.json", "{" TOP ", \"frames\": [{\"file_path\": \"b.png\", "
         "\"transform_matrix\": [[-1,0,0,0],[0,1,0,0],[0,0,1,0],[0,0,0,1]]}]}",
         "det = -1"},
        {"last_row.json", "{" TOP ", \"frames\": [{\"file_path\": \"b.png\", "
         "\"transform_matrix\": [[1,0,0,0],[0,1,0,0],[0,0,1,0],[0,0,1,1]]}]}",
         "last_row.json: frames[0].transform_matrix: last row is not (0, 0, 0, 1)"},
        {"no_matrix.json", "{" TOP ", \"frames\": [{\"file_path\": \"b.png\"}]}",
         "no_matrix.json: frames[0]: missing key transform_matrix"},
        {"no_path.json", "{" TOP ", \"frames\": [{\"transform_matrix\": [[1,0,0,0],[0,1,0,0],[0,0,1,0]]}]}",
         "no_path.json: frames[0]: missing key file_path"},
        {"distorted.json", "{" TOP ", \"k1\": 0.1, \"frames\": [" FRAME_A "]}",
         "distorted.json: k1 = 0.1: non-zero distortion is not supported"},
        {"distorted2.json", "{" TOP ", \"frames\": [" FRAME_A ", {\"p2\": 0.001, \"file_path\": "
         "\"b.png\", \"transform_matrix\": [[1,0,0,0],[0,1,0,0],[0,0,1,0]]}]}",
         "distorted2.json: frames[1].p2 = 0.001"},
        {"fisheye.json", "{" TOP ", \"camera_model\": \"OPENCV_FISHEYE\", \"frames\": [" FRAME_A "]}",
         "fisheye.json: camera_model OPENCV_FISHEYE is not supported"},
        {"size.json", "{\"fl_x\": 100, \"w\": 12.5, \"h\": 8, \"frames\": [" FRAME_A "]}",
         "size.json: frames[0]: image size w=12.5 h=8"},
        {"focal.json", "{\"fl_x\": -100, \"w\": 12, \"h\": 8, \"frames\": [" FRAME_A "]}",
         "focal.json: frames[0]: focal length must be positive"},
        {"empty.json", "{" TOP ", \"frames\": []}", "empty.json: frames is not a non-empty array"},
        {"no_frames.json", "{" TOP "}", "no_frames.json: missing key frames"},
        {"array.json", "[1, 2]", "array.json: top level is not a JSON object"},
        {"broken.json", "{" TOP ",\n\n \"frames\": [" FRAME_A "", "broken.json: line 3"},
        /* found by fuzz/: a quote and a colon at the very start read before the text */
        {"start.json", "\":Na", "start.json: line 1: invalid JSON"},
        {"absolute.json", "{" TOP ", \"frames\": [{\"file_path\": \"/etc/a.png\", "
         "\"transform_matrix\": [[1,0,0,0],[0,1,0,0],[0,0,1,0]]}]}",
         "absolute.json: frames[0].file_path /etc/a.png must be relative"},
    };
    for (size_t i = 0; i < sizeof cases / sizeof *cases; i++) {
        gv_transforms tf;
        CHECK_FAILS_WITH(gv_transforms_read(write_text(cases[i].name, cases[i].text), &tf), cases[i].needle);
        CHECK(tf.cameras == NULL && tf.n_frames == 0);
    }
    gv_transforms tf;
    char missing[4200];
    snprintf(missing, sizeof missing, "%s/nope/transforms.json", tmp);
    CHECK_FAILS_WITH(gv_transforms_read(missing, &tf), "nope/transforms.json: cannot open");
}

/* Mutation fuzzing of the hand-computed file (seeded): every read returns 0 or fails with a
 * message naming the file; under ASan nothing may go out of bounds. */
static void test_mutations(void)
{
    static const char specials[] = "\"{}[],:-.eN0123456789 \n";
    size_t n = strlen(hand_json);
    char *text = malloc(n + 1);
    int named = 1, failures = 0;
    uint64_t draw = 0;
    for (int trial = 0; trial < 400; trial++) {
        memcpy(text, hand_json, n + 1);
        int n_changes = 1 + (int)(gv_uniform_at(5, draw++) * 3);
        for (int c = 0; c < n_changes; c++) {
            size_t at = (size_t)(gv_uniform_at(5, draw++) * n);
            text[at] = specials[(int)(gv_uniform_at(5, draw++) * (sizeof specials - 1))];
        }
        if (gv_uniform_at(5, draw++) < 0.1) text[(size_t)(gv_uniform_at(5, draw++) * n)] = '\0';
        gv_transforms tf;
        gv_clear_error();
        if (gv_transforms_read(write_text("fuzz.json", text), &tf) != 0) {
            failures++;
            if (!strstr(gv_last_error(), "fuzz.json")) {
                named = 0;
                fprintf(stderr, "unnamed failure: %s\n", gv_last_error());
            }
        }
        gv_transforms_free(&tf);
    }
    free(text);
    printf("mutations: %d of 400 mutated files refused, each naming the file\n", failures);
    CHECK(named);
    CHECK(failures > 100);
}

int main(void)
{
    tmp = check_tmp_dir();
    test_hand_computed();
    test_nerf_synthetic();
    test_writer_round_trip();
    test_pose_conversion();
    test_bad_files();
    test_mutations();
    return check_summary();
}
