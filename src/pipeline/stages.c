/* The stages of `reconstruct` as a table (pipeline.h) and the loop over intervals and stages:
 * a stage is skipped when metrics.json lists it as finished and its files exist; once one
 * stage runs, every later one runs again (its inputs may have changed). */
#include <dirent.h>
#include <errno.h>
#include <libgen.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <time.h>
#include <unistd.h>

#include "gaussvid/train/checkpoint.h"
#include "gaussvid/train/condition.h"
#include "gaussvid/core/core.h"
#include "gaussvid/data/internal_pairs.h"
#include "gaussvid/model/model_config.h"
#include "gaussvid/report/report.h"
#include "gaussvid/splat/splat_train.h"
#include "pipeline/pipeline_internal.h"

/* Which stages a run has: adapt where it runs on this interval, restore and refine unless
 * restoration is off (a skipped restoration or refinement still runs its stage: it writes
 * the renders and the sparse model under their names, and says why). */
static int always(const pipeline_run *r) { return (void)r, 1; }
static int adapting(const pipeline_run *r) { return r->adapt; }
static int restoring(const pipeline_run *r) { return r->opt->restore_with != GV_RESTORE_NONE; }

typedef struct {
    const char *name;
    int (*run)(pipeline_run *r);
    int (*applies)(const pipeline_run *r);
    const char *inputs;             /* the options it depends on (keys of metrics.json's "inputs") */
    const char *outputs[4];         /* in DIR/nN; "frames/X" means every evaluated frame's PNG */
    const char *decides;            /* the decision it records in metrics.json for a later stage
                                       to read, or NULL */
    const char *scratch;            /* a folder in DIR/nN of files it writes on the way (restore's
                                       clips), or NULL: emptied before it runs again and when it
                                       no longer applies, never needed for it to count as done */
} stage;

static const stage STAGES[] = {
    {"train", pipeline_train, always, "iters densify regularize resolution_schedule seed downscale", {"sparse.ply", "sparse.splat"}, NULL, NULL},
    {"render", pipeline_render, always, "", {"frames/render"}, NULL, NULL},
    {"adapt", pipeline_adapt, adapting, "checkpoint adapt_steps adapt_config", {"restorer.safetensors"}, NULL, NULL},
    {"restore", pipeline_restore, restoring, "checkpoint restore_with seed", {"frames/restored"}, "restoration", "clips"},
    {"refine", pipeline_refine, restoring, "refine_iters refine_weight", {"refined.ply", "refined.splat", "frames/refined"}, NULL, NULL},
    {"evaluate", pipeline_evaluate, always, "lpips restore_with", {NULL}, NULL, NULL},
    {"video", pipeline_video, always, "fps restore_with", {"flythrough.mp4"}, NULL, NULL},
};
#define N_STAGES ((int)(sizeof STAGES / sizeof STAGES[0]))

const char *const *gv_reconstruct_stages(int *n)
{
    static const char *names[N_STAGES];
    for (int i = 0; i < N_STAGES; i++) names[i] = STAGES[i].name;
    *n = N_STAGES;
    return names;
}

void gv_reconstruct_defaults(gv_reconstruct_options *o)
{
    memset(o, 0, sizeof *o);
    o->downscale = 0; /* chosen from the images' size */
    o->iters = 8000;
    o->densify = GV_DENSIFY_LEAN; /* the user's model (issue 38): the reference's quality, half its time */
    o->regularize = GV_REGULARIZE_USER;
    o->resolution_start = GV_RESOLUTION_USER;
    o->refine_iters = 1000;
    o->refine_weight = 0.3;
    o->restore_with = GV_RESTORE_ADAPTED;
    o->preset = "default";
    o->fps = 8;
    gv_adapt_defaults(&o->adapt_options);
}

static double cpu_seconds(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &ts);
    return ts.tv_sec + 1e-9 * ts.tv_nsec;
}

static int outputs_exist(const pipeline_run *r, const stage *s)
{
    for (int k = 0; k < 4 && s->outputs[k]; k++) {
        char path[4200];
        const char *o = s->outputs[k];
        if (!strncmp(o, "frames/", 7)) {
            for (int i = 0; i < r->n_frames; i++)
                if (pipeline_frame_path(r, o + 7, r->frames[i].index, path, sizeof path) || !gv_file_exists(path))
                    return 0;
        } else if (pipeline_file(r, o, path, sizeof path) || !gv_file_exists(path)) {
            return 0;
        }
    }
    return 1;
}

/* Empties and removes the stage's scratch folder: a restore whose gate has closed since, or
 * that no longer runs, leaves no clips of an earlier run. Only regular files are removed: the
 * folder is the stage's own. */
static int remove_scratch(const pipeline_run *r, const stage *s)
{
    char dir[4200], path[4500];
    if (!s->scratch || pipeline_file(r, s->scratch, dir, sizeof dir)) return s->scratch ? -1 : 0;
    DIR *d = opendir(dir);
    if (!d) return errno == ENOENT ? 0 : gv_fail("%s: cannot open: %s", dir, strerror(errno));
    int rc = 0;
    for (struct dirent *e; rc == 0 && (e = readdir(d));) {
        struct stat st;
        snprintf(path, sizeof path, "%s/%s", dir, e->d_name);
        if (lstat(path, &st) == 0 && S_ISREG(st.st_mode) && remove(path) != 0)
            rc = gv_fail("%s: cannot remove: %s", path, strerror(errno));
    }
    closedir(d);
    if (rc == 0) rmdir(dir); /* left when something else is in it */
    return rc;
}

/* A stage that no longer applies (the folder was made in another mode) leaves its files with
 * its record, so that the folder holds only what this run's numbers stand for: switched to
 * --no-restore, no refined model, restored frames or clips from before remain. */
static int remove_outputs(const pipeline_run *r, const stage *s)
{
    if (remove_scratch(r, s)) return -1;
    char path[4200];
    for (int k = 0; k < 4 && s->outputs[k]; k++) {
        const char *o = s->outputs[k];
        int frames = !strncmp(o, "frames/", 7), n = frames ? r->n_frames : 1;
        for (int i = 0; i < n; i++) {
            if (frames ? pipeline_frame_path(r, o + 7, r->frames[i].index, path, sizeof path)
                       : pipeline_file(r, o, path, sizeof path))
                return -1;
            if (remove(path) != 0 && errno != ENOENT) return gv_fail("%s: cannot remove: %s", path, strerror(errno));
        }
        if (frames && n > 0) rmdir(dirname(path)); /* frames/X, when nothing else is in it */
    }
    return 0;
}

static int stage_index(const char *name)
{
    for (int i = 0; i < N_STAGES; i++)
        if (!strcmp(STAGES[i].name, name)) return i;
    return -1;
}

/* 1 when the default path will adapt a cross-scene checkpoint for some interval: an interval
 * with the training views for it (the caller knows the checkpoint is not a scene one). */
static int adapts_somewhere(const gv_reconstruct_options *o, const gv_scene *scene)
{
    if (o->restore_with != GV_RESTORE_ADAPTED) return 0;
    for (int k = 0; k < o->n_intervals; k++)
        if (o->intervals[k] > 1 && gv_internal_check(scene->n_frames, o->intervals[k]) == 0) return 1;
    return 0;
}

/* The checks that need no training: flags, the checkpoint (its record into rec), one image
 * size (any: the restorer pads), ffmpeg when the video stage will run. */
static int check_options(const gv_reconstruct_options *o, const gv_scene *scene, int last, gv_restorer *rec)
{
    if (o->n_intervals < 1) return gv_fail("no --interval given");
    if (o->iters < 1 || o->refine_iters < 1) return gv_fail("--iters and --refine-iters must be at least 1");
    if (!(o->refine_weight > 0) || o->refine_weight > 1)
        return gv_fail("--refine-weight %g: expected a weight in (0, 1]", o->refine_weight);
    if (!(o->fps > 0) || o->fps > 240) return gv_fail("--fps %g: expected 0 < fps <= 240", o->fps);
    if (o->restore_with < GV_RESTORE_ADAPTED || o->restore_with > GV_RESTORE_NONE)
        return gv_fail("restoration mode %d: expected " GV_RESTORE_WITH_NAMES, o->restore_with);
    for (int k = 0; k < o->n_intervals; k++)
        if (gv_interval_check(o->intervals[k], scene->n_frames, GV_INTERVAL_RECONSTRUCT))
            return gv_fail_context("%s: --interval", scene->dir);
    char ffmpeg[4200];
    if (last >= stage_index("video") && pipeline_find_ffmpeg(o, ffmpeg, sizeof ffmpeg)) return -1;
    if (o->restore_with == GV_RESTORE_NONE) return 0; /* no restorer needed */
    if (!gv_file_exists(o->ckpt)) return gv_fail("%s: no such checkpoint", o->ckpt);
    gv_model_cost cost;
    int w = scene->cameras[0].width, h = scene->cameras[0].height;
    for (int i = 1; i < scene->n_frames; i++)
        if (scene->cameras[i].width != w || scene->cameras[i].height != h)
            return gv_fail("%s: frame %d is %dx%d, frame 0 %dx%d: the restorer's clips need one size", scene->dir, i,
                           scene->cameras[i].width, scene->cameras[i].height, w, h);
    if (gv_restorer_open(o->ckpt, GV_RESTORER_RECORD, rec)) return -1;
    const gv_model_config cfg = rec->cfg;
    if (!rec->scene && adapts_somewhere(o, scene)) {
        gv_adapt_options a = o->adapt_options;
        a.base = o->ckpt;
        if (gv_adapt_check_base(&a)) {
            char why[1024];
            snprintf(why, sizeof why, "%s", gv_last_error());
            return gv_fail("%s (the default path adapts it; --restore-with checkpoint restores with it as it is)", why);
        }
    }
    /* any size: the restorer pads each clip to its block and crops the result (condition.h) */
    int pw = 0, ph = 0;
    if (gv_condition_padded_size(&cfg, w, h, &pw, &ph)) return gv_fail_context("%s", scene->dir);
    if (gv_model_cost_estimate(&cfg, 5, ph, pw, &cost))
        return gv_fail_context("%s: the restorer %s (%s) on 5-frame clips of %dx%d", scene->dir, o->ckpt, cfg.name, pw, ph);
    return 0;
}

/* 1 when the run's stages list has the stage, finished from any inputs. */
static int stage_recorded(const pipeline_run *r, const stage *s)
{
    char why[256];
    return pipeline_stage_done(r, s->name, s->inputs, why, sizeof why) || why[0];
}

/* Every stage of one interval up to `last`. */
static int run_interval(pipeline_run *r, int last)
{
    int redo = 0, recorded[N_STAGES]; /* before any record is forgotten with an earlier one */
    for (int i = 0; i < N_STAGES; i++) recorded[i] = stage_recorded(r, &STAGES[i]);
    for (int i = 0; i <= last; i++) {
        const stage *s = &STAGES[i];
        if (!s->applies(r)) { /* a record from another mode is stale, and so are the later ones */
            if (recorded[i]) {
                pipeline_stage_forget(r, s->name), redo = 1;
                if (remove_outputs(r, s) != 0) return gv_fail_context("n=%d %s", r->interval, s->name);
            }
            continue;
        }
        char why[256];
        if (!redo && pipeline_stage_done(r, s->name, s->inputs, why, sizeof why)) {
            if (s->decides && pipeline_decision_ran(r, s->decides) < 0) {
                gv_info("n=%d %s: its decision is not recorded (an older metrics.json): done again", r->interval,
                        s->name);
            } else if (outputs_exist(r, s)) {
                gv_info("n=%d %s: done before, skipped", r->interval, s->name);
                continue;
            } else {
                gv_info("n=%d %s: some of its files are missing: done again", r->interval, s->name);
            }
        } else if (!redo && why[0]) {
            gv_info("n=%d %s: made before with %s: done again", r->interval, s->name, why);
        }
        redo = 1;
        pipeline_stage_forget(r, s->name);
        if (remove_scratch(r, s)) return gv_fail_context("n=%d %s", r->interval, s->name);
        r->summary[0] = 0;
        double wall = gv_now(), cpu = cpu_seconds();
        if (s->run(r)) return gv_fail_context("n=%d %s", r->interval, s->name);
        wall = gv_now() - wall, cpu = cpu_seconds() - cpu;
        if (pipeline_stage_record(r, s->name, s->inputs, wall, cpu)) return -1;
        if (r->opt->on_stage) r->opt->on_stage(r->opt->on_stage_ctx, r->interval, s->name, r->summary, wall, cpu);
    }
    return 0;
}

int gv_reconstruct_auto_downscale(int width, int height)
{
    int side = width > height ? width : height, k = 1;
    while (k < 8 && (side + k - 1) / k > GV_RECONSTRUCT_AUTO_SIDE) k *= 2;
    return k;
}

/* The scene at the downscale asked for, or, with none asked, at the one its largest image gets. */
static int load_scene(const gv_reconstruct_options *o, gv_scene *scene, int *downscale)
{
    gv_scene_options so = {.downscale = o->downscale ? o->downscale : 1};
    if (gv_scene_load(o->scene_dir, &so, scene)) return -1;
    *downscale = so.downscale;
    if (o->downscale) return 0;
    int width = 0, height = 0;
    for (int i = 0; i < scene->n_frames; i++) {
        if (scene->cameras[i].width > width) width = scene->cameras[i].width;
        if (scene->cameras[i].height > height) height = scene->cameras[i].height;
    }
    int k = gv_reconstruct_auto_downscale(width, height);
    if (k > 1) {
        gv_info("%s: images of %dx%d: downscale %d chosen (the longer side at most %d pixels; --downscale 1 for the "
                "full size)", o->scene_dir, width, height, k, GV_RECONSTRUCT_AUTO_SIDE);
        gv_scene_free(scene);
        so.downscale = k;
        if (gv_scene_load(o->scene_dir, &so, scene)) return -1;
    }
    *downscale = k;
    return 0;
}

int gv_reconstruct(const gv_reconstruct_options *asked)
{
    gv_reconstruct_options chosen = *asked; /* with the downscale decided */
    const gv_reconstruct_options *o = &chosen;
    int last = N_STAGES - 1;
    if (o->stop_after && (last = stage_index(o->stop_after)) < 0)
        return gv_fail("--stop-after %s: not a stage (train, render, adapt, restore, refine, evaluate, video)",
                       o->stop_after);
    if (o->stop_after && !strcmp(o->stop_after, "adapt") && o->restore_with != GV_RESTORE_ADAPTED)
        return gv_fail("--stop-after adapt: the adapt stage runs only with --restore-with adapted (the default)");
    if (o->stop_after && (!strcmp(o->stop_after, "restore") || !strcmp(o->stop_after, "refine")) &&
        o->restore_with == GV_RESTORE_NONE)
        return gv_fail("--stop-after %s: --no-restore has no %s stage", o->stop_after, o->stop_after);
    gv_scene scene;
    if (load_scene(asked, &scene, &chosen.downscale)) return -1;
    cJSON *doc = NULL;
    gv_restorer rec; /* the checkpoint's record, without its weights */
    memset(&rec, 0, sizeof rec);
    int rc = check_options(o, &scene, last, &rec);
    char scene_name[GV_SCENE_NAME_MAX];
    if (rc == 0 && o->restore_with != GV_RESTORE_NONE) /* the scene's numbers mean less when the restorer learned from it */
        rc = gv_scene_name_of(o->scene_dir, scene_name, sizeof scene_name) || gv_warn_if_trained_on(&rec, o->ckpt, scene_name);
    if (rc == 0) rc = gv_mkdirs(o->out_dir);
    if (rc == 0) gv_atomic_sweep(o->out_dir, NULL);
    if (rc == 0) rc = pipeline_doc_open(o, &scene, &rec, &doc);
    int scene_ckpt = rec.scene; /* the checkpoint is adapted already (read once, here) */
    gv_restorer_free(&rec);
    for (int k = 0; k < o->n_intervals && rc == 0; k++) {
        pipeline_run r;
        memset(&r, 0, sizeof r);
        r.opt = o, r.doc = doc;
        char name[32];
        snprintf(name, sizeof name, "n%d", o->intervals[k]);
        rc = gv_scene_name_of(o->scene_dir, r.scene_name, sizeof r.scene_name) ||
             gv_path_join(r.dir, sizeof r.dir, o->out_dir, name) || pipeline_plan(&r, &scene, o->intervals[k]);
        if (rc == 0) pipeline_plan_adaptation(&r, scene_ckpt);
        if (rc == 0) rc = gv_mkdirs(r.dir) || pipeline_doc_run(&r) || pipeline_doc_write(&r);
        if (rc == 0) {
            gv_atomic_sweep(r.dir, NULL);
            gv_info("n=%d: %d training views, %d %s frames in %d clips", r.interval, r.n_train, r.n_frames,
                    r.smooth_path ? "path" : "held-out", r.n_clips);
            rc = run_interval(&r, last);
        }
        pipeline_plan_free(&r);
    }
    if (rc == 0 && last == N_STAGES - 1) { /* every interval finished: the page that shows them */
        double wall = gv_now();
        rc = gv_report_write(o->out_dir);
        if (rc == 0) gv_info("report: %s/report.html and a viewer.html per model, %.1f s", o->out_dir, gv_now() - wall);
    }
    cJSON_Delete(doc);
    gv_scene_free(&scene);
    return rc ? -1 : 0;
}
