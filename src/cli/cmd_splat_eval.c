/* gaussvid splat eval --model model.ply --scene DIR --interval n [--json FILE]: PSNR and
 * SSIM of a model's renders of the held-out and training views, per frame and mean, as the
 * 3DGS evaluation computes them (8-bit renders; docs/SPLAT_TRAINING.md). */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>

#include <cjson/cJSON.h>

#include "cli/commands.h"
#include "gaussvid/core/core.h"
#include "gaussvid/io/ply.h"
#include "gaussvid/scene/scene.h"
#include "gaussvid/splat/splat_train.h"

typedef struct { double psnr, ssim; int frames; } split_mean;

static split_mean mean_of(const gv_splat_frame_metrics *m, int n, int train)
{
    split_mean s = {0, 0, 0};
    for (int i = 0; i < n; i++)
        if (m[i].train == train) s.psnr += m[i].psnr, s.ssim += m[i].ssim, s.frames++;
    if (s.frames) s.psnr /= s.frames, s.ssim /= s.frames;
    else s.psnr = s.ssim = NAN;
    return s;
}

static void add_number(cJSON *o, const char *key, double v)
{
    if (isfinite(v)) cJSON_AddNumberToObject(o, key, v);
    else cJSON_AddNullToObject(o, key); /* JSON has no infinity or NaN */
}

static cJSON *mean_json(split_mean s)
{
    cJSON *o = cJSON_CreateObject();
    add_number(o, "psnr", s.psnr);
    add_number(o, "ssim", s.ssim);
    cJSON_AddNumberToObject(o, "frames", s.frames);
    return o;
}

static int write_json(const char *path, const char *model, const gv_scene *scene, int interval,
                      const gv_splat_frame_metrics *m, int n)
{
    cJSON *root = cJSON_CreateObject();
    cJSON_AddStringToObject(root, "model", model);
    cJSON_AddStringToObject(root, "scene", scene->dir);
    cJSON_AddNumberToObject(root, "interval", interval);
    cJSON_AddItemToObject(root, "held_out", mean_json(mean_of(m, n, 0)));
    cJSON_AddItemToObject(root, "train", mean_json(mean_of(m, n, 1)));
    cJSON *list = cJSON_AddArrayToObject(root, "per_frame");
    for (int i = 0; i < n; i++) {
        cJSON *f = cJSON_CreateObject();
        cJSON_AddNumberToObject(f, "frame", m[i].frame);
        cJSON_AddStringToObject(f, "name", scene->cameras[m[i].frame].name);
        cJSON_AddStringToObject(f, "split", m[i].train ? "train" : "held_out");
        add_number(f, "psnr", m[i].psnr);
        add_number(f, "ssim", m[i].ssim);
        cJSON_AddItemToArray(list, f);
    }
    char *text = cJSON_Print(root);
    cJSON_Delete(root);
    if (!text) return gv_fail("%s: out of memory writing JSON", path);
    gv_atomic_file af;
    int ok = gv_atomic_open(&af, path);
    if (ok == 0) {
        fprintf(af.f, "%s\n", text);
        ok = gv_atomic_commit(&af);
    }
    cJSON_free(text);
    return ok;
}

static void print_table(const gv_scene *scene, const gv_splat_frame_metrics *m, int n)
{
    printf("%-6s %-24s %-9s %8s %7s\n", "frame", "name", "split", "PSNR", "SSIM");
    for (int i = 0; i < n; i++)
        printf("%-6d %-24s %-9s %8.3f %7.4f\n", m[i].frame, scene->cameras[m[i].frame].name,
               m[i].train ? "train" : "held-out", m[i].psnr, m[i].ssim);
    split_mean h = mean_of(m, n, 0), t = mean_of(m, n, 1);
    printf("held-out mean (%d frames): PSNR %.3f dB, SSIM %.4f\n", h.frames, h.psnr, h.ssim);
    printf("train mean (%d frames): PSNR %.3f dB, SSIM %.4f\n", t.frames, t.psnr, t.ssim);
}

int cmd_splat_eval(int argc, char **argv)
{
    const char *model_path = NULL, *scene_dir = NULL, *json = NULL;
    int interval = 1, downscale = 1, white_bg = 0;
    const gv_flag flags[] = {
        {"model", GV_FLAG_STRING, &model_path, "FILE.ply", "the 3DGS model", 1},
        {"scene", GV_FLAG_STRING, &scene_dir, "DIR", "the scene it was trained on", 1},
        {"interval", GV_FLAG_INT, &interval, "N", "the sparse split it was trained with", 1},
        {"json", GV_FLAG_STRING, &json, "FILE", "also write the results as JSON", 0},
        {"downscale", GV_FLAG_INT, &downscale, "K", "image downscale 1, 2, 4 or 8 (default 1)", 0},
        {"white-bg", GV_FLAG_BOOL, &white_bg, NULL, "white background (default black)", 0},
    };
    const gv_command_spec spec = {
        "splat eval", NULL, "PSNR and SSIM of a model on held-out and training views",
        "Renders every frame of the scene, quantises the render to 8 bits as the 3DGS\n"
        "evaluation does, and compares it with the frame's image. Frames 0, N, 2N, ... are the\n"
        "training views, the others held out. The JSON has the means under \"held_out\" and\n"
        "\"train\" (psnr, ssim, frames) and a \"per_frame\" list.",
        flags, sizeof flags / sizeof flags[0], 0, 0};
    int parsed = gv_args_parse(&spec, argc, argv, NULL, NULL);
    if (parsed != GV_ARGS_OK) return gv_args_exit_code(parsed);

    gv_gaussians g = {0};
    gv_scene scene = {0};
    gv_scene_options so = {.downscale = downscale, .white_background = white_bg};
    int *train = NULL, *held = NULL, *frames = NULL, n_train = 0, n_held = 0, ok = -1;
    gv_splat_frame_metrics *m = NULL;
    if (gv_gaussians_read_ply(model_path, &g) != 0 || gv_scene_load(scene_dir, &so, &scene) != 0)
        goto done;
    int n = scene.n_frames;
    train = malloc((size_t)n * sizeof(int)), held = malloc((size_t)n * sizeof(int));
    frames = malloc((size_t)n * sizeof(int)), m = calloc((size_t)n, sizeof *m);
    if (!train || !held || !frames || !m) {
        gv_fail("out of memory for %d frames", n);
        goto done;
    }
    if (gv_scene_split(n, interval, train, &n_train, held, &n_held) != 0) {
        gv_fail_context("%s", scene_dir);
        goto done;
    }
    for (int i = 0; i < n; i++) frames[i] = i;
    float bg[3] = {white_bg, white_bg, white_bg};
    if (gv_splat_evaluate(&g, &scene, frames, n, bg, m) != 0) goto done;
    for (int i = 0; i < n; i++) m[i].train = gv_scene_is_train(i, interval);
    print_table(&scene, m, n);
    if (json && write_json(json, model_path, &scene, interval, m, n) != 0) goto done;
    ok = 0;
done:
    free(train), free(held), free(frames), free(m);
    gv_gaussians_free(&g);
    gv_scene_free(&scene);
    return ok == 0 ? 0 : gv_report_failure();
}
