/* runs/<scene>_n<NN>.json: what one (scene, n) run of artifact simulation measured, the
 * baseline quality of the corrupted renders of every held-out frame (how hard the restorer's
 * task is at this n) and how long the run took. `dataset stats` aggregates these. */
#include <cjson/cJSON.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "gaussvid/data/dataset.h"
#include "gaussvid/io/json.h"

/* PSNR of identical images is infinite, which JSON cannot hold: it is recorded as this. */
#define PSNR_CAP 100.0

int gv_run_record_alloc(gv_run_record *r, int n_held_out)
{
    r->n_held_out = n_held_out;
    r->held_out = calloc((size_t)(n_held_out > 0 ? n_held_out : 1), sizeof *r->held_out);
    r->psnr = calloc((size_t)(n_held_out > 0 ? n_held_out : 1), sizeof *r->psnr);
    r->ssim = calloc((size_t)(n_held_out > 0 ? n_held_out : 1), sizeof *r->ssim);
    if (!r->held_out || !r->psnr || !r->ssim) {
        gv_run_record_free(r);
        return gv_fail("out of memory for a run of %d held-out frames", n_held_out);
    }
    return 0;
}

void gv_run_record_free(gv_run_record *r)
{
    free(r->held_out);
    free(r->psnr);
    free(r->ssim);
    r->held_out = NULL;
    r->psnr = r->ssim = NULL;
    r->n_held_out = 0;
}

void gv_run_record_summarise(gv_run_record *r)
{
    double psnr = 0, ssim = 0;
    for (int i = 0; i < r->n_held_out; i++) {
        if (!(r->psnr[i] <= PSNR_CAP)) r->psnr[i] = PSNR_CAP;
        psnr += r->psnr[i];
        ssim += r->ssim[i];
    }
    r->psnr_mean = r->n_held_out ? psnr / r->n_held_out : 0;
    r->ssim_mean = r->n_held_out ? ssim / r->n_held_out : 0;
}

/* Rounds to 1e-6 so the file stays readable (metrics are not meaningful beyond that). */
static double tidy(double x) { return round(x * 1e6) / 1e6; }

int gv_run_record_write(const char *path, const gv_run_record *r)
{
    cJSON *root = cJSON_CreateObject();
    cJSON_AddStringToObject(root, "scene", r->id.scene);
    cJSON_AddStringToObject(root, "split", r->id.split);
    cJSON_AddNumberToObject(root, "n", r->id.interval);
    cJSON_AddNumberToObject(root, "iters", r->iters);
    cJSON_AddNumberToObject(root, "train_views", r->n_train);
    cJSON_AddNumberToObject(root, "clips", r->n_clips);
    cJSON_AddNumberToObject(root, "seconds", tidy(r->seconds));
    cJSON_AddNumberToObject(root, "train_seconds", tidy(r->train_seconds));
    cJSON_AddNumberToObject(root, "render_seconds", tidy(r->render_seconds));
    cJSON *baseline = cJSON_AddObjectToObject(root, "baseline");
    cJSON_AddNumberToObject(baseline, "psnr", tidy(r->psnr_mean));
    cJSON_AddNumberToObject(baseline, "ssim", tidy(r->ssim_mean));
    cJSON_AddNumberToObject(baseline, "frames", r->n_held_out);
    if (r->train_frames > 0) {
        cJSON *train = cJSON_AddObjectToObject(root, "train");
        cJSON_AddNumberToObject(train, "psnr", tidy(r->train_psnr));
        cJSON_AddNumberToObject(train, "ssim", tidy(r->train_ssim));
        cJSON_AddNumberToObject(train, "frames", r->train_frames);
    }
    cJSON *frames = cJSON_AddArrayToObject(root, "frames");
    for (int i = 0; i < r->n_held_out; i++) {
        cJSON *o = cJSON_CreateObject();
        cJSON_AddNumberToObject(o, "frame", r->held_out[i]);
        cJSON_AddNumberToObject(o, "psnr", tidy(r->psnr[i] <= PSNR_CAP ? r->psnr[i] : PSNR_CAP));
        cJSON_AddNumberToObject(o, "ssim", tidy(r->ssim[i]));
        cJSON_AddItemToArray(frames, o);
    }
    char *text = cJSON_PrintUnformatted(root);
    cJSON_Delete(root);
    if (!text) return gv_fail("%s: out of memory", path);
    int rc = gv_write_text_atomic(path, text);
    free(text);
    return rc;
}

static int read_frames(const cJSON *list, const char *path, gv_run_record *r)
{
    if (!cJSON_IsArray(list)) return gv_fail("%s: \"frames\" must be a list", path);
    int count = cJSON_GetArraySize(list);
    if (gv_run_record_alloc(r, count) != 0) return -1;
    for (int i = 0; i < count; i++) {
        const cJSON *o = cJSON_GetArrayItem(list, i);
        double frame, psnr, ssim;
        if (gv_json_number(o, "frame", 0, 1e9, 1, &frame) ||
            gv_json_number(o, "psnr", -PSNR_CAP, PSNR_CAP, 0, &psnr) || gv_json_number(o, "ssim", -1, 1, 0, &ssim))
            return gv_fail("%s: frames[%d]: needs an integer \"frame\", \"psnr\" in -100..100 and "
                           "\"ssim\" in -1..1", path, i);
        r->held_out[i] = (int)frame, r->psnr[i] = psnr, r->ssim[i] = ssim;
    }
    return 0;
}

/* The optional "train" summary (records written before it existed have none). */
static int read_train(const cJSON *train, const char *path, gv_run_record *r)
{
    if (!train) return 0;
    double psnr, ssim, frames;
    if (!cJSON_IsObject(train) || gv_json_number(train, "psnr", -PSNR_CAP, PSNR_CAP, 0, &psnr) ||
        gv_json_number(train, "ssim", -1, 1, 0, &ssim) || gv_json_number(train, "frames", 1, 1e9, 1, &frames))
        return gv_fail("%s: \"train\" needs \"psnr\" in -100..100, \"ssim\" in -1..1 and an "
                       "integer \"frames\" of at least 1", path);
    r->train_psnr = psnr, r->train_ssim = ssim, r->train_frames = (int)frames;
    return 0;
}

int gv_run_record_read(const char *path, gv_run_record *r)
{
    memset(r, 0, sizeof *r);
    char *text;
    size_t size;
    if (gv_read_file(path, &text, &size) != 0) return -1;
    cJSON *root = cJSON_ParseWithLength(text, size);
    free(text);
    double v[6];
    int rc = 0;
    if (!cJSON_IsObject(root)) rc = gv_fail("%s: not a JSON object", path);
    else if (gv_json_string(root, "scene", r->id.scene, sizeof r->id.scene) ||
             gv_json_string(root, "split", r->id.split, sizeof r->id.split))
        rc = gv_fail("%s: \"scene\" and \"split\" must be short strings", path);
    else if (gv_json_number(root, "n", 2, 1e6, 0, &v[0]) || gv_json_number(root, "iters", 0, 1e9, 0, &v[1]) ||
             gv_json_number(root, "train_views", 0, 1e9, 0, &v[2]) || gv_json_number(root, "clips", 0, 1e6, 0, &v[3]) ||
             gv_json_number(root, "seconds", 0, 1e12, 0, &v[4]) ||
             gv_json_number(root, "train_seconds", 0, 1e12, 0, &v[5]))
        rc = gv_fail("%s: needs numbers \"n\", \"iters\", \"train_views\", \"clips\", \"seconds\" "
                     "and \"train_seconds\" in range", path);
    else
        rc = read_frames(cJSON_GetObjectItemCaseSensitive(root, "frames"), path, r);
    if (rc == 0) {
        r->id.interval = (int)v[0], r->iters = (int)v[1], r->n_train = (int)v[2], r->n_clips = (int)v[3];
        r->seconds = v[4], r->train_seconds = v[5];
        double render;
        r->render_seconds = gv_json_number(root, "render_seconds", 0, 1e12, 0, &render) ? 0 : render;
        rc = read_train(cJSON_GetObjectItemCaseSensitive(root, "train"), path, r);
        gv_run_record_summarise(r);
    }
    cJSON_Delete(root);
    if (rc != 0) gv_run_record_free(r);
    return rc;
}
