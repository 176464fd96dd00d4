/* The plan of one interval (pipeline.h): training views, the evaluated frames and the clips
 * that restore them. Held-out frames: each gap between consecutive training views s and
 * s + n holds n - 1 of them, restored by ceil((n - 1) / 3) clips with the anchors s and s + n
 * (the layout of `dataset build`, docs/FORMATS-DATASET.md); the last clip of a gap takes the
 * gap's last three frames and restores those the earlier clips did not. Smooth path (n = 1):
 * one clip per pair of consecutive views, its three frames at a quarter, half and three
 * quarters of the way. */
#include <stdlib.h>
#include <string.h>

#include "gaussvid/core/core.h"
#include "gaussvid/splat/splat_train.h"
#include "pipeline/pipeline_internal.h"

#define SLOTS GV_INTERVAL_CLIP_HELD_OUT /* restored frames per clip */

void pipeline_plan_free(pipeline_run *r)
{
    free(r->train), free(r->held_out), free(r->frames), free(r->clips);
    r->train = r->held_out = NULL, r->frames = NULL, r->clips = NULL;
}

static int plan_held_out(pipeline_run *r)
{
    const gv_scene *s = r->scene;
    int gaps = r->n_train - 1, per_gap = (r->interval - 1 + SLOTS - 1) / SLOTS;
    r->frames = calloc((size_t)gaps * (r->interval - 1) + 1, sizeof *r->frames);
    r->clips = calloc((size_t)gaps * per_gap + 1, sizeof *r->clips);
    if (!r->frames || !r->clips) return gv_fail("out of memory for the plan of n = %d", r->interval);
    for (int k = 0; k < gaps; k++) {
        int first = r->n_frames, start = r->train[k] + 1, m = r->interval - 1;
        for (int i = 0; i < m; i++) {
            pipeline_frame *f = &r->frames[r->n_frames++];
            f->index = f->truth = start + i;
            f->camera = s->cameras[start + i];
        }
        for (int g = 0; g < per_gap; g++) {
            int from = g * SLOTS < m - SLOTS ? g * SLOTS : m - SLOTS; /* the last clip: the last 3 */
            int *c = r->clips[r->n_clips];
            c[0] = -1 - k, c[GV_CLIP_FRAMES - 1] = -2 - k;
            for (int j = 0; j < SLOTS; j++) {
                pipeline_frame *f = &r->frames[first + from + j];
                c[1 + j] = first + from + j;
                if (from + j >= g * SLOTS) f->clip = r->n_clips, f->slot = 1 + j; /* not yet restored */
            }
            r->n_clips++;
        }
    }
    return 0;
}

static int plan_smooth_path(pipeline_run *r)
{
    int gaps = r->n_train - 1;
    r->frames = calloc((size_t)gaps * SLOTS, sizeof *r->frames);
    r->clips = calloc((size_t)gaps, sizeof *r->clips);
    if (!r->frames || !r->clips) return gv_fail("out of memory for the plan of a %d-view path", r->n_train);
    for (int k = 0; k < gaps; k++) {
        const gv_camera *a = &r->scene->cameras[r->train[k]], *b = &r->scene->cameras[r->train[k + 1]];
        int *c = r->clips[k];
        c[0] = -1 - k, c[GV_CLIP_FRAMES - 1] = -2 - k;
        for (int j = 1; j <= SLOTS; j++) {
            pipeline_frame *f = &r->frames[r->n_frames];
            f->index = (SLOTS + 1) * k + j;
            f->truth = -1;
            gv_camera_interpolate(a, b, (double)j / (SLOTS + 1), &f->camera);
            f->clip = k, f->slot = j;
            c[j] = r->n_frames++;
        }
    }
    r->n_clips = gaps;
    return 0;
}

/* A photo's name as a file stem: the extension dropped, anything but letters, digits, '.',
 * '-' and '_' (a folder's '/', spaces) made '_', at most max - 1 bytes. */
static void stem_of(const char *image_name, char *out, size_t max)
{
    size_t n = 0;
    const char *dot = strrchr(image_name, '.'), *slash = strrchr(image_name, '/');
    if (dot && slash && dot < slash) dot = NULL; /* a dot in a folder name */
    for (const char *c = image_name; *c && c != dot && n + 1 < max; c++) {
        int keep = (*c >= 'a' && *c <= 'z') || (*c >= 'A' && *c <= 'Z') || (*c >= '0' && *c <= '9') || *c == '.' ||
                   *c == '-' || *c == '_';
        out[n++] = keep ? *c : '_';
    }
    if (n == 0) out[n++] = '_';
    out[n] = 0;
}

/* Frames named after the photos; two photos that make one stem (x.jpg and x.png) keep their
 * frame numbers too, so every name of the run is unique. */
static int name_frames(pipeline_run *r)
{
    const gv_camera *cams = r->scene->cameras;
    for (int i = 0; i < r->n_frames; i++) {
        pipeline_frame *f = &r->frames[i];
        if (!r->smooth_path) {
            stem_of(cams[f->index].name, f->name, sizeof f->name);
            continue;
        }
        int k = f->index / (SLOTS + 1), j = f->index % (SLOTS + 1);
        char a[64], b[64];
        stem_of(cams[r->train[k]].name, a, sizeof a), stem_of(cams[r->train[k + 1]].name, b, sizeof b);
        snprintf(f->name, sizeof f->name, "%s_to_%s_%dof%d", a, b, j, SLOTS + 1);
    }
    char *clash = calloc((size_t)r->n_frames + 1, 1);
    if (!clash) return gv_fail("out of memory naming %d frames", r->n_frames);
    for (int i = 0; i < r->n_frames; i++)
        for (int k = i + 1; k < r->n_frames; k++)
            if (!strcmp(r->frames[k].name, r->frames[i].name)) clash[i] = clash[k] = 1;
    for (int i = 0; i < r->n_frames; i++) {
        pipeline_frame *f = &r->frames[i];
        char stem[PIPELINE_NAME_MAX - 16];
        snprintf(stem, sizeof stem, "%s", f->name);
        if (clash[i]) snprintf(f->name, sizeof f->name, "%s_%05d", stem, f->index);
    }
    free(clash);
    return 0;
}

int pipeline_plan(pipeline_run *r, const gv_scene *scene, int n)
{
    int total = scene->n_frames;
    r->scene = scene, r->interval = n, r->smooth_path = n == 1;
    r->n_frames = r->n_clips = 0;
    if (gv_interval_check(n, total, GV_INTERVAL_RECONSTRUCT)) return gv_fail_context("%s: --interval", scene->dir);
    r->train = malloc((size_t)total * sizeof *r->train);
    r->held_out = malloc((size_t)total * sizeof *r->held_out);
    if (!r->train || !r->held_out) return gv_fail("out of memory for %d frames", total);
    if (gv_scene_split(total, n, r->train, &r->n_train, r->held_out, &r->n_held_out)) return -1;
    if (r->smooth_path ? plan_smooth_path(r) : plan_held_out(r)) return -1;
    return name_frames(r);
}

static const char *frame_name(const pipeline_run *r, int frame)
{
    for (int i = 0; i < r->n_frames; i++)
        if (r->frames[i].index == frame) return r->frames[i].name;
    return NULL;
}

int pipeline_file(const pipeline_run *r, const char *name, char *out, size_t size)
{
    return gv_path_join(out, size, r->dir, name);
}

int pipeline_frame_path(const pipeline_run *r, const char *what, int frame, char *out, size_t size)
{
    const char *name = frame_name(r, frame);
    if (!name) return gv_fail("%s: frame %d is not one of the run's", r->dir, frame);
    int len = snprintf(out, size, "%s/frames/%s/%s.png", r->dir, what, name);
    return len < 0 || (size_t)len >= size ? gv_fail("%s: path too long", r->dir) : 0;
}

void pipeline_frame_relpath(const pipeline_run *r, const char *what, int frame, char *out, size_t size)
{
    const char *name = frame_name(r, frame);
    snprintf(out, size, "n%d/frames/%s/%s.png", r->interval, what, name ? name : "?");
}
