/* DIR/metrics.json (docs/RECONSTRUCT.md, "metrics.json"): the numbers of every interval's run
 * and, per run, the inputs it was made from and the stages finished, so that a rerun knows
 * what to skip. Kept as a cJSON tree and rewritten atomically after every stage. */
#include <errno.h>
#include <limits.h>
#include <stdlib.h>
#include <string.h>

#include "gaussvid/train/checkpoint.h"
#include "gaussvid/core/core.h"
#include "gaussvid/io/json.h"
#include "gaussvid/train/scene_adapt.h"
#include "gaussvid/splat/splat_train.h"
#include "pipeline/pipeline_internal.h"

static int metrics_path(const gv_reconstruct_options *o, char *out, size_t size)
{
    return gv_path_join(out, size, o->out_dir, "metrics.json");
}

/* The restorer as the document names it: the checkpoint, "scene" or "cross-scene", a scene
 * checkpoint's gate ("open" / "closed"; null otherwise) and the scenes it was trained on (a
 * scene checkpoint: its base's; null when the checkpoint does not record them). */
cJSON *pipeline_restorer_json(const char *ckpt, const gv_restorer *r, int adapt)
{
    cJSON *j = cJSON_CreateObject();
    cJSON_AddStringToObject(j, "checkpoint", ckpt);
    cJSON_AddStringToObject(j, "kind", r->scene || adapt ? "scene" : "cross-scene");
    if (r->scene) cJSON_AddStringToObject(j, "gate", r->adaptation.gate_open ? "open" : "closed");
    else cJSON_AddNullToObject(j, "gate");
    if (r->scenes_known == 1) cJSON_AddStringToObject(j, "training_scenes", r->training_scenes);
    else cJSON_AddNullToObject(j, "training_scenes"); /* unknown, or unreadable: the stages say why */
    return j;
}

static cJSON *read_doc(const char *path, const char *scene_dir)
{
    FILE *f = fopen(path, "rb");
    if (!f) return NULL;
    fseek(f, 0, SEEK_END);
    long size = ftell(f);
    fseek(f, 0, SEEK_SET);
    char *text = size >= 0 ? malloc((size_t)size + 1) : NULL;
    size_t got = text ? fread(text, 1, (size_t)size, f) : 0;
    fclose(f);
    if (!text || got != (size_t)size) {
        free(text);
        gv_fail("%s: cannot read", path);
        return NULL;
    }
    text[size] = 0;
    cJSON *doc = cJSON_Parse(text);
    free(text);
    char format[64] = "", dir[PATH_MAX] = "";
    if (!doc || !cJSON_IsObject(doc) || gv_json_string(doc, "format", format, sizeof format) ||
        strcmp(format, GV_RECONSTRUCT_FORMAT) || !cJSON_IsArray(cJSON_GetObjectItem(doc, "runs")) ||
        gv_json_string(doc, "scene_dir", dir, sizeof dir)) {
        gv_fail("%s: not a %s file (remove it or use another --out)", path, GV_RECONSTRUCT_FORMAT);
        cJSON_Delete(doc);
        return NULL;
    }
    if (strcmp(dir, scene_dir)) {
        gv_fail("%s: made for the scene %s, not %s (use another --out)", path, dir, scene_dir);
        cJSON_Delete(doc);
        return NULL;
    }
    return doc;
}

int pipeline_doc_open(const gv_reconstruct_options *o, const gv_scene *scene, const gv_restorer *rec, cJSON **out)
{
    char path[4096], abs[PATH_MAX], name[GV_SCENE_NAME_MAX];
    *out = NULL;
    if (metrics_path(o, path, sizeof path)) return -1;
    if (!realpath(o->scene_dir, abs)) return gv_fail("%s: cannot resolve: %s", o->scene_dir, strerror(errno));
    if (gv_scene_name_of(o->scene_dir, name, sizeof name)) return -1;
    cJSON *doc = NULL;
    if (gv_file_exists(path) && !(doc = read_doc(path, abs))) return -1;
    if (!doc) {
        doc = cJSON_CreateObject();
        cJSON_AddStringToObject(doc, "format", GV_RECONSTRUCT_FORMAT);
        cJSON_AddStringToObject(doc, "scene", name);
        cJSON_AddStringToObject(doc, "scene_dir", abs);
        cJSON_AddNumberToObject(doc, "width", scene->cameras[0].width);
        cJSON_AddNumberToObject(doc, "height", scene->cameras[0].height);
        cJSON_AddItemToObject(doc, "runs", cJSON_CreateArray());
    }
    cJSON_DeleteItemFromObject(doc, "restorer");
    if (o->restore_with == GV_RESTORE_NONE) cJSON_AddNullToObject(doc, "restorer");
    else cJSON_AddItemToObject(doc, "restorer", pipeline_restorer_json(o->ckpt, rec, o->restore_with == GV_RESTORE_ADAPTED));
    cJSON_DeleteItemFromObject(doc, "preset");
    cJSON_AddStringToObject(doc, "preset", o->preset ? o->preset : "default");
    *out = doc;
    return 0;
}

/* What a run's results depend on: a finished run made from other inputs is not reused. */
static cJSON *inputs_json(const gv_reconstruct_options *o)
{
    cJSON *j = cJSON_CreateObject();
    int adapted = o->restore_with == GV_RESTORE_ADAPTED;
    cJSON_AddStringToObject(j, "preset", o->preset ? o->preset : "default");
    cJSON_AddNumberToObject(j, "iters", o->iters);
    cJSON_AddStringToObject(j, "densify", gv_splat_densify_mode_name(o->densify));
    char regularize[64];
    gv_splat_regularize_name(o->regularize, regularize, sizeof regularize);
    cJSON_AddStringToObject(j, "regularize", regularize);
    cJSON_AddNumberToObject(j, "resolution_schedule", o->resolution_start > 1 ? o->resolution_start : 1);
    cJSON_AddNumberToObject(j, "refine_iters", o->refine_iters);
    cJSON_AddNumberToObject(j, "refine_weight", o->refine_weight);
    cJSON_AddStringToObject(j, "checkpoint", o->ckpt);
    cJSON_AddStringToObject(j, "restore_with", gv_restore_with_name(o->restore_with));
    cJSON_AddNumberToObject(j, "adapt_steps", adapted ? (double)o->adapt_options.train.steps : 0);
    cJSON_AddStringToObject(j, "adapt_config", adapted && o->adapt_options.config ? o->adapt_options.config : "");
    cJSON_AddNumberToObject(j, "downscale", o->downscale);
    cJSON_AddNumberToObject(j, "seed", (double)o->seed);
    if (o->lpips) cJSON_AddStringToObject(j, "lpips", o->lpips);
    else cJSON_AddNullToObject(j, "lpips");
    cJSON_AddNumberToObject(j, "fps", o->fps);
    return j;
}

/* The first input that differs, as "iters 3000, now 2000". */
static void describe_difference(const cJSON *was, const cJSON *now, char *out, size_t size)
{
    snprintf(out, size, "other inputs");
    for (const cJSON *n = now->child; n; n = n->next) {
        const cJSON *w = cJSON_GetObjectItem(was, n->string);
        if (w && cJSON_Compare(w, n, 1)) continue;
        char *a = w ? cJSON_PrintUnformatted(w) : NULL, *b = cJSON_PrintUnformatted(n);
        snprintf(out, size, "%s %s, now %s", n->string, a ? a : "(none)", b ? b : "?");
        free(a), free(b);
        return;
    }
}

/* The frame's name as a person reads it, and its images' paths: set again on a resumed run,
 * whose folder may have been written when frames were named otherwise. */
static void set_string(cJSON *o, const char *key, const char *value)
{
    if (cJSON_GetObjectItem(o, key)) cJSON_ReplaceItemInObject(o, key, cJSON_CreateString(value)); /* keeps the order */
    else cJSON_AddStringToObject(o, key, value);
}

static void name_frame(const pipeline_run *r, const pipeline_frame *f, cJSON *j, cJSON *images)
{
    char rel[256];
    const char *kinds[3] = {"render", "restored", "refined"};
    set_string(j, "name", r->smooth_path ? f->name : r->scene->cameras[f->index].name);
    for (int k = 0; k < 3; k++) {
        pipeline_frame_relpath(r, kinds[k], f->index, rel, sizeof rel);
        set_string(images, kinds[k], rel);
    }
}

static cJSON *frame_json(const pipeline_run *r, const pipeline_frame *f)
{
    cJSON *j = cJSON_CreateObject(), *images = cJSON_CreateObject();
    cJSON_AddNumberToObject(j, "frame", f->index);
    name_frame(r, f, j, images);
    char truth[PATH_MAX], abs[PATH_MAX];
    if (f->truth >= 0 && realpath(r->scene->image_dir, abs) &&
        snprintf(truth, sizeof truth, "%s/%s", abs, r->scene->cameras[f->truth].name) < (int)sizeof truth)
        cJSON_AddStringToObject(images, "ground_truth", truth);
    else
        cJSON_AddNullToObject(images, "ground_truth");
    cJSON_AddItemToObject(j, "images", images);
    cJSON_AddNullToObject(j, "sparse");
    cJSON_AddNullToObject(j, "restored");
    cJSON_AddNullToObject(j, "refined");
    return j;
}

static cJSON *new_run(const pipeline_run *r, cJSON *inputs)
{
    cJSON *run = cJSON_CreateObject();
    cJSON_AddNumberToObject(run, "interval", r->interval);
    cJSON_AddItemToObject(run, "train_frames", cJSON_CreateIntArray(r->train, r->n_train));
    cJSON_AddStringToObject(run, "path", r->smooth_path ? "smooth" : "held-out");
    cJSON_AddItemToObject(run, "inputs", inputs);
    cJSON *g = cJSON_AddObjectToObject(run, "gaussians");
    cJSON_AddNullToObject(g, "sparse");
    cJSON_AddNullToObject(g, "refined");
    cJSON *frames = cJSON_AddArrayToObject(run, "frames");
    for (int i = 0; i < r->n_frames; i++) cJSON_AddItemToArray(frames, frame_json(r, &r->frames[i]));
    cJSON_AddNullToObject(run, "means");
    cJSON_AddNullToObject(run, "all_held_out");
    cJSON_AddArrayToObject(run, "stages");
    return run;
}

/* Where restoration is off, the frames have no restored or refined image. */
static void frame_images(pipeline_run *r)
{
    int restoring = r->opt->restore_with != GV_RESTORE_NONE;
    const cJSON *f;
    int i = 0;
    cJSON_ArrayForEach(f, cJSON_GetObjectItem(r->run, "frames"))
    {
        cJSON *images = cJSON_GetObjectItem(f, "images");
        const char *kinds[2] = {"restored", "refined"};
        for (int k = 0; k < 2 && images && i < r->n_frames; k++) {
            char rel[256];
            pipeline_frame_relpath(r, kinds[k], r->frames[i].index, rel, sizeof rel);
            cJSON_ReplaceItemInObject(images, kinds[k], restoring ? cJSON_CreateString(rel) : cJSON_CreateNull());
        }
        i++;
    }
}

static cJSON *decision_json(int ran, const char *why)
{
    cJSON *j = cJSON_CreateObject();
    cJSON_AddBoolToObject(j, "ran", ran);
    if (why) cJSON_AddStringToObject(j, "why", why);
    else cJSON_AddNullToObject(j, "why");
    return j;
}

void pipeline_decision(pipeline_run *r, const char *what, int ran, const char *why)
{
    cJSON *d = cJSON_GetObjectItem(r->run, "decisions");
    cJSON_DeleteItemFromObject(d, what);
    cJSON_AddItemToObject(d, what, decision_json(ran, why));
}

int pipeline_decision_ran(const pipeline_run *r, const char *what)
{
    const cJSON *d = cJSON_GetObjectItem(r->run, "decisions");
    const cJSON *ran = cJSON_GetObjectItem(cJSON_GetObjectItem(d, what), "ran");
    return cJSON_IsBool(ran) ? cJSON_IsTrue(ran) : -1;
}

void pipeline_decision_gate(pipeline_run *r, const char *gate)
{
    cJSON *d = cJSON_GetObjectItem(r->run, "decisions");
    cJSON_ReplaceItemInObject(d, "gate", gate ? cJSON_CreateString(gate) : cJSON_CreateNull());
}

/* The run's "decisions" as far as the options and the plan decide them; restore and refine
 * fill in the gate and whether they ran. */
static void plan_decisions(pipeline_run *r)
{
    int mode = r->opt->restore_with;
    cJSON *d = cJSON_GetObjectItem(r->run, "decisions");
    if (!cJSON_IsObject(d)) {
        cJSON_DeleteItemFromObject(r->run, "decisions");
        d = cJSON_AddObjectToObject(r->run, "decisions");
    }
    cJSON_DeleteItemFromObject(d, "restore_with");
    cJSON_AddStringToObject(d, "restore_with", gv_restore_with_name(mode));
    const char *adapt_why = r->adapt ? NULL : r->no_adapt[0] ? r->no_adapt
                            : mode == GV_RESTORE_ADAPTED ? "the checkpoint is adapted already (a scene checkpoint): its gate decides"
                            : mode == GV_RESTORE_CHECKPOINT ? "--restore-with checkpoint"
                                                            : "--no-restore";
    pipeline_decision(r, "adaptation", r->adapt, adapt_why);
    if (!cJSON_GetObjectItem(d, "gate")) cJSON_AddNullToObject(d, "gate");
    if (mode == GV_RESTORE_NONE) {
        pipeline_decision_gate(r, NULL);
        pipeline_decision(r, "restoration", 0, "--no-restore");
        pipeline_decision(r, "refinement", 0, "--no-restore");
        cJSON_ReplaceItemInObject(cJSON_GetObjectItem(r->run, "gaussians"), "refined", cJSON_CreateNull());
    } else { /* decided by the stages; a decision of --no-restore is undone */
        const char *keys[2] = {"restoration", "refinement"};
        for (int k = 0; k < 2; k++) {
            const cJSON *was = cJSON_GetObjectItem(cJSON_GetObjectItem(d, keys[k]), "why");
            if (!cJSON_GetObjectItem(d, keys[k]) || (cJSON_IsString(was) && !strcmp(was->valuestring, "--no-restore"))) {
                cJSON_DeleteItemFromObject(d, keys[k]);
                cJSON_AddNullToObject(d, keys[k]);
            }
        }
    }
}

int pipeline_doc_run(pipeline_run *r)
{
    cJSON *runs = cJSON_GetObjectItem(r->doc, "runs"), *inputs = inputs_json(r->opt), *found = NULL;
    for (cJSON *run = runs->child; run && !found; run = run->next) {
        const cJSON *n = cJSON_GetObjectItem(run, "interval");
        if (cJSON_IsNumber(n) && n->valueint == r->interval) found = run;
    }
    if (found) { /* the stages' records say what they were made from (pipeline_stage_done) */
        cJSON_ReplaceItemInObject(found, "inputs", inputs);
        r->run = found;
        cJSON *frames = cJSON_GetObjectItem(found, "frames");
        for (int i = 0; i < r->n_frames && i < cJSON_GetArraySize(frames); i++) {
            cJSON *fj = cJSON_GetArrayItem(frames, i), *images = cJSON_GetObjectItem(fj, "images");
            if (images) name_frame(r, &r->frames[i], fj, images);
        }
        frame_images(r);
        plan_decisions(r);
        return 0;
    }
    r->run = new_run(r, inputs);
    frame_images(r);
    plan_decisions(r);
    /* runs stay sorted by interval */
    int at = 0;
    for (cJSON *run = runs->child; run; run = run->next, at++)
        if (cJSON_GetObjectItem(run, "interval")->valueint > r->interval) break;
    cJSON_InsertItemInArray(runs, at, r->run);
    return 0;
}

int pipeline_doc_write(const pipeline_run *r)
{
    char path[4096];
    if (metrics_path(r->opt, path, sizeof path)) return -1;
    char *text = cJSON_Print(r->doc);
    if (!text) return gv_fail("%s: out of memory", path);
    int rc = gv_write_text_atomic(path, text);
    free(text);
    return rc;
}

/* The run's inputs that a stage depends on: the keys listed (space-separated). */
static cJSON *stage_inputs(const pipeline_run *r, const char *keys)
{
    cJSON *all = cJSON_GetObjectItem(r->run, "inputs"), *j = cJSON_CreateObject();
    char list[256];
    snprintf(list, sizeof list, "%s", keys);
    for (char *save = NULL, *k = strtok_r(list, " ", &save); k; k = strtok_r(NULL, " ", &save)) {
        const cJSON *v = cJSON_GetObjectItem(all, k);
        cJSON_AddItemToObject(j, k, v ? cJSON_Duplicate(v, 1) : cJSON_CreateNull());
    }
    return j;
}

int pipeline_stage_done(const pipeline_run *r, const char *name, const char *keys, char *why, size_t size)
{
    const cJSON *stages = cJSON_GetObjectItem(r->run, "stages");
    why[0] = 0;
    for (const cJSON *s = stages ? stages->child : NULL; s; s = s->next) {
        const cJSON *n = cJSON_GetObjectItem(s, "name");
        if (!cJSON_IsString(n) || strcmp(n->valuestring, name)) continue;
        cJSON *now = stage_inputs(r, keys);
        const cJSON *recorded = cJSON_GetObjectItem(s, "inputs");
        cJSON *was = recorded ? cJSON_Duplicate(recorded, 1) : NULL;
        /* Runs from before "densify" was an input trained with the reference's control. */
        if (was && cJSON_GetObjectItem(now, "densify") && !cJSON_GetObjectItem(was, "densify"))
            cJSON_AddStringToObject(was, "densify", gv_splat_densify_mode_name(GV_DENSIFY_REFERENCE));
        /* ... and before "regularize" was, with none. */
        if (was && cJSON_GetObjectItem(now, "regularize") && !cJSON_GetObjectItem(was, "regularize"))
            cJSON_AddStringToObject(was, "regularize", "none");
        /* ... and before "resolution_schedule" was, at full size. */
        if (was && cJSON_GetObjectItem(now, "resolution_schedule") && !cJSON_GetObjectItem(was, "resolution_schedule"))
            cJSON_AddNumberToObject(was, "resolution_schedule", 1);
        int same = was && cJSON_Compare(was, now, 1);
        if (!same) describe_difference(was, now, why, size);
        cJSON_Delete(now), cJSON_Delete(was);
        return same;
    }
    return 0;
}

int pipeline_stage_record(pipeline_run *r, const char *name, const char *keys, double seconds, double cpu_seconds)
{
    cJSON *stages = cJSON_GetObjectItem(r->run, "stages");
    cJSON *s = cJSON_CreateObject();
    cJSON_AddStringToObject(s, "name", name);
    cJSON_AddNumberToObject(s, "seconds", seconds);
    cJSON_AddNumberToObject(s, "cpu_seconds", cpu_seconds);
    cJSON_AddStringToObject(s, "summary", r->summary);
    cJSON_AddItemToObject(s, "inputs", stage_inputs(r, keys));
    cJSON_AddItemToArray(stages, s);
    return pipeline_doc_write(r);
}

void pipeline_stage_forget(pipeline_run *r, const char *name)
{
    cJSON *stages = cJSON_GetObjectItem(r->run, "stages");
    int n = 0;
    const char *const *order = gv_reconstruct_stages(&n);
    int from = 0;
    while (from < n && strcmp(order[from], name)) from++;
    for (int i = from; i < n; i++) {
        for (int k = cJSON_GetArraySize(stages) - 1; k >= 0; k--) {
            const cJSON *nm = cJSON_GetObjectItem(cJSON_GetArrayItem(stages, k), "name");
            if (cJSON_IsString(nm) && !strcmp(nm->valuestring, order[i])) cJSON_DeleteItemFromArray(stages, k);
        }
    }
}

cJSON *pipeline_metric_json(double psnr, double ssim, double lpips, int has_lpips)
{
    cJSON *j = cJSON_CreateObject();
    cJSON_AddNumberToObject(j, "psnr", psnr);
    cJSON_AddNumberToObject(j, "ssim", ssim);
    if (has_lpips) cJSON_AddNumberToObject(j, "lpips", lpips);
    else cJSON_AddNullToObject(j, "lpips");
    return j;
}
