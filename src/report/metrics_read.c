/* Reads metrics.json, the record `gaussvid reconstruct` keeps of its run (docs/REPORT.md),
 * into report_metrics. Every problem is one line naming the file and the key as a path
 * (runs[0].frames[3].sparse.psnr), because the file is written stage by stage and a user who
 * edits or truncates it needs to know where it went wrong.
 *
 * What is required is what exists from the first stage on (format, scene, size, runs with
 * their interval, path and frames with a render); what later stages add (restored and
 * refined images, scores, means, Gaussian counts, stages) may be null or absent, and the
 * report shows a dash. Unknown keys are ignored, so a newer writer can add some. */
#include "report_internal.h"

#include "gaussvid/core/core.h"
#include "gaussvid/io/json.h"

#include <math.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

const char *const report_model_names[N_MODELS] = {"sparse", "restored", "refined"};
const char *const report_image_names[N_IMAGES] = {"render", "restored", "refined", "ground_truth"};
const char *const report_decision_names[N_DECISIONS] = {"adaptation", "restoration", "refinement"};

typedef struct {
    const char *path; /* the file, for messages */
    char where[256];  /* the key path of the object being read */
} reader;

/* "runs[0].frames[3]" + ".psnr" -> a key path for a message. */
static const char *key_path(const reader *r, const char *key, char *buf, size_t size)
{
    snprintf(buf, size, "%s%s%s", r->where, r->where[0] ? "." : "", key);
    return buf;
}

static int bad_key(const reader *r, const char *key, const char *fmt, ...)
    __attribute__((format(printf, 3, 4)));
static int bad_key(const reader *r, const char *key, const char *fmt, ...)
{
    char path[320], what[256];
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(what, sizeof what, fmt, ap);
    va_end(ap);
    return gv_fail("%s: %s: %s", r->path, key_path(r, key, path, sizeof path), what);
}

/* The member, or NULL (with a message when required) when it is absent. */
static const cJSON *member(const reader *r, const cJSON *o, const char *key, int required)
{
    const cJSON *v = cJSON_GetObjectItemCaseSensitive(o, key);
    if (!v && required) bad_key(r, key, "missing");
    return v;
}

static int read_number(const reader *r, const cJSON *o, const char *key, double min, double max,
                       int integer, double *out)
{
    const cJSON *v = member(r, o, key, 1);
    if (!v) return -1;
    if (!cJSON_IsNumber(v)) return bad_key(r, key, "expected a number, found %s", gv_json_type(v));
    if (!(v->valuedouble >= min && v->valuedouble <= max))
        return bad_key(r, key, "%g is outside [%g, %g]", v->valuedouble, min, max);
    if (integer && v->valuedouble != floor(v->valuedouble))
        return bad_key(r, key, "expected an integer, found %g", v->valuedouble);
    *out = v->valuedouble;
    return 0;
}

static int read_int(const reader *r, const cJSON *o, const char *key, int min, int max, int *out)
{
    double v;
    if (read_number(r, o, key, min, max, 1, &v) != 0) return -1;
    *out = (int)v;
    return 0;
}

/* A string member; with nullable, null gives "" (or NULL through dup). */
static int read_string(const reader *r, const cJSON *o, const char *key, int nullable, char *out, size_t size)
{
    const cJSON *v = member(r, o, key, 1);
    if (!v) return -1;
    if (nullable && cJSON_IsNull(v)) {
        out[0] = '\0';
        return 0;
    }
    if (!cJSON_IsString(v))
        return bad_key(r, key, "expected a string%s, found %s", nullable ? " or null" : "", gv_json_type(v));
    if (strlen(v->valuestring) >= size) return bad_key(r, key, "longer than %zu characters", size - 1);
    memcpy(out, v->valuestring, strlen(v->valuestring) + 1);
    return 0;
}

/* A string from the file as a message shows it: at most 60 characters, control characters as
 * '?', so a message stays one line. */
static const char *shown(const char *s, char *buf, size_t size)
{
    size_t n = 0;
    for (; *s && n + 1 < size && n < 60; s++) buf[n++] = (unsigned char)*s < 0x20 ? '?' : *s;
    buf[n] = '\0';
    return buf;
}

static int has_control_character(const char *s)
{
    for (; *s; s++)
        if ((unsigned char)*s < 0x20) return 1;
    return 0;
}

/* Enters a child object or array for messages: where += ".key" or "[i]". */
static void enter(reader *r, const char *fmt, ...) __attribute__((format(printf, 2, 3)));
static void enter(reader *r, const char *fmt, ...)
{
    size_t n = strlen(r->where);
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(r->where + n, sizeof r->where - n, fmt, ap);
    va_end(ap);
}

static void leave(reader *r, size_t length) { r->where[length] = '\0'; }

/* An object or null: returns the object, NULL for null or absent (when optional), or sets *bad. */
static const cJSON *object_or_null(const reader *r, const cJSON *o, const char *key, int required, int *bad)
{
    const cJSON *v = member(r, o, key, required);
    *bad = required && !v;
    if (!v || cJSON_IsNull(v)) return NULL;
    if (!cJSON_IsObject(v)) {
        bad_key(r, key, "expected an object or null, found %s", gv_json_type(v));
        *bad = 1;
        return NULL;
    }
    return v;
}

/* {"psnr": .., "ssim": .., "lpips": .. | null [, "frames": N]} or null. */
static int read_score(reader *r, const cJSON *o, const char *key, int with_frames, report_score *s)
{
    memset(s, 0, sizeof *s);
    int bad;
    const cJSON *v = object_or_null(r, o, key, 0, &bad);
    if (bad) return -1;
    if (!v) return 0;
    size_t at = strlen(r->where);
    enter(r, "%s%s", at ? "." : "", key);
    int rc = read_number(r, v, "psnr", 0, 1000, 0, &s->psnr);
    if (rc == 0) rc = read_number(r, v, "ssim", -1, 1, 0, &s->ssim);
    const cJSON *l = rc == 0 ? member(r, v, "lpips", 0) : NULL;
    if (l && !cJSON_IsNull(l)) {
        rc = read_number(r, v, "lpips", 0, 10, 0, &s->lpips);
        s->has_lpips = rc == 0;
    }
    if (rc == 0 && with_frames) rc = read_int(r, v, "frames", 0, 1 << 30, &s->frames);
    leave(r, at);
    s->present = rc == 0;
    return rc;
}

static int read_images(reader *r, const cJSON *frame, report_frame *f)
{
    int bad;
    const cJSON *images = object_or_null(r, frame, "images", 1, &bad);
    if (bad) return -1;
    if (!images) return bad_key(r, "images", "expected an object, found null");
    size_t at = strlen(r->where);
    enter(r, ".images");
    int rc = 0;
    for (int k = 0; k < N_IMAGES && rc == 0; k++) {
        char name[4096];
        /* the render exists from the first stage on; the others come later (or never: ground truth) */
        rc = read_string(r, images, report_image_names[k], k != IMAGE_RENDER, name, sizeof name);
        if (rc == 0 && k == IMAGE_RENDER && !name[0]) rc = bad_key(r, report_image_names[k], "expected a path, found \"\"");
        if (rc == 0 && name[0] && !(f->images[k] = strdup(name))) rc = gv_fail("out of memory");
        char buf[64];
        if (rc == 0 && has_control_character(name))
            rc = bad_key(r, report_image_names[k], "the path contains a control character");
        if (rc == 0 && k != IMAGE_GROUND_TRUTH && name[0] == '/')
            rc = bad_key(r, report_image_names[k], "expected a path relative to the folder, found %s", shown(name, buf, sizeof buf));
    }
    leave(r, at);
    return rc;
}

/* The frame's name: "name" (the photo's, absent from folders written before it), else the
 * render's file name without its folder and .png. */
static int read_name(reader *r, const cJSON *frame, report_frame *f)
{
    char name[4096] = "";
    if (cJSON_GetObjectItem(frame, "name") && read_string(r, frame, "name", 1, name, sizeof name)) return -1;
    if (has_control_character(name)) return bad_key(r, "name", "the name contains a control character");
    if (!name[0]) {
        const char *base = strrchr(f->images[IMAGE_RENDER], '/');
        snprintf(name, sizeof name, "%s", base ? base + 1 : f->images[IMAGE_RENDER]);
        size_t n = strlen(name);
        if (n > 4 && !strcmp(name + n - 4, ".png")) name[n - 4] = '\0';
    }
    return (f->name = strdup(name)) ? 0 : gv_fail("out of memory");
}

static int read_frames(reader *r, const cJSON *run, report_run *out)
{
    const cJSON *frames = member(r, run, "frames", 1);
    if (!frames) return -1;
    if (!cJSON_IsArray(frames)) return bad_key(r, "frames", "expected an array, found %s", gv_json_type(frames));
    int n = cJSON_GetArraySize(frames);
    out->frames = calloc(n ? (size_t)n : 1, sizeof *out->frames);
    if (!out->frames) return gv_fail("out of memory");
    size_t at = strlen(r->where);
    const cJSON *frame;
    cJSON_ArrayForEach(frame, frames) {
        report_frame *f = &out->frames[out->n_frames];
        enter(r, ".frames[%d]", out->n_frames);
        out->n_frames++;
        int rc = cJSON_IsObject(frame) ? 0 : gv_fail("%s: %s: expected an object, found %s", r->path, r->where, gv_json_type(frame));
        if (rc == 0) rc = read_int(r, frame, "frame", 0, 1 << 30, &f->frame);
        if (rc == 0) rc = read_images(r, frame, f);
        if (rc == 0) rc = read_name(r, frame, f);
        for (int k = 0; k < N_MODELS && rc == 0; k++) rc = read_score(r, frame, report_model_names[k], 0, &f->score[k]);
        leave(r, at);
        if (rc != 0) return -1;
    }
    return 0;
}

static int read_int_array(reader *r, const cJSON *o, const char *key, int **out, int *n)
{
    const cJSON *a = member(r, o, key, 1);
    if (!a) return -1;
    if (!cJSON_IsArray(a)) return bad_key(r, key, "expected an array, found %s", gv_json_type(a));
    *n = 0;
    *out = calloc((size_t)cJSON_GetArraySize(a) + 1, sizeof **out);
    if (!*out) return gv_fail("out of memory");
    const cJSON *v;
    cJSON_ArrayForEach(v, a) {
        if (!cJSON_IsNumber(v) || v->valuedouble < 0 || v->valuedouble != floor(v->valuedouble) || v->valuedouble > 1 << 30)
            return gv_fail("%s: %s%s%s[%d]: expected a frame index, found %s", r->path, r->where,
                           r->where[0] ? "." : "", key, *n, cJSON_IsNumber(v) ? "a negative or fractional number" : gv_json_type(v));
        (*out)[(*n)++] = (int)v->valuedouble;
    }
    return 0;
}

static int read_stages(reader *r, const cJSON *run, report_run *out)
{
    const cJSON *stages = member(r, run, "stages", 0);
    if (!stages || cJSON_IsNull(stages)) return 0;
    if (!cJSON_IsArray(stages)) return bad_key(r, "stages", "expected an array, found %s", gv_json_type(stages));
    out->stages = calloc((size_t)cJSON_GetArraySize(stages) + 1, sizeof *out->stages);
    if (!out->stages) return gv_fail("out of memory");
    size_t at = strlen(r->where);
    const cJSON *s;
    cJSON_ArrayForEach(s, stages) {
        report_stage *st = &out->stages[out->n_stages];
        enter(r, ".stages[%d]", out->n_stages);
        out->n_stages++;
        int rc = cJSON_IsObject(s) ? 0 : gv_fail("%s: %s: expected an object, found %s", r->path, r->where, gv_json_type(s));
        if (rc == 0) rc = read_string(r, s, "name", 0, st->name, sizeof st->name);
        if (rc == 0) rc = read_number(r, s, "seconds", 0, 1e9, 0, &st->seconds);
        st->cpu_seconds = -1;
        if (rc == 0 && member(r, s, "cpu_seconds", 0) && !cJSON_IsNull(member(r, s, "cpu_seconds", 0)))
            rc = read_number(r, s, "cpu_seconds", 0, 1e9, 0, &st->cpu_seconds);
        if (rc == 0 && member(r, s, "summary", 0))
            rc = read_string(r, s, "summary", 1, st->summary, sizeof st->summary);
        leave(r, at);
        if (rc != 0) return -1;
    }
    return 0;
}

/* "gaussians": {"sparse": N, "refined": N}: each absent or null until its stage ran. */
static int read_gaussians(reader *r, const cJSON *run, report_run *out)
{
    out->gaussians[0] = out->gaussians[1] = -1;
    int bad;
    const cJSON *g = object_or_null(r, run, "gaussians", 0, &bad);
    if (bad || !g) return bad ? -1 : 0;
    size_t at = strlen(r->where);
    enter(r, ".gaussians");
    int rc = 0;
    for (int k = 0; k < 2 && rc == 0; k++) {
        const char *key = k ? "refined" : "sparse";
        const cJSON *v = member(r, g, key, 0);
        double count;
        if (!v || cJSON_IsNull(v)) continue;
        rc = read_number(r, g, key, 0, 1e12, 1, &count);
        if (rc == 0) out->gaussians[k] = (long)count;
    }
    leave(r, at);
    return rc;
}

/* "restorer": {"checkpoint", "kind", "gate", "training_scenes"} or null / absent (nothing
 * restored yet); "training_scenes" may be absent (files written before it was recorded). */
static int read_restorer(reader *r, const cJSON *o, report_restorer *out)
{
    int bad;
    const cJSON *restorer = object_or_null(r, o, "restorer", 0, &bad);
    if (bad || !restorer) return bad ? -1 : 0;
    size_t at = strlen(r->where);
    enter(r, "%srestorer", at ? "." : "");
    int rc = read_string(r, restorer, "checkpoint", 1, out->checkpoint, sizeof out->checkpoint);
    if (rc == 0) rc = read_string(r, restorer, "kind", 1, out->kind, sizeof out->kind);
    if (rc == 0) rc = read_string(r, restorer, "gate", 1, out->gate, sizeof out->gate);
    out->training_scenes[0] = '\0';
    if (rc == 0 && member(r, restorer, "training_scenes", 0))
        rc = read_string(r, restorer, "training_scenes", 1, out->training_scenes, sizeof out->training_scenes);
    leave(r, at);
    out->present = rc == 0;
    return rc;
}

/* "inputs": the options a run was made with, shown as they are: every number, string and
 * boolean member as "key value", in the file's order. */
static void read_inputs(const cJSON *run, char *out, size_t size)
{
    const cJSON *inputs = cJSON_GetObjectItemCaseSensitive(run, "inputs"), *v;
    size_t used = 0;
    out[0] = '\0';
    if (!cJSON_IsObject(inputs)) return;
    cJSON_ArrayForEach(v, inputs) {
        char value[256];
        if (cJSON_IsNumber(v)) snprintf(value, sizeof value, "%g", v->valuedouble);
        else if (cJSON_IsString(v) && v->valuestring[0]) snprintf(value, sizeof value, "%s", v->valuestring);
        else if (cJSON_IsBool(v)) snprintf(value, sizeof value, "%s", cJSON_IsTrue(v) ? "yes" : "no");
        else continue;
        int n = snprintf(out + used, size - used, "%s%s %s", used ? ", " : "", v->string, value);
        if (n < 0 || (size_t)n >= size - used) break;
        used += (size_t)n;
    }
}

/* "consistency" (optional: the evaluate stage adds it): per set {"psnr": number | null, ...}. */
static int read_consistency(reader *r, const cJSON *run, report_run *out)
{
    int bad;
    const cJSON *c = object_or_null(r, run, "consistency", 0, &bad);
    if (bad) return -1;
    if (!c) return 0;
    size_t at = strlen(r->where);
    enter(r, ".consistency");
    int rc = 0;
    for (int k = 0; k < N_MODELS && rc == 0; k++) {
        out->consistency[k] = NAN;
        const cJSON *set = object_or_null(r, c, report_model_names[k], 0, &bad);
        if (bad) rc = -1;
        const cJSON *psnr = set ? cJSON_GetObjectItem(set, "psnr") : NULL;
        if (rc == 0 && psnr && !cJSON_IsNull(psnr)) {
            enter(r, ".%s", report_model_names[k]);
            rc = read_number(r, set, "psnr", 0, 1000, 0, &out->consistency[k]);
            leave(r, at + strlen(".consistency"));
        }
    }
    leave(r, at);
    if (rc == 0) out->has_consistency = 1;
    return rc;
}

/* "decisions": {"restore_with", "gate", "adaptation": {"ran", "why"} | null, ...}; absent in
 * files from before they were recorded. */
static int read_decisions(reader *r, const cJSON *run, report_run *out)
{
    int bad;
    const cJSON *d = object_or_null(r, run, "decisions", 0, &bad);
    if (bad || !d) return bad ? -1 : 0;
    size_t at = strlen(r->where);
    enter(r, ".decisions");
    int rc = 0;
    if (member(r, d, "restore_with", 0)) rc = read_string(r, d, "restore_with", 1, out->restore_with, sizeof out->restore_with);
    if (rc == 0 && member(r, d, "gate", 0)) rc = read_string(r, d, "gate", 1, out->gate, sizeof out->gate);
    for (int k = 0; k < N_DECISIONS && rc == 0; k++) {
        const cJSON *v = object_or_null(r, d, report_decision_names[k], 0, &bad);
        if (bad) rc = -1;
        if (rc || !v) continue;
        report_decision *dec = &out->decisions[k];
        const cJSON *ran = member(r, v, "ran", 0);
        if (!cJSON_IsBool(ran)) {
            enter(r, ".%s", report_decision_names[k]);
            rc = bad_key(r, "ran", "expected true or false");
            break;
        }
        dec->ran = cJSON_IsTrue(ran);
        enter(r, ".%s", report_decision_names[k]);
        rc = read_string(r, v, "why", 1, dec->why, sizeof dec->why);
        leave(r, at + strlen(".decisions"));
        dec->present = rc == 0;
    }
    leave(r, at);
    return rc;
}

static int read_run(reader *r, const cJSON *run, report_run *out)
{
    char path[16];
    if (!cJSON_IsObject(run)) return gv_fail("%s: %s: expected an object, found %s", r->path, r->where, gv_json_type(run));
    if (read_int(r, run, "interval", 1, 1 << 20, &out->interval) != 0) return -1;
    if (read_string(r, run, "path", 0, path, sizeof path) != 0) return -1;
    char buf[64];
    if (strcmp(path, "held-out") && strcmp(path, "smooth"))
        return bad_key(r, "path", "expected \"held-out\" or \"smooth\", found \"%s\"", shown(path, buf, sizeof buf));
    out->smooth = !strcmp(path, "smooth");
    if (read_int_array(r, run, "train_frames", &out->train_frames, &out->n_train) != 0) return -1;
    if (read_gaussians(r, run, out) != 0) return -1;
    if (read_frames(r, run, out) != 0) return -1;
    int bad;
    const cJSON *means = object_or_null(r, run, "means", 0, &bad);
    if (bad) return -1;
    if (means) {
        size_t at = strlen(r->where);
        enter(r, ".means");
        int rc = 0;
        for (int k = 0; k < N_MODELS && rc == 0; k++) rc = read_score(r, means, report_model_names[k], 1, &out->means[k]);
        leave(r, at);
        if (rc != 0) return -1;
        out->has_means = 1;
    }
    const cJSON *all = object_or_null(r, run, "all_held_out", 0, &bad);
    if (bad) return -1;
    if (all) {
        size_t at = strlen(r->where);
        enter(r, ".all_held_out");
        int rc = 0;
        for (int k = 0; k < N_MODELS && rc == 0; k++)
            if (k != MODEL_RESTORED) rc = read_score(r, all, report_model_names[k], 1, &out->all_held_out[k]);
        leave(r, at);
        if (rc != 0) return -1;
        out->has_all_held_out = 1;
    }
    if (read_consistency(r, run, out) != 0) return -1;
    if (read_restorer(r, run, &out->restorer) != 0) return -1;
    if (read_decisions(r, run, out) != 0) return -1;
    read_inputs(run, out->inputs, sizeof out->inputs);
    return read_stages(r, run, out);
}

static int read_document(reader *r, const cJSON *root, report_metrics *m)
{
    char format[64];
    if (!cJSON_IsObject(root)) return gv_fail("%s: expected a JSON object, found %s", r->path, gv_json_type(root));
    if (read_string(r, root, "format", 0, format, sizeof format) != 0) return -1;
    char buf[64];
    if (strcmp(format, "gaussvid-reconstruct-1"))
        return bad_key(r, "format", "expected \"gaussvid-reconstruct-1\", found \"%s\"", shown(format, buf, sizeof buf));
    if (read_string(r, root, "scene", 0, m->scene, sizeof m->scene) != 0) return -1;
    if (read_string(r, root, "scene_dir", 0, m->scene_dir, sizeof m->scene_dir) != 0) return -1;
    if (has_control_character(m->scene_dir)) return bad_key(r, "scene_dir", "the path contains a control character");
    if (read_int(r, root, "width", 1, 1 << 16, &m->width) != 0) return -1;
    if (read_int(r, root, "height", 1, 1 << 16, &m->height) != 0) return -1;
    if (read_restorer(r, root, &m->restorer) != 0) return -1;
    if (member(r, root, "preset", 0) && read_string(r, root, "preset", 1, m->preset, sizeof m->preset) != 0) return -1;
    const cJSON *runs = member(r, root, "runs", 1);
    if (!runs) return -1;
    if (!cJSON_IsArray(runs)) return bad_key(r, "runs", "expected an array, found %s", gv_json_type(runs));
    m->runs = calloc((size_t)cJSON_GetArraySize(runs) + 1, sizeof *m->runs);
    if (!m->runs) return gv_fail("out of memory");
    const cJSON *run;
    cJSON_ArrayForEach(run, runs) {
        enter(r, "runs[%d]", m->n_runs);
        int rc = read_run(r, run, &m->runs[m->n_runs++]);
        leave(r, 0);
        if (rc != 0) return -1;
    }
    return 0;
}

int report_metrics_read(const char *path, report_metrics *m)
{
    memset(m, 0, sizeof *m);
    char *text;
    size_t size;
    if (gv_read_file(path, &text, &size) != 0) return -1;
    const char *end = NULL;
    cJSON *root = cJSON_ParseWithLengthOpts(text, size, &end, 0);
    if (!root) {
        long offset = end ? (long)(end - text) : 0;
        free(text);
        return gv_fail("%s: not valid JSON (near byte %ld)", path, offset);
    }
    free(text);
    reader r = {.path = path};
    int rc = read_document(&r, root, m);
    cJSON_Delete(root);
    if (rc != 0) report_metrics_free(m);
    return rc;
}

void report_metrics_free(report_metrics *m)
{
    for (int i = 0; i < m->n_runs; i++) {
        report_run *run = &m->runs[i];
        for (int f = 0; f < run->n_frames; f++) {
            for (int k = 0; k < N_IMAGES; k++) free(run->frames[f].images[k]);
            free(run->frames[f].name);
        }
        free(run->frames);
        free(run->train_frames);
        free(run->stages);
    }
    free(m->runs);
    memset(m, 0, sizeof *m);
}
