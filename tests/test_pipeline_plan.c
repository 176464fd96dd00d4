/* The plan of `reconstruct` (src/pipeline/plan.c): for held-out frames, every held-out frame
 * between the first and the last training view is evaluated once, restored by exactly one
 * clip, and every clip is a valid dataset clip (gv_clip_check_info: anchors training views n
 * apart, three held-out frames strictly between); the tail after the last training view is
 * left to the evaluation; n = 2, 3 and n >= the frame count are refused. The smooth path of
 * n = 1: three frames 4k + j per gap, at a quarter, half and three quarters of the way. The
 * frames' files are named after the photos (a phone's names, a folder, characters a file name
 * should not carry, two photos of one stem), and the path's after the two photos around it. */
#include "check.h"
#include "gaussvid/core/core.h"
#include "gaussvid/data/dataset.h"
#include "pipeline/pipeline_internal.h"

static void make_scene(gv_scene *s, int n_frames, gv_camera *cams)
{
    memset(s, 0, sizeof *s);
    snprintf(s->dir, sizeof s->dir, "tiny");
    s->n_frames = n_frames;
    s->cameras = cams;
    for (int i = 0; i < n_frames; i++) {
        gv_camera *c = &cams[i];
        memset(c, 0, sizeof *c);
        c->width = 64, c->height = 48, c->fx = c->fy = 50, c->cx = 32, c->cy = 24;
        c->R[0] = c->R[4] = c->R[8] = 1;
        c->t[0] = -0.1 * i; /* centre (0.1 i, 0, 0) */
        snprintf(c->name, sizeof c->name, "frame_%05d.png", i);
    }
}

/* The scene frame of a clip entry (anchors -1 - k: training view k). */
static int entry_frame(const pipeline_run *r, int e)
{
    return e >= 0 ? r->frames[e].index : r->train[-1 - e];
}

static void check_held_out(int n_frames, int n, int want_clips)
{
    gv_camera cams[64];
    gv_scene s;
    make_scene(&s, n_frames, cams);
    pipeline_run r;
    memset(&r, 0, sizeof r);
    CHECK(pipeline_plan(&r, &s, n) == 0);
    int last_train = (n_frames - 1) / n * n;
    CHECK(r.n_frames == last_train - last_train / n); /* held-out frames before the last view */
    CHECK(r.n_clips == want_clips);
    int restored[64] = {0};
    for (int c = 0; c < r.n_clips; c++) {
        gv_clip_info info;
        memset(&info, 0, sizeof info);
        snprintf(info.id.scene, sizeof info.id.scene, "tiny");
        snprintf(info.id.split, sizeof info.id.split, "eval");
        info.id.interval = n, info.anchor_gap = 1, info.width = 64, info.height = 48;
        for (int i = 0; i < GV_CLIP_FRAMES; i++) info.frames[i] = entry_frame(&r, r.clips[c][i]);
        CHECK(gv_clip_check_info(&info, "clip") == 0);
        for (int slot = 1; slot <= 3; slot++) {
            const pipeline_frame *f = &r.frames[r.clips[c][slot]];
            if (f->clip != c) continue;
            CHECK(f->slot == slot);
            restored[f->index]++;
        }
    }
    for (int i = 0; i < r.n_frames; i++) {
        const pipeline_frame *f = &r.frames[i];
        CHECK(f->index % n != 0 && f->index < last_train && f->truth == f->index);
        CHECK(restored[f->index] == 1);
        if (i > 0) CHECK(f->index > r.frames[i - 1].index);
    }
    CHECK(r.n_held_out == n_frames - (last_train / n + 1)); /* the tail is held out too */
    pipeline_plan_free(&r);
}

static void check_smooth_path(void)
{
    gv_camera cams[6];
    gv_scene s;
    make_scene(&s, 6, cams);
    pipeline_run r;
    memset(&r, 0, sizeof r);
    CHECK(pipeline_plan(&r, &s, 1) == 0);
    CHECK(r.smooth_path && r.n_train == 6 && r.n_held_out == 0);
    CHECK(r.n_clips == 5 && r.n_frames == 15);
    for (int i = 0; i < r.n_frames; i++) {
        const pipeline_frame *f = &r.frames[i];
        int k = i / 3, j = i % 3 + 1;
        double centre[3];
        gv_camera_center(&f->camera, centre);
        CHECK(f->index == 4 * k + j && f->truth == -1 && f->clip == k && f->slot == j);
        CHECK_NEAR(centre[0], 0.1 * (k + j / 4.0), 1e-12);
    }
    for (int k = 0; k < 5; k++) CHECK(r.clips[k][0] == -1 - k && r.clips[k][4] == -2 - k);
    pipeline_plan_free(&r);
}

static void check_names(void)
{
    gv_camera cams[10];
    gv_scene s;
    make_scene(&s, 10, cams);
    static const char *const photos[10] = {"IMG_0001.jpg", "IMG_0002.JPG", "day 2/IMG_0003.jpeg", "IMG_0004",
                                           "IMG_0005.jpg", "IMG_0006.jpg", "x.jpg", "x.png", "v1.2/a&b.jpg",
                                           "IMG_0010.HEIC"};
    for (int i = 0; i < 10; i++) snprintf(cams[i].name, sizeof cams[i].name, "%s", photos[i]);
    pipeline_run r;
    memset(&r, 0, sizeof r);
    snprintf(r.dir, sizeof r.dir, "out/n4");
    REQUIRE(pipeline_plan(&r, &s, 4) == 0); /* evaluated: 1-3, 5-7 */
    static const char *const want[6] = {"IMG_0002", "day_2_IMG_0003", "IMG_0004", "IMG_0006", "x_00006", "x_00007"};
    char path[4200];
    for (int i = 0; i < r.n_frames && i < 6; i++) {
        CHECK(!strcmp(r.frames[i].name, want[i]));
        if (strcmp(r.frames[i].name, want[i])) printf("  frame %d: '%s', want '%s'\n", i, r.frames[i].name, want[i]);
    }
    CHECK(pipeline_frame_path(&r, "restored", 2, path, sizeof path) == 0 &&
          !strcmp(path, "out/n4/frames/restored/day_2_IMG_0003.png"));
    pipeline_frame_relpath(&r, "render", 7, path, sizeof path);
    CHECK(!strcmp(path, "n4/frames/render/x_00007.png"));
    CHECK_FAILS_WITH(pipeline_frame_path(&r, "render", 4, path, sizeof path), "frame 4 is not one of the run's");
    pipeline_plan_free(&r);
    /* the smooth path: after the photos on either side, and where between them */
    REQUIRE(pipeline_plan(&r, &s, 1) == 0);
    CHECK(!strcmp(r.frames[0].name, "IMG_0001_to_IMG_0002_1of4"));
    CHECK(!strcmp(r.frames[26].name, "v1.2_a_b_to_IMG_0010_3of4"));
    printf("  path names: %s ... %s\n", r.frames[0].name, r.frames[26].name);
    pipeline_plan_free(&r);
}

static void check_refused(void)
{
    gv_camera cams[25];
    gv_scene s;
    make_scene(&s, 25, cams);
    pipeline_run r;
    memset(&r, 0, sizeof r);
    CHECK_FAILS_WITH(pipeline_plan(&r, &s, 3), "interval 3: reconstruct takes n = 1 or 4 <= n <= 24 on this scene");
    pipeline_plan_free(&r);
    CHECK_FAILS_WITH(pipeline_plan(&r, &s, 2), "n = 1 or 4 <= n <= 24");
    pipeline_plan_free(&r);
    CHECK_FAILS_WITH(pipeline_plan(&r, &s, 25), "interval 25 leaves 1 training frame of the scene's 25 frames");
    pipeline_plan_free(&r);
    CHECK(pipeline_plan(&r, &s, 24) == 0 && r.n_train == 2);
    pipeline_plan_free(&r);
}

/* reconstruct's own downscale: the smallest of 1, 2, 4, 8 with the longer side at most 512. */
static void check_auto_downscale(void)
{
    CHECK(GV_RECONSTRUCT_AUTO_SIDE == 512);
    CHECK(gv_reconstruct_auto_downscale(256, 144) == 1);
    CHECK(gv_reconstruct_auto_downscale(512, 512) == 1);
    CHECK(gv_reconstruct_auto_downscale(513, 10) == 2);    /* ceil(513 / 2) = 257 */
    CHECK(gv_reconstruct_auto_downscale(1024, 576) == 2);
    CHECK(gv_reconstruct_auto_downscale(1025, 576) == 4);  /* ceil(1025 / 2) = 513 */
    CHECK(gv_reconstruct_auto_downscale(1080, 1920) == 4); /* a phone's portrait: 270x480 */
    CHECK(gv_reconstruct_auto_downscale(953, 1695) == 4);  /* COLMAP's undistorted copy of it */
    CHECK(gv_reconstruct_auto_downscale(4032, 3024) == 8); /* 504x378 */
    CHECK(gv_reconstruct_auto_downscale(8000, 6000) == 8); /* none suffices: the largest */
    CHECK(gv_reconstruct_auto_downscale(1, 1) == 1);
}

int main(void)
{
    gv_log_set_level(GV_LOG_QUIET);
    check_held_out(25, 6, 8);   /* 4 gaps of 5 frames: 2 clips each, frame 3 from the first */
    check_held_out(25, 4, 6);   /* 6 gaps of exactly 3 frames */
    check_held_out(30, 5, 10);  /* 5 gaps of 4; tail 26-29 */
    check_held_out(40, 16, 10); /* 2 gaps of 15: 5 clips each; tail 33-39 */
    check_held_out(20, 7, 4);   /* 2 gaps of 6 (2 clips each, no overlap); tail 15-19 */
    check_smooth_path();
    check_names();
    check_refused();
    check_auto_downscale();
    return check_summary();
}
