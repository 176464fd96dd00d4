/* Clip sampling, the clip file (round trip and malformed files), the contact sheet, the
 * manifest and the run records of the paired clip dataset (src/data). The build itself is
 * tested in test_dataset_build.c. */
#include <math.h>
#include <stdint.h>

#include "check.h"
#include "gaussvid/core/core.h"
#include "gaussvid/data/dataset.h"
#include "gaussvid/splat/splat_train.h"
#include "gaussvid/io/safetensors.h"

/* ---- sampling ----------------------------------------------------------------------- */

/* The uniform rule for anchor gap 1 written independently: nearbyint rounds half to even
 * in the default rounding mode, like Python's round. With gap 1 no position can land on a
 * training view for n >= 4, so no frame moves. */
static void test_uniform_gap1(void)
{
    int ok = 1;
    for (int n = 4; n <= 40; n++) {
        int frames_total = 5 * n + 1;
        for (int s = 0; s + n <= frames_total - 1; s += n) {
            int f[5];
            if (gv_clip_frames(frames_total, n, 1, GV_SAMPLING_UNIFORM, s, NULL, f) != 0) { ok = 0; continue; }
            ok &= f[0] == s && f[4] == s + n;
            for (int j = 1; j <= 3; j++) {
                ok &= f[j] == (int)nearbyint(s + j * n / 4.0);
                ok &= !gv_scene_is_train(f[j], n) && f[j] > f[j - 1];
                ok &= fabs(f[j] - (s + j * n / 4.0)) <= 0.5; /* uniformly spaced, rounded */
            }
        }
    }
    CHECK(ok);
    int f[5];
    CHECK(gv_clip_frames(160, 8, 1, GV_SAMPLING_UNIFORM, 16, NULL, f) == 0);
    CHECK(f[0] == 16 && f[1] == 18 && f[2] == 20 && f[3] == 22 && f[4] == 24);
    CHECK(gv_clip_frames(160, 6, 1, GV_SAMPLING_UNIFORM, 0, NULL, f) == 0); /* 1.5, 3, 4.5 */
    CHECK(f[1] == 2 && f[2] == 3 && f[3] == 4);
    CHECK(gv_clip_frames(160, 10, 1, GV_SAMPLING_UNIFORM, 30, NULL, f) == 0); /* 32.5, 35, 37.5 */
    CHECK(f[1] == 32 && f[2] == 35 && f[3] == 38);
    /* Python's round of the absolute position: halves go to the even frame. */
    CHECK(gv_clip_frames(160, 5, 1, GV_SAMPLING_UNIFORM, 5, NULL, f) == 0); /* 6.25, 7.5, 8.75 */
    CHECK(f[1] == 6 && f[2] == 8 && f[3] == 9);
    CHECK(gv_clip_frames(160, 5, 1, GV_SAMPLING_UNIFORM, 10, NULL, f) == 0); /* 11.25, 12.5, 13.75 */
    CHECK(f[1] == 11 && f[2] == 12 && f[3] == 14);
    CHECK(gv_clip_frames(160, 26, 1, GV_SAMPLING_UNIFORM, 130, NULL, f) == 0); /* 6.5, 13, 19.5 */
    CHECK(f[0] == 130 && f[1] == 136 && f[2] == 143 && f[3] == 150 && f[4] == 156);
}

/* Gaps of several training views: a position on a training view moves to the nearest
 * held-out frame, the lower one on a tie. */
static void test_uniform_wide_gap(void)
{
    int f[5];
    CHECK(gv_clip_frames(160, 6, 2, GV_SAMPLING_UNIFORM, 6, NULL, f) == 0); /* 9, 12, 15 */
    CHECK(f[0] == 6 && f[1] == 9 && f[2] == 11 && f[3] == 15 && f[4] == 18);
    CHECK(gv_clip_frames(160, 6, 4, GV_SAMPLING_UNIFORM, 0, NULL, f) == 0); /* 6, 12, 18 */
    CHECK(f[1] == 5 && f[2] == 11 && f[3] == 17 && f[4] == 24);
    CHECK(gv_clip_frames(160, 4, 3, GV_SAMPLING_UNIFORM, 0, NULL, f) == 0); /* 3, 6, 9 */
    CHECK(f[1] == 3 && f[2] == 6 && f[3] == 9 && f[4] == 12);
    /* Every interval and gap: anchors are training views g n apart, intermediates held out,
     * increasing, and within n / 2 + 1 of their exact uniform positions. */
    int ok = 1;
    for (int n = 4; n <= 30; n++) {
        for (int g = 1; g <= 5; g++) {
            int total = 3 * g * n + 1;
            for (int s = 0; s + g * n < total; s += n) {
                if (gv_clip_frames(total, n, g, GV_SAMPLING_UNIFORM, s, NULL, f) != 0) { ok = 0; continue; }
                ok &= f[0] == s && f[4] == s + g * n && gv_scene_is_train(f[0], n) && gv_scene_is_train(f[4], n);
                for (int j = 1; j <= 3; j++)
                    ok &= !gv_scene_is_train(f[j], n) && f[j] > f[j - 1] && f[j] < f[4] &&
                          fabs(f[j] - (s + j * g * n / 4.0)) <= n / 2.0 + 1;
            }
        }
    }
    CHECK(ok);
}

static void test_released(void)
{
    int f[5];
    /* The authors' released test clips (docs/reference/wan-vace-gaussvid.md section 1.3). */
    CHECK(gv_clip_frames(200, 10, 1, GV_SAMPLING_RELEASED, 80, NULL, f) == 0);
    CHECK(f[0] == 80 && f[1] == 81 && f[2] == 85 && f[3] == 89 && f[4] == 90);
    CHECK(gv_clip_frames(200, 24, 1, GV_SAMPLING_RELEASED, 96, NULL, f) == 0);
    CHECK(f[0] == 96 && f[1] == 97 && f[2] == 108 && f[3] == 119 && f[4] == 120);
    CHECK(gv_clip_frames(200, 7, 1, GV_SAMPLING_RELEASED, 7, NULL, f) == 0); /* 7 / 2 = 3 */
    CHECK(f[1] == 8 && f[2] == 10 && f[3] == 13);
    CHECK(gv_clip_frames(200, 6, 2, GV_SAMPLING_RELEASED, 0, NULL, f) == 0); /* 1, 6 -> 5, 11 */
    CHECK(f[1] == 1 && f[2] == 5 && f[3] == 11 && f[4] == 12);
}

static void test_random(void)
{
    gv_rng rng;
    gv_rng_init(&rng, 42);
    int ok = 1, hits[6] = {0};
    const int draws = 3000;
    for (int i = 0; i < draws; i++) {
        int f[5];
        if (gv_clip_frames(100, 6, 1, GV_SAMPLING_RANDOM, 12, &rng, f) != 0) { ok = 0; break; }
        ok &= f[0] == 12 && f[4] == 18;
        for (int j = 1; j <= 3; j++) {
            ok &= f[j] > f[j - 1] && f[j] < 18 && !gv_scene_is_train(f[j], 6);
            hits[f[j] - 12]++;
        }
    }
    CHECK(ok);
    /* Uniform 3-subsets of the 5 held-out frames: each frame is in 3/5 of them. */
    for (int k = 1; k <= 5; k++) CHECK_NEAR(hits[k] / (double)draws, 0.6, 0.04);
    /* Wide gap: stays strictly between the anchors. */
    ok = 1;
    for (int i = 0; i < 500; i++) {
        int f[5];
        ok &= gv_clip_frames(100, 5, 3, GV_SAMPLING_RANDOM, 20, &rng, f) == 0 && f[0] == 20 &&
              f[4] == 35 && f[1] > 20 && f[3] < 35 && f[1] < f[2] && f[2] < f[3] &&
              !gv_scene_is_train(f[1], 5) && !gv_scene_is_train(f[2], 5) && !gv_scene_is_train(f[3], 5);
    }
    CHECK(ok);
    CHECK_FAILS_WITH(gv_clip_frames(100, 6, 1, GV_SAMPLING_RANDOM, 12, NULL, (int[5]){0}), "random");
}

static void test_sample_clips(void)
{
    int frames[64][5], frames2[64][5], count, count2;
    CHECK(gv_clip_anchor_count(160, 6, 1) == 26);
    CHECK(gv_clip_anchor_count(160, 26, 1) == 6);
    CHECK(gv_clip_anchor_count(160, 26, 2) == 5);
    CHECK(gv_clip_anchor_count(160, 200, 1) == 0);
    CHECK(gv_sample_clips(160, 6, 1, GV_SAMPLING_UNIFORM, 4, 7, frames, &count) == 0 && count == 4);
    int ok = 1;
    for (int k = 0; k < count; k++) {
        ok &= frames[k][0] % 6 == 0 && frames[k][4] == frames[k][0] + 6;
        if (k) ok &= frames[k][0] > frames[k - 1][0]; /* distinct anchors, sorted */
    }
    CHECK(ok);
    CHECK(gv_sample_clips(160, 6, 1, GV_SAMPLING_UNIFORM, 4, 7, frames2, &count2) == 0);
    CHECK(count2 == 4 && !memcmp(frames, frames2, sizeof(int[4][5]))); /* same seed, same clips */
    CHECK(gv_sample_clips(160, 6, 1, GV_SAMPLING_UNIFORM, 4, 8, frames2, &count2) == 0);
    CHECK(memcmp(frames, frames2, sizeof(int[4][5])) != 0);
    /* More clips than anchor pairs: uniform stops at every pair once. */
    CHECK(gv_sample_clips(160, 26, 1, GV_SAMPLING_RELEASED, 10, 1, frames, &count) == 0 && count == 6);
    ok = 1;
    for (int k = 0; k < count; k++) ok &= frames[k][0] == 26 * k && frames[k][1] == 26 * k + 1;
    CHECK(ok);
    /* Random reuses pairs with other intermediates, every clip distinct. */
    CHECK(gv_sample_clips(160, 26, 1, GV_SAMPLING_RANDOM, 20, 1, frames, &count) == 0 && count == 20);
    ok = 1;
    for (int a = 0; a < count; a++)
        for (int b = a + 1; b < count; b++) ok &= memcmp(frames[a], frames[b], sizeof frames[a]) != 0;
    CHECK(ok);
    /* Only C(5, 3) = 10 distinct random clips exist in a 7-frame scene at n = 6. */
    CHECK(gv_sample_clips(7, 6, 1, GV_SAMPLING_RANDOM, 30, 3, frames, &count) == 0 && count == 10);
    CHECK_FAILS_WITH(gv_sample_clips(160, 6, 1, GV_SAMPLING_UNIFORM, 0, 1, frames, &count), "clips per run");
}

static void test_interval_checks(void)
{
    CHECK(gv_clip_check_interval(160, 159, 1) == 0);
    CHECK_FAILS_WITH(gv_clip_check_interval(160, 160, 1), "scene has 160 frames");
    CHECK_FAILS_WITH(gv_clip_check_interval(160, 200, 1), "no clip fits");
    CHECK_FAILS_WITH(gv_clip_check_interval(160, 60, 3), "spans 180 frames");
    CHECK_FAILS_WITH(gv_clip_check_interval(160, 3, 1), "leaves 2 held-out");
    CHECK(gv_clip_check_interval(160, 3, 2) == 0);
    CHECK_FAILS_WITH(gv_clip_check_interval(160, 1, 1), "interval 1: a clip takes 2 <= n <= 100000");
    CHECK_FAILS_WITH(gv_clip_frames(160, 6, 1, GV_SAMPLING_UNIFORM, 5, NULL, (int[5]){0}), "not a training view");
    CHECK_FAILS_WITH(gv_clip_frames(160, 6, 1, GV_SAMPLING_UNIFORM, 156, NULL, (int[5]){0}), "within");
    gv_clip_sampling s;
    CHECK(gv_sampling_from_name("released", &s) == 0 && s == GV_SAMPLING_RELEASED);
    CHECK(!strcmp(gv_sampling_name(GV_SAMPLING_RANDOM), "random"));
    CHECK_FAILS_WITH(gv_sampling_from_name("even", &s), "even");
}

/* ---- clips -------------------------------------------------------------------------- */

/* A rotation about the axis (1, 2, 2) / 3 by angle a (Rodrigues). */
static void rotation(double a, float R[9])
{
    const double k[3] = {1 / 3.0, 2 / 3.0, 2 / 3.0};
    double c = cos(a), s = sin(a);
    for (int i = 0; i < 3; i++)
        for (int j = 0; j < 3; j++) {
            double cross = 0;
            if (i == 0 && j == 1) cross = -k[2];
            if (i == 0 && j == 2) cross = k[1];
            if (i == 1 && j == 0) cross = k[2];
            if (i == 1 && j == 2) cross = -k[0];
            if (i == 2 && j == 0) cross = -k[1];
            if (i == 2 && j == 1) cross = k[0];
            R[i * 3 + j] = (float)((i == j) * c + s * cross + (1 - c) * k[i] * k[j]);
        }
}

static void make_clip(gv_clip *clip, int w, int h, uint64_t seed)
{
    gv_clip_info info = {0};
    snprintf(info.id.scene, sizeof info.id.scene, "room-7");
    snprintf(info.id.split, sizeof info.id.split, "eval");
    info.id.interval = 6, info.anchor_gap = 1, info.iters = 8000, info.width = w, info.height = h;
    info.sampling = GV_SAMPLING_UNIFORM;
    info.seed = 12345678901234ull;
    const int frames[5] = {12, 14, 15, 16, 18};
    memcpy(info.frames, frames, sizeof frames);
    for (int i = 0; i < 5; i++) snprintf(info.frame_names[i], 256, "frame_%05d.png", frames[i]);
    CHECK(gv_clip_alloc(clip, &info) == 0);
    size_t bytes = (size_t)5 * w * h * 3;
    for (size_t i = 0; i < bytes; i++) {
        clip->inputs[i] = (uint8_t)(gv_uniform_at(seed, i) * 256);
        clip->targets[i] = (uint8_t)(gv_uniform_at(seed + 1, i) * 256);
    }
    for (int f = 0; f < 5; f += 4) /* anchors are ground truth in both */
        memcpy(gv_clip_frame(clip->inputs, &info, f), gv_clip_frame(clip->targets, &info, f), (size_t)w * h * 3);
    for (int f = 0; f < 5; f++) {
        float R[9];
        rotation(0.1 * f + 0.3, R);
        for (int r = 0; r < 3; r++) {
            for (int c = 0; c < 3; c++) clip->poses[f][r * 4 + c] = R[r * 3 + c];
            clip->poses[f][r * 4 + 3] = 0.25f * (float)(f + r) - 1.0f;
        }
        clip->intrinsics[f][0] = 100.5f + f, clip->intrinsics[f][1] = 99.25f;
        clip->intrinsics[f][2] = w / 2.0f, clip->intrinsics[f][3] = h / 2.0f;
    }
}

static int same_clip(const gv_clip *a, const gv_clip *b)
{
    const gv_clip_info *x = &a->info, *y = &b->info;
    size_t bytes = (size_t)5 * x->width * x->height * 3;
    return !strcmp(x->id.scene, y->id.scene) && !strcmp(x->id.split, y->id.split) && x->id.interval == y->id.interval &&
           x->anchor_gap == y->anchor_gap && x->iters == y->iters && x->width == y->width &&
           x->height == y->height && x->sampling == y->sampling && x->seed == y->seed &&
           !memcmp(x->frames, y->frames, sizeof x->frames) &&
           !memcmp(x->frame_names, y->frame_names, sizeof x->frame_names) &&
           !memcmp(a->inputs, b->inputs, bytes) && !memcmp(a->targets, b->targets, bytes) &&
           !memcmp(a->intrinsics, b->intrinsics, sizeof a->intrinsics) &&
           !memcmp(a->poses, b->poses, sizeof a->poses);
}

static void test_clip_round_trip(const char *dir)
{
    gv_clip clip, back;
    make_clip(&clip, 7, 5, 3);
    char path[4200];
    snprintf(path, sizeof path, "%s/clip.safetensors", dir);
    CHECK(gv_clip_write(path, &clip) == 0);
    CHECK(gv_clip_read(path, &back) == 0);
    CHECK(same_clip(&clip, &back));
    gv_clip_info info;
    CHECK(gv_clip_read_info(path, &info) == 0);
    CHECK(!memcmp(&info, &clip.info, sizeof info));
    /* The file as any safetensors reader sees it. */
    gv_st_file f;
    CHECK(gv_st_open(&f, path) == 0);
    const char *indices = gv_st_metadata(&f, "frame_indices");
    CHECK(indices && !strcmp(indices, "[12,14,15,16,18]"));
    CHECK(gv_st_metadata(&f, "n") && !strcmp(gv_st_metadata(&f, "n"), "6"));
    CHECK(gv_st_metadata(&f, "seed") && !strcmp(gv_st_metadata(&f, "seed"), "12345678901234"));
    CHECK(gv_st_metadata(&f, "format_version") && !strcmp(gv_st_metadata(&f, "format_version"), "1"));
    const gv_st_tensor *t = gv_st_find(&f, "inputs");
    CHECK(t && t->dtype == GV_ST_U8 && t->rank == 4 && t->shape[0] == 5 && t->shape[1] == 5 &&
          t->shape[2] == 7 && t->shape[3] == 3);
    CHECK(t && !memcmp(t->data, clip.inputs, 5 * 7 * 5 * 3));
    t = gv_st_find(&f, "poses");
    CHECK(t && t->dtype == GV_ST_F32 && t->rank == 3 && t->shape[1] == 3 && t->shape[2] == 4);
    gv_st_close(&f);
    gv_clip_free(&back);

    /* Contact sheet: inputs above, targets below, gaps and the separator. */
    gv_image sheet;
    CHECK(gv_clip_contact_sheet(&clip, &sheet) == 0);
    CHECK(sheet.width == 5 * 7 + 4 * GV_SHEET_GAP && sheet.height == 2 * 5 + GV_SHEET_GAP);
    int ok = 1;
    for (int row = 0; row < 2; row++)
        for (int fr = 0; fr < 5; fr++)
            for (int y = 0; y < 5; y++)
                for (int x = 0; x < 7; x++) {
                    const uint8_t *src = gv_clip_frame(row ? clip.targets : clip.inputs, &clip.info, fr) + (y * 7 + x) * 3;
                    const uint8_t *dst = sheet.pixels + (((row * 7) + y) * sheet.width + fr * 9 + x) * 3;
                    ok &= !memcmp(src, dst, 3);
                }
    CHECK(ok);
    CHECK(sheet.pixels[(5 * sheet.width + 3) * 3] > sheet.pixels[(2 * sheet.width + 7) * 3]);
    gv_image_free(&sheet);
    gv_clip_free(&clip);
}

/* Writes a clip file by hand with up to two metadata values replaced (value NULL: key
 * removed), optionally a wrong inputs shape or an extra tensor. */
static void write_tampered2(const char *path, const gv_clip *clip, const char *key,
                            const char *value, const char *key2, const char *value2,
                            int bad_shape, int extra_tensor)
{
    const gv_clip_info *in = &clip->info;
    char n[16], w[16], h[16];
    snprintf(n, sizeof n, "%d", in->id.interval), snprintf(w, sizeof w, "%d", in->width), snprintf(h, sizeof h, "%d", in->height);
    const char *meta[][2] = {{"format", "gaussvid.clip"}, {"format_version", "1"}, {"scene", in->id.scene},
                             {"split", in->id.split}, {"n", n}, {"anchor_gap", "1"},
                             {"frame_indices", "[12, 14, 15, 16, 18]"}, {"iters", "8000"},
                             {"sampling", "uniform"}, {"seed", "5"}, {"width", w}, {"height", h}};
    gv_st_builder b;
    gv_st_builder_init(&b);
    int64_t fs[4] = {5, in->height, in->width, bad_shape ? 1 : 3}, ks[2] = {5, 4}, ps[3] = {5, 3, 4};
    gv_st_add_raw(&b, "inputs", GV_ST_U8, fs, 4, clip->inputs);
    fs[3] = 3;
    gv_st_add_raw(&b, "targets", GV_ST_U8, fs, 4, clip->targets);
    gv_st_add_f32(&b, "intrinsics", GV_ST_F32, ks, 2, &clip->intrinsics[0][0]);
    gv_st_add_f32(&b, "poses", GV_ST_F32, ps, 3, &clip->poses[0][0]);
    if (extra_tensor) gv_st_add_f32(&b, "depth", GV_ST_F32, ks, 2, &clip->intrinsics[0][0]);
    for (int i = 0; i < (int)(sizeof meta / sizeof meta[0]); i++) {
        if (key && !strcmp(key, meta[i][0])) {
            if (value) gv_st_add_metadata(&b, key, value);
        } else if (key2 && !strcmp(key2, meta[i][0])) {
            gv_st_add_metadata(&b, key2, value2);
        } else {
            gv_st_add_metadata(&b, meta[i][0], meta[i][1]);
        }
    }
    CHECK(gv_st_write(&b, path) == 0);
    gv_st_builder_free(&b);
}

static void write_tampered(const char *path, const gv_clip *clip, const char *key,
                           const char *value, int bad_shape, int extra_tensor)
{
    write_tampered2(path, clip, key, value, NULL, NULL, bad_shape, extra_tensor);
}

static void test_bad_clips(const char *dir)
{
    gv_clip clip, back;
    char path[4200];
    snprintf(path, sizeof path, "%s/bad.safetensors", dir);
    make_clip(&clip, 4, 3, 9);
    write_tampered(path, &clip, NULL, NULL, 0, 0);
    CHECK(gv_clip_read(path, &back) == 0); /* the untampered hand-written file reads */
    gv_clip_free(&back);
    struct { const char *key, *value, *needle; } cases[] = {
        {"format", "gaussvid.model", "not a gaussvid clip"},
        {"format_version", "2", "version 2"},
        {"n", NULL, "no 'n'"},
        {"n", "six", "metadata n 'six'"},
        {"n", "5", "not training views"},
        {"frame_indices", "[12, 14, 15, 16]", "frame_indices"},
        {"frame_indices", "[12, 14, 18, 16, 18]", "not strictly increasing"},
        {"split", "test", "split 'test'"},
        {"sampling", "sorted", "sampling"},
        {"seed", "-1", "seed"},
        {"width", "5", "inputs"},
        {"height", "0", "height"},
    };
    for (int i = 0; i < (int)(sizeof cases / sizeof cases[0]); i++) {
        write_tampered(path, &clip, cases[i].key, cases[i].value, 0, 0);
        CHECK_FAILS_WITH(gv_clip_read(path, &back), cases[i].needle);
        CHECK(strstr(gv_last_error(), path) != NULL);
        CHECK(back.inputs == NULL);
    }
    write_tampered2(path, &clip, "anchor_gap", "2", "frame_indices", "[12, 15, 18, 21, 24]", 0, 0);
    CHECK_FAILS_WITH(gv_clip_read(path, &back), "intermediate frame 18 is a training view");
    write_tampered2(path, &clip, "anchor_gap", "2", "frame_indices", "[12, 15, 19, 21, 24]", 0, 0);
    CHECK(gv_clip_read(path, &back) == 0 && back.info.anchor_gap == 2 && back.info.frames[2] == 19);
    gv_clip_free(&back);
    write_tampered(path, &clip, NULL, NULL, 1, 0);
    CHECK_FAILS_WITH(gv_clip_read(path, &back), "'inputs'");
    write_tampered(path, &clip, NULL, NULL, 0, 1);
    CHECK_FAILS_WITH(gv_clip_read(path, &back), "unexpected tensor 'depth'");
    CHECK_FAILS_WITH(gv_clip_read_info(path, (gv_clip_info[1]){0}), "unexpected tensor");
    /* Content: a moved anchor, a non-rotation, a NaN, a zero focal length. */
    gv_clip_frame(clip.inputs, &clip.info, 4)[5] ^= 1;
    write_tampered(path, &clip, NULL, NULL, 0, 0);
    CHECK_FAILS_WITH(gv_clip_read(path, &back), "anchor frame 4 differs");
    gv_clip_frame(clip.inputs, &clip.info, 4)[5] ^= 1;
    clip.poses[2][0] *= 1.1f;
    write_tampered(path, &clip, NULL, NULL, 0, 0);
    CHECK_FAILS_WITH(gv_clip_read(path, &back), "not a rotation");
    clip.poses[2][0] /= 1.1f;
    clip.poses[1][3] = NAN;
    write_tampered(path, &clip, NULL, NULL, 0, 0);
    CHECK_FAILS_WITH(gv_clip_read(path, &back), "pose of frame 1 is not finite");
    clip.poses[1][3] = 0;
    clip.intrinsics[3][1] = 0;
    write_tampered(path, &clip, NULL, NULL, 0, 0);
    CHECK_FAILS_WITH(gv_clip_read(path, &back), "focal");
    clip.intrinsics[3][1] = 99;
    /* Not a safetensors file, a truncated clip, a missing file. */
    FILE *f = fopen(path, "wb");
    fputs("these bytes are no clip at all", f);
    fclose(f);
    CHECK_FAILS_WITH(gv_clip_read(path, &back), path);
    CHECK(gv_clip_write(path, &clip) == 0);
    char *data;
    size_t size;
    CHECK(gv_read_file(path, &data, &size) == 0);
    f = fopen(path, "wb");
    fwrite(data, 1, size - 10, f);
    fclose(f);
    free(data);
    CHECK_FAILS_WITH(gv_clip_read(path, &back), "truncated");
    snprintf(path, sizeof path, "%s/missing.safetensors", dir);
    CHECK_FAILS_WITH(gv_clip_read(path, &back), "missing.safetensors");
    /* The writer refuses what the reader would refuse, and leaves nothing behind. */
    snprintf(clip.info.id.split, sizeof clip.info.id.split, "test");
    snprintf(path, sizeof path, "%s/refused.safetensors", dir);
    CHECK_FAILS_WITH(gv_clip_write(path, &clip), "split 'test'");
    CHECK(!gv_file_exists(path));
    gv_clip_free(&clip);
}

/* Single-byte corruptions anywhere in the header and near the start of the data: every read
 * either succeeds or fails with a message naming the file (and never crashes; ASan run). */
static void test_clip_corruptions(const char *dir)
{
    gv_clip clip, back;
    make_clip(&clip, 4, 3, 21);
    char path[4200];
    snprintf(path, sizeof path, "%s/flip.safetensors", dir);
    CHECK(gv_clip_write(path, &clip) == 0);
    char *data;
    size_t size;
    CHECK(gv_read_file(path, &data, &size) == 0);
    uint64_t header = 0;
    for (int i = 0; i < 8; i++) header |= (uint64_t)(uint8_t)data[i] << (8 * i);
    int named = 1, failures = 0;
    for (size_t pos = 0; pos < 8 + header + 16 && pos < size; pos++) {
        uint8_t saved = (uint8_t)data[pos];
        data[pos] = (char)(saved ^ (pos % 7 == 0 ? 0x80 : 0x01 << (pos % 7)));
        FILE *f = fopen(path, "wb");
        fwrite(data, 1, size, f);
        fclose(f);
        gv_clear_error();
        if (gv_clip_read(path, &back) == 0) gv_clip_free(&back);
        else failures++, named &= strstr(gv_last_error(), "flip.safetensors") != NULL;
        data[pos] = (char)saved;
    }
    CHECK(named);
    CHECK(failures > (int)header / 2); /* most header bytes matter */
    free(data);
    gv_clip_free(&clip);
}

/* ---- manifest and run records -------------------------------------------------------- */

static gv_manifest_clip clip_entry(const char *scene, int n, int k, const char *split, int s)
{
    gv_manifest_clip c = {0};
    gv_clip_file_name(c.file, sizeof c.file, scene, n, k);
    snprintf(c.id.scene, sizeof c.id.scene, "%s", scene);
    snprintf(c.id.split, sizeof c.id.split, "%s", split);
    c.id.interval = n;
    int f[5] = {s, s + 2, s + 3, s + 4, s + n};
    memcpy(c.frames, f, sizeof f);
    return c;
}

static void write_text(const char *path, const char *text)
{
    FILE *f = fopen(path, "w");
    fputs(text, f);
    fclose(f);
}

static void test_manifest(const char *base)
{
    char dir[4200], path[4300];
    snprintf(dir, sizeof dir, "%s/manifest", base);
    gv_mkdirs(dir);
    gv_manifest m, back;
    int found = 1;
    CHECK(gv_manifest_read(dir, &back, &found) == 0 && found == 0 && back.n_runs == 0);
    gv_dataset_params p;
    gv_dataset_default_params(&p);
    CHECK(p.densify == GV_DENSIFY_REFERENCE); /* the trainer's default */
    p.seed = 77, p.sampling = GV_SAMPLING_RANDOM, p.clips_per_run = 2, p.densify = GV_DENSIFY_MCMC;
    gv_manifest_init(&m, &p);
    gv_manifest_run r1 = {{"zeta", "train", 6}, 2, 12.5}, r2 = {{"alpha", "eval", 8}, 1, 3.0};
    gv_manifest_clip c1[2] = {clip_entry("zeta", 6, 1, "train", 6), clip_entry("zeta", 6, 0, "train", 0)};
    gv_manifest_clip c2[1] = {clip_entry("alpha", 8, 0, "eval", 8)};
    CHECK(gv_manifest_add_run(&m, &r1, c1, 2) == 0 && gv_manifest_add_run(&m, &r2, c2, 1) == 0);
    CHECK(m.n_runs == 2 && !strcmp(m.runs[0].id.scene, "alpha")); /* sorted by scene */
    CHECK(m.n_clips == 3 && !strcmp(m.clips[1].file, "clips/zeta_n06_000.safetensors"));
    /* Replacing a run drops its previous clips. */
    gv_manifest_run r1b = {{"zeta", "train", 6}, 1, 13.0};
    CHECK(gv_manifest_add_run(&m, &r1b, c1 + 1, 1) == 0 && m.n_runs == 2 && m.n_clips == 2);
    CHECK(gv_manifest_find_run(&m, "zeta", 6) == 1 && gv_manifest_find_run(&m, "zeta", 8) == -1);
    CHECK(gv_manifest_write(dir, &m) == 0);
    CHECK(gv_manifest_read(dir, &back, &found) == 0 && found == 1);
    CHECK(back.n_runs == 2 && back.n_clips == 2 && back.params.seed == 77 &&
          back.params.sampling == GV_SAMPLING_RANDOM && back.params.clips_per_run == 2 &&
          back.params.iters == 8000 && back.params.densify == GV_DENSIFY_MCMC);
    CHECK(!memcmp(back.clips, m.clips, 2 * sizeof *m.clips));
    CHECK(!strcmp(back.runs[1].id.scene, "zeta") && back.runs[1].n_clips == 1 &&
          back.runs[1].seconds == 13.0 && !strcmp(back.runs[0].id.split, "eval"));
    gv_manifest_free(&back);
    /* The file a Python reader sees. */
    char *text;
    snprintf(path, sizeof path, "%s/manifest.json", dir);
    CHECK(gv_read_file(path, &text, NULL) == 0);
    CHECK(strstr(text, "\"file\":\t\"clips/alpha_n08_000.safetensors\"") != NULL);
    CHECK(strstr(text, "\"record\":\t\"runs/zeta_n06.json\"") != NULL);
    CHECK(strstr(text, "\"densify\":\t\"mcmc\"") != NULL);
    free(text);
    gv_manifest_free(&m);

    /* A folder from before "densify" was recorded was built with the reference's control. */
    write_text(path, "{\"format\": \"gaussvid.clips\", \"format_version\": 1, \"params\": {\"iters\": 10, "
                     "\"anchor_gap\": 1, \"clips_per_run\": 1, \"seed\": 0, \"downscale\": 1, \"sampling\": "
                     "\"uniform\"}, \"runs\": [], \"clips\": []}");
    CHECK(gv_manifest_read(dir, &back, &found) == 0 && back.params.densify == GV_DENSIFY_REFERENCE);
    gv_manifest_free(&back);

    struct { const char *text, *needle; } bad[] = {
        {"{\"format\": \"gaussvid.clips\"", "not a JSON object"},
        {"[1, 2]", "not a JSON object"},
        {"{\"format\": \"other\", \"format_version\": 1}", "not a gaussvid dataset manifest"},
        {"{\"format\": \"gaussvid.clips\", \"format_version\": 9}", "version"},
        {"{\"format\": \"gaussvid.clips\", \"format_version\": 1, \"runs\": [], \"clips\": []}", "\"params\""},
        {"{\"format\": \"gaussvid.clips\", \"format_version\": 1, \"params\": {\"iters\": 10, "
         "\"anchor_gap\": 1, \"clips_per_run\": 1, \"seed\": 0, \"downscale\": 1, \"sampling\": "
         "\"uniform\"}, \"runs\": [{\"scene\": \"a\", \"n\": 6, \"split\": \"train\", \"clips\": 1}], "
         "\"clips\": [{\"file\": \"clips/a.safetensors\", \"scene\": \"b\", \"n\": 6, \"split\": "
         "\"train\", \"frame_indices\": [0, 2, 3, 4, 6]}]}", "not a run of the manifest"},
        {"{\"format\": \"gaussvid.clips\", \"format_version\": 1, \"params\": {\"iters\": 10, "
         "\"anchor_gap\": 1, \"clips_per_run\": 1, \"seed\": 0, \"downscale\": 1, \"sampling\": "
         "\"uniform\"}, \"runs\": [{\"scene\": \"a\", \"n\": 6, \"split\": \"train\", \"clips\": 1}, "
         "{\"scene\": \"a\", \"n\": 6, \"split\": \"train\", \"clips\": 1}], \"clips\": []}", "listed twice"},
        {"{\"format\": \"gaussvid.clips\", \"format_version\": 1, \"params\": {\"iters\": 10, "
         "\"anchor_gap\": 1, \"clips_per_run\": 1, \"seed\": 0, \"downscale\": 1, \"sampling\": "
         "\"uniform\"}, \"runs\": [{\"scene\": \"a\", \"n\": 6, \"split\": \"train\", \"clips\": 1}], "
         "\"clips\": [{\"file\": \"../x.safetensors\", \"scene\": \"a\", \"n\": 6, \"split\": "
         "\"train\", \"frame_indices\": [0, 2, 3, 4, 6]}]}", "inside the dataset folder"},
        {"{\"format\": \"gaussvid.clips\", \"format_version\": 1, \"params\": {\"iters\": 10, "
         "\"anchor_gap\": 1, \"clips_per_run\": 1, \"seed\": 0, \"downscale\": 1, \"sampling\": "
         "\"uniform\"}, \"runs\": [{\"scene\": \"a\", \"n\": 6.5, \"split\": \"train\", \"clips\": 1}], "
         "\"clips\": []}", "runs[0]: \"n\""},
        {"{\"format\": \"gaussvid.clips\", \"format_version\": 1, \"params\": {\"iters\": 10, "
         "\"anchor_gap\": 1, \"clips_per_run\": 1, \"seed\": 0, \"downscale\": 1, \"sampling\": "
         "\"uniform\"}, \"runs\": [{\"scene\": \"a\", \"n\": 6, \"split\": \"train\", \"clips\": 1}], "
         "\"clips\": [{\"file\": \"clips/a.safetensors\", \"scene\": \"a\", \"n\": 6, \"split\": "
         "\"train\", \"frame_indices\": [0, 2, 3, 4]}]}", "frame_indices"},
        {"{\"format\": \"gaussvid.clips\", \"format_version\": 1, \"params\": {\"iters\": 10, "
         "\"anchor_gap\": 1, \"clips_per_run\": 1, \"seed\": 0, \"downscale\": 1, \"sampling\": "
         "\"uniform\", \"densify\": \"dense\"}, \"runs\": [], \"clips\": []}", "densify \"dense\""},
    };
    for (int i = 0; i < (int)(sizeof bad / sizeof bad[0]); i++) {
        write_text(path, bad[i].text);
        CHECK_FAILS_WITH(gv_manifest_read(dir, &back, &found), bad[i].needle);
        CHECK(strstr(gv_last_error(), "manifest.json") != NULL);
    }
}

static void test_run_record(const char *dir)
{
    char path[4200];
    snprintf(path, sizeof path, "%s/run.json", dir);
    gv_run_record r = {0}, back;
    snprintf(r.id.scene, sizeof r.id.scene, "courtyard");
    snprintf(r.id.split, sizeof r.id.split, "train");
    r.id.interval = 10, r.iters = 8000, r.n_train = 16, r.n_clips = 4;
    r.seconds = 120.25, r.train_seconds = 100.5, r.render_seconds = 18.0;
    r.train_frames = 16, r.train_psnr = 33.5, r.train_ssim = 0.96875;
    CHECK(gv_run_record_alloc(&r, 3) == 0);
    const double psnr[3] = {20.5, 22.25, INFINITY}, ssim[3] = {0.5, 0.75, 1.0};
    for (int i = 0; i < 3; i++) r.held_out[i] = i + 1, r.psnr[i] = psnr[i], r.ssim[i] = ssim[i];
    gv_run_record_summarise(&r);
    CHECK_NEAR(r.psnr_mean, (20.5 + 22.25 + 100) / 3, 1e-12); /* identical frames count as 100 dB */
    CHECK_NEAR(r.ssim_mean, 0.75, 1e-12);
    CHECK(gv_run_record_write(path, &r) == 0);
    CHECK(gv_run_record_read(path, &back) == 0);
    CHECK(!strcmp(back.id.scene, "courtyard") && back.id.interval == 10 && back.iters == 8000 &&
          back.n_train == 16 && back.n_clips == 4 && back.n_held_out == 3);
    CHECK(back.held_out[2] == 3 && back.psnr[1] == 22.25 && back.ssim[0] == 0.5);
    CHECK_NEAR(back.psnr_mean, r.psnr_mean, 1e-9);
    CHECK(back.seconds == 120.25 && back.train_seconds == 100.5 && back.render_seconds == 18.0);
    CHECK(back.train_frames == 16 && back.train_psnr == 33.5 && back.train_ssim == 0.96875);
    gv_run_record_free(&back);
    gv_run_record_free(&r);
    write_text(path, "{\"scene\": \"a\", \"split\": \"train\", \"n\": 6}");
    CHECK_FAILS_WITH(gv_run_record_read(path, &back), "run.json: needs numbers");
    write_text(path, "{\"scene\": \"a\", \"split\": \"train\", \"n\": 6, \"iters\": 1, \"train_views\": 3, "
                     "\"clips\": 1, \"seconds\": 1, \"train_seconds\": 1, \"frames\": [{\"frame\": 1, "
                     "\"psnr\": 20, \"ssim\": 2}]}");
    CHECK_FAILS_WITH(gv_run_record_read(path, &back), "frames[0]");
    /* Without "train" (records of older builds) it reads, with train_frames 0; a bad one fails. */
    write_text(path, "{\"scene\": \"a\", \"split\": \"train\", \"n\": 6, \"iters\": 1, \"train_views\": 3, "
                     "\"clips\": 1, \"seconds\": 1, \"train_seconds\": 1, \"frames\": []}");
    CHECK(gv_run_record_read(path, &back) == 0 && back.train_frames == 0);
    gv_run_record_free(&back);
    write_text(path, "{\"scene\": \"a\", \"split\": \"train\", \"n\": 6, \"iters\": 1, \"train_views\": 3, "
                     "\"clips\": 1, \"seconds\": 1, \"train_seconds\": 1, \"frames\": [], "
                     "\"train\": {\"psnr\": 30, \"ssim\": 0.9, \"frames\": 0}}");
    CHECK_FAILS_WITH(gv_run_record_read(path, &back), "\"train\" needs");
    write_text(path, "not json");
    CHECK_FAILS_WITH(gv_run_record_read(path, &back), "run.json: not a JSON object");
}

int main(void)
{
    const char *dir = check_tmp_dir();
    test_uniform_gap1();
    test_uniform_wide_gap();
    test_released();
    test_random();
    test_sample_clips();
    test_interval_checks();
    test_clip_round_trip(dir);
    test_bad_clips(dir);
    test_clip_corruptions(dir);
    test_manifest(dir);
    test_run_record(dir);
    return check_summary();
}
