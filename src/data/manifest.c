/* manifest.json of a dataset folder (docs/FORMATS-DATASET.md): the build's options, every
 * finished (scene, n) run and every clip. It is the commit point of a run: clips and the
 * run record are written first, the manifest last and atomically, so after an interruption
 * it lists exactly the runs that finished. */
#include <cjson/cJSON.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "gaussvid/data/dataset.h"
#include "gaussvid/io/json.h"
#include "gaussvid/splat/splat_train.h"

#define MANIFEST_NAME "manifest.json"
#define MAX_SEED 9007199254740992.0 /* 2^53: integers a JSON number (a double) holds exactly */

void gv_manifest_init(gv_manifest *m, const gv_dataset_params *params)
{
    memset(m, 0, sizeof *m);
    if (params) m->params = *params;
}

void gv_manifest_free(gv_manifest *m)
{
    free(m->runs);
    free(m->clips);
    memset(m, 0, sizeof *m);
}

int gv_clip_file_name(char *out, size_t size, const char *scene, int n, int k)
{
    if ((size_t)snprintf(out, size, "clips/%s_n%02d_%03d.safetensors", scene, n, k) >= size)
        return gv_fail("%s: clip file name too long", scene);
    return 0;
}

int gv_run_file_name(char *out, size_t size, const char *scene, int n)
{
    if ((size_t)snprintf(out, size, "runs/%s_n%02d.json", scene, n) >= size)
        return gv_fail("%s: run file name too long", scene);
    return 0;
}

void gv_dataset_params_flags(const gv_dataset_params *p, char *out, size_t size)
{
    snprintf(out, size, "--iters %d --densify %s --anchor-gap %d --sampling %s --clips-per-run %d "
             "--seed %llu --downscale %d", p->iters, gv_splat_densify_mode_name(p->densify), p->anchor_gap,
             gv_sampling_name(p->sampling), p->clips_per_run, (unsigned long long)p->seed, p->downscale);
}

int gv_manifest_find_run(const gv_manifest *m, const char *scene, int n)
{
    for (int i = 0; i < m->n_runs; i++)
        if (m->runs[i].id.interval == n && !strcmp(m->runs[i].id.scene, scene)) return i;
    return -1;
}

static int compare_runs(const void *a, const void *b)
{
    const gv_manifest_run *x = a, *y = b;
    int c = strcmp(x->id.scene, y->id.scene);
    return c ? c : (x->id.interval > y->id.interval) - (x->id.interval < y->id.interval);
}

static int compare_clips(const void *a, const void *b)
{
    const gv_manifest_clip *x = a, *y = b;
    int c = strcmp(x->id.scene, y->id.scene);
    if (c) return c;
    if (x->id.interval != y->id.interval) return x->id.interval < y->id.interval ? -1 : 1;
    return strcmp(x->file, y->file);
}

/* Grows an array of `size`-byte items to hold `need`. */
static int reserve(void **items, int *cap, int need, size_t size)
{
    if (need <= *cap) return 0;
    int grown = *cap ? *cap : 16;
    while (grown < need) grown *= 2;
    void *p = realloc(*items, (size_t)grown * size);
    if (!p) return gv_fail("out of memory for a manifest of %d entries", need);
    *items = p;
    *cap = grown;
    return 0;
}

int gv_manifest_add_run(gv_manifest *m, const gv_manifest_run *run,
                        const gv_manifest_clip *clips, int n_clips)
{
    int kept = 0; /* drop the previous entries of this (scene, n) */
    for (int i = 0; i < m->n_runs; i++)
        if (m->runs[i].id.interval != run->id.interval || strcmp(m->runs[i].id.scene, run->id.scene)) m->runs[kept++] = m->runs[i];
    m->n_runs = kept;
    kept = 0;
    for (int i = 0; i < m->n_clips; i++)
        if (m->clips[i].id.interval != run->id.interval || strcmp(m->clips[i].id.scene, run->id.scene)) m->clips[kept++] = m->clips[i];
    m->n_clips = kept;
    if (reserve((void **)&m->runs, &m->cap_runs, m->n_runs + 1, sizeof *m->runs) ||
        reserve((void **)&m->clips, &m->cap_clips, m->n_clips + n_clips, sizeof *m->clips))
        return -1;
    m->runs[m->n_runs++] = *run;
    memcpy(m->clips + m->n_clips, clips, (size_t)n_clips * sizeof *clips);
    m->n_clips += n_clips;
    qsort(m->runs, (size_t)m->n_runs, sizeof *m->runs, compare_runs);
    qsort(m->clips, (size_t)m->n_clips, sizeof *m->clips, compare_clips);
    return 0;
}

/* ---- writing ------------------------------------------------------------------------ */

cJSON *gv_dataset_params_json(const gv_dataset_params *p)
{
    cJSON *o = cJSON_CreateObject();
    cJSON_AddNumberToObject(o, "iters", p->iters);
    cJSON_AddStringToObject(o, "densify", gv_splat_densify_mode_name(p->densify));
    cJSON_AddNumberToObject(o, "anchor_gap", p->anchor_gap);
    cJSON_AddStringToObject(o, "sampling", gv_sampling_name(p->sampling));
    cJSON_AddNumberToObject(o, "clips_per_run", p->clips_per_run);
    cJSON_AddNumberToObject(o, "seed", (double)p->seed);
    cJSON_AddNumberToObject(o, "downscale", p->downscale);
    if (p->subsets) cJSON_AddNumberToObject(o, "subsets", p->subsets);
    return o;
}

static cJSON *manifest_json(const gv_manifest *m)
{
    cJSON *root = cJSON_CreateObject();
    cJSON_AddStringToObject(root, "format", GV_MANIFEST_FORMAT);
    cJSON_AddNumberToObject(root, "format_version", GV_MANIFEST_FORMAT_VERSION);
    cJSON_AddItemToObject(root, "params", gv_dataset_params_json(&m->params));
    cJSON *runs = cJSON_AddArrayToObject(root, "runs");
    for (int i = 0; i < m->n_runs; i++) {
        const gv_manifest_run *r = &m->runs[i];
        char record[GV_SCENE_NAME_MAX + 32] = "";
        gv_run_file_name(record, sizeof record, r->id.scene, r->id.interval);
        cJSON *o = cJSON_CreateObject();
        cJSON_AddStringToObject(o, "scene", r->id.scene);
        cJSON_AddNumberToObject(o, "n", r->id.interval);
        cJSON_AddStringToObject(o, "split", r->id.split);
        cJSON_AddNumberToObject(o, "clips", r->n_clips);
        cJSON_AddNumberToObject(o, "seconds", round(r->seconds * 10) / 10);
        cJSON_AddStringToObject(o, "record", record);
        cJSON_AddItemToArray(runs, o);
    }
    cJSON *clips = cJSON_AddArrayToObject(root, "clips");
    for (int i = 0; i < m->n_clips; i++) {
        const gv_manifest_clip *c = &m->clips[i];
        cJSON *o = cJSON_CreateObject();
        cJSON_AddStringToObject(o, "file", c->file);
        cJSON_AddStringToObject(o, "scene", c->id.scene);
        cJSON_AddNumberToObject(o, "n", c->id.interval);
        cJSON_AddStringToObject(o, "split", c->id.split);
        cJSON_AddItemToObject(o, "frame_indices", cJSON_CreateIntArray(c->frames, GV_CLIP_FRAMES));
        cJSON_AddItemToArray(clips, o);
    }
    return root;
}

int gv_manifest_write(const char *dir, const gv_manifest *m)
{
    char path[4096];
    if (gv_path_join(path, sizeof path, dir, MANIFEST_NAME) != 0) return -1;
    cJSON *root = manifest_json(m);
    char *text = root ? cJSON_Print(root) : NULL;
    cJSON_Delete(root);
    if (!text) return gv_fail("%s: out of memory", path);
    int rc = gv_write_text_atomic(path, text);
    free(text);
    return rc;
}

/* ---- reading ------------------------------------------------------------------------ */

static int get_int(const cJSON *o, const char *key, double min, double max, const char *path,
                   const char *where, double *out)
{
    if (gv_json_number(o, key, min, max, 1, out))
        return gv_fail("%s: %s: \"%s\" must be an integer in %.0f..%.0f", path, where, key, min, max);
    return 0;
}

static int get_string(const cJSON *o, const char *key, char *out, size_t size, const char *path,
                      const char *where)
{
    if (gv_json_string(o, key, out, size) || !out[0])
        return gv_fail("%s: %s: \"%s\" must be a non-empty string of at most %zu bytes", path,
                       where, key, size - 1);
    return 0;
}

static int read_params(const cJSON *o, const char *path, gv_dataset_params *p)
{
    double v[5];
    char sampling[16];
    if (!cJSON_IsObject(o)) return gv_fail("%s: \"params\" must be an object", path);
    if (get_int(o, "iters", 0, 1e9, path, "params", &v[0]) ||
        get_int(o, "anchor_gap", 1, 1e6, path, "params", &v[1]) ||
        get_int(o, "clips_per_run", 1, 1e6, path, "params", &v[2]) ||
        get_int(o, "seed", 0, MAX_SEED, path, "params", &v[3]) ||
        get_int(o, "downscale", 1, 64, path, "params", &v[4]) ||
        get_string(o, "sampling", sampling, sizeof sampling, path, "params"))
        return -1;
    if (gv_sampling_from_name(sampling, &p->sampling) != 0) return gv_fail_context("%s", path);
    /* Absent in folders built before lean density control existed: they used the reference's. */
    p->densify = GV_DENSIFY_REFERENCE;
    if (cJSON_GetObjectItemCaseSensitive(o, "densify")) {
        char densify[16];
        if (get_string(o, "densify", densify, sizeof densify, path, "params")) return -1;
        int mode = gv_splat_densify_mode_parse(densify);
        if (mode < 0)
            return gv_fail("%s: params: densify \"%s\": expected " GV_DENSIFY_MODE_NAMES, path, densify);
        p->densify = mode;
    }
    p->iters = (int)v[0], p->anchor_gap = (int)v[1], p->clips_per_run = (int)v[2];
    p->seed = (uint64_t)v[3], p->downscale = (int)v[4];
    /* Only in scene-internal folders whose pairs come from other than 2 subsets. */
    p->subsets = 0;
    if (cJSON_GetObjectItemCaseSensitive(o, "subsets")) {
        double k;
        if (get_int(o, "subsets", 3, 1e6, path, "params", &k)) return -1;
        p->subsets = (int)k;
    }
    return 0;
}

static int check_split(const char *split, const char *path, const char *where)
{
    if (strcmp(split, "train") && strcmp(split, "eval"))
        return gv_fail("%s: %s: split '%s': expected train or eval", path, where, split);
    return 0;
}

static int read_run(const cJSON *o, const char *path, int i, gv_manifest_run *r)
{
    char where[32];
    double n, clips, seconds;
    snprintf(where, sizeof where, "runs[%d]", i);
    memset(r, 0, sizeof *r);
    const cJSON *s = cJSON_GetObjectItemCaseSensitive(o, "seconds");
    if (!cJSON_IsObject(o)) return gv_fail("%s: %s: not an object", path, where);
    if (get_string(o, "scene", r->id.scene, sizeof r->id.scene, path, where) ||
        get_string(o, "split", r->id.split, sizeof r->id.split, path, where) ||
        check_split(r->id.split, path, where) || get_int(o, "n", 2, 1e6, path, where, &n) ||
        get_int(o, "clips", 0, 1e6, path, where, &clips))
        return -1;
    seconds = cJSON_IsNumber(s) ? s->valuedouble : 0;
    r->id.interval = (int)n, r->n_clips = (int)clips, r->seconds = isfinite(seconds) ? seconds : 0;
    return 0;
}

static int read_clip(const cJSON *o, const char *path, int i, gv_manifest_clip *c)
{
    char where[32];
    double n;
    snprintf(where, sizeof where, "clips[%d]", i);
    memset(c, 0, sizeof *c);
    if (!cJSON_IsObject(o)) return gv_fail("%s: %s: not an object", path, where);
    if (get_string(o, "file", c->file, sizeof c->file, path, where) ||
        get_string(o, "scene", c->id.scene, sizeof c->id.scene, path, where) ||
        get_string(o, "split", c->id.split, sizeof c->id.split, path, where) ||
        check_split(c->id.split, path, where) || get_int(o, "n", 2, 1e6, path, where, &n))
        return -1;
    c->id.interval = (int)n;
    const cJSON *list = cJSON_GetObjectItemCaseSensitive(o, "frame_indices");
    if (!cJSON_IsArray(list) || cJSON_GetArraySize(list) != GV_CLIP_FRAMES)
        return gv_fail("%s: %s: \"frame_indices\" must be a list of %d integers", path, where, GV_CLIP_FRAMES);
    for (int k = 0; k < GV_CLIP_FRAMES; k++) {
        const cJSON *v = cJSON_GetArrayItem(list, k);
        if (!cJSON_IsNumber(v) || v->valuedouble < 0 || v->valuedouble > 1e9 ||
            v->valuedouble != floor(v->valuedouble))
            return gv_fail("%s: %s: \"frame_indices\" must be a list of %d integers", path, where, GV_CLIP_FRAMES);
        c->frames[k] = (int)v->valuedouble;
    }
    if (strstr(c->file, "..") || c->file[0] == '/')
        return gv_fail("%s: %s: file '%s' must stay inside the dataset folder", path, where, c->file);
    return 0;
}

static int read_lists(const cJSON *root, const char *path, gv_manifest *m)
{
    const cJSON *runs = cJSON_GetObjectItemCaseSensitive(root, "runs");
    const cJSON *clips = cJSON_GetObjectItemCaseSensitive(root, "clips");
    if (!cJSON_IsArray(runs) || !cJSON_IsArray(clips))
        return gv_fail("%s: \"runs\" and \"clips\" must be lists", path);
    int n_runs = cJSON_GetArraySize(runs), n_clips = cJSON_GetArraySize(clips);
    if (reserve((void **)&m->runs, &m->cap_runs, n_runs, sizeof *m->runs) ||
        reserve((void **)&m->clips, &m->cap_clips, n_clips, sizeof *m->clips))
        return -1;
    const cJSON *item;
    cJSON_ArrayForEach(item, runs) {
        if (read_run(item, path, m->n_runs, &m->runs[m->n_runs]) != 0) return -1;
        if (gv_manifest_find_run(m, m->runs[m->n_runs].id.scene, m->runs[m->n_runs].id.interval) >= 0)
            return gv_fail("%s: runs[%d]: run %s n=%d is listed twice", path, m->n_runs,
                           m->runs[m->n_runs].id.scene, m->runs[m->n_runs].id.interval);
        m->n_runs++;
    }
    cJSON_ArrayForEach(item, clips) {
        gv_manifest_clip *c = &m->clips[m->n_clips];
        if (read_clip(item, path, m->n_clips, c) != 0) return -1;
        int r = gv_manifest_find_run(m, c->id.scene, c->id.interval);
        if (r < 0 || strcmp(m->runs[r].id.split, c->id.split))
            return gv_fail("%s: clips[%d]: %s n=%d (%s) is not a run of the manifest", path,
                           m->n_clips, c->id.scene, c->id.interval, c->id.split);
        m->n_clips++;
    }
    return 0;
}

int gv_manifest_read_dataset(const char *dir, gv_manifest *m)
{
    int found = 0;
    if (gv_manifest_read(dir, m, &found)) return -1;
    if (!found) return gv_fail("%s: no manifest.json (not a dataset folder)", dir);
    return 0;
}

int gv_manifest_read(const char *dir, gv_manifest *m, int *found)
{
    char path[4096];
    gv_manifest_init(m, NULL);
    *found = 0;
    if (gv_path_join(path, sizeof path, dir, MANIFEST_NAME) != 0) return -1;
    if (!gv_file_exists(path)) return 0;
    char *text;
    size_t size;
    if (gv_read_file(path, &text, &size) != 0) return -1;
    cJSON *root = cJSON_ParseWithLength(text, size);
    free(text);
    int rc = 0;
    const cJSON *format = cJSON_GetObjectItemCaseSensitive(root, "format");
    const cJSON *version = cJSON_GetObjectItemCaseSensitive(root, "format_version");
    if (!cJSON_IsObject(root)) rc = gv_fail("%s: not a JSON object", path);
    else if (!cJSON_IsString(format) || strcmp(format->valuestring, GV_MANIFEST_FORMAT))
        rc = gv_fail("%s: \"format\" is not \"%s\" (not a gaussvid dataset manifest)", path, GV_MANIFEST_FORMAT);
    else if (!cJSON_IsNumber(version) || version->valuedouble != GV_MANIFEST_FORMAT_VERSION)
        rc = gv_fail("%s: manifest format version is not %d", path, GV_MANIFEST_FORMAT_VERSION);
    else
        rc = read_params(cJSON_GetObjectItemCaseSensitive(root, "params"), path, &m->params) ||
                     read_lists(root, path, m) ? -1 : 0;
    cJSON_Delete(root);
    if (rc != 0) {
        gv_manifest_free(m);
        return -1;
    }
    *found = 1;
    return 0;
}
