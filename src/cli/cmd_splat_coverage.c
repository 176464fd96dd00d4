/* gaussvid splat coverage --model M.ply --scene DIR --interval n [--json FILE]: where a
 * sparse model's error is and what its anchors can give (include/gaussvid/splat/coverage.h):
 * per held-out frame, anchor coverage, PSNR of the render and of each warped anchor on the
 * pixels it covers, a per-pixel oracle, and the share of the error no anchor sees. */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>

#include <cjson/cJSON.h>

#include "cli/commands.h"
#include "gaussvid/core/core.h"
#include "gaussvid/splat/coverage.h"
#include "gaussvid/io/ply.h"
#include "gaussvid/scene/scene.h"

static void add_number(cJSON *o, const char *key, double v)
{
    if (isfinite(v)) cJSON_AddNumberToObject(o, key, v);
    else cJSON_AddNullToObject(o, key); /* JSON has no infinity or NaN */
}

static void add_pair(cJSON *o, const char *key, const double v[2])
{
    cJSON *a = cJSON_AddArrayToObject(o, key);
    for (int k = 0; k < 2; k++)
        cJSON_AddItemToArray(a, isfinite(v[k]) ? cJSON_CreateNumber(v[k]) : cJSON_CreateNull());
}

static cJSON *summary_json(const gv_coverage_summary *s)
{
    cJSON *o = cJSON_CreateObject();
    cJSON_AddNumberToObject(o, "frames", s->frames);
    add_number(o, "covered", s->covered);
    add_pair(o, "anchor_covered", s->anchor_covered);
    add_number(o, "psnr_render", s->psnr_render);
    add_pair(o, "psnr_render_on", s->psnr_render_on);
    add_pair(o, "psnr_warp", s->psnr_warp);
    double with[2] = {s->frames_with[0], s->frames_with[1]};
    add_pair(o, "frames_with", with);
    add_number(o, "psnr_render_covered", s->psnr_render_covered);
    add_number(o, "psnr_render_uncovered", s->psnr_render_uncovered);
    add_number(o, "psnr_oracle", s->psnr_oracle);
    add_number(o, "oracle_gain", s->psnr_oracle - s->psnr_render);
    add_number(o, "psnr_blend", s->psnr_blend);
    add_number(o, "uncovered_error_share", s->uncovered_error_share);
    add_number(o, "uncovered_error_share_mean", s->uncovered_error_share_mean);
    return o;
}

static cJSON *frame_json(const gv_scene *scene, const gv_coverage_frame *f)
{
    cJSON *o = cJSON_CreateObject();
    cJSON_AddNumberToObject(o, "frame", f->frame);
    cJSON_AddStringToObject(o, "name", scene->cameras[f->frame].name);
    double anchors[2] = {f->anchor[0], f->anchor[1]};
    add_pair(o, "anchors", anchors);
    add_number(o, "covered", f->covered);
    add_pair(o, "anchor_covered", f->anchor_covered);
    add_number(o, "psnr_render", f->psnr_render);
    add_pair(o, "psnr_render_on", f->psnr_render_on);
    add_pair(o, "psnr_warp", f->psnr_warp);
    add_number(o, "psnr_render_covered", f->psnr_render_covered);
    add_number(o, "psnr_render_uncovered", f->psnr_render_uncovered);
    add_number(o, "psnr_oracle", f->psnr_oracle);
    add_number(o, "psnr_blend", f->psnr_blend);
    add_number(o, "uncovered_error_share",
               f->sse_render > 0 ? f->sse_uncovered / f->sse_render : NAN);
    return o;
}

static int write_json(const char *path, const char *model, const gv_scene *scene, int interval,
                      const gv_coverage_options *opt, const gv_coverage_frame *r, int n,
                      const gv_coverage_summary *s)
{
    cJSON *root = cJSON_CreateObject();
    cJSON_AddStringToObject(root, "model", model);
    cJSON_AddStringToObject(root, "scene", scene->dir);
    cJSON_AddNumberToObject(root, "interval", interval);
    cJSON_AddNumberToObject(root, "tolerance", opt->rel_tolerance);
    cJSON_AddNumberToObject(root, "min_opacity", opt->min_opacity);
    cJSON_AddItemToObject(root, "mean", summary_json(s));
    cJSON *list = cJSON_AddArrayToObject(root, "per_frame");
    for (int i = 0; i < n; i++) cJSON_AddItemToArray(list, frame_json(scene, &r[i]));
    char *text = cJSON_Print(root);
    cJSON_Delete(root);
    if (!text) return gv_fail("%s: out of memory writing JSON", path);
    int ok = gv_write_text_atomic(path, text);
    cJSON_free(text);
    return ok;
}

static void print_table(const gv_scene *scene, const gv_coverage_frame *r, int n,
                        const gv_coverage_summary *s)
{
    printf("%-6s %-22s %-9s %7s %8s %15s %15s %8s %6s\n", "frame", "name", "anchors", "covered",
           "render", "render/warp 1", "render/warp 2", "oracle", "unc.err");
    for (int i = 0; i < n; i++) {
        const gv_coverage_frame *f = &r[i];
        printf("%-6d %-22s %4d,%-4d %6.1f%% %8.2f %7.2f/%-7.2f %7.2f/%-7.2f %8.2f %5.1f%%\n",
               f->frame, scene->cameras[f->frame].name, f->anchor[0], f->anchor[1],
               100 * f->covered, f->psnr_render, f->psnr_render_on[0], f->psnr_warp[0],
               f->psnr_render_on[1], f->psnr_warp[1], f->psnr_oracle,
               f->sse_render > 0 ? 100 * f->sse_uncovered / f->sse_render : 0.0);
    }
    printf("mean over %d held-out frames: covered %.1f%% (anchor 1 %.1f%%, anchor 2 %.1f%%)\n",
           s->frames, 100 * s->covered, 100 * s->anchor_covered[0], 100 * s->anchor_covered[1]);
    printf("  render %.2f dB; on covered pixels %.2f, on uncovered %.2f\n", s->psnr_render,
           s->psnr_render_covered, s->psnr_render_uncovered);
    for (int k = 0; k < 2; k++)
        printf("  anchor %d on the pixels it covers: render %.2f dB, warp %.2f dB\n", k + 1,
               s->psnr_render_on[k], s->psnr_warp[k]);
    printf("  oracle %.2f dB (%+.2f), mean of render and warps %.2f dB (%+.2f)\n",
           s->psnr_oracle, s->psnr_oracle - s->psnr_render, s->psnr_blend,
           s->psnr_blend - s->psnr_render);
    printf("  uncovered pixels hold %.1f%% of the render's squared error\n",
           100 * s->uncovered_error_share);
}

int cmd_splat_coverage(int argc, char **argv)
{
    const char *model_path = NULL, *scene_dir = NULL, *json = NULL;
    int interval = 0, downscale = 1, white_bg = 0;
    gv_coverage_options opt;
    gv_coverage_options_default(&opt);
    const gv_flag flags[] = {
        {"model", GV_FLAG_STRING, &model_path, "FILE.ply", "the 3DGS model", 1},
        {"scene", GV_FLAG_STRING, &scene_dir, "DIR", "the scene it was trained on", 1},
        {"interval", GV_FLAG_INT, &interval, "N", "the sparse split it was trained with", 1},
        {"json", GV_FLAG_STRING, &json, "FILE", "also write the results as JSON", 0},
        {"tolerance", GV_FLAG_DOUBLE, &opt.rel_tolerance, "R",
         "relative depth agreement of the occlusion test (default 0.05)", 0},
        {"min-opacity", GV_FLAG_DOUBLE, &opt.min_opacity, "A",
         "rendered depth counts where the opacity reaches A (default 0.5)", 0},
        {"downscale", GV_FLAG_INT, &downscale, "K", "image downscale 1, 2, 4 or 8 (default 1)", 0},
        {"white-bg", GV_FLAG_BOOL, &white_bg, NULL, "white background (default black)", 0},
    };
    const gv_command_spec spec = {
        "splat coverage", NULL, "where a sparse model's error is, and what its anchors can give",
        "For each held-out frame i between two training frames, the anchors are the training\n"
        "frames a = floor(i/N) N and a + N. Each anchor's image is warped into frame i by the\n"
        "model's rendered depth, keeping the pixels whose point the anchor's own rendered\n"
        "depth sees (the occlusion test). Prints, per frame and as means: the share of pixels\n"
        "some anchor covers; PSNR of the render, of the render and each warp on the pixels that\n"
        "anchor covers, of a per-pixel oracle (best of render and covering warps) and of the\n"
        "per-pixel mean of render and covering warps; and the share of the render's squared\n"
        "error on the pixels no anchor covers. Renders are scored as 'splat eval' scores\n"
        "them (8 bits). See docs/SPLAT_TRAINING.md.",
        flags, sizeof flags / sizeof flags[0], 0, 0};
    int parsed = gv_args_parse(&spec, argc, argv, NULL, NULL);
    if (parsed != GV_ARGS_OK) return gv_args_exit_code(parsed);
    if (!(opt.rel_tolerance > 0 && opt.rel_tolerance < 1) ||
        !(opt.min_opacity >= 0 && opt.min_opacity <= 1)) {
        fprintf(stderr, "gaussvid splat coverage: --tolerance needs 0 < R < 1 and "
                        "--min-opacity 0 <= A <= 1\n");
        return 2;
    }
    opt.bg[0] = opt.bg[1] = opt.bg[2] = (float)white_bg;

    gv_gaussians g = {0};
    gv_scene scene = {0};
    gv_scene_options so = {.downscale = downscale, .white_background = white_bg};
    int *frames = NULL, ok = -1;
    gv_coverage_frame *results = NULL;
    if (gv_gaussians_read_ply(model_path, &g) != 0 || gv_scene_load(scene_dir, &so, &scene) != 0)
        goto done;
    frames = malloc((size_t)scene.n_frames * sizeof(int));
    results = calloc((size_t)scene.n_frames, sizeof *results);
    if (!frames || !results) {
        gv_fail("out of memory for %d frames", scene.n_frames);
        goto done;
    }
    int n = gv_coverage_frames(&scene, interval, frames);
    if (n < 0 || gv_coverage_measure(&g, &scene, interval, frames, n, &opt, results) != 0)
        goto done;
    gv_coverage_summary s;
    gv_coverage_summarise(results, n, &s);
    print_table(&scene, results, n, &s);
    if (json && write_json(json, model_path, &scene, interval, &opt, results, n, &s) != 0)
        goto done;
    ok = 0;
done:
    free(frames), free(results);
    gv_gaussians_free(&g);
    gv_scene_free(&scene);
    return ok == 0 ? 0 : gv_report_failure();
}
