/* What the video of a run shows, frame by frame (docs/RECONSTRUCT.md, "The video"):
 *   1. a fly-through: a smooth path through the training cameras (gv_camera_interpolate:
 *      rotations by slerp, centres and intrinsics linearly), `steps` frames per gap, the
 *      sparse and the refined model rendered side by side (the sparse alone with --no-restore),
 *      and with ground truth the scene's photo nearest on the capture's path beside them, a
 *      held-out photo marked in amber;
 *   2. every evaluated frame: its sparse render, its restored frame (not with --no-restore) and
 *      its ground truth (not on a smooth path), named after its photo.
 * Each panel is labelled at its top and each frame says at its bottom where it is, in the
 * bitmap font of gv_image_draw_text, so the labels need no font file and no ffmpeg filter. */
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "gaussvid/core/core.h"
#include "gaussvid/io/ply.h"
#include "gaussvid/splat/splat_train.h"
#include "pipeline/pipeline_internal.h"

static const uint8_t WHITE[3] = {255, 255, 255}, AMBER[3] = {255, 176, 0};

int pipeline_video_open(pipeline_video_frames *v, pipeline_run *r)
{
    memset(v, 0, sizeof *v);
    v->r = r;
    v->w = r->frames[0].camera.width, v->h = r->frames[0].camera.height;
    v->restoring = r->opt->restore_with != GV_RESTORE_NONE;
    v->truth = r->frames[0].truth >= 0;
    v->panels = 1 + v->restoring + v->truth;
    v->W = (v->panels * v->w + 1) & ~1, v->H = (v->h + 1) & ~1;
    v->scale = v->h / 144 > 1 ? v->h / 144 : 1;
    v->steps = r->interval > 8 ? r->interval : 8;
    v->n_flight = (r->n_train - 1) * v->steps + 1;
    v->n_total = v->n_flight + r->n_frames;
    char path[4200];
    if (pipeline_file(r, "sparse.ply", path, sizeof path) || gv_gaussians_read_ply(path, &v->models[0]) ||
        (v->restoring &&
         (pipeline_file(r, "refined.ply", path, sizeof path) || gv_gaussians_read_ply(path, &v->models[1])))) {
        pipeline_video_close(v);
        return -1;
    }
    return 0;
}

void pipeline_video_close(pipeline_video_frames *v)
{
    gv_gaussians_free(&v->models[0]), gv_gaussians_free(&v->models[1]);
    gv_splat_renderer_free(&v->renderer);
}

/* A label at the top of panel p, on a darkened band, cut to the characters that fit the panel. */
static void label(const pipeline_video_frames *v, gv_image *canvas, int p, const char *text, const uint8_t rgb[3])
{
    int pad = 2 * v->scale, band = GV_GLYPH_H * v->scale + 2 * pad;
    int fit = (v->w - 2 * pad + v->scale) / ((GV_GLYPH_W + 1) * v->scale);
    char cut[64];
    snprintf(cut, sizeof cut, "%.*s", fit > 0 ? fit : 0, text);
    gv_image_shade_rect(canvas, p * v->w, 0, gv_text_width(cut, v->scale) + 2 * pad, band, 0.35);
    gv_image_draw_text(canvas, p * v->w + pad, pad, cut, v->scale, rgb);
}

/* A line at the bottom of the frame, across the panels. */
static void caption(const pipeline_video_frames *v, gv_image *canvas, const char *text, const uint8_t rgb[3])
{
    int pad = 2 * v->scale, band = GV_GLYPH_H * v->scale + 2 * pad;
    gv_image_shade_rect(canvas, 0, v->h - band, v->panels * v->w, band, 0.35);
    gv_image_draw_text(canvas, pad, v->h - band + pad, text, v->scale, rgb);
}

static int paste(const pipeline_video_frames *v, gv_image *canvas, int p, const gv_image *img, const char *what)
{
    if (img->width != v->w || img->height != v->h || img->channels != 3)
        return gv_fail("%s: %s is %dx%d, not %dx%d", v->r->dir, what, img->width, img->height, v->w, v->h);
    for (int y = 0; y < v->h; y++)
        memcpy(canvas->pixels + ((size_t)y * v->W + (size_t)p * v->w) * 3, img->pixels + (size_t)y * v->w * 3,
               (size_t)v->w * 3);
    return 0;
}

static int paste_file(const pipeline_video_frames *v, gv_image *canvas, int p, const char *path)
{
    gv_image img = {0};
    int rc = gv_image_read_rgb(path, &img) || paste(v, canvas, p, &img, path);
    gv_image_free(&img);
    return rc;
}

static int paste_photo(const pipeline_video_frames *v, gv_image *canvas, int p, int frame)
{
    gv_image img = {0};
    int rc = gv_scene_load_image(v->r->scene, frame, &img) || paste(v, canvas, p, &img, v->r->scene->cameras[frame].name);
    gv_image_free(&img);
    return rc;
}

static int is_training_view(const pipeline_run *r, int frame)
{
    for (int k = 0; k < r->n_train; k++)
        if (r->train[k] == frame) return 1;
    return 0;
}

/* Fly-through frame i: the models at the path's pose, and the photo nearest on the capture. */
static int flight_frame(pipeline_video_frames *v, int i, gv_image *canvas)
{
    static const float black[3] = {0, 0, 0};
    const pipeline_run *r = v->r;
    int k = i / v->steps;
    double s = (double)(i % v->steps) / v->steps;
    if (k == r->n_train - 1) k--, s = 1; /* the last training view */
    const gv_camera *a = &r->scene->cameras[r->train[k]], *b = &r->scene->cameras[r->train[k + 1]];
    gv_camera pose;
    gv_camera_interpolate(a, b, s, &pose);
    static const char *const names[2] = {"sparse 3DGS", "refined 3DGS"};
    for (int m = 0; m < 1 + v->restoring; m++) {
        gv_image img = {0};
        int rc = gv_splat_render_camera(&v->renderer, &v->models[m], &pose, black, &img) ||
                 paste(v, canvas, m, &img, names[m]);
        gv_image_free(&img);
        if (rc) return -1;
        label(v, canvas, m, names[m], WHITE);
    }
    int nearest = r->train[k] + (int)lround(s * (r->train[k + 1] - r->train[k]));
    int held_out = !is_training_view(r, nearest);
    char text[PIPELINE_NAME_MAX + 64];
    if (v->truth) {
        if (paste_photo(v, canvas, v->panels - 1, nearest)) return -1;
        label(v, canvas, v->panels - 1, held_out ? "held-out photo" : "training photo", held_out ? AMBER : WHITE);
    }
    snprintf(text, sizeof text, "fly-through %d/%d, near %s%s", i + 1, v->n_flight, r->scene->cameras[nearest].name,
             held_out ? " (held out)" : " (training view)");
    caption(v, canvas, text, held_out ? AMBER : WHITE);
    return 0;
}

/* Evaluated frame j: render | restored | ground truth (those it has), named after its photo. */
static int evaluated_frame(pipeline_video_frames *v, int j, gv_image *canvas)
{
    const pipeline_run *r = v->r;
    const pipeline_frame *f = &r->frames[j];
    char path[4200], text[PIPELINE_NAME_MAX + 64];
    if (pipeline_frame_path(r, "render", f->index, path, sizeof path) || paste_file(v, canvas, 0, path))
        return -1;
    label(v, canvas, 0, "sparse render", WHITE);
    if (v->restoring) {
        if (pipeline_frame_path(r, "restored", f->index, path, sizeof path) || paste_file(v, canvas, 1, path))
            return -1;
        label(v, canvas, 1, "restored", WHITE);
    }
    if (v->truth) {
        if (paste_photo(v, canvas, v->panels - 1, f->truth)) return -1;
        label(v, canvas, v->panels - 1, "ground truth", WHITE);
    }
    if (r->smooth_path) snprintf(text, sizeof text, "path frame %s", f->name);
    else snprintf(text, sizeof text, "held out: %s", r->scene->cameras[f->index].name);
    caption(v, canvas, text, AMBER);
    return 0;
}

int pipeline_video_frame(pipeline_video_frames *v, int i, uint8_t *out)
{
    gv_image canvas = {.width = v->W, .height = v->H, .channels = 3, .pixels = out};
    memset(out, 0, (size_t)v->W * v->H * 3);
    return i < v->n_flight ? flight_frame(v, i, &canvas) : evaluated_frame(v, i - v->n_flight, &canvas);
}
