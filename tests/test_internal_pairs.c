/* Scene-internal pairs (src/data/internal_pairs.c, internal_build.c): which frames make each
 * clip, which subset renders it, which frames are masked and where the ground truth is; the
 * clip format's offset and target mask; resuming; bad inputs. A cheap stand-in simulator
 * paints each render from the frame it shows and the subset it was trained on, and the
 * held-out images are deleted before building, so reading one would fail the build. */
#include <math.h>

#include "check.h"
#include "gaussvid/core/core.h"
#include "gaussvid/data/dataset.h"
#include "gaussvid/io/image.h"
#include "gaussvid/data/internal_pairs.h"
#include "gaussvid/io/safetensors.h"
#include "gaussvid/scene/scene.h"
#include "gaussvid/splat/splat_train.h"

#define FRAMES 20
#define W 16
#define H 16
#define N 3 /* training views 0, 3, ..., 18: 7 of them, 5 interior */

static int truth_value(int frame, int x, int y, int c) { return (x * 7 + y * 13 + frame * 5 + c * 50) & 255; }

/* A scene folder of FRAMES cameras sliding along x, gradient images. */
static void make_scene(const char *dir, int frames)
{
    gv_scene s;
    memset(&s, 0, sizeof s);
    snprintf(s.dir, sizeof s.dir, "%s", dir);
    s.n_frames = frames;
    s.cameras = calloc((size_t)frames, sizeof *s.cameras);
    float points[6] = {0, 0, 3, 0.5f, 0.2f, 4};
    uint8_t colors[6] = {200, 100, 50, 10, 20, 30};
    s.n_points = 2, s.points = points, s.colors = colors;
    char path[4400];
    snprintf(path, sizeof path, "%s/images", dir);
    gv_mkdirs(path);
    for (int i = 0; i < frames; i++) {
        gv_camera *c = &s.cameras[i];
        const double R[9] = {1, 0, 0, 0, 1, 0, 0, 0, 1};
        memcpy(c->R, R, sizeof R);
        c->t[0] = -0.1 * i, c->t[2] = 0.2;
        c->width = W, c->height = H, c->fx = c->fy = 20, c->cx = W / 2.0, c->cy = H / 2.0;
        snprintf(c->name, sizeof c->name, "frame_%05d.png", i);
        gv_image img;
        gv_image_alloc(&img, W, H, 3);
        for (int y = 0; y < H; y++)
            for (int x = 0; x < W; x++)
                for (int k = 0; k < 3; k++) img.pixels[(y * W + x) * 3 + k] = (uint8_t)truth_value(i, x, y, k);
        snprintf(path, sizeof path, "%s/images/%s", dir, c->name);
        CHECK(gv_image_write_png(path, &img) == 0);
        gv_image_free(&img);
    }
    CHECK(gv_scene_write(dir, &s) == 0);
    free(s.cameras);
}

/* make_scene, loaded. */
static void new_scene(const char *dir, gv_scene *scene)
{
    make_scene(dir, FRAMES);
    CHECK(gv_scene_load(dir, NULL, scene) == 0);
}

/* ---- the stand-in simulator ------------------------------------------------------------- */
enum { MAX_TRAINS = 8 };
typedef struct {
    int trains;
    int trained_on[MAX_TRAINS][FRAMES]; /* per training: 1 for the scene frames it trained on */
    uint64_t seeds[MAX_TRAINS];
    int densify;               /* the density control of the last training */
} fake_state;

/* The scene frame a camera shows, from its image name. */
static int frame_of(const gv_camera *c) { return atoi(c->name + strlen("frame_")); }

/* The model is the first training view (a multiple of N) its list lacks: it tells the subsets apart. */
static int fake_train(void *ctx, const gv_scene *scene, const int *views, int n_views, int iters, int densify,
                      uint64_t seed, void **model)
{
    fake_state *st = ctx;
    st->densify = densify;
    int *m = malloc(sizeof *m);
    *m = -1;
    for (int i = 0, want = 0; i <= n_views && *m < 0; i++, want += N)
        if (i == n_views || views[i] != want) *m = want;
    if (st->trains < MAX_TRAINS) {
        st->seeds[st->trains] = seed;
        for (int i = 0; i < n_views; i++) st->trained_on[st->trains][frame_of(&scene->cameras[views[i]])] = 1;
    }
    st->trains++;
    *model = m;
    return 0;
}

static int render_value(int frame, int first, int x, int y, int c) { return (x * 3 + y * 5 + frame * 11 + first * 29 + c * 60 + 7) & 255; }

static int fake_render(void *ctx, void *model, const gv_scene *scene, int frame, gv_image *out)
{
    int shown = frame_of(&scene->cameras[frame]), first = *(int *)model;
    if (gv_image_alloc(out, W, H, 3)) return -1;
    for (int y = 0; y < H; y++)
        for (int x = 0; x < W; x++)
            for (int k = 0; k < 3; k++) out->pixels[(y * W + x) * 3 + k] = (uint8_t)render_value(shown, first, x, y, k);
    return 0;
}

static void fake_free(void *ctx, void *model) { free(model); }

/* Depth 1 at every pixel: a wall just in front of every camera. */
static int fake_depth(void *ctx, void *model, const gv_scene *scene, int frame, float *depth)
{
    (void)ctx, (void)model, (void)scene, (void)frame;
    for (int p = 0; p < W * H; p++) depth[p] = 1.0f;
    return 0;
}

static fake_state state;
static const gv_artifact_simulator fake = {"fake", fake_train, fake_render, fake_free, &state, NULL}; /* no depth: no coverage plane */
static const gv_artifact_simulator fake_with_depth = {"fake", fake_train, fake_render, fake_free, &state, fake_depth};

/* ---- the plan ---------------------------------------------------------------------------- */
static void test_plan(void)
{
    gv_internal_clip c[FRAMES];
    int count = 0;
    CHECK(gv_internal_views(20, 3) == 7 && gv_internal_views(19, 3) == 7 && gv_internal_views(18, 3) == 6);
    CHECK(gv_internal_plan(20, 3, 2, c, &count) == 0 && count == 5);
    /* the uniform positions of a 2n = 6 clip (round half to even), from the subset's first view */
    const int want[5][5] = {{0, 2, 3, 4, 6}, {3, 5, 6, 7, 9}, {6, 8, 9, 10, 12}, {9, 11, 12, 13, 15}, {12, 14, 15, 16, 18}};
    for (int i = 0; i < 5; i++) {
        CHECK(c[i].view == i + 1 && c[i].subset == i % 2);
        CHECK(!memcmp(c[i].frames, want[i], sizeof want[i]));
        CHECK(c[i].frames[2] == 3 * (i + 1));  /* the left-out training view, in the middle */
        CHECK(c[i].frames[1] % 3 && c[i].frames[3] % 3); /* the others are held out at n */
    }
    CHECK(gv_internal_plan(9, 2, 2, c, &count) == 0 && count == 3);
    CHECK(!memcmp(c[1].frames, ((int[]){2, 3, 4, 5, 6}), sizeof c[1].frames) && c[1].subset == 1);
    CHECK(gv_internal_plan(160, 26, 2, c, &count) == 0 && count == 5); /* the shared scenes at n = 26: 7 views */
    CHECK(c[0].frames[2] == 26 && c[0].frames[1] == 13 && c[0].frames[3] == 39);
    CHECK_FAILS_WITH(gv_internal_plan(16, 4, 2, c, &count), "need at least 5 (at least 17 frames)");
    CHECK_FAILS_WITH(gv_internal_plan(20, 3, 1, c, &count), "need at least 2");
    /* more subsets: the same clips, rendered by subset (k - 1) mod K */
    gv_internal_clip c3[FRAMES];
    CHECK(gv_internal_plan(20, 3, 3, c3, &count) == 0 && count == 5);
    for (int i = 0; i < 5; i++) CHECK(c3[i].subset == i % 3 && !memcmp(c3[i].frames, want[i], sizeof want[i]));
    CHECK(gv_internal_plan(20, 3, 99, c3, &count) == 0 && count == 5);
    for (int i = 0; i < 5; i++) CHECK(c3[i].subset == i);

    /* which views each subset holds (7 views 0..6 at n = 3): every view but one residue class */
    int v[FRAMES], nv;
    CHECK(gv_internal_subset_views(20, 3, 2, 0, v, &nv) == 0 && nv == 4 && !memcmp(v, ((int[]){0, 6, 12, 18}), 4 * sizeof(int)));
    CHECK(gv_internal_subset_views(20, 3, 2, 1, v, &nv) == 0 && nv == 3 && !memcmp(v, ((int[]){3, 9, 15}), 3 * sizeof(int)));
    CHECK(gv_internal_subset_views(20, 3, 3, 0, v, &nv) == 0 && nv == 5 && !memcmp(v, ((int[]){0, 6, 9, 15, 18}), 5 * sizeof(int)));
    CHECK(gv_internal_subset_views(20, 3, 3, 1, v, &nv) == 0 && nv == 5 && !memcmp(v, ((int[]){0, 3, 9, 12, 18}), 5 * sizeof(int)));
    CHECK(gv_internal_subset_views(20, 3, 3, 2, v, &nv) == 0 && nv == 4 && !memcmp(v, ((int[]){3, 6, 12, 15}), 4 * sizeof(int)));
    /* K >= T: view 3 of 7 alone left out */
    CHECK(gv_internal_subset_views(20, 3, 7, 2, v, &nv) == 0 && nv == 6 && !memcmp(v, ((int[]){0, 3, 6, 12, 15, 18}), 6 * sizeof(int)));
    for (int k = 1; k <= 5; k++) /* every clip's anchors are in the subset that renders it, its middle is not */
        for (int K = 2; K <= 9; K++) {
            CHECK(gv_internal_plan(20, 3, K, c3, &count) == 0);
            CHECK(gv_internal_subset_views(20, 3, K, c3[k - 1].subset, v, &nv) == 0);
            int has[3] = {0, 0, 0};
            for (int i = 0; i < nv; i++)
                for (int f = 0; f < 3; f++) has[f] |= v[i] == c3[k - 1].frames[2 * f];
            CHECK(has[0] && !has[1] && has[2]);
        }
    CHECK_FAILS_WITH(gv_internal_subset_views(20, 3, 3, 3, v, &nv), "subset 3 of 3");
    CHECK_FAILS_WITH(gv_internal_check(20, 5), "4 training views at n = 5");
    CHECK_FAILS_WITH(gv_internal_check(20, 1), "interval 1: a clip takes 2 <= n <= 100000");
}

/* ---- the clip format's offset and mask ---------------------------------------------------- */
static void test_clip_format(const char *base)
{
    gv_clip_info info;
    memset(&info, 0, sizeof info);
    snprintf(info.id.scene, sizeof info.id.scene, "s");
    snprintf(info.id.split, sizeof info.id.split, "train");
    info.id.interval = 6, info.anchor_gap = 1, info.iters = 5, info.width = 4, info.height = 2, info.offset = 3;
    const int frames[5] = {3, 5, 6, 7, 9};
    memcpy(info.frames, frames, sizeof frames);
    info.no_target[1] = info.no_target[3] = 1;
    CHECK(gv_clip_check_info(&info, "x") == 0);
    gv_clip clip;
    CHECK(gv_clip_alloc(&clip, &info) == 0);
    for (int f = 0; f < 5; f++) {
        const gv_camera cam = {4, 2, 5, 5, 2, 1, {1, 0, 0, 0, 1, 0, 0, 0, 1}, {0, 0, 0}, ""};
        gv_clip_set_camera(&clip, f, &cam);
        for (int i = 0; i < 24; i++) gv_clip_frame(clip.inputs, &info, f)[i] = (uint8_t)(f * 40 + i);
        for (int i = 0; i < 24; i++) gv_clip_frame(clip.targets, &info, f)[i] = (uint8_t)(f * 40 + i + (f == 2));
    }
    char path[4400];
    snprintf(path, sizeof path, "%s/masked.safetensors", base);
    CHECK(gv_clip_write(path, &clip) == 0);
    gv_clip back;
    CHECK(gv_clip_read(path, &back) == 0);
    CHECK(back.info.offset == 3 && back.info.no_target[1] == 1 && back.info.no_target[2] == 0 && back.info.no_target[3] == 1);
    gv_clip_free(&back);
    gv_st_file f;
    CHECK(gv_st_open(&f, path) == 0);
    CHECK(gv_st_metadata(&f, "target_mask") && !strcmp(gv_st_metadata(&f, "target_mask"), "[1,0,1,0,1]"));
    CHECK(gv_st_metadata(&f, "offset") && !strcmp(gv_st_metadata(&f, "offset"), "3"));
    gv_st_close(&f);
    /* a frame without ground truth keeps its input as target; the reader checks it */
    gv_clip_frame(clip.targets, &info, 1)[0] ^= 1;
    CHECK(gv_clip_write(path, &clip) == 0);
    CHECK_FAILS_WITH(gv_clip_read(path, &back), "has no ground truth (target_mask 0) but its targets frame differs");
    gv_clip_frame(clip.targets, &info, 1)[0] ^= 1;
    /* the clips of `dataset build` keep their metadata: no offset, no mask */
    clip.info.offset = 0, clip.info.no_target[1] = clip.info.no_target[3] = 0;
    const int plain[5] = {0, 2, 3, 4, 6};
    memcpy(clip.info.frames, plain, sizeof plain);
    snprintf(path, sizeof path, "%s/plain.safetensors", base);
    CHECK(gv_clip_write(path, &clip) == 0);
    CHECK(gv_st_open(&f, path) == 0);
    CHECK(!gv_st_metadata(&f, "target_mask") && !gv_st_metadata(&f, "offset"));
    gv_st_close(&f);
    gv_clip_free(&clip);
    /* the rules */
    info.no_target[0] = 1;
    CHECK_FAILS_WITH(gv_clip_check_info(&info, "x"), "frame 0 must be 1 (an anchor)");
    info.no_target[0] = 0, info.no_target[2] = 1;
    CHECK_FAILS_WITH(gv_clip_check_info(&info, "x"), "no intermediate frame has ground truth");
    info.no_target[2] = 0, info.offset = 0;
    CHECK_FAILS_WITH(gv_clip_check_info(&info, "x"), "are not training views");
    info.offset = 6;
    CHECK_FAILS_WITH(gv_clip_check_info(&info, "x"), "offset 6: expected 0..n - 1");
    info.offset = 3, info.anchor_gap = 2;
    const int wide[5] = {3, 5, 9, 11, 15};
    memcpy(info.frames, wide, sizeof wide);
    CHECK_FAILS_WITH(gv_clip_check_info(&info, "x"), "intermediate frame 9 is a training view (n = 6, offset 3)");
}

/* ---- building ------------------------------------------------------------------------------ */
static int frame_equals_truth(const uint8_t *pixels, int frame)
{
    for (int y = 0; y < H; y++)
        for (int x = 0; x < W; x++)
            for (int k = 0; k < 3; k++)
                if (pixels[(y * W + x) * 3 + k] != truth_value(frame, x, y, k)) return 0;
    return 1;
}

static int frame_equals_render(const uint8_t *pixels, int frame, int first)
{
    for (int y = 0; y < H; y++)
        for (int x = 0; x < W; x++)
            for (int k = 0; k < 3; k++)
                if (pixels[(y * W + x) * 3 + k] != render_value(frame, first, x, y, k)) return 0;
    return 1;
}

static void check_clips(const char *out, int subsets)
{
    gv_manifest m;
    int found = 0;
    CHECK(gv_manifest_read(out, &m, &found) == 0 && found);
    CHECK(m.n_runs == 1 && m.runs[0].id.interval == 2 * N && !strcmp(m.runs[0].id.scene, "room") && !strcmp(m.runs[0].id.split, "train"));
    CHECK(m.n_clips == 5 && m.params.iters == 7 && m.params.seed == 4 && m.params.clips_per_run == 5);
    CHECK(m.params.densify == GV_DENSIFY_MCMC); /* recorded as asked (not the default) */
    gv_internal_clip plan[FRAMES];
    int count;
    CHECK(gv_internal_plan(FRAMES, N, subsets, plan, &count) == 0 && count == 5);
    CHECK(m.params.subsets == (subsets == 2 ? 0 : subsets)); /* recorded when not 2 */
    for (int i = 0; i < m.n_clips && i < count; i++) {
        char path[4400], want[64];
        snprintf(want, sizeof want, "clips/room_n06_%03d.safetensors", i);
        CHECK(!strcmp(m.clips[i].file, want) && !memcmp(m.clips[i].frames, plan[i].frames, sizeof plan[i].frames));
        snprintf(path, sizeof path, "%s/%s", out, m.clips[i].file);
        gv_clip c;
        CHECK(gv_clip_read(path, &c) == 0);
        const gv_clip_info *info = &c.info;
        int view = i + 1, first = (view % subsets) * N; /* the first view that view k's subset lacks */
        CHECK(info->id.interval == 2 * N && info->offset == i % 2 * N && info->iters == 7 && !strcmp(info->id.split, "train"));
        CHECK(info->subsets == (subsets == 2 ? 0 : subsets));
        CHECK(!memcmp(info->frames, plan[i].frames, sizeof info->frames));
        /* masked: the two held-out frames; the left-out view in the middle has ground truth */
        CHECK(!info->no_target[0] && info->no_target[1] && !info->no_target[2] && info->no_target[3] && !info->no_target[4]);
        for (int f = 0; f < 5; f++) {
            int frame = info->frames[f];
            const uint8_t *in = gv_clip_frame(c.inputs, info, f), *tg = gv_clip_frame(c.targets, info, f);
            if (f == 0 || f == 4) CHECK(frame_equals_truth(in, frame) && frame_equals_truth(tg, frame));
            else CHECK(frame_equals_render(in, frame, first)); /* rendered by the subset without it */
            if (f == 2) CHECK(frame_equals_truth(tg, frame));
            if (f == 1 || f == 3) CHECK(!memcmp(in, tg, (size_t)W * H * 3));
            CHECK_NEAR(c.poses[f][3], -0.1 * frame, 1e-6);
        }
        gv_clip_free(&c);
    }
    gv_manifest_free(&m);
    /* the record: the left-out views and their renders' PSNR */
    char path[4400];
    snprintf(path, sizeof path, "%s/runs/room_n06.json", out);
    gv_run_record r;
    CHECK(gv_run_record_read(path, &r) == 0);
    CHECK(r.id.interval == 6 && r.n_held_out == 5 && r.n_train == 7 && r.n_clips == 5);
    for (int i = 0; i < r.n_held_out; i++) CHECK(r.held_out[i] == 3 * (i + 1) && r.psnr[i] > 0 && r.psnr[i] < 40);
    gv_run_record_free(&r);
}

static void test_build(const char *base)
{
    char scene_dir[4400], out[4400], path[4400];
    snprintf(scene_dir, sizeof scene_dir, "%s/room", base);
    gv_scene scene;
    new_scene(scene_dir, &scene);
    for (int f = 0; f < FRAMES; f++) /* the held-out frames: never to be read */
        if (f % N) {
            snprintf(path, sizeof path, "%s/images/frame_%05d.png", scene_dir, f);
            CHECK(remove(path) == 0);
        }
    snprintf(out, sizeof out, "%s/pairs", base);
    gv_internal_options o = {.interval = N, .iters = 7, .densify = GV_DENSIFY_MCMC, .seed = 4, .simulator = &fake,
                             .out_dir = out};
    gv_internal_result r;
    memset(&state, 0, sizeof state);
    CHECK(gv_internal_build(&scene, &o, &r) == 0);
    CHECK(r.clips == 5 && r.subsets_trained == 2 && state.trains == 2);
    CHECK(state.densify == GV_DENSIFY_MCMC); /* passed through to the simulator */
    CHECK(state.seeds[1] == (state.seeds[0] ^ 0x9E3779B97F4A7C15ull));
    for (int f = 0; f < FRAMES; f++) { /* every other training view, once per offset */
        CHECK(state.trained_on[0][f] == (f % (2 * N) == 0));
        CHECK(state.trained_on[1][f] == (f % (2 * N) == N));
    }
    check_clips(out, 2);

    /* built: nothing trained again */
    memset(&state, 0, sizeof state);
    CHECK(gv_internal_build(&scene, &o, &r) == 0 && r.subsets_trained == 0 && state.trains == 0 && r.clips == 5);
    /* interrupted before the manifest, with a clip of subset 2 missing: only subset 2 trains */
    char clip1[4400], saved[4400];
    snprintf(clip1, sizeof clip1, "%s/clips/room_n06_001.safetensors", out);
    snprintf(saved, sizeof saved, "%s/saved.safetensors", base);
    CHECK(rename(clip1, saved) == 0);
    snprintf(path, sizeof path, "%s/manifest.json", out);
    CHECK(remove(path) == 0);
    memset(&state, 0, sizeof state);
    CHECK(gv_internal_build(&scene, &o, &r) == 0 && r.subsets_trained == 1 && state.trains == 1);
    CHECK(state.trained_on[0][N] && state.trained_on[0][3 * N] && !state.trained_on[0][0]);
    char *a, *b;
    size_t na, nb;
    CHECK(gv_read_file(clip1, &a, &na) == 0 && gv_read_file(saved, &b, &nb) == 0);
    CHECK(na == nb && !memcmp(a, b, na)); /* the same bytes again */
    free(a), free(b);
    check_clips(out, 2);

    /* one folder, one build */
    gv_internal_options other = o;
    other.iters = 8;
    CHECK_FAILS_WITH(gv_internal_build(&scene, &other, &r), "holds other clips than the internal pairs of room");
    other = o;
    other.densify = GV_DENSIFY_REFERENCE;
    CHECK_FAILS_WITH(gv_internal_build(&scene, &other, &r), "density control reference");
    other = o;
    other.interval = 5;
    char other_out[4400];
    snprintf(other_out, sizeof other_out, "%s/pairs5", base);
    other.out_dir = other_out;
    CHECK_FAILS_WITH(gv_internal_build(&scene, &other, &r), "4 training views at n = 5");

    /* the coverage mask needs every clip's plane: not from a simulator without depth; a folder
     * built before the plane is rebuilt, then taken as it is; without the mask both are taken */
    other = o;
    other.coverage = 1;
    CHECK_FAILS_WITH(gv_internal_build(&scene, &other, &r), "renders no depth");
    other.simulator = &fake_with_depth;
    memset(&state, 0, sizeof state);
    CHECK(gv_internal_build(&scene, &other, &r) == 0 && r.subsets_trained == 2 && r.clips == 5);
    gv_clip_info info;
    CHECK(gv_clip_read_info(clip1, &info) == 0 && info.has_coverage);
    CHECK(gv_internal_build(&scene, &other, &r) == 0 && r.subsets_trained == 0);
    CHECK(gv_internal_build(&scene, &o, &r) == 0 && r.subsets_trained == 0);
    gv_scene_free(&scene);
}

/* Three subsets: each leaves out every third view; the folder records K and is refused to
 * another K; clips of another K are not taken over when a build resumes. */
static void test_build_subsets(const char *base)
{
    char scene_dir[4400], out[4400], path[4400];
    snprintf(scene_dir, sizeof scene_dir, "%s/k3/room", base);
    gv_scene scene;
    new_scene(scene_dir, &scene);
    snprintf(out, sizeof out, "%s/k3/pairs", base);
    gv_internal_options o = {.interval = N, .iters = 7, .subsets = 3, .densify = GV_DENSIFY_MCMC, .seed = 4,
                             .simulator = &fake, .out_dir = out};
    gv_internal_result r;
    memset(&state, 0, sizeof state);
    CHECK(gv_internal_build(&scene, &o, &r) == 0 && r.clips == 5 && r.subsets_trained == 3 && state.trains == 3);
    for (int j = 0; j < 3; j++) {
        for (int v = 0; v < 7; v++) CHECK(state.trained_on[j][v * N] == (v % 3 != (j + 1) % 3));
        CHECK(state.seeds[j] == (state.seeds[0] ^ ((uint64_t)j * 0x9E3779B97F4A7C15ull)));
    }
    check_clips(out, 3);
    gv_internal_options two = o;
    two.subsets = 2;
    CHECK_FAILS_WITH(gv_internal_build(&scene, &two, &r), "internal pairs of room at n = 3 with 7 iterations, 2 subsets");
    /* an interrupted K = 3 build (no manifest) resumed with K = 2: every clip is rebuilt */
    snprintf(path, sizeof path, "%s/manifest.json", out);
    CHECK(remove(path) == 0);
    memset(&state, 0, sizeof state);
    CHECK(gv_internal_build(&scene, &two, &r) == 0 && r.subsets_trained == 2);
    check_clips(out, 2);
    /* K beyond the views: one run per interior view */
    snprintf(out, sizeof out, "%s/k3/loo", base);
    o.subsets = 99;
    memset(&state, 0, sizeof state);
    CHECK(gv_internal_build(&scene, &o, &r) == 0 && r.subsets_trained == 5 && state.trains == 5);
    for (int j = 0; j < 5; j++)
        for (int v = 0; v < 7; v++) CHECK(state.trained_on[j][v * N] == (v != j + 1));
    check_clips(out, 99);
    gv_scene_free(&scene);
}

/* The do-no-harm clips: the same frames and masks as the pairs, all rendered by one model
 * trained on every training view at n. */
static void test_build_harm(const char *base)
{
    char scene_dir[4400], out[4400];
    snprintf(scene_dir, sizeof scene_dir, "%s/full/room", base);
    gv_scene scene;
    new_scene(scene_dir, &scene);
    snprintf(out, sizeof out, "%s/harm", base);
    gv_internal_options o = {.interval = N, .iters = 7, .densify = GV_DENSIFY_MCMC, .seed = 4, .simulator = &fake,
                             .out_dir = out, .full_model = 1};
    gv_internal_result r;
    memset(&state, 0, sizeof state);
    CHECK(gv_internal_build(&scene, &o, &r) == 0);
    CHECK(r.clips == 5 && r.subsets_trained == 1 && state.trains == 1);
    for (int f = 0; f < FRAMES; f++) CHECK(state.trained_on[0][f] == (f % N == 0)); /* every training view */
    gv_manifest m;
    int found = 0;
    CHECK(gv_manifest_read(out, &m, &found) == 0 && found);
    CHECK(m.n_runs == 1 && m.runs[0].id.interval == 2 * N && m.n_clips == 5); /* the pairs' metadata */
    gv_internal_clip plan[FRAMES];
    int count;
    CHECK(gv_internal_plan(FRAMES, N, 2, plan, &count) == 0 && count == 5);
    for (int i = 0; i < m.n_clips && i < count; i++) {
        char path[4400], want[64];
        snprintf(want, sizeof want, "clips/room_n06_%03d.safetensors", i);
        CHECK(!strcmp(m.clips[i].file, want));
        snprintf(path, sizeof path, "%s/%s", out, m.clips[i].file);
        gv_clip c;
        CHECK(gv_clip_read(path, &c) == 0);
        const gv_clip_info *info = &c.info;
        CHECK(info->id.interval == 2 * N && info->offset == i % 2 * N);
        CHECK(!memcmp(info->frames, plan[i].frames, sizeof info->frames));
        CHECK(!info->no_target[0] && info->no_target[1] && !info->no_target[2] && info->no_target[3] && !info->no_target[4]);
        for (int f = 1; f < 4; f++) /* rendered by the full model (it lacks no view: the fake calls it 7 N) */
            CHECK(frame_equals_render(gv_clip_frame(c.inputs, info, f), info->frames[f], 7 * N));
        CHECK(frame_equals_truth(gv_clip_frame(c.targets, info, 2), info->frames[2]));
        gv_clip_free(&c);
    }
    gv_manifest_free(&m);
    memset(&state, 0, sizeof state); /* built: nothing trained again */
    CHECK(gv_internal_build(&scene, &o, &r) == 0 && r.subsets_trained == 0 && state.trains == 0);
    gv_scene_free(&scene);
}

int main(void)
{
    const char *base = check_tmp_dir();
    gv_log_set_level(GV_LOG_QUIET);
    test_plan();
    test_clip_format(base);
    test_build(base);
    test_build_harm(base);
    test_build_subsets(base);
    return check_summary();
}
