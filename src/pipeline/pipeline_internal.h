/* What the stages of `reconstruct` share (pipeline.h): the plan of one interval's run and the
 * metrics document. Stages talk to each other through files only (the PLY models and the
 * PNG frames in DIR/nN), so any of them can be resumed from what the earlier ones wrote. */
#ifndef GAUSSVID_PIPELINE_INTERNAL_H
#define GAUSSVID_PIPELINE_INTERNAL_H

#include <cjson/cJSON.h>

#include "gaussvid/data/dataset.h"
#include "gaussvid/io/gaussians.h"
#include "gaussvid/pipeline/pipeline.h"
#include "gaussvid/splat/render.h"
#include "gaussvid/scene/scene.h"

#define PIPELINE_NAME_MAX 160

/* One evaluated frame: a held-out view of the scene or a camera of the smooth path. */
typedef struct {
    int index;                   /* scene frame (held-out) or path frame 4k + j (smooth path) */
    gv_camera camera;
    int truth;                   /* scene frame with ground truth, or -1 */
    int clip, slot;              /* the clip that restores it and its place there (1..3) */
    char name[PIPELINE_NAME_MAX];/* its files' name without .png: the photo's (held-out) or
                                    "<photo a>_to_<photo b>_<j>of4" (path), unique in the run */
} pipeline_frame;

typedef struct {
    const gv_reconstruct_options *opt;
    const gv_scene *scene;
    char scene_name[GV_SCENE_NAME_MAX];
    int interval;                /* n */
    int smooth_path;             /* 1: every view trains (n = 1), the frames are a path */
    char dir[4096];              /* DIR/nN */
    int n_train, *train;         /* training frames */
    int n_held_out, *held_out;   /* every held-out frame (the tail after the last view too) */
    int n_frames;
    pipeline_frame *frames;      /* the evaluated frames, in path order */
    int n_clips;
    int (*clips)[GV_CLIP_FRAMES];/* indices into frames for slots 1..3; anchors: training-view
                                    positions k (scene frame train[k]) as -1 - k */
    int adapt;                   /* the adapt stage runs for this interval */
    char no_adapt[512];          /* restore_with adapted: why adaptation cannot run here ("" when it can) */
    char restorer[4096];         /* the checkpoint restore uses */
    cJSON *doc;                  /* the whole metrics.json */
    cJSON *run;                  /* this interval's object in doc's "runs" */
    char summary[512];           /* the stage's one-line summary, set by the stage */
} pipeline_run;

/* plan.c: the training views, the evaluated frames and the clips of interval n; fails unless
 * gv_interval_check(n, scene frames, GV_INTERVAL_RECONSTRUCT). */
int pipeline_plan(pipeline_run *r, const gv_scene *scene, int n);
void pipeline_plan_free(pipeline_run *r);
/* DIR/nN/frames/<what>/<name>.png of the evaluated frame numbered `frame` (what: render,
 * restored, refined). */
int pipeline_frame_path(const pipeline_run *r, const char *what, int frame, char *out, size_t size);
/* The same path relative to DIR (metrics.json's "images"). */
void pipeline_frame_relpath(const pipeline_run *r, const char *what, int frame, char *out, size_t size);
/* A file of the run's folder: DIR/nN/name. */
int pipeline_file(const pipeline_run *r, const char *name, char *out, size_t size);

/* splat_stages.c */
int pipeline_train(pipeline_run *r);
int pipeline_refine(pipeline_run *r);
/* Renders a model from every evaluated frame's camera into DIR/nN/frames/<what>/. */
int pipeline_render_model(pipeline_run *r, const gv_gaussians *g, const char *what);
int pipeline_render(pipeline_run *r);
/* restore_stages.c */
/* Decides r->adapt and r->no_adapt from the options, the checkpoint (scene_ckpt: a scene
 * checkpoint, as its record read before the stages says) and the interval. */
void pipeline_plan_adaptation(pipeline_run *r, int scene_ckpt);
int pipeline_adapt(pipeline_run *r);
/* Restores every evaluated frame, or, when the restorer would not help (no adaptation
 * possible, a closed gate), keeps the renders; the run's "decisions" say which. Opens the
 * restorer once. */
int pipeline_restore(pipeline_run *r);
/* Copies every evaluated frame's DIR/nN/frames/<from>/ PNG to frames/<to>/. */
int pipeline_copy_frames(pipeline_run *r, const char *from, const char *to);
/* Copies a file of the run's folder to another name there, atomically. */
int pipeline_copy_file(pipeline_run *r, const char *from, const char *to);
/* evaluate.c */
int pipeline_evaluate(pipeline_run *r);
/* consistency.c: the 3D consistency of the run's sparse renders, restored frames and refined
 * renders (gv_consistency_measure in path order): an object {"sparse": {"psnr", "coverage",
 * "pairs", "scored", "depth"[, "per_pair"]}, "restored", "refined"} and the three mean PSNRs. */
int pipeline_consistency(const pipeline_run *r, int with_pairs, cJSON **out, double psnr[3]);
/* Its one-line summary; the three means alone ("sparse 30.24, restored 30.21, refined 30.43 dB"). */
void pipeline_consistency_line(const pipeline_run *r, const double psnr[3], char *out, size_t size);
/* The sets measured: 3, or the sparse renders alone with --no-restore (the others null, NaN). */
int pipeline_consistency_sets(const pipeline_run *r);
void pipeline_consistency_means(const double psnr[3], int sets, char *out, size_t size);
/* video.c */
int pipeline_video(pipeline_run *r);
/* video_frames.c: the video's frames, a fly-through along the training cameras and then the
 * evaluated frames, each W x H RGB (panels of the frames' size side by side, padded to even). */
typedef struct {
    pipeline_run *r;
    int w, h, W, H, panels, scale;
    int restoring, truth;        /* a restored panel (not with --no-restore); a ground-truth panel */
    int steps;                   /* fly-through frames per gap between training views */
    int n_flight, n_total;       /* fly-through frames; all frames */
    gv_gaussians models[2];      /* sparse, refined (when restoring) */
    gv_splat_renderer renderer;
} pipeline_video_frames;
int pipeline_video_open(pipeline_video_frames *v, pipeline_run *r);
/* Frame i (0 .. n_total - 1) into out (W x H x 3 bytes). */
int pipeline_video_frame(pipeline_video_frames *v, int i, uint8_t *out);
void pipeline_video_close(pipeline_video_frames *v);
/* The ffmpeg program to use: o->ffmpeg, else "ffmpeg" found on the PATH; fails with one line
 * saying how to install it. */
int pipeline_find_ffmpeg(const gv_reconstruct_options *o, char *out, size_t size);

/* metrics_doc.c: DIR/metrics.json. */
int pipeline_doc_open(const gv_reconstruct_options *o, const gv_scene *scene, const gv_restorer *rec, cJSON **doc);
/* This interval's run object: the existing one when its inputs are this run's (else a line
 * saying what differs), or a new one listing the plan's frames. */
int pipeline_doc_run(pipeline_run *r);
int pipeline_doc_write(const pipeline_run *r);
/* 1 when the run's "stages" lists the stage as finished from the same inputs (the keys of
 * the run's "inputs" listed, space-separated); else 0, and why says which input changed when
 * the stage was finished from other ones. */
int pipeline_stage_done(const pipeline_run *r, const char *name, const char *keys, char *why, size_t size);
/* Records a finished stage with its wall and CPU seconds, r->summary and its inputs (keys),
 * and writes the file. */
int pipeline_stage_record(pipeline_run *r, const char *name, const char *keys, double seconds, double cpu_seconds);
/* Drops the records of the stage and of every stage after it. */
void pipeline_stage_forget(pipeline_run *r, const char *name);
/* The restorer object of metrics.json for a checkpoint (adapt: the scene checkpoint of --adapt). */
cJSON *pipeline_restorer_json(const char *ckpt, const gv_restorer *r, int adapt);
/* The run's "decisions" (what: "adaptation", "restoration" or "refinement"): whether it ran
 * and, when it did not, why (NULL: it ran). */
void pipeline_decision(pipeline_run *r, const char *what, int ran, const char *why);
/* Whether the run's "decisions" say the step (what) ran: 1 or 0; -1 when not recorded (not
 * decided yet, or a metrics.json from before decisions were recorded). */
int pipeline_decision_ran(const pipeline_run *r, const char *what);
/* The run's "decisions"."gate": "open", "closed" or NULL (no scene checkpoint). */
void pipeline_decision_gate(pipeline_run *r, const char *gate);
/* doc-building helpers */
cJSON *pipeline_metric_json(double psnr, double ssim, double lpips, int has_lpips);

#endif
