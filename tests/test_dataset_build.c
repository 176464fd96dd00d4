/* `dataset build` (src/data/build.c): runs, clips, manifest, resuming after simulated
 * interruptions, determinism, bad inputs, stats; with a cheap stand-in for the 3DGS
 * simulator on small hand-made scenes, then once end to end with sparse 3DGS on a tiny
 * synthesised scene. */
#include <math.h>
#include <omp.h>
#include <signal.h>
#include <sys/wait.h>

#include "check.h"
#include "gaussvid/core/core.h"
#include "gaussvid/data/dataset.h"
#include "gaussvid/splat/splat_train.h"
#include "gaussvid/io/image.h"
#include "gaussvid/scene/scene.h"
#include "gaussvid/synth/synth.h"

#define FRAMES 20
#define W 24
#define H 16

static int pixel_value(int frame, int x, int y, int c, int seed)
{
    return (x * 7 + y * 13 + frame * 5 + c * 50 + seed * 31) & 255;
}

/* A scene folder: FRAMES cameras sliding along x with a slow turn, gradient images. */
static void make_scene(const char *dir, int seed)
{
    gv_scene s;
    memset(&s, 0, sizeof s);
    snprintf(s.dir, sizeof s.dir, "%s", dir);
    s.n_frames = FRAMES;
    s.cameras = calloc(FRAMES, sizeof *s.cameras);
    float points[6] = {0, 0, 3, 0.5f, 0.2f, 4};
    uint8_t colors[6] = {200, 100, 50, 10, 20, 30};
    s.n_points = 2, s.points = points, s.colors = colors;
    char path[4400];
    snprintf(path, sizeof path, "%s/images", dir);
    gv_mkdirs(path);
    for (int i = 0; i < FRAMES; i++) {
        gv_camera *c = &s.cameras[i];
        double a = 0.01 * i;
        const double R[9] = {cos(a), 0, sin(a), 0, 1, 0, -sin(a), 0, cos(a)};
        memcpy(c->R, R, sizeof R);
        c->t[0] = -0.1 * i, c->t[1] = 0.05, c->t[2] = 0.2;
        c->width = W, c->height = H, c->fx = c->fy = 20, c->cx = W / 2.0, c->cy = H / 2.0;
        snprintf(c->name, sizeof c->name, "frame_%05d.png", i);
        gv_image img;
        gv_image_alloc(&img, W, H, 3);
        for (int y = 0; y < H; y++)
            for (int x = 0; x < W; x++)
                for (int k = 0; k < 3; k++) img.pixels[(y * W + x) * 3 + k] = (uint8_t)pixel_value(i, x, y, k, seed);
        snprintf(path, sizeof path, "%s/images/%s", dir, c->name);
        CHECK(gv_image_write_png(path, &img) == 0);
        gv_image_free(&img);
    }
    CHECK(gv_scene_write(dir, &s) == 0);
    free(s.cameras);
}

/* ---- a stand-in simulator: the ground truth pulled towards grey by n / 40 ------------ */

typedef struct { int trains, renders, fail_render_at; } fake_state;

static int fake_train(void *ctx, const gv_scene *scene, const int *views, int n_views, int iters, int densify,
                      uint64_t seed, void **model)
{
    fake_state *st = ctx;
    st->trains++;
    int n = views[1] - views[0];
    for (int i = 0; i < n_views; i++) /* the training views, and only those: 0, n, 2n, ... */
        if (views[i] != i * n) return gv_fail("fake: view %d of the list is frame %d, not %d", i, views[i], i * n);
    if (n_views != (scene->n_frames - 1) / n + 1) return gv_fail("fake: %d training views at n = %d", n_views, n);
    int *m = malloc(sizeof *m);
    *m = n;
    *model = m;
    return 0;
}

static uint8_t corrupt(int v, int n)
{
    double a = n / 40.0;
    return (uint8_t)floor(v * (1 - a) + 128 * a + 0.5);
}

static int fake_render(void *ctx, void *model, const gv_scene *scene, int frame, gv_image *out)
{
    fake_state *st = ctx;
    if (++st->renders == st->fail_render_at) return gv_fail("fake renderer: failed on purpose");
    if (gv_scene_load_image(scene, frame, out) != 0) return -1;
    for (int i = 0; i < out->width * out->height * 3; i++) out->pixels[i] = corrupt(out->pixels[i], *(int *)model);
    return 0;
}

static void fake_free(void *ctx, void *model) { free(model); }

static fake_state state;
static const gv_artifact_simulator fake = {"fake", fake_train, fake_render, fake_free, &state, NULL}; /* no depth: no coverage plane */

/* ---- helpers ------------------------------------------------------------------------- */

static char scene_a[4200], scene_b[4200];
static const int intervals[2] = {6, 8};

static void options(gv_dataset_build_options *o, const char *out, const char **dirs, const char **eval)
{
    memset(o, 0, sizeof *o);
    dirs[0] = scene_a, dirs[1] = scene_b;
    eval[0] = "beta";
    o->scene_dirs = dirs, o->n_scenes = 2;
    o->intervals = intervals, o->n_intervals = 2;
    o->eval_scenes = eval, o->n_eval_scenes = 1;
    gv_dataset_default_params(&o->params);
    o->params.clips_per_run = 2;
    o->params.seed = 11;
    o->out_dir = out;
    o->simulator = &fake;
}

static int build(const gv_dataset_build_options *o, gv_dataset_build_result *r)
{
    memset(&state, 0, sizeof state);
    return gv_dataset_build(o, r);
}


/* Reads a file whole, or NULL. */
static char *slurp(const char *path, size_t *size)
{
    char *data;
    return gv_read_file(path, &data, size) == 0 ? data : NULL;
}

/* Every clip of the manifest holds what it should: ground truth anchors and targets read
 * straight from the scene's PNGs, the stand-in's corruption of the intermediates, the
 * scene's cameras, the manifest's frame indices. */
static void check_clips(const char *out, const gv_manifest *m)
{
    int ok = 1;
    for (int i = 0; i < m->n_clips; i++) {
        const gv_manifest_clip *e = &m->clips[i];
        char path[4400];
        snprintf(path, sizeof path, "%s/%s", out, e->file);
        gv_clip clip;
        if (gv_clip_read(path, &clip) != 0) { ok = 0; fprintf(stderr, "%s\n", gv_last_error()); continue; }
        const char *dir = !strcmp(e->id.scene, "alpha") ? scene_a : scene_b;
        gv_scene scene;
        CHECK(gv_scene_load(dir, NULL, &scene) == 0);
        ok &= !strcmp(clip.info.id.scene, e->id.scene) && clip.info.id.interval == e->id.interval &&
              !memcmp(clip.info.frames, e->frames, sizeof e->frames) &&
              !strcmp(clip.info.id.split, !strcmp(e->id.scene, "beta") ? "eval" : "train") &&
              clip.info.width == W && clip.info.height == H && clip.info.seed == 11;
        for (int f = 0; f < 5; f++) {
            int frame = e->frames[f];
            char png[4400];
            snprintf(png, sizeof png, "%s/images/frame_%05d.png", dir, frame);
            gv_image truth;
            CHECK(gv_image_read(png, &truth) == 0);
            const uint8_t *input = gv_clip_frame(clip.inputs, &clip.info, f);
            const uint8_t *target = gv_clip_frame(clip.targets, &clip.info, f);
            for (int p = 0; p < W * H * 3; p++) {
                ok &= target[p] == truth.pixels[p];
                ok &= input[p] == ((f == 0 || f == 4) ? truth.pixels[p] : corrupt(truth.pixels[p], e->id.interval));
            }
            const gv_camera *cam = &scene.cameras[frame];
            ok &= clip.intrinsics[f][0] == (float)cam->fx && clip.intrinsics[f][3] == (float)cam->cy;
            for (int r = 0; r < 3; r++)
                ok &= clip.poses[f][r * 4] == (float)cam->R[r * 3] && clip.poses[f][r * 4 + 3] == (float)cam->t[r];
            ok &= !strcmp(clip.info.frame_names[f], cam->name);
            gv_image_free(&truth);
        }
        gv_scene_free(&scene);
        gv_clip_free(&clip);
    }
    CHECK(ok);
}

/* PSNR of the stand-in's corruption of one frame, from the definition. */
static double stand_in_psnr(const char *dir, int frame, int n)
{
    char png[4400];
    snprintf(png, sizeof png, "%s/images/frame_%05d.png", dir, frame);
    gv_image truth;
    CHECK(gv_image_read(png, &truth) == 0);
    double se = 0;
    for (int p = 0; p < W * H * 3; p++) {
        double d = (corrupt(truth.pixels[p], n) - truth.pixels[p]) / 255.0;
        se += d * d;
    }
    gv_image_free(&truth);
    return -10 * log10(se / (W * H * 3));
}

/* The run record's PSNR over the held-out frames and over the training views (frames 0, n,
 * 2n, ..., rendered by the same stand-in), against the definition. */
static void check_record(const char *out, const char *scene, const char *dir, int n)
{
    char path[4400];
    snprintf(path, sizeof path, "%s/runs/%s_n%02d.json", out, scene, n);
    gv_run_record r;
    CHECK(gv_run_record_read(path, &r) == 0);
    int expected_held = FRAMES - ((FRAMES - 1) / n + 1);
    CHECK(r.n_held_out == expected_held && r.n_train == FRAMES - expected_held && r.iters == 8000);
    double sum = 0;
    for (int i = 0; i < r.n_held_out; i++) {
        CHECK(!gv_scene_is_train(r.held_out[i], n));
        double psnr = stand_in_psnr(dir, r.held_out[i], n);
        CHECK_NEAR(r.psnr[i], psnr, 1e-5);
        sum += psnr;
    }
    CHECK_NEAR(r.psnr_mean, sum / r.n_held_out, 1e-5);
    sum = 0;
    for (int f = 0; f < FRAMES; f += n) sum += stand_in_psnr(dir, f, n);
    CHECK(r.train_frames == r.n_train);
    CHECK_NEAR(r.train_psnr, sum / r.n_train, 1e-5);
    gv_run_record_free(&r);
}

/* A pid that is certainly not running: a child that has exited and been reaped. */
static long dead_pid(void)
{
    pid_t pid = fork();
    if (pid == 0) _exit(0);
    waitpid(pid, NULL, 0);
    return (long)pid;
}

static void test_build_and_resume(const char *base)
{
    char out[4200], path[4400], tmp[4400];
    snprintf(out, sizeof out, "%s/data", base);
    gv_dataset_build_options o;
    const char *dirs[2], *eval[1];
    options(&o, out, dirs, eval);
    gv_dataset_build_result r;
    CHECK(build(&o, &r) == 0);
    CHECK(r.runs_total == 4 && r.runs_built == 4 && r.runs_skipped == 0 && state.trains == 4);
    /* n = 6: anchors 0-6, 6-12, 12-18 (2 of 3 taken); n = 8: 0-8, 8-16 (both). */
    CHECK(r.clips_written == 8);
    gv_manifest m;
    int found;
    CHECK(gv_manifest_read(out, &m, &found) == 0 && found && m.n_runs == 4 && m.n_clips == 8);
    CHECK(m.params.clips_per_run == 2 && m.params.seed == 11 && m.params.iters == 8000);
    check_clips(out, &m);
    check_record(out, "alpha", scene_a, 6);
    check_record(out, "beta", scene_b, 8);
    snprintf(path, sizeof path, "%s/%s", out, m.clips[7].file);
    size_t size_before;
    char *before = slurp(path, &size_before);

    /* Again: everything is complete, nothing is trained. */
    CHECK(build(&o, &r) == 0 && r.runs_skipped == 4 && r.runs_built == 0 && state.trains == 0);

    /* Interruption after the clips of beta n=8 were written but before the manifest was:
     * the manifest loses the run, a temporary of a dead writer lies in clips/. */
    gv_manifest cut;
    gv_manifest_init(&cut, &m.params);
    for (int i = 0; i < m.n_runs; i++) {
        if (!strcmp(m.runs[i].id.scene, "beta") && m.runs[i].id.interval == 8) continue;
        gv_manifest_clip clips[8];
        int k = 0;
        for (int j = 0; j < m.n_clips; j++)
            if (!strcmp(m.clips[j].id.scene, m.runs[i].id.scene) && m.clips[j].id.interval == m.runs[i].id.interval) clips[k++] = m.clips[j];
        gv_manifest_add_run(&cut, &m.runs[i], clips, k);
    }
    CHECK(gv_manifest_write(out, &cut) == 0 && cut.n_runs == 3);
    snprintf(tmp, sizeof tmp, "%s.tmp.%ld", path, dead_pid());
    FILE *f = fopen(tmp, "wb");
    fputs("half a clip", f);
    fclose(f);
    char live[4400]; /* a temporary of a live writer (this process's parent) stays */
    snprintf(live, sizeof live, "%s/runs/x.json.tmp.%ld", out, (long)getppid());
    f = fopen(live, "wb");
    fclose(f);
    CHECK(build(&o, &r) == 0 && r.runs_built == 1 && r.runs_skipped == 3 && state.trains == 1);
    CHECK(!gv_file_exists(tmp) && gv_file_exists(live));
    unlink(live);
    gv_manifest again;
    CHECK(gv_manifest_read(out, &again, &found) == 0 && again.n_runs == 4 && again.n_clips == 8);
    CHECK(!memcmp(again.clips, m.clips, sizeof *m.clips * 8));
    size_t size_after;
    char *after = slurp(path, &size_after); /* the same seed gives the same clip, bytewise */
    CHECK(before && after && size_before == size_after && !memcmp(before, after, size_after));
    free(after);
    gv_manifest_free(&again);
    gv_manifest_free(&cut);

    /* A clip the manifest lists has gone: that run is built again. */
    snprintf(path, sizeof path, "%s/%s", out, m.clips[0].file);
    unlink(path);
    CHECK(build(&o, &r) == 0 && r.runs_built == 1 && state.trains == 1 && gv_file_exists(path));

    /* A run killed while rendering: no clip of it, the manifest unchanged. */
    snprintf(path, sizeof path, "%s/manifest.json", out);
    size_t manifest_size;
    char *manifest_before = slurp(path, &manifest_size);
    gv_dataset_build_options o2 = o;
    const int more[1] = {10};
    o2.intervals = more, o2.n_intervals = 1;
    memset(&state, 0, sizeof state);
    state.fail_render_at = 3;
    CHECK_FAILS_WITH(gv_dataset_build(&o2, &r), "failed on purpose");
    CHECK(strstr(gv_last_error(), "alpha") != NULL);
    snprintf(path, sizeof path, "%s/clips/alpha_n10_000.safetensors", out);
    CHECK(!gv_file_exists(path));
    snprintf(path, sizeof path, "%s/manifest.json", out);
    char *manifest_after = slurp(path, NULL);
    CHECK(manifest_before && manifest_after && !strcmp(manifest_before, manifest_after));
    free(manifest_before), free(manifest_after);

    /* Other options into the same folder are refused. */
    gv_dataset_build_options o3 = o;
    o3.params.iters = 100;
    CHECK_FAILS_WITH(build(&o3, &r), "--iters 8000");
    o3 = o;
    o3.params.densify = GV_DENSIFY_LEAN;
    CHECK_FAILS_WITH(build(&o3, &r), "--densify reference"); /* what the folder was built with */
    o3 = o;
    o3.n_eval_scenes = 0;
    CHECK_FAILS_WITH(build(&o3, &r), "beta n=6 was built in the eval split");

    /* Stats: clips per n and split, baseline falling with n. */
    gv_dataset_stats st;
    CHECK(gv_dataset_stats_read(out, &st) == 0);
    CHECK(st.n_runs == 4 && st.n_clips == 8 && st.n_scenes == 2 && st.n_rows == 2);
    CHECK(st.rows[0].interval == 6 && st.rows[0].clips_train == 2 && st.rows[0].clips_eval == 2 && st.rows[0].runs == 2);
    CHECK(st.rows[1].interval == 8 && st.rows[1].clips_train == 2 && st.rows[1].clips_eval == 2);
    CHECK(st.rows[0].frames == 2 * 16 && st.rows[1].frames == 2 * 17);
    CHECK(st.rows[0].psnr > st.rows[1].psnr + 1 && st.rows[0].ssim > st.rows[1].ssim);
    free(before);
    gv_manifest_free(&m);
}

static void test_bad_inputs(const char *base)
{
    char out[4200], missing[4200];
    snprintf(out, sizeof out, "%s/never", base);
    gv_dataset_build_options o;
    const char *dirs[2], *eval[1];
    gv_dataset_build_result r;
    options(&o, out, dirs, eval);
    snprintf(missing, sizeof missing, "%s/no-such-scene", base);
    dirs[1] = missing;
    CHECK_FAILS_WITH(build(&o, &r), "no-such-scene");
    options(&o, out, dirs, eval);
    const int too_big[2] = {6, 30};
    o.intervals = too_big;
    CHECK_FAILS_WITH(build(&o, &r), "interval 30 with anchor gap 1 spans 30 frames");
    CHECK(strstr(gv_last_error(), "alpha") != NULL);
    options(&o, out, dirs, eval);
    eval[0] = "gamma";
    CHECK_FAILS_WITH(build(&o, &r), "eval scene 'gamma'");
    options(&o, out, dirs, eval);
    dirs[1] = scene_a;
    CHECK_FAILS_WITH(build(&o, &r), "also that of");
    options(&o, out, dirs, eval);
    o.params.clips_per_run = 0;
    CHECK_FAILS_WITH(build(&o, &r), "clips per run");
    CHECK(!gv_dir_exists(out) && state.trains == 0); /* nothing made before the checks pass */
    CHECK_FAILS_WITH(gv_dataset_stats_read(base, &(gv_dataset_stats){0}), "no manifest.json");
    /* Scene names: the folder's last path component. */
    char name[GV_SCENE_NAME_MAX], path[4400];
    snprintf(path, sizeof path, "%s//", scene_a);
    CHECK(gv_scene_name_of(path, name, sizeof name) == 0 && !strcmp(name, "alpha"));
    snprintf(path, sizeof path, "%s/.", scene_b);
    CHECK(gv_scene_name_of(path, name, sizeof name) == 0 && !strcmp(name, "beta"));
    CHECK_FAILS_WITH(gv_scene_name_of(missing, name, sizeof name), "no-such-scene: no such scene folder");
    /* A folder whose first run failed has no finished run: it takes other options. */
    snprintf(out, sizeof out, "%s/fresh", base);
    options(&o, out, dirs, eval);
    memset(&state, 0, sizeof state);
    state.fail_render_at = 1;
    CHECK_FAILS_WITH(gv_dataset_build(&o, &r), "failed on purpose");
    o.params.iters = 50;
    CHECK(build(&o, &r) == 0 && r.runs_built == 4);
}

/* The real simulator: sparse 3DGS for a few iterations on a tiny synthesised scene. */
static void test_end_to_end(const char *base)
{
    char scene[4200], out[4200];
    snprintf(scene, sizeof scene, "%s/synth-room", base);
    snprintf(out, sizeof out, "%s/e2e", base);
    gv_synth_params p;
    gv_synth_default_params(&p);
    p.seed = 3, p.n_frames = 14, p.width = 32, p.height = 24, p.samples = 1;
    if (gv_synth_write(&p, scene) != 0) {
        CHECK(0);
        fprintf(stderr, "%s\n", gv_last_error());
        return;
    }
    const char *dirs[1] = {scene};
    const int n[1] = {6};
    gv_dataset_build_options o;
    memset(&o, 0, sizeof o);
    o.scene_dirs = dirs, o.n_scenes = 1, o.intervals = n, o.n_intervals = 1, o.out_dir = out;
    gv_dataset_default_params(&o.params);
    o.params.iters = 30;
    omp_set_num_threads(1); /* a 32x24 image gains nothing from threads on a busy machine */
    double t0 = gv_now();
    gv_dataset_build_result r;
    CHECK(gv_dataset_build(&o, &r) == 0);
    printf("end to end: 1 run of 30 iterations on 32x24, %.2f s\n", gv_now() - t0);
    CHECK(r.runs_built == 1 && r.clips_written == 2); /* anchor pairs 0-6 and 6-12 */
    gv_dataset_stats st;
    CHECK(gv_dataset_stats_read(out, &st) == 0 && st.n_rows == 1 && st.rows[0].frames == 11);
    CHECK(st.rows[0].psnr > 5 && st.rows[0].psnr < 60 && st.rows[0].ssim < 1);
    printf("end to end: baseline PSNR %.2f dB, SSIM %.4f over %d held-out frames\n",
           st.rows[0].psnr, st.rows[0].ssim, st.rows[0].frames);
    char path[4400];
    snprintf(path, sizeof path, "%s/clips/synth-room_n06_001.safetensors", out);
    gv_clip clip;
    CHECK(gv_clip_read(path, &clip) == 0);
    CHECK(clip.info.frames[0] == 6 && clip.info.frames[4] == 12 && clip.info.iters == 30);
    size_t frame = 32 * 24 * 3;
    CHECK(memcmp(clip.inputs + frame, clip.targets + frame, frame) != 0); /* a render, not the truth */
    /* sparse 3DGS renders depth, so the clip carries the coverage plane: two anchor bits per
     * pixel, and neighbouring views of a room see part of each intermediate */
    CHECK(clip.info.has_coverage && clip.coverage != NULL);
    size_t seen = 0, bad = 0, plane = 32 * 24;
    for (size_t i = 0; clip.coverage && i < 3 * plane; i++) bad += clip.coverage[i] > 3, seen += clip.coverage[i] != 0;
    CHECK(bad == 0 && seen > 0);
    gv_clip_free(&clip);
}

int main(void)
{
    const char *base = check_tmp_dir();
    gv_log_set_level(GV_LOG_QUIET);
    snprintf(scene_a, sizeof scene_a, "%s/alpha", base);
    snprintf(scene_b, sizeof scene_b, "%s/beta", base);
    make_scene(scene_a, 1);
    make_scene(scene_b, 2);
    test_build_and_resume(base);
    test_bad_inputs(base);
    test_end_to_end(base);
    return check_summary();
}
