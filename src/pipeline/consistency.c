/* 3D consistency of a run's outputs (docs/METRICS.md, "3D consistency"): the evaluated frames
 * in path order, each warped into its previous and next by a model's depth
 * (gv_consistency_measure): the sparse renders and the restored frames with the sparse model's
 * depth (the geometry the restorer was given), the refined renders with the refined model's.
 * The evaluate stage records the means in metrics.json; gv_reconstruct_consistency measures a
 * finished folder again, pair by pair. */
#include <limits.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "gaussvid/eval/consistency.h"
#include "gaussvid/core/core.h"
#include "gaussvid/io/json.h"
#include "gaussvid/io/ply.h"
#include "pipeline/pipeline_internal.h"

static const char *const KINDS[3] = {"render", "restored", "refined"};
static const char *const NAMES[3] = {"sparse", "restored", "refined"};
static const char *const MODELS[3] = {"sparse.ply", "sparse.ply", "refined.ply"};

static cJSON *number_or_null(double v)
{
    return isfinite(v) ? cJSON_CreateNumber(v) : cJSON_CreateNull(); /* JSON has no NaN */
}

/* One set's object: its means, and with pairs each pair by frame number. */
static cJSON *set_json(const pipeline_run *r, const gv_consistency *c, int k, int with_pairs)
{
    cJSON *j = cJSON_CreateObject();
    cJSON_AddItemToObject(j, "psnr", number_or_null(c->mean_psnr));
    cJSON_AddItemToObject(j, "coverage", number_or_null(c->mean_coverage));
    cJSON_AddNumberToObject(j, "pairs", c->n_pairs);
    cJSON_AddNumberToObject(j, "scored", c->scored);
    cJSON_AddStringToObject(j, "depth", MODELS[k]);
    if (!with_pairs) return j;
    cJSON *pairs = cJSON_AddArrayToObject(j, "per_pair");
    for (int i = 0; i < c->n_pairs; i++) {
        const gv_consistency_pair *p = &c->pairs[i];
        cJSON *pj = cJSON_CreateObject();
        cJSON_AddNumberToObject(pj, "from", r->frames[p->from].index);
        cJSON_AddNumberToObject(pj, "to", r->frames[p->to].index);
        cJSON_AddItemToObject(pj, "psnr", number_or_null(p->psnr));
        cJSON_AddNumberToObject(pj, "coverage", p->coverage);
        cJSON_AddItemToArray(pairs, pj);
    }
    return j;
}

/* The frames of one set and their cameras, measured with the model's depth. */
static int measure_set(const pipeline_run *r, const gv_gaussians *g, int k, gv_consistency *c)
{
    char(*names)[4200] = malloc((size_t)r->n_frames * sizeof *names);
    const char **paths = malloc((size_t)r->n_frames * sizeof *paths);
    gv_camera *cams = malloc((size_t)r->n_frames * sizeof *cams);
    int rc = names && paths && cams ? 0 : gv_fail("consistency: out of memory for %d frames", r->n_frames);
    for (int i = 0; i < r->n_frames && rc == 0; i++) {
        rc = pipeline_frame_path(r, KINDS[k], r->frames[i].index, names[i], sizeof names[i]);
        paths[i] = names[i], cams[i] = r->frames[i].camera;
    }
    if (rc == 0) rc = gv_consistency_measure(g, cams, paths, r->n_frames, NULL, c);
    free(names), free(paths), free(cams);
    return rc;
}

int pipeline_consistency_sets(const pipeline_run *r)
{
    return r->opt->restore_with == GV_RESTORE_NONE ? 1 : 3; /* --no-restore: the renders alone */
}

int pipeline_consistency(const pipeline_run *r, int with_pairs, cJSON **out, double psnr[3])
{
    *out = NULL;
    gv_gaussians g = {0};
    cJSON *j = cJSON_CreateObject();
    int rc = 0, sets = pipeline_consistency_sets(r);
    for (int k = sets; k < 3; k++) {
        cJSON_AddNullToObject(j, NAMES[k]);
        psnr[k] = NAN;
    }
    for (int k = 0; k < sets && rc == 0; k++) {
        char path[4200];
        if (k != 1) { /* the restored frames share the sparse model's depth */
            gv_gaussians_free(&g);
            rc = pipeline_file(r, MODELS[k], path, sizeof path) || gv_gaussians_read_ply(path, &g);
        }
        gv_consistency c;
        if (rc == 0 && (rc = measure_set(r, &g, k, &c)) == 0) {
            cJSON_AddItemToObject(j, NAMES[k], set_json(r, &c, k, with_pairs));
            psnr[k] = c.mean_psnr;
            gv_consistency_free(&c);
        }
    }
    gv_gaussians_free(&g);
    if (rc) {
        cJSON_Delete(j);
        return -1;
    }
    *out = j;
    return 0;
}

void pipeline_consistency_means(const double psnr[3], int sets, char *out, size_t size)
{
    char v[3][32];
    for (int k = 0; k < 3; k++)
        if (isfinite(psnr[k])) snprintf(v[k], sizeof v[k], "%.2f", psnr[k]);
        else snprintf(v[k], sizeof v[k], "- (no pixel in common)");
    if (sets == 1) snprintf(out, size, "sparse %s dB", v[0]);
    else snprintf(out, size, "sparse %s, restored %s, refined %s dB", v[0], v[1], v[2]);
}

void pipeline_consistency_line(const pipeline_run *r, const double psnr[3], char *out, size_t size)
{
    char means[160];
    pipeline_consistency_means(psnr, pipeline_consistency_sets(r), means, sizeof means);
    snprintf(out, size, "n=%d consistency (masked PSNR of each frame warped into its neighbours, %d pairs): %s", r->interval,
             2 * (r->n_frames - 1), means);
}

/* A run object of metrics.json measured again: the plan of its interval must list the same
 * frames (else the scene changed since). */
static int measure_run(pipeline_run *r, const char *dir, const cJSON *run, cJSON *runs, char *summary, size_t size)
{
    const cJSON *frames = cJSON_GetObjectItem(run, "frames");
    int listed = cJSON_IsArray(frames) ? cJSON_GetArraySize(frames) : -1;
    if (listed != r->n_frames)
        return gv_fail("%s/metrics.json: run n=%d lists %d frames but the scene's plan has %d (was the scene changed?)",
                       dir, r->interval, listed, r->n_frames);
    for (int i = 0; i < listed; i++) {
        double index;
        if (gv_json_number(cJSON_GetArrayItem(frames, i), "frame", 0, 1e9, 1, &index) || (int)index != r->frames[i].index)
            return gv_fail("%s/metrics.json: run n=%d frame %d is not the plan's frame %d (was the scene changed?)", dir,
                           r->interval, i, r->frames[i].index);
    }
    cJSON *j;
    double psnr[3];
    if (pipeline_consistency(r, 1, &j, psnr)) return gv_fail_context("%s n=%d", dir, r->interval);
    cJSON *rj = cJSON_CreateObject();
    cJSON_AddNumberToObject(rj, "interval", r->interval);
    cJSON_AddNumberToObject(rj, "frames", r->n_frames);
    for (int k = 0; k < 3; k++) cJSON_AddItemToObject(rj, NAMES[k], cJSON_DetachItemFromObject(j, NAMES[k]));
    cJSON_Delete(j);
    cJSON_AddItemToArray(runs, rj);
    size_t used = strlen(summary);
    pipeline_consistency_line(r, psnr, summary + used, size - used);
    used = strlen(summary);
    if (used + 1 < size) summary[used] = '\n', summary[used + 1] = 0;
    return 0;
}

static cJSON *read_metrics(const char *dir)
{
    char path[4200], *text = NULL, format[64] = "";
    size_t length = 0;
    if (gv_path_join(path, sizeof path, dir, "metrics.json")) return NULL;
    if (!gv_file_exists(path)) {
        gv_fail("%s: no metrics.json: not a reconstruct output folder", dir);
        return NULL;
    }
    if (gv_read_file(path, &text, &length)) return NULL;
    cJSON *doc = cJSON_ParseWithLength(text, length);
    free(text);
    if (!doc || gv_json_string(doc, "format", format, sizeof format) || strcmp(format, GV_RECONSTRUCT_FORMAT) ||
        !cJSON_IsArray(cJSON_GetObjectItem(doc, "runs"))) {
        gv_fail("%s: not a %s file", path, GV_RECONSTRUCT_FORMAT);
        cJSON_Delete(doc);
        return NULL;
    }
    return doc;
}

int gv_reconstruct_consistency(const char *dir, char **json, char *summary, size_t size)
{
    *json = NULL, summary[0] = 0;
    cJSON *doc = read_metrics(dir);
    if (!doc) return -1;
    char scene_dir[PATH_MAX];
    cJSON *out = cJSON_CreateObject(), *runs = cJSON_CreateArray();
    cJSON_AddStringToObject(out, "dir", dir);
    cJSON_AddItemToObject(out, "runs", runs);
    int rc = gv_json_string(doc, "scene_dir", scene_dir, sizeof scene_dir) ? gv_fail_context("%s/metrics.json", dir) : 0;
    const cJSON *run;
    cJSON_ArrayForEach(run, cJSON_GetObjectItem(doc, "runs"))
    {
        double n, downscale;
        if (rc == 0 && (gv_json_number(run, "interval", 1, 1e9, 1, &n) ||
                        gv_json_number(cJSON_GetObjectItem(run, "inputs"), "downscale", 1, 8, 1, &downscale)))
            rc = gv_fail_context("%s/metrics.json", dir);
        if (rc) break;
        gv_scene scene;
        gv_scene_options so = {.downscale = (int)downscale};
        if (gv_scene_load(scene_dir, &so, &scene)) {
            rc = gv_fail_context("%s/metrics.json: its scene", dir);
            break;
        }
        pipeline_run r;
        memset(&r, 0, sizeof r);
        gv_reconstruct_options o; /* what the sets measured depend on: whether it restored */
        gv_reconstruct_defaults(&o);
        o.downscale = (int)downscale;
        char mode[32];
        if (gv_json_string(cJSON_GetObjectItem(run, "inputs"), "restore_with", mode, sizeof mode) == 0 &&
            gv_restore_with_parse(mode) >= 0)
            o.restore_with = gv_restore_with_parse(mode);
        r.opt = &o;
        char name[32];
        snprintf(name, sizeof name, "n%d", (int)n);
        rc = gv_path_join(r.dir, sizeof r.dir, dir, name) || pipeline_plan(&r, &scene, (int)n) ||
             measure_run(&r, dir, run, runs, summary, size);
        pipeline_plan_free(&r);
        gv_scene_free(&scene);
    }
    if (rc == 0 && cJSON_GetArraySize(runs) == 0) rc = gv_fail("%s/metrics.json: no run to measure", dir);
    if (rc == 0 && !(*json = cJSON_PrintUnformatted(out))) rc = gv_fail("consistency: out of memory writing JSON");
    cJSON_Delete(out);
    cJSON_Delete(doc);
    size_t used = strlen(summary);
    if (used && summary[used - 1] == '\n') summary[used - 1] = 0;
    return rc ? -1 : 0;
}
