/* The frames of reconstruct's video (src/pipeline/video_frames.c) on a hand-built run: a wall
 * of Gaussians seen by three cameras on a line, n = 1 (a smooth path, render | restored). The
 * fly-through is 2 gaps x 8 + 1 frames whose panels are, outside their label bands, exactly the
 * sparse and the refined model rendered at the interpolated pose (the first at the first
 * training camera, the middle of a gap at gv_camera_interpolate(a, b, 1/2), the last at the
 * last camera); the bands are the image darkened to 0.35 with the label's ink in white; the
 * evaluated frames show their render and restored files named after the photos, captioned in
 * amber. */
#include <stdint.h>

#include "check.h"
#include "gaussvid/core/core.h"
#include "gaussvid/io/image.h"
#include "gaussvid/io/ply.h"
#include "gaussvid/splat/splat_train.h"
#include "pipeline/pipeline_internal.h"

enum { W = 48, H = 32 };

static gv_camera wall_camera(int k)
{
    gv_camera c;
    memset(&c, 0, sizeof c);
    c.width = W, c.height = H, c.fx = c.fy = 24, c.cx = W / 2.0, c.cy = H / 2.0;
    c.R[0] = c.R[4] = c.R[8] = 1;
    c.t[0] = -0.3 * k;
    snprintf(c.name, sizeof c.name, "IMG_%04d.JPG", k + 1);
    return c;
}

/* A textured wall at z = 2; tint shifts the colours (the "refined" model). */
static void wall(gv_gaussians *g, float tint)
{
    const int side = 61;
    CHECK(gv_gaussians_alloc(g, side * side, 0) == 0);
    for (int i = 0; i < side * side; i++) {
        int x = i % side, y = i / side;
        g->means[3 * i] = -3 + 0.1f * (float)x, g->means[3 * i + 1] = -3 + 0.1f * (float)y, g->means[3 * i + 2] = 2;
        g->scales[3 * i] = g->scales[3 * i + 1] = logf(0.06f), g->scales[3 * i + 2] = logf(0.001f);
        g->rotations[4 * i] = 1;
        g->opacities[i] = 5;
        g->sh[3 * i] = (float)((x * 7) % 5) * 0.3f - 0.6f + tint;
        g->sh[3 * i + 1] = (float)((y * 3) % 4) * 0.3f - 0.5f;
        g->sh[3 * i + 2] = tint;
    }
}

/* Panel p of a video frame against an image: equal, except in the label and caption bands,
 * where a pixel may also be the image darkened to 0.35 or a label's ink (white or amber).
 * Returns the pixels that differ; counts in *inked the band's pixels of colour ink. */
static int panel_differs(const pipeline_video_frames *v, const uint8_t *frame, int p, const gv_image *img,
                         const uint8_t ink[3], int *inked)
{
    int band = GV_GLYPH_H * v->scale + 4 * v->scale, wrong = 0;
    for (int y = 0; y < H; y++)
        for (int x = 0; x < W; x++) {
            const uint8_t *got = frame + ((size_t)y * v->W + (size_t)p * W + x) * 3, *want = img->pixels + ((size_t)y * W + x) * 3;
            int same = memcmp(got, want, 3) == 0, in_band = y < band || y >= H - band;
            int dark = 1, is_ink = got[0] == ink[0] && got[1] == ink[1] && got[2] == ink[2];
            for (int c = 0; c < 3; c++) dark &= got[c] == (uint8_t)(want[c] * 0.35 + 0.5);
            *inked += in_band && is_ink;
            int white = got[0] == 255 && got[1] == 255 && got[2] == 255, amber = got[0] == 255 && got[1] == 176 && got[2] == 0;
            wrong += !(same || (in_band && (dark || white || amber)));
        }
    return wrong;
}

static void render(const gv_gaussians *g, const gv_camera *cam, gv_image *out)
{
    static const float black[3] = {0, 0, 0};
    gv_splat_renderer r;
    memset(&r, 0, sizeof r);
    CHECK(gv_splat_render_camera(&r, g, cam, black, out) == 0);
    gv_splat_renderer_free(&r);
}

static void test_video(const char *tmp)
{
    gv_camera cams[3] = {wall_camera(0), wall_camera(1), wall_camera(2)};
    gv_scene scene;
    memset(&scene, 0, sizeof scene);
    snprintf(scene.dir, sizeof scene.dir, "hand");
    scene.n_frames = 3, scene.cameras = cams;
    gv_reconstruct_options opt;
    gv_reconstruct_defaults(&opt);
    pipeline_run r;
    memset(&r, 0, sizeof r);
    r.opt = &opt;
    snprintf(r.dir, sizeof r.dir, "%s/n1", tmp);
    REQUIRE(pipeline_plan(&r, &scene, 1) == 0);
    gv_gaussians models[2];
    wall(&models[0], 0), wall(&models[1], 0.4f);
    char path[4200];
    CHECK(pipeline_file(&r, "sparse.ply", path, sizeof path) == 0 && gv_mkdirs(r.dir) == 0 &&
          gv_gaussians_write_ply(path, &models[0]) == 0);
    CHECK(pipeline_file(&r, "refined.ply", path, sizeof path) == 0 && gv_gaussians_write_ply(path, &models[1]) == 0);
    /* the evaluated frames' files: the render, and a "restored" frame of its own (inverted) */
    for (int i = 0; i < r.n_frames; i++) {
        gv_image img = {0};
        render(&models[0], &r.frames[i].camera, &img);
        char dir[4200];
        snprintf(dir, sizeof dir, "%s/frames/render", r.dir), gv_mkdirs(dir);
        snprintf(dir, sizeof dir, "%s/frames/restored", r.dir), gv_mkdirs(dir);
        CHECK(pipeline_frame_path(&r, "render", r.frames[i].index, path, sizeof path) == 0 && gv_image_write_png(path, &img) == 0);
        for (int k = 0; k < W * H * 3; k++) img.pixels[k] = (uint8_t)(255 - img.pixels[k]);
        CHECK(pipeline_frame_path(&r, "restored", r.frames[i].index, path, sizeof path) == 0 && gv_image_write_png(path, &img) == 0);
        gv_image_free(&img);
    }

    pipeline_video_frames v;
    REQUIRE(pipeline_video_open(&v, &r) == 0);
    CHECK(v.panels == 2 && v.W == 2 * W && v.H == H && v.steps == 8 && v.n_flight == 17 && v.n_total == 17 + 6);
    uint8_t *frame = malloc((size_t)v.W * v.H * 3);
    static const uint8_t WHITE[3] = {255, 255, 255}, AMBER[3] = {255, 176, 0};
    /* fly-through: frames 0 (camera 0), 4 (half way to camera 1), 16 (camera 2) */
    const int at[3] = {0, 4, 16};
    for (int q = 0; q < 3; q++) {
        gv_camera pose;
        if (q == 1) gv_camera_interpolate(&cams[0], &cams[1], 0.5, &pose);
        else pose = cams[q == 0 ? 0 : 2];
        REQUIRE(pipeline_video_frame(&v, at[q], frame) == 0);
        for (int m = 0; m < 2; m++) {
            gv_image want = {0};
            render(&models[m], &pose, &want);
            int inked = 0, wrong = panel_differs(&v, frame, m, &want, WHITE, &inked);
            printf("  fly-through frame %d, %s: %d pixels differ, %d inked\n", at[q], m ? "refined" : "sparse", wrong, inked);
            CHECK(wrong == 0 && inked > 20);
            gv_image_free(&want);
        }
    }
    /* the evaluated frames: render and restored files, captioned in amber */
    REQUIRE(pipeline_video_frame(&v, 17 + 4, frame) == 0);
    for (int p = 0; p < 2; p++) {
        gv_image want = {0};
        CHECK(pipeline_frame_path(&r, p ? "restored" : "render", r.frames[4].index, path, sizeof path) == 0 &&
              gv_image_read_rgb(path, &want) == 0);
        int inked = 0, wrong = panel_differs(&v, frame, p, &want, AMBER, &inked);
        CHECK(wrong == 0 && (p == 1 || inked > 20)); /* the caption starts in the first panel */
        gv_image_free(&want);
    }
    /* r.frames[4] is path frame 6: gap 1 (IMG_0002 to IMG_0003), half way */
    CHECK(strstr(path, "/frames/restored/IMG_0002_to_IMG_0003_2of4.png") != NULL);
    remove(path);
    CHECK_FAILS_WITH(pipeline_video_frame(&v, 17 + 4, frame), "IMG_0002_to_IMG_0003_2of4.png");
    pipeline_video_close(&v);
    free(frame);
    gv_gaussians_free(&models[0]), gv_gaussians_free(&models[1]);
    pipeline_plan_free(&r);
}

int main(void)
{
    const char *tmp = check_tmp_dir();
    gv_log_set_level(GV_LOG_QUIET);
    test_video(tmp);
    return check_summary();
}
