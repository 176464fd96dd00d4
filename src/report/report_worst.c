/* The frames a person looks at first (report_internal.h): the worst frames by the PSNR of what
 * the run ends with and the frames the restorer changed most, each named after its photo, as
 * two short tables under the plot. */
#include "report_internal.h"

#include <math.h>
#include <stdlib.h>

#include "gaussvid/core/core.h"

#define LISTED 5 /* rows per table */

/* The PSNR of what the run ends with on frame f: refined, else restored, else sparse; NAN when
 * the frame has no score. */
static double final_psnr(const report_frame *f)
{
    for (int k = N_MODELS - 1; k >= 0; k--)
        if (f->score[k].present) return f->score[k].psnr;
    return NAN;
}

int report_worst_frame(const report_run *run)
{
    int worst = -1;
    for (int i = 0; i < run->n_frames; i++) {
        double v = final_psnr(&run->frames[i]);
        if (!isnan(v) && (worst < 0 || v < final_psnr(&run->frames[worst]))) worst = i;
    }
    return worst;
}

typedef struct {
    int index;
    double key;
} ranked;

/* Ascending key, then frame order: the same folder gives the same page. */
static int by_key(const void *a, const void *b)
{
    const ranked *x = a, *y = b;
    if (x->key != y->key) return x->key < y->key ? -1 : 1;
    return (x->index > y->index) - (x->index < y->index);
}

static void psnr_cell(report_text *t, const report_score *s)
{
    if (s->present) text_printf(t, "<td>%.2f</td>", s->psnr);
    else text_append(t, "<td>&ndash;</td>");
}

static void name_cell(report_text *t, const report_frame *f)
{
    text_append(t, "<td>");
    text_escaped(t, f->name);
    text_printf(t, "</td><td>%d</td>", f->frame);
}

static void worst_table(report_text *t, const report_run *run, ranked *rows)
{
    int n = 0;
    for (int i = 0; i < run->n_frames; i++) {
        double v = final_psnr(&run->frames[i]);
        if (!isnan(v)) rows[n].index = i, rows[n].key = v, n++;
    }
    if (n == 0) return;
    qsort(rows, (size_t)n, sizeof *rows, by_key);
    text_append(t, "<h3>Worst frames by PSNR</h3>\n<table class=\"worst\">\n<thead><tr><th>photo</th><th>frame</th>"
                   "<th>sparse</th><th>restored</th><th>refined</th></tr></thead>\n<tbody>\n");
    for (int r = 0; r < n && r < LISTED; r++) {
        const report_frame *f = &run->frames[rows[r].index];
        text_printf(t, "<tr data-frame=\"%d\">", f->frame);
        name_cell(t, f);
        for (int k = 0; k < N_MODELS; k++) psnr_cell(t, &f->score[k]);
        text_append(t, "</tr>\n");
    }
    text_append(t, "</tbody></table>\n");
}

/* With ground truth the change is restored minus sparse PSNR, largest in size first; without,
 * the restorer's mean absolute change of the image. */
static int change_table(report_text *t, const char *dir, const report_run *run, ranked *rows)
{
    if (report_skipped(run, DECISION_RESTORATION)) return 0; /* the restored frames are the renders */
    int n = 0, by_psnr = !run->smooth;
    for (int i = 0; i < run->n_frames; i++) {
        const report_frame *f = &run->frames[i];
        double v;
        if (by_psnr) {
            if (!f->score[MODEL_SPARSE].present || !f->score[MODEL_RESTORED].present) continue;
            v = f->score[MODEL_RESTORED].psnr - f->score[MODEL_SPARSE].psnr;
        } else {
            if (report_restorer_change(dir, f, &v) != 0) return -1;
            if (v < 0) continue;
        }
        rows[n].index = i, rows[n].key = -fabs(v), n++;
    }
    if (n == 0) return 0;
    qsort(rows, (size_t)n, sizeof *rows, by_key);
    text_printf(t, "<h3>Biggest changes by the restorer</h3>\n<table class=\"changes\">\n<thead><tr><th>photo</th>"
                   "<th>frame</th>%s</tr></thead>\n<tbody>\n",
                by_psnr ? "<th>sparse</th><th>restored</th><th>change (dB)</th>"
                        : "<th>mean |restored &minus; render| (8-bit levels)</th>");
    for (int r = 0; r < n && r < LISTED; r++) {
        const report_frame *f = &run->frames[rows[r].index];
        text_printf(t, "<tr data-frame=\"%d\">", f->frame);
        name_cell(t, f);
        if (by_psnr) {
            psnr_cell(t, &f->score[MODEL_SPARSE]);
            psnr_cell(t, &f->score[MODEL_RESTORED]);
            text_printf(t, "<td>%+.2f</td>", f->score[MODEL_RESTORED].psnr - f->score[MODEL_SPARSE].psnr);
        } else {
            text_printf(t, "<td>%.2f</td>", -rows[r].key);
        }
        text_append(t, "</tr>\n");
    }
    text_append(t, "</tbody></table>\n");
    return 0;
}

int report_frame_lists(report_text *t, const char *dir, const report_run *run)
{
    ranked *rows = malloc(((size_t)run->n_frames + 1) * sizeof *rows);
    if (!rows) return gv_fail("out of memory for %d frames", run->n_frames);
    worst_table(t, run, rows);
    int rc = change_table(t, dir, run, rows);
    free(rows);
    return rc;
}
