/* gaussvid splat render --model model.ply --scene DIR --frames SEL --out DIR: renders a
 * model from a scene's cameras (or along a path between them) to PNGs, and with --depth /
 * --opacity its expected depth and accumulated opacity to float32 .npy files. */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "cli/commands.h"
#include "gaussvid/core/core.h"
#include "gaussvid/io/npy.h"
#include "gaussvid/io/ply.h"
#include "gaussvid/scene/scene.h"
#include "gaussvid/splat/splat_train.h"

/* Frames chosen by "held-out", "train", "all" or a list "i,j,k" (in the given order).
 * frames holds scene->n_frames entries at most... for lists, up to `capacity`. */
static int select_frames(const gv_scene *scene, const char *sel, int interval, int *frames,
                         int capacity, int *n)
{
    int total = scene->n_frames, n_train, n_held;
    *n = 0;
    if (!strcmp(sel, "all")) {
        for (int i = 0; i < total; i++) frames[(*n)++] = i;
        return 0;
    }
    if (!strcmp(sel, "train") || !strcmp(sel, "held-out")) {
        int *other = malloc((size_t)total * sizeof(int));
        if (!other) return gv_fail("out of memory");
        int ok = !strcmp(sel, "train")
                     ? gv_scene_split(total, interval, frames, &n_train, other, &n_held)
                     : gv_scene_split(total, interval, other, &n_train, frames, &n_held);
        free(other);
        if (ok != 0) return gv_fail_context("%s", scene->dir);
        *n = !strcmp(sel, "train") ? n_train : n_held;
        if (*n == 0) return gv_fail("%s: no held-out frames at interval %d", scene->dir, interval);
        return 0;
    }
    for (const char *p = sel; *p;) {
        char *end;
        long v = strtol(p, &end, 10);
        if (end == p || (*end && *end != ',') || v < 0 || v >= total)
            return gv_fail("--frames %s: expected held-out, train, all or frame numbers 0..%d "
                           "separated by commas", sel, total - 1);
        if (*n >= capacity) return gv_fail("--frames %s: more than %d frames", sel, capacity);
        frames[(*n)++] = (int)v;
        p = *end ? end + 1 : end;
    }
    if (*n == 0) return gv_fail("--frames is empty");
    return 0;
}

/* out/<image name without folders and extension><suffix>, e.g. suffix ".png" */
static int out_path(char *path, size_t size, const char *dir, const char *image_name,
                    const char *suffix)
{
    const char *base = strrchr(image_name, '/');
    base = base ? base + 1 : image_name;
    char name[512];
    snprintf(name, sizeof name, "%s", base);
    char *dot = strrchr(name, '.');
    if (dot) *dot = '\0';
    if (strlen(name) + strlen(suffix) >= sizeof name)
        return gv_fail("%s: image name too long", image_name);
    strcat(name, suffix);
    return gv_path_join(path, size, dir, name);
}

/* The depth and opacity maps of the renderer's last forward of cam, as H x W .npy files
 * (docs/SPLAT_TRAINING.md); a flag of 0 skips that map. */
static int write_maps(const gv_splat_renderer *r, const gv_camera *cam, const char *out_dir,
                      int depth, int opacity)
{
    size_t pixels = (size_t)cam->width * cam->height;
    float *d = malloc(pixels * sizeof(float)), *o = malloc(pixels * sizeof(float));
    int64_t shape[2] = {cam->height, cam->width};
    char path[4200];
    int ok = d && o ? gv_splat_render_depth(r, d, o) : gv_fail("render: out of memory for maps");
    if (ok == 0 && depth) ok = out_path(path, sizeof path, out_dir, cam->name, ".depth.npy");
    if (ok == 0 && depth) ok = gv_npy_write_f32(path, 2, shape, d);
    if (ok == 0 && opacity) ok = out_path(path, sizeof path, out_dir, cam->name, ".opacity.npy");
    if (ok == 0 && opacity) ok = gv_npy_write_f32(path, 2, shape, o);
    free(d), free(o);
    return ok;
}

static int render_all(const gv_gaussians *g, const gv_camera *cams, int n, const char *out_dir,
                      const float bg[3], int depth, int opacity)
{
    gv_splat_renderer r = {0};
    gv_progress bar;
    gv_progress_start(&bar, "render", n);
    int ok = 0;
    for (int i = 0; i < n && ok == 0; i++) {
        char path[4200];
        gv_image img = {0};
        ok = out_path(path, sizeof path, out_dir, cams[i].name, ".png");
        if (ok == 0) ok = gv_splat_render_camera(&r, g, &cams[i], bg, &img);
        if (ok == 0) ok = gv_image_write_png(path, &img);
        if (ok == 0 && (depth || opacity)) ok = write_maps(&r, &cams[i], out_dir, depth, opacity);
        gv_image_free(&img);
        gv_progress_update(&bar, i + 1, NULL);
    }
    gv_progress_finish(&bar);
    gv_splat_renderer_free(&r);
    return ok;
}

int cmd_splat_render(int argc, char **argv)
{
    const char *model_path = NULL, *scene_dir = NULL, *sel = "held-out", *out = NULL;
    int interval = 1, downscale = 1, path_frames = 0, white_bg = 0, depth = 0, opacity = 0;
    const gv_flag flags[] = {
        {"model", GV_FLAG_STRING, &model_path, "FILE.ply", "the 3DGS model", 1},
        {"scene", GV_FLAG_STRING, &scene_dir, "DIR", "scene whose cameras to render", 1},
        {"out", GV_FLAG_STRING, &out, "DIR", "folder for the PNGs (created)", 1},
        {"frames", GV_FLAG_STRING, &sel, "SEL", "held-out (default), train, all, or i,j,k", 0},
        {"interval", GV_FLAG_INT, &interval, "N", "sparse split for held-out/train (default 1)", 0},
        {"path", GV_FLAG_INT, &path_frames, "K", "render K frames along a path through the selected frames", 0},
        {"downscale", GV_FLAG_INT, &downscale, "K", "image downscale 1, 2, 4 or 8 (default 1)", 0},
        {"white-bg", GV_FLAG_BOOL, &white_bg, NULL, "white background (default black)", 0},
        {"depth", GV_FLAG_BOOL, &depth, NULL, "also write NAME.depth.npy: expected view depth", 0},
        {"opacity", GV_FLAG_BOOL, &opacity, NULL, "also write NAME.opacity.npy: accumulated opacity", 0},
    };
    const gv_command_spec spec = {
        "splat render", NULL, "render a 3DGS model from a scene's cameras to PNGs",
        "Writes one PNG per selected frame, named like the scene's image (extension .png).\n"
        "With --path K, writes path_00000.png ... : K cameras evenly spaced along the\n"
        "selected frames in order (rotations by slerp, centres and intrinsics linearly).\n"
        "--depth and --opacity add float32 H x W NumPy files beside each PNG: the expected\n"
        "view-space depth sum(w z) / sum(w) (0 where nothing blends) and 1 - T_final.",
        flags, sizeof flags / sizeof flags[0], 0, 0};
    int parsed = gv_args_parse(&spec, argc, argv, NULL, NULL);
    if (parsed != GV_ARGS_OK) return gv_args_exit_code(parsed);
    if (path_frames < 0 || path_frames > 100000) {
        fprintf(stderr, "gaussvid splat render: --path needs 0..100000 frames\n");
        return 2;
    }

    gv_gaussians g = {0};
    gv_scene scene = {0};
    gv_scene_options so = {.downscale = downscale, .white_background = white_bg};
    int *frames = NULL, n = 0, ok = -1;
    gv_camera *cams = NULL;
    if (gv_gaussians_read_ply(model_path, &g) != 0 || gv_scene_load(scene_dir, &so, &scene) != 0)
        goto done;
    int capacity = scene.n_frames > 4096 ? scene.n_frames : 4096;
    frames = malloc((size_t)capacity * sizeof(int));
    if (!frames || select_frames(&scene, sel, interval, frames, capacity, &n) != 0) goto done;
    int n_out = path_frames > 0 ? path_frames : n;
    cams = malloc((size_t)(n_out > n ? n_out : n) * sizeof(gv_camera));
    if (!cams) goto done;
    for (int i = 0; i < n; i++) cams[i] = scene.cameras[frames[i]];
    if (path_frames > 0) {
        gv_camera *keys = malloc((size_t)n * sizeof(gv_camera));
        if (!keys) goto done;
        memcpy(keys, cams, (size_t)n * sizeof(gv_camera));
        gv_camera_path(keys, n, n_out, cams);
        free(keys);
        for (int i = 0; i < n_out; i++) snprintf(cams[i].name, sizeof cams[i].name, "path_%05d.png", i);
    }
    float bg[3] = {white_bg, white_bg, white_bg};
    if (gv_mkdirs(out) != 0 || render_all(&g, cams, n_out, out, bg, depth, opacity) != 0) goto done;
    printf("%s: %d frames rendered from %s (%d Gaussians)\n", out, n_out, model_path, g.n);
    ok = 0;
done:
    free(frames), free(cams);
    gv_gaussians_free(&g);
    gv_scene_free(&scene);
    return ok == 0 ? 0 : gv_report_failure();
}
