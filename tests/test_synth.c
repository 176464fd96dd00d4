/* Procedural scenes (gaussvid scene synth): ray-primitive intersections against hand-derived
 * values, the box-filtered patterns against numeric integration, the BVH against brute
 * force, and on tiny generated scenes: points projected with the written cameras land on
 * pixels of their colour (and do not with a wrong pose), byte-identical files for the same
 * seed with 1 and 2 threads, different images for different seeds, a smooth camera path that
 * translates and turns inside the room and clear of the furniture, and bad parameters. */
#include <omp.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>

#include "check.h"
#include "gaussvid/core/core.h"
#include "gaussvid/io/image.h"
#include "gaussvid/scene/scene.h"
#include "gaussvid/synth/synth.h"
#include "synth/synth_internal.h"

static sy_prim make_prim(sy_shape shape, sy_vec center, sy_vec half, double yaw)
{
    sy_prim p;
    memset(&p, 0, sizeof p);
    p.shape = shape;
    p.center = center;
    p.half = half;
    p.light = -1;
    sy_prim_set_yaw(&p, yaw);
    return p;
}

static int hit(const sy_prim *p, sy_vec o, sy_vec d, double *t, int *face)
{
    return sy_prim_intersect(p, o, sy_normalize(d), 1e-9, 1e9, t, face);
}

static void test_intersections(void)
{
    double t;
    int face;
    /* box centred (1, 2, 3), half (1, 0.5, 0.25): from x = -5 along +x it is entered at x = 0
     * through its -x face (1); from its centre upwards it is left at z = 3.25 (+z, face 4) */
    sy_prim box = make_prim(SY_BOX, sy_v(1, 2, 3), sy_v(1, 0.5, 0.25), 0);
    CHECK(hit(&box, sy_v(-5, 2, 3), sy_v(1, 0, 0), &t, &face) && face == 1);
    CHECK_NEAR(t, 5, 1e-12);
    CHECK(hit(&box, sy_v(1, 2, 3), sy_v(0, 0, 1), &t, &face) && face == 4);
    CHECK_NEAR(t, 0.25, 1e-12);
    CHECK(!hit(&box, sy_v(-5, 2.6, 3), sy_v(1, 0, 0), &t, &face));
    CHECK(!hit(&box, sy_v(-5, 2, 3), sy_v(-1, 0, 0), &t, &face));
    /* unit cube turned 45 degrees: its corner is at x = -sqrt(2) on the x axis */
    sy_prim turned = make_prim(SY_BOX, sy_v(0, 0, 0), sy_v(1, 1, 1), M_PI / 4);
    CHECK(hit(&turned, sy_v(-5, 0, 0), sy_v(1, 0, 0), &t, &face));
    CHECK_NEAR(t, 5 - sqrt(2), 1e-12);
    CHECK(!hit(&turned, sy_v(-5, 1.45, 0), sy_v(1, 0, 0), &t, &face));
    CHECK(hit(&turned, sy_v(-5, 1.40, 0), sy_v(1, 0, 0), &t, &face));
    /* sphere of radius 2 at the origin */
    sy_prim ball = make_prim(SY_SPHERE, sy_v(0, 0, 0), sy_v(2, 2, 2), 0);
    CHECK(hit(&ball, sy_v(0, 0, -5), sy_v(0, 0, 1), &t, &face));
    CHECK_NEAR(t, 3, 1e-12);
    CHECK(hit(&ball, sy_v(0, 0, 0), sy_v(0, 1, 0), &t, &face));
    CHECK_NEAR(t, 2, 1e-12);
    CHECK(!hit(&ball, sy_v(2.01, 0, -5), sy_v(0, 0, 1), &t, &face));
    /* ray at height 1 towards (0, 1.2, 1): distance 5 along +x, the sphere at y = 1.2 has
     * half-chord sqrt(4 - 1.44 - 1) */
    CHECK(hit(&ball, sy_v(-5, 1.2, 1), sy_v(1, 0, 0), &t, &face));
    CHECK_NEAR(t, 5 - sqrt(4 - 1.44 - 1), 1e-12);
    /* cylinder r 1, height 2 from z = 0: side at x = -1, top at z = 2, misses above */
    sy_prim can = make_prim(SY_CYLINDER, sy_v(0, 0, 0), sy_v(1, 1, 2), 0.3);
    CHECK(hit(&can, sy_v(-5, 0, 1), sy_v(1, 0, 0), &t, &face) && face == 0);
    CHECK_NEAR(t, 4, 1e-12);
    CHECK(hit(&can, sy_v(0.5, 0, 5), sy_v(0, 0, -1), &t, &face) && face == 1);
    CHECK_NEAR(t, 3, 1e-12);
    CHECK(hit(&can, sy_v(0.5, 0.5, -1), sy_v(0, 0, 1), &t, &face) && face == 2);
    CHECK_NEAR(t, 1, 1e-12);
    CHECK(!hit(&can, sy_v(-5, 0, 2.5), sy_v(1, 0, 0), &t, &face));
    CHECK(!hit(&can, sy_v(1.01, 0, 5), sy_v(0, 0, -1), &t, &face));
    /* a slanted ray through the top rim: enters the side at z = 1.9 */
    CHECK(hit(&can, sy_v(-2, 0, 0.9), sy_v(1, 0, 1), &t, &face) && face == 0);
    CHECK_NEAR(t, sqrt(2.0), 1e-12);
}

/* Every face's (s, t) parameterisation: the point it gives is hit again from outside along
 * the normal, on the same face, with the same (s, t). */
static void test_face_parameters(void)
{
    sy_prim prims[3] = {make_prim(SY_BOX, sy_v(1, -2, 0.5), sy_v(0.7, 0.3, 0.5), 0.4),
                        make_prim(SY_SPHERE, sy_v(-1, 0, 2), sy_v(0.6, 0.6, 0.6), 1.1),
                        make_prim(SY_CYLINDER, sy_v(0, 3, 0), sy_v(0.4, 0.4, 1.5), -0.7)};
    int checked = 0, agreed = 0;
    for (int k = 0; k < 3; k++)
        for (int face = 0; face < sy_prim_n_faces(&prims[k]); face++)
            for (int i = 0; i < 5; i++) {
                double s = 0.1 + 0.19 * i, tt = 0.85 - 0.17 * i;
                if (prims[k].shape == SY_CYLINDER && face > 0) { s = 0.5 + 0.1 * (i - 2); tt = 0.5 - 0.08 * (i - 2); }
                sy_vec p, n, o;
                sy_prim_face_point(&prims[k], face, s, tt, &p, &n);
                o = sy_add(p, sy_scale(n, 0.5));
                double t;
                int f;
                sy_surface surf;
                checked++;
                if (!sy_prim_intersect(&prims[k], o, sy_scale(n, -1), 1e-9, 1e9, &t, &f)) continue;
                sy_prim_surface(&prims[k], f, o, sy_scale(n, -1), t, &surf);
                if (f == face && fabs(t - 0.5) < 1e-9 && fabs(surf.s - s) < 1e-9 && fabs(surf.t - tt) < 1e-9 &&
                    sy_dot(surf.n, n) > 1 - 1e-12)
                    agreed++;
            }
    printf("face parameterisation: %d of %d points round-trip\n", agreed, checked);
    CHECK(checked == 5 * (6 + 1 + 3));
    CHECK(agreed == checked);
}

/* The box-filtered line pattern equals the mean of the pattern over the box (midpoint rule
 * with 20000 points), and noise stays in [-1, 1] and fades out under a wide footprint. */
static void test_patterns(void)
{
    double worst = 0;
    const double xs[] = {0.013, 0.37, 1.9}, ws[] = {0.004, 0.05, 0.31, 3.0};
    for (int a = 0; a < 3; a++)
        for (int b = 0; b < 4; b++) {
            double x = xs[a], w = ws[b], period = 0.25, width = 0.03, sum = 0;
            for (int i = 0; i < 20000; i++) {
                double y = x - 0.5 * w + w * (i + 0.5) / 20000 + 0.5 * width;
                sum += (y - period * floor(y / period)) < width;
            }
            worst = fmax(worst, fabs(sy_lines(x, period, width, w) - sum / 20000));
        }
    printf("box-filtered lines vs numeric mean: worst difference %.2e\n", worst);
    CHECK(worst < 2e-4);
    CHECK_NEAR(sy_lines(0.0, 0.25, 0.03, 0), 1.0, 0);
    CHECK_NEAR(sy_lines(0.1, 0.25, 0.03, 0), 0.0, 0);
    CHECK_NEAR(sy_square(0.1, 1.0, 1.0), 0.5, 1e-12);
    double lo = 1, hi = -1, fbm_wide = 0;
    for (int i = 0; i < 5000; i++) {
        sy_vec p = sy_v(0.37 * i, 0.11 * i - 3, 0.07 * i);
        double v = sy_noise3(p, 7);
        lo = fmin(lo, v), hi = fmax(hi, v);
        fbm_wide = fmax(fbm_wide, fabs(sy_fbm3(p, 2.0, 5, 10.0, 7)));
    }
    CHECK(lo >= -1 && hi <= 1 && hi - lo > 1.0);
    CHECK(fbm_wide == 0);
    CHECK_NEAR(sy_noise3(sy_v(0.5, 0.5, 0.5), 3), sy_noise3(sy_v(0.5 + 1e-9, 0.5, 0.5), 3), 1e-6);
}

/* The BVH's closest and any hits equal a loop over every primitive. */
static void test_bvh(void)
{
    gv_synth_world *w = calloc(1, sizeof *w);
    w->open_group = -1;
    w->sky.ground_z = -1e6;
    gv_rng r;
    gv_rng_init(&r, 99);
    sy_material m = {.kind = SY_MAT_PAINT};
    sy_add_material(w, &m);
    for (int g = 0; g < 20; g++) {
        sy_begin_group(w, 1);
        for (int i = 0; i < 10; i++) {
            sy_vec c = sy_v(sy_uniform(&r, -5, 5), sy_uniform(&r, -5, 5), sy_uniform(&r, -2, 2));
            double a = sy_uniform(&r, 0.05, 0.6), b = sy_uniform(&r, 0.05, 0.6), yaw = sy_uniform(&r, -3, 3);
            int kind = i % 3;
            if (kind == 0) sy_add_box(w, c, sy_v(a, b, sy_uniform(&r, 0.05, 0.6)), yaw, 0);
            else if (kind == 1) sy_add_sphere(w, c, a, 0);
            else sy_add_cylinder(w, c, a, b, yaw, 0);
        }
        sy_end_group(w);
    }
    w->prims[17].light = 0; /* an emitter: seen by camera rays, casts no shadow */
    CHECK(sy_build_bvh(w) == 0);
    int same_closest = 0, same_any = 0, hits = 0;
    for (int k = 0; k < 3000; k++) {
        sy_vec o = sy_v(sy_uniform(&r, -7, 7), sy_uniform(&r, -7, 7), sy_uniform(&r, -3, 3));
        sy_vec d = sy_normalize(sy_v(gv_rng_normal(&r), gv_rng_normal(&r), gv_rng_normal(&r)));
        double tmax = sy_uniform(&r, 0.5, 20), best = 1e30;
        int best_prim = -1, any = 0;
        for (int i = 0; i < w->n_prims; i++) {
            double t;
            int face;
            if (sy_prim_intersect(&w->prims[i], o, d, 1e-7, best, &t, &face)) best = t, best_prim = i;
            if (w->prims[i].light < 0 && sy_prim_intersect(&w->prims[i], o, d, 1e-7, tmax, &t, &face)) any = 1;
        }
        sy_hit h;
        sy_trace(w, o, d, 1e30, &h);
        int prim = h.prim >= 0 ? h.prim : -1;
        same_closest += prim == best_prim && (prim < 0 || fabs(h.t - best) < 1e-12);
        same_any += sy_occluded(w, o, d, tmax) == any;
        hits += prim >= 0;
    }
    printf("bvh: %d of 3000 closest hits and %d of 3000 shadow tests agree (%d rays hit)\n", same_closest, same_any, hits);
    CHECK(same_closest == 3000);
    CHECK(same_any == 3000);
    CHECK(hits > 300);
    gv_synth_free(w);
}

static int files_equal(const char *a, const char *b)
{
    char *x, *y;
    size_t nx, ny;
    if (gv_read_file(a, &x, &nx)) return 0;
    if (gv_read_file(b, &y, &ny)) { free(x); return 0; }
    int same = nx == ny && !memcmp(x, y, nx);
    free(x), free(y);
    return same;
}

static void tiny_params(gv_synth_params *p, uint64_t seed)
{
    gv_synth_default_params(p);
    p->seed = seed;
    p->n_frames = 8;
    p->width = 64;
    p->height = 36;
}

/* Same seed, 1 and 2 threads: the same bytes in every file; another seed: other images. */
static void test_files(const char *tmp)
{
    gv_synth_params p;
    tiny_params(&p, 3);
    char a[4200], b[4200], c[4200], fa[4300], fb[4300];
    snprintf(a, sizeof a, "%s/one_thread", tmp);
    snprintf(b, sizeof b, "%s/two_threads", tmp);
    snprintf(c, sizeof c, "%s/other_seed", tmp);
    omp_set_num_threads(1);
    CHECK(gv_synth_write(&p, a) == 0);
    omp_set_num_threads(2);
    CHECK(gv_synth_write(&p, b) == 0);
    const char *names[] = {"transforms.json", "points3D.ply", "synth.txt", "sparse/0/cameras.txt",
                           "sparse/0/images.txt", "sparse/0/points3D.txt"};
    int same = 0, total = 0;
    for (int i = 0; i < 6 + p.n_frames; i++) {
        char name[64];
        if (i < 6) snprintf(name, sizeof name, "%s", names[i]);
        else snprintf(name, sizeof name, "images/frame_%05d.png", i - 6);
        snprintf(fa, sizeof fa, "%s/%s", a, name);
        snprintf(fb, sizeof fb, "%s/%s", b, name);
        total++;
        same += gv_file_exists(fa) && files_equal(fa, fb);
    }
    printf("same seed, 1 and 2 threads: %d of %d files identical\n", same, total);
    CHECK(same == total);
    snprintf(fa, sizeof fa, "%s/images/frame_%05d.png", a, p.n_frames);
    CHECK(!gv_file_exists(fa));

    p.seed = 4;
    p.n_frames = 2; /* two frames are enough to see another room */
    CHECK(gv_synth_write(&p, c) == 0);
    double mean_diff = 0;
    for (int f = 0; f < p.n_frames; f++) {
        gv_image x, y;
        snprintf(fa, sizeof fa, "%s/images/frame_%05d.png", a, f);
        snprintf(fb, sizeof fb, "%s/images/frame_%05d.png", c, f);
        if (gv_image_read_rgb(fa, &x) || gv_image_read_rgb(fb, &y)) { CHECK(0); return; }
        double sum = 0;
        for (int i = 0; i < 64 * 36 * 3; i++) sum += abs((int)x.pixels[i] - (int)y.pixels[i]);
        mean_diff += sum / (64 * 36 * 3) / p.n_frames;
        gv_image_free(&x), gv_image_free(&y);
    }
    printf("seeds 3 and 4: mean absolute pixel difference %.1f levels\n", mean_diff);
    CHECK(mean_diff > 15);

    /* rewriting a synthesised scene (here smaller) replaces it and leaves nothing beside it */
    p.width = p.height = 16;
    CHECK(gv_synth_write(&p, c) == 0);
    snprintf(fa, sizeof fa, "%s/synth.txt", c);
    CHECK(gv_file_exists(fa));
    gv_image small;
    snprintf(fa, sizeof fa, "%s/images/frame_00001.png", c);
    CHECK(gv_image_read_rgb(fa, &small) == 0 && small.width == 16);
    gv_image_free(&small);
    char command[4400];
    snprintf(command, sizeof command, "test $(ls -a '%s' | grep -c -e partial -e '[.]old') -eq 0", tmp);
    CHECK(system(command) == 0);
}

static int cmp_double(const void *a, const void *b)
{
    double x = *(const double *)a, y = *(const double *)b;
    return (x > y) - (x < y);
}

/* Projects every point into every frame where it is in view and not hidden, and compares
 * its colour with the pixel there; with the pose turned by 6 degrees as a control. */
static double colour_error(const gv_scene *s, const gv_image *images, const gv_synth_world *w, double turn,
                           int *pairs)
{
    double *diffs = malloc((size_t)s->n_points * s->n_frames * sizeof *diffs);
    int n = 0;
    for (int f = 0; f < s->n_frames; f++) {
        gv_camera cam = s->cameras[f], seen = cam;
        double c = cos(turn), sn = sin(turn), *R = cam.R;
        for (int j = 0; j < 3; j++) { /* rows x and z turned about the camera's y axis */
            double x = R[j], z = R[6 + j];
            R[j] = c * x - sn * z;
            R[6 + j] = sn * x + c * z;
        }
        double center[3];
        gv_camera_center(&seen, center);
        for (int k = 0; k < 3; k++) { /* keep the true centre: t = -R C */
            cam.t[k] = -(R[3 * k] * center[0] + R[3 * k + 1] * center[1] + R[3 * k + 2] * center[2]);
        }
        for (int i = 0; i < s->n_points; i++) {
            const float *X = s->points + 3 * i;
            double xc[3];
            for (int k = 0; k < 3; k++) /* visibility from the true pose */
                xc[k] = seen.R[3 * k] * X[0] + seen.R[3 * k + 1] * X[1] + seen.R[3 * k + 2] * X[2] + seen.t[k];
            if (xc[2] < 0.05) continue;
            double u0 = seen.fx * xc[0] / xc[2] + seen.cx, v0 = seen.fy * xc[1] / xc[2] + seen.cy;
            if (u0 < 1 || v0 < 1 || u0 >= seen.width - 1 || v0 >= seen.height - 1) continue;
            sy_vec o = sy_v(center[0], center[1], center[2]), to = sy_sub(sy_v(X[0], X[1], X[2]), o);
            double dist = sy_length(to);
            sy_hit h;
            sy_trace(w, o, sy_scale(to, 1 / dist), 1e30, &h);
            if (fabs(h.t - dist) > 0.01 + 0.01 * dist) continue;
            for (int k = 0; k < 3; k++)
                xc[k] = cam.R[3 * k] * X[0] + cam.R[3 * k + 1] * X[1] + cam.R[3 * k + 2] * X[2] + cam.t[k];
            if (xc[2] < 0.05) continue;
            double u = cam.fx * xc[0] / xc[2] + cam.cx, v = cam.fy * xc[1] / xc[2] + cam.cy;
            if (u < 0 || v < 0 || u >= cam.width || v >= cam.height) continue;
            const uint8_t *px = images[f].pixels + 3 * ((size_t)(int)v * cam.width + (int)u);
            const uint8_t *col = s->colors + 3 * i;
            diffs[n++] = (abs(px[0] - col[0]) + abs(px[1] - col[1]) + abs(px[2] - col[2])) / 3.0;
        }
    }
    qsort(diffs, (size_t)n, sizeof *diffs, cmp_double);
    double median = n ? diffs[n / 2] : 1e9;
    free(diffs);
    *pairs = n;
    return median;
}

static void test_colour_agreement(const char *tmp)
{
    char dir[4200];
    snprintf(dir, sizeof dir, "%s/one_thread", tmp);
    gv_scene s;
    if (gv_scene_load(dir, NULL, &s)) { printf("%s\n", gv_last_error()); CHECK(0); return; }
    gv_synth_params p;
    tiny_params(&p, 3);
    gv_synth_world *w;
    CHECK(gv_synth_build(&p, &w) == 0);
    gv_image *images = calloc((size_t)s.n_frames, sizeof *images);
    int loaded = 1;
    for (int f = 0; f < s.n_frames; f++) loaded &= gv_scene_load_image(&s, f, &images[f]) == 0;
    CHECK(loaded);
    CHECK(s.n_frames == 8 && s.n_points > 100);
    int pairs, control_pairs;
    double good = colour_error(&s, images, w, 0, &pairs);
    double bad = colour_error(&s, images, w, 6 * M_PI / 180, &control_pairs);
    printf("points vs pixels: median difference %.2f levels over %d (point, frame) pairs of %d points; "
           "pose turned 6 degrees: %.2f over %d\n", good, pairs, s.n_points, bad, control_pairs);
    CHECK(pairs > 1.5 * s.n_points); /* a point is seen in its own frame and often others */
    CHECK(good <= 4.0);
    CHECK(bad >= 3 * good + 6);
    for (int f = 0; f < s.n_frames; f++) gv_image_free(&images[f]);
    free(images);
    gv_synth_free(w);
    gv_scene_free(&s);
}

/* The path at the default 160 frames (tiny images: the path does not depend on them):
 * inside the room, clear of furniture, near-constant steps of |(travel, 0.6 m x turn)| with
 * no jerks, and it both moves and turns; the cameras are proper rotations with the shared
 * scenes' intrinsics (fx = W x 28/36, principal point at the centre). */
#define PATH_FRAMES 160
static void test_path(uint64_t seed)
{
    gv_synth_params p;
    tiny_params(&p, seed);
    p.n_frames = PATH_FRAMES;
    p.width = 32;
    p.height = 18;
    gv_synth_world *w;
    CHECK(gv_synth_build(&p, &w) == 0);
    if (!w) return;
    static sy_vec c[PATH_FRAMES];
    static double effort[PATH_FRAMES];
    double min_clear = 1e9, max_jerk = 0, reach = 0, length = 0, turn = 0, max_step = 0, max_turn = 0;
    int inside = 1, in_object = 0, rotations = 1;
    for (int f = 0; f < PATH_FRAMES; f++) {
        gv_camera cam, prev;
        gv_synth_camera(w, f, &cam);
        double C[3];
        gv_camera_center(&cam, C);
        c[f] = sy_v(C[0], C[1], C[2]);
        inside &= C[0] > w->room_lo.x + 0.3 && C[0] < w->room_hi.x - 0.3 && C[1] > w->room_lo.y + 0.3 &&
                  C[1] < w->room_hi.y - 0.3 && C[2] > 1.2 && C[2] < 1.8;
        min_clear = fmin(min_clear, sy_furniture_clearance(w, c[f]));
        for (int i = 0; i < w->n_prims; i++) in_object += sy_prim_contains(&w->prims[i], c[f]);
        const double *R = cam.R;
        for (int a = 0; a < 3; a++)
            for (int b = 0; b < 3; b++) {
                double dot = R[3 * a] * R[3 * b] + R[3 * a + 1] * R[3 * b + 1] + R[3 * a + 2] * R[3 * b + 2];
                rotations &= fabs(dot - (a == b)) < 1e-9;
            }
        double det = R[0] * (R[4] * R[8] - R[5] * R[7]) - R[1] * (R[3] * R[8] - R[5] * R[6]) + R[2] * (R[3] * R[7] - R[4] * R[6]);
        rotations &= fabs(det - 1) < 1e-9;
        rotations &= fabs(cam.fx - 32 * 28.0 / 36) < 1e-9 && cam.fy == cam.fx && cam.cx == 16 && cam.cy == 9;
        if (f == 0) continue;
        gv_synth_camera(w, f - 1, &prev);
        double tr = 0;
        for (int k = 0; k < 9; k++) tr += cam.R[k] * prev.R[k];
        double angle = acos(sy_clamp(0.5 * (tr - 1), -1, 1)), step = sy_length(sy_sub(c[f], c[f - 1]));
        effort[f - 1] = hypot(step, 0.6 * angle);
        length += step;
        turn += angle;
        max_step = fmax(max_step, step);
        max_turn = fmax(max_turn, angle);
        if (f > 1) max_jerk = fmax(max_jerk, sy_length(sy_add(sy_sub(c[f], sy_scale(c[f - 1], 2)), c[f - 2])));
        for (int g = 0; g < f; g++) reach = fmax(reach, sy_length(sy_sub(c[f], c[g])));
    }
    double mean_effort = 0, max_effort = 0;
    for (int i = 0; i < PATH_FRAMES - 1; i++) {
        mean_effort += effort[i] / (PATH_FRAMES - 1);
        max_effort = fmax(max_effort, effort[i]);
    }
    double mean_step = length / (PATH_FRAMES - 1);
    printf("path (seed %d): %.2f m long (reach %.2f m), %.0f degrees of turn; largest step %.3f m, %.2f deg; "
           "largest effort step %.2f x the mean; largest second difference %.2f x the mean step; "
           "clearance %.2f m\n", (int)seed, length, reach, turn * 180 / M_PI, max_step, max_turn * 180 / M_PI,
           max_effort / mean_effort, max_jerk / mean_step, min_clear);
    CHECK(inside);
    CHECK(in_object == 0);
    CHECK(min_clear > 0.3);
    CHECK(rotations);
    CHECK(length > 2.0 && reach > 1.5);
    CHECK(turn > 60 * M_PI / 180);
    CHECK(max_effort < 1.3 * mean_effort);
    CHECK(max_step < 0.12 && max_turn < 8 * M_PI / 180);
    CHECK(max_jerk < 0.5 * mean_step);
    gv_synth_free(w);
}

/* Frames outside [0, n_frames) are refused, not read out of bounds. */
static void test_frame_range(void)
{
    gv_synth_params p;
    tiny_params(&p, 2);
    p.n_frames = 2;
    p.width = p.height = 16;
    gv_synth_world *w;
    if (gv_synth_build(&p, &w)) { CHECK(0); return; }
    gv_camera cam;
    gv_image img;
    CHECK(gv_synth_camera(w, 1, &cam) == 0 && cam.width == 16);
    CHECK_FAILS_WITH(gv_synth_camera(w, 2, &cam), "frame 2 is out of range");
    CHECK_FAILS_WITH(gv_synth_camera(w, -1, &cam), "frame -1 is out of range");
    CHECK_FAILS_WITH(gv_synth_render(w, 2, &img), "frame 2 is out of range");
    CHECK(gv_synth_render(w, 0, &img) == 0 && img.width == 16 && img.channels == 3);
    gv_image_free(&img);
    gv_synth_free(w);
}

static void test_bad_parameters(const char *tmp)
{
    gv_synth_params p;
    char dir[4200];
    snprintf(dir, sizeof dir, "%s/never", tmp);
    tiny_params(&p, 1);
    p.n_frames = 1;
    CHECK_FAILS_WITH(gv_synth_write(&p, dir), "--frames 1");
    tiny_params(&p, 1);
    p.width = 8;
    CHECK_FAILS_WITH(gv_synth_write(&p, dir), "--size 8x36");
    tiny_params(&p, 1);
    p.width = 4097;
    CHECK_FAILS_WITH(gv_synth_check_params(&p), "out of range");
    tiny_params(&p, 1);
    p.width = 600;
    p.height = 16;
    CHECK_FAILS_WITH(gv_synth_check_params(&p), "aspect ratio");
    tiny_params(&p, 1);
    p.samples = 9;
    CHECK_FAILS_WITH(gv_synth_check_params(&p), "--samples 9");
    CHECK(!gv_dir_exists(dir));
    /* a folder holding something else is not replaced, and left as it was */
    snprintf(dir, sizeof dir, "%s/foreign", tmp);
    gv_mkdirs(dir);
    char keep[4300];
    snprintf(keep, sizeof keep, "%s/notes.txt", dir);
    FILE *f = fopen(keep, "w");
    if (f) fputs("mine\n", f), fclose(f);
    tiny_params(&p, 1);
    CHECK_FAILS_WITH(gv_synth_write(&p, dir), "not a synthesised scene");
    CHECK(gv_file_exists(keep));
    snprintf(keep, sizeof keep, "%s/images", dir);
    CHECK(!gv_dir_exists(keep));
    CHECK_FAILS_WITH(gv_synth_write(&p, ""), "bad output folder");
}

/* Mean absolute difference between horizontal neighbours: the image's fine detail. */
static double neighbour_difference(const gv_image *im)
{
    double sum = 0;
    for (int y = 0; y < im->height; y++)
        for (int x = 0; x + 1 < im->width; x++)
            for (int c = 0; c < 3; c++) {
                const uint8_t *px = im->pixels + ((size_t)y * im->width + x) * 3 + c;
                sum += abs((int)px[3] - (int)px[0]);
            }
    return sum / ((double)im->height * (im->width - 1) * 3);
}

/* --texture-detail: the same room and cameras, more fine detail in every frame; 0 is the
 * default room. */
static void test_texture_detail(void)
{
    gv_synth_params p;
    tiny_params(&p, 1);
    p.width = 128, p.height = 72, p.n_frames = 4;
    gv_synth_world *plain = NULL, *detailed = NULL;
    CHECK(gv_synth_build(&p, &plain) == 0);
    p.texture_detail = 1;
    CHECK(gv_synth_build(&p, &detailed) == 0);
    if (!plain || !detailed) return;
    for (int f = 0; f < p.n_frames; f += 3) {
        gv_camera a, b;
        gv_image x, y;
        CHECK(gv_synth_camera(plain, f, &a) == 0 && gv_synth_camera(detailed, f, &b) == 0);
        CHECK(!memcmp(&a, &b, sizeof a));
        if (gv_synth_render(plain, f, &x) || gv_synth_render(detailed, f, &y)) { CHECK(0); break; }
        double dx = neighbour_difference(&x), dy = neighbour_difference(&y);
        printf("frame %d: neighbour difference %.2f levels plain, %.2f with texture detail 1\n", f, dx, dy);
        CHECK(dy > 1.1 * dx);
        gv_image_free(&x), gv_image_free(&y);
    }
    gv_synth_free(plain), gv_synth_free(detailed);
    p.texture_detail = 1.5;
    CHECK_FAILS_WITH(gv_synth_check_params(&p), "--texture-detail 1.5");
    p.texture_detail = -0.1;
    CHECK_FAILS_WITH(gv_synth_check_params(&p), "--texture-detail -0.1");
}

int main(void)
{
    const char *tmp = check_tmp_dir();
    gv_log_set_level(GV_LOG_QUIET);
    test_intersections();
    test_face_parameters();
    test_patterns();
    test_bvh();
    test_bad_parameters(tmp);
    test_files(tmp);
    test_colour_agreement(tmp);
    for (uint64_t seed = 11; seed <= 13; seed++) test_path(seed);
    test_frame_range();
    test_texture_detail();
    return check_summary();
}
