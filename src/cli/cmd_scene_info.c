/* gaussvid scene info DIR [--interval n] [--downscale k] [--json]: loads a scene folder,
 * checks that every frame's image opens and has its camera's size, and describes it
 * (docs/SCENES.md). The first problem found is reported as one line, exit code 1. */
#include <cjson/cJSON.h>
#include <float.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "cli/commands.h"
#include "gaussvid/core/core.h"
#include "gaussvid/scene/scene.h"

/* What is printed, in either form. */
typedef struct {
    const char *source;
    int shared_size, shared_intrinsics;
    double lo[6], hi[6];  /* ranges of width, height, fx, fy, cx, cy */
    double extent;
    int interval;         /* 0 when no split was asked for */
    int *train, n_train, *held_out, n_held_out;
    double train_extent;
} scene_summary;

static const char *source_name(gv_scene_source s)
{
    switch (s) {
    case GV_SCENE_FROM_COLMAP_BIN: return "COLMAP binary (sparse/0/*.bin)";
    case GV_SCENE_FROM_COLMAP_TEXT: return "COLMAP text (sparse/0/*.txt)";
    default: return "transforms.json";
    }
}

static void summarise(const gv_scene *s, scene_summary *sum)
{
    sum->source = source_name(s->source);
    for (int k = 0; k < 6; k++) sum->lo[k] = DBL_MAX, sum->hi[k] = -DBL_MAX;
    for (int i = 0; i < s->n_frames; i++) {
        const gv_camera *c = &s->cameras[i];
        const double v[6] = {c->width, c->height, c->fx, c->fy, c->cx, c->cy};
        for (int k = 0; k < 6; k++) {
            if (v[k] < sum->lo[k]) sum->lo[k] = v[k];
            if (v[k] > sum->hi[k]) sum->hi[k] = v[k];
        }
    }
    sum->shared_size = sum->lo[0] == sum->hi[0] && sum->lo[1] == sum->hi[1];
    sum->shared_intrinsics = sum->shared_size;
    for (int k = 2; k < 6; k++) sum->shared_intrinsics &= sum->lo[k] == sum->hi[k];
    sum->extent = gv_scene_extent(s, NULL, 0);
    if (sum->interval) sum->train_extent = gv_scene_extent(s, sum->train, sum->n_train);
}

/* Every image must open and have its camera's size. */
static int check_images(const gv_scene *s)
{
    gv_progress p;
    gv_progress_start(&p, "checking images", s->n_frames);
    for (int i = 0; i < s->n_frames; i++) {
        gv_image img;
        if (gv_scene_load_image(s, i, &img) != 0) {
            if (p.enabled && p.on_terminal) fputc('\n', stderr);
            return -1;
        }
        gv_image_free(&img);
        gv_progress_update(&p, i + 1, NULL);
    }
    gv_progress_finish(&p);
    return 0;
}

static void print_text(const gv_scene *s, const scene_summary *sum)
{
    static const char *names[6] = {"width", "height", "fx", "fy", "cx", "cy"};
    printf("scene       %s\nsource      %s\nframes      %d (images in %s", s->dir, sum->source,
           s->n_frames, s->image_dir);
    if (s->memory_downscale > 1) printf(", downscaled by %d in memory", s->memory_downscale);
    printf(")\n");
    if (sum->shared_size) printf("image size  %.0fx%.0f\n", sum->lo[0], sum->hi[1]);
    else printf("image size  %.0f..%.0f x %.0f..%.0f\n", sum->lo[0], sum->hi[0], sum->lo[1], sum->hi[1]);
    if (sum->shared_intrinsics) {
        printf("intrinsics  shared by all frames: fx %.6g fy %.6g cx %.6g cy %.6g\n", sum->lo[2],
               sum->lo[3], sum->lo[4], sum->lo[5]);
    } else {
        printf("intrinsics  differ between frames:");
        for (int k = 2; k < 6; k++) printf(" %s %.6g..%.6g", names[k], sum->lo[k], sum->hi[k]);
        printf("\n");
    }
    printf("points      %d\nextent      %.6g (all frames)\n", s->n_points, sum->extent);
    if (!sum->interval) return;
    printf("split       interval %d: %d training frames, %d held out\ntraining   ", sum->interval,
           sum->n_train, sum->n_held_out);
    for (int i = 0; i < sum->n_train; i++) printf(" %d", sum->train[i]);
    printf("\nextent      %.6g (training frames)\n", sum->train_extent);
    if (gv_interval_check(sum->interval, s->n_frames, GV_INTERVAL_RECONSTRUCT)) /* a split reconstruct refuses */
        printf("note        %s\n", gv_last_error());
}

/* A number, or a [min, max] pair when the frames differ. */
static cJSON *range(const scene_summary *sum, int k)
{
    if (sum->lo[k] == sum->hi[k]) return cJSON_CreateNumber(sum->lo[k]);
    const double pair[2] = {sum->lo[k], sum->hi[k]};
    return cJSON_CreateDoubleArray(pair, 2);
}

static int print_json(const gv_scene *s, const scene_summary *sum)
{
    static const char *names[6] = {"width", "height", "fx", "fy", "cx", "cy"};
    cJSON *root = cJSON_CreateObject(), *size = cJSON_CreateObject(), *intr = cJSON_CreateObject();
    cJSON_AddStringToObject(root, "dir", s->dir);
    cJSON_AddStringToObject(root, "source", s->source == GV_SCENE_FROM_COLMAP_BIN    ? "colmap_bin"
                                            : s->source == GV_SCENE_FROM_COLMAP_TEXT ? "colmap_text"
                                                                                     : "transforms");
    cJSON_AddStringToObject(root, "image_dir", s->image_dir);
    cJSON_AddNumberToObject(root, "downscale", s->downscale);
    cJSON_AddNumberToObject(root, "frames", s->n_frames);
    cJSON_AddBoolToObject(size, "shared", sum->shared_size);
    for (int k = 0; k < 2; k++) cJSON_AddItemToObject(size, names[k], range(sum, k));
    cJSON_AddItemToObject(root, "image_size", size);
    cJSON_AddBoolToObject(intr, "shared", sum->shared_intrinsics);
    for (int k = 2; k < 6; k++) cJSON_AddItemToObject(intr, names[k], range(sum, k));
    cJSON_AddItemToObject(root, "intrinsics", intr);
    cJSON_AddNumberToObject(root, "points", s->n_points);
    cJSON_AddNumberToObject(root, "extent", sum->extent);
    if (sum->interval) {
        cJSON *split = cJSON_CreateObject();
        cJSON_AddNumberToObject(split, "interval", sum->interval);
        cJSON_AddItemToObject(split, "train", cJSON_CreateIntArray(sum->train, sum->n_train));
        cJSON_AddNumberToObject(split, "held_out", sum->n_held_out);
        cJSON_AddNumberToObject(split, "train_extent", sum->train_extent);
        cJSON_AddItemToObject(root, "split", split);
    }
    char *text = cJSON_Print(root);
    cJSON_Delete(root);
    if (!text) return gv_fail("out of memory while writing the JSON");
    printf("%s\n", text);
    free(text);
    return 0;
}

static int run(const char *dir, int interval, int downscale, int json)
{
    gv_scene_options opt = {.downscale = downscale};
    gv_scene s;
    scene_summary sum = {.interval = interval};
    if (gv_scene_load(dir, &opt, &s) != 0) return -1;
    int ok = 0;
    if (interval && s.n_frames >= 2 && interval > s.n_frames - 1) /* the advice: what reconstruct takes here */
        ok = gv_interval_check(interval, s.n_frames, GV_INTERVAL_RECONSTRUCT) ? gv_fail_context("%s", dir) : 0;
    if (ok == 0 && interval) { /* before the images: a split that cannot work fails at once */
        sum.train = malloc((size_t)s.n_frames * sizeof(int));
        sum.held_out = malloc((size_t)s.n_frames * sizeof(int));
        if (!sum.train || !sum.held_out) ok = gv_fail("%s: out of memory", dir);
        else if (gv_scene_split(s.n_frames, interval, sum.train, &sum.n_train, sum.held_out,
                                &sum.n_held_out) != 0)
            ok = gv_fail_context("%s", dir);
    }
    if (ok == 0) ok = check_images(&s);
    if (ok == 0) {
        summarise(&s, &sum);
        if (json) ok = print_json(&s, &sum);
        else print_text(&s, &sum);
    }
    free(sum.train);
    free(sum.held_out);
    gv_scene_free(&s);
    return ok;
}

int cmd_scene_info(int argc, char **argv)
{
    int interval = -1, downscale = 1, json = 0; /* interval -1: no split asked for */
    const gv_flag flags[] = {
        {"interval", GV_FLAG_INT, &interval, "N", "also show the split: frames 0, N, 2N, ... train", 0},
        {"downscale", GV_FLAG_INT, &downscale, "K", "image downscale factor 1..64 (default 1)", 0},
        {"json", GV_FLAG_BOOL, &json, NULL, "print the description as JSON on stdout", 0},
    };
    const gv_command_spec spec = {
        "scene info", "DIR", "validate a scene folder and describe it (frames, cameras, split)",
        "Loads sparse/0 (binary, else text) or transforms.json, opens every frame's image and\n"
        "checks its size against its camera, then prints the source, frame count, image size,\n"
        "intrinsics, point count and scene extent (3DGS getNerfppNorm), and with --interval\n"
        "the training frames and the held-out count (with a note when reconstruct would refuse\n"
        "that n; it takes n = 1 or n >= 4). The first problem is reported as one line\n"
        "(exit code 1). The folder format is described in docs/SCENES.md.",
        flags, 3, 1, 1};
    char *positional[1];
    int n_positional = 0;
    int parsed = gv_args_parse(&spec, argc, argv, positional, &n_positional);
    if (parsed != GV_ARGS_OK) return gv_args_exit_code(parsed);
    const char *bad = interval != -1 && gv_interval_check(interval, 0, GV_INTERVAL_SPLIT) ? gv_last_error()
                      : downscale < 1 || downscale > 64 ? "--downscale must be in 1..64"
                                                        : NULL;
    if (bad) {
        fprintf(stderr, "gaussvid scene info: %s (see 'gaussvid scene info --help')\n", bad);
        return 2;
    }
    if (run(positional[0], interval > 0 ? interval : 0, downscale, json) != 0)
        return gv_report_failure();
    return 0;
}
