/* The report module's own types: metrics.json as read (metrics_read.c), a growable text
 * (text.c) and the page's parts (report_*.c). */
#ifndef GAUSSVID_REPORT_INTERNAL_H
#define GAUSSVID_REPORT_INTERNAL_H

#include <stddef.h>
#include <stdint.h>

#include "gaussvid/io/image.h"

/* ---- metrics.json (docs/REPORT.md) ----------------------------------------------------- */
enum { MODEL_SPARSE, MODEL_RESTORED, MODEL_REFINED, N_MODELS };
enum { IMAGE_RENDER, IMAGE_RESTORED, IMAGE_REFINED, IMAGE_GROUND_TRUTH, N_IMAGES };
extern const char *const report_model_names[N_MODELS];  /* "sparse", "restored", "refined" */
extern const char *const report_image_names[N_IMAGES];  /* the keys of "images" */

typedef struct {
    int present;     /* 0 when the block is null (no ground truth, or not evaluated yet) */
    double psnr, ssim;
    int has_lpips;
    double lpips;
    int frames;      /* means only */
} report_score;

typedef struct {
    int frame;
    char *images[N_IMAGES];     /* as written: relative to DIR, ground truth absolute; NULL when null */
    char *name;                 /* the photo's name ("name"), else the render's file name */
    report_score score[N_MODELS];
} report_frame;

typedef struct {
    char name[64];
    double seconds;
    double cpu_seconds;         /* -1 when not recorded */
    char summary[512];          /* the stage's one-line summary, "" when not recorded */
} report_stage;

typedef struct {
    int present;
    char checkpoint[4096];
    char kind[64];
    char gate[64];              /* "" when null */
    char training_scenes[8192]; /* comma-separated; "" when null or absent (not recorded) */
} report_restorer;

/* One of a run's "decisions" (metrics.json): adaptation, restoration, refinement. */
enum { DECISION_ADAPTATION, DECISION_RESTORATION, DECISION_REFINEMENT, N_DECISIONS };
extern const char *const report_decision_names[N_DECISIONS];
typedef struct {
    int present;                /* 0: not decided yet, or a file from before decisions were recorded */
    int ran;
    char why[1024];             /* "" when it ran */
} report_decision;

typedef struct {
    int interval;
    int smooth;                 /* "path": "smooth" (no ground truth) or "held-out" */
    long gaussians[2];          /* sparse, refined; -1 when not known yet */
    int n_train;
    int *train_frames;
    int n_frames;
    report_frame *frames;
    int has_means;
    report_score means[N_MODELS];
    int has_all_held_out;       /* "all_held_out": every held-out view, also those no clip restores */
    report_score all_held_out[N_MODELS]; /* sparse and refined (restored is never present) */
    int has_consistency;        /* "consistency": the 3D consistency (docs/METRICS.md) */
    double consistency[N_MODELS]; /* its mean PSNR per set, NAN where null */
    report_restorer restorer;   /* what restored this run, when the run says */
    char inputs[1024];          /* the run's options as "key value, ..." ("" when not recorded) */
    char restore_with[32];      /* "decisions"."restore_with" ("" when not recorded) */
    char gate[16];              /* "decisions"."gate": "open", "closed", "" (none) */
    report_decision decisions[N_DECISIONS];
    int n_stages;
    report_stage *stages;
} report_run;

typedef struct {
    char scene[256];
    char scene_dir[4096];
    char preset[32];            /* the preset of the last run ("" when not recorded) */
    int width, height;
    report_restorer restorer;
    int n_runs;
    report_run *runs;
} report_metrics;

/* Reads and checks DIR/metrics.json; one line naming the key on failure. */
/* The line that states a run's 3D consistency ("" without it). */
void report_consistency_line(const report_run *run, char *out, size_t size);
int report_metrics_read(const char *path, report_metrics *m);
void report_metrics_free(report_metrics *m);

/* Whether the run decided against one of its steps (DECISION_*): a skipped restoration leaves
 * copies of the renders as restored frames, a skipped refinement the sparse model as refined. */
static inline int report_skipped(const report_run *run, int decision)
{
    return run->decisions[decision].present && !run->decisions[decision].ran;
}

/* ---- a growable text ------------------------------------------------------------------ */
typedef struct {
    char *data;
    size_t length, capacity;
    int failed;                 /* out of memory once: every later append is ignored */
} report_text;

void text_append(report_text *t, const char *s);
void text_append_n(report_text *t, const char *s, size_t n);
void text_printf(report_text *t, const char *fmt, ...) __attribute__((format(printf, 2, 3)));
/* s with &, <, >, " and ' escaped for HTML text and attribute values. */
void text_escaped(report_text *t, const char *s);
void text_free(report_text *t);
/* Writes the text atomically; fails on an earlier out-of-memory. */
int text_write_atomic(const report_text *t, const char *path);

/* ---- the page's parts ----------------------------------------------------------------- */
/* A run's decisions in words, one sentence each, ending with a full stop ("" when none is
 * recorded). */
void report_decisions_text(const report_run *run, char *out, size_t size);
/* The per-n table of PSNR / SSIM (/ LPIPS) with the changes against the sparse model. */
void report_table(report_text *t, const report_metrics *m);
/* The per-frame PSNR of the three models along the path, as inline SVG. */
void report_plot(report_text *t, const report_run *run);
/* The frames whose strips are shown: worst and best restored-minus-sparse PSNR (with ground
 * truth), else the largest and smallest change the restorer made (report_strips.c). Fills
 * indices into run->frames (-1 when the run has no frames), the rule used in words and the
 * two strips' labels. */
int report_pick_frames(const char *dir, const report_run *run, int picked[2], const char **rule,
                       const char *labels[2]);
/* report_worst.c: the frames a person looks at first, each named: the worst by the PSNR of
 * what the run ends with (refined, else restored, else sparse) and the largest changes the
 * restorer made (restored minus sparse PSNR; without ground truth, the mean absolute change
 * of the image), as two short tables. */
int report_frame_lists(report_text *t, const char *dir, const report_run *run);
/* The index of the frame with the lowest final PSNR, or -1 when no frame has a score. */
int report_worst_frame(const report_run *run);
/* The restorer's change on a frame: mean |restored - render| over its values in 8-bit levels,
 * -1 when it has no restored image (report_strips.c). */
int report_restorer_change(const char *dir, const report_frame *f, double *change);
/* One strip: the frame's images and error maps, embedded as PNG data URIs. */
int report_strip(report_text *t, const char *dir, const report_run *run, int index, const char *label);

/* The whole report.html in memory; with viewers, each run whose model exists links to its
 * nN/viewer.html (report_page.c). */
int report_build_page(report_text *t, const char *dir, const report_metrics *m, int viewers);
/* The model a run's viewer shows: nN/refined.splat, else nN/sparse.splat; 0 when neither
 * exists. which is "refined" or "sparse". */
int report_run_model(const char *dir, const report_run *run, char *path, size_t size, const char **which);

/* An image's pixels as an embedded PNG: <img src="data:image/png;base64,..." ...>. */
int report_embed_image(report_text *t, const gv_image *img, const char *alt);
/* Reads an image named in metrics.json (relative to dir unless absolute) as RGB. */
int report_read_image(const char *dir, const char *name, gv_image *out);

#endif
