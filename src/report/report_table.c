/* The report's table: per interval n, PSNR / SSIM (/ LPIPS when any run has it) of the sparse,
 * restored and refined frames, means over the evaluated frames, and each one's change against
 * the sparse model. Every number cell carries its exact value (data-value, %.17g, which reads
 * back to the same double) beside the rounded text, and a key naming it (data-key), so a test
 * or a script can read the table back. */
#include "report_internal.h"

#include <stdio.h>

static const char *const METRIC_NAMES[3] = {"psnr", "ssim", "lpips"};
static const char *const METRIC_FORMATS[3] = {"%.2f", "%.4f", "%.4f"};
static const char *const CHANGE_FORMATS[3] = {"%+.2f", "%+.4f", "%+.4f"};

static int metric_of(const report_score *s, int metric, double *v)
{
    if (!s->present) return 0;
    if (metric == 2 && !s->has_lpips) return 0;
    *v = metric == 0 ? s->psnr : metric == 1 ? s->ssim : s->lpips;
    return 1;
}

static void number_cell(report_text *t, const char *key, const char *format, double v, const char *cls)
{
    char shown[64];
    snprintf(shown, sizeof shown, format, v);
    text_printf(t, "<td class=\"%s\" data-key=\"%s\" data-value=\"%.17g\">%s</td>", cls, key, v, shown);
}

/* Rows of one set of means: label "sparse" etc. (+ suffix), keys nN.<prefix><model>.<metric>. */
static void score_rows(report_text *t, const report_run *run, const report_score *scores, int n_metrics,
                       const char *suffix, const char *prefix, int first_row_span)
{
    for (int k = 0; k < N_MODELS; k++) {
        const report_score *s = &scores[k];
        if (*prefix && !s->present) continue; /* all held-out: sparse and refined only */
        text_append(t, "<tr>");
        if (first_row_span) text_printf(t, "<td rowspan=\"%d\">%d</td>", first_row_span, run->interval);
        first_row_span = 0;
        text_printf(t, "<td>%s%s</td>", report_model_names[k], suffix);
        if (s->present) text_printf(t, "<td>%d</td>", s->frames);
        else text_append(t, "<td>&ndash;</td>");
        for (int metric = 0; metric < n_metrics; metric++) {
            char key[96];
            double v, base;
            snprintf(key, sizeof key, "n%d.%s%s.%s", run->interval, prefix, report_model_names[k], METRIC_NAMES[metric]);
            if (metric_of(s, metric, &v)) number_cell(t, key, METRIC_FORMATS[metric], v, "num");
            else text_append(t, "<td>&ndash;</td>");
            if (k == 0) {
                text_append(t, "<td></td>");
            } else if (metric_of(s, metric, &v) && metric_of(&scores[0], metric, &base)) {
                /* better is up for PSNR and SSIM, down for LPIPS */
                int better = metric == 2 ? v < base : v > base, worse = metric == 2 ? v > base : v < base;
                snprintf(key, sizeof key, "n%d.%s%s.%s_change", run->interval, prefix, report_model_names[k], METRIC_NAMES[metric]);
                number_cell(t, key, CHANGE_FORMATS[metric], v - base, better ? "num better" : worse ? "num worse" : "num");
            } else {
                text_append(t, "<td>&ndash;</td>");
            }
        }
        text_append(t, "</tr>\n");
    }
}

static void run_rows(report_text *t, const report_run *run, int n_metrics)
{
    int columns = 3 + 2 * n_metrics;
    if (!run->has_means) {
        text_printf(t, "<tr><td>%d</td><td colspan=\"%d\" class=\"note\">%s</td></tr>\n", run->interval,
                    columns - 1,
                    run->smooth ? "smooth path between the training views: no ground truth, no metrics"
                                : "not evaluated yet");
        return;
    }
    int rows = N_MODELS;
    if (run->has_all_held_out)
        for (int k = 0; k < N_MODELS; k++) rows += run->all_held_out[k].present;
    score_rows(t, run, run->means, n_metrics, "", "", rows);
    if (run->has_all_held_out) score_rows(t, run, run->all_held_out, n_metrics, ", all held-out views", "all_held_out.", 0);
}

static int any_lpips(const report_metrics *m)
{
    for (int i = 0; i < m->n_runs; i++)
        for (int k = 0; k < N_MODELS; k++)
            if ((m->runs[i].has_means && m->runs[i].means[k].has_lpips) ||
                (m->runs[i].has_all_held_out && m->runs[i].all_held_out[k].has_lpips))
                return 1;
    return 0;
}

void report_table(report_text *t, const report_metrics *m)
{
    int n_metrics = any_lpips(m) ? 3 : 2;
    text_append(t, "<table class=\"metrics\">\n<thead><tr><th>n</th><th>model</th><th>frames</th>"
                   "<th>PSNR (dB)</th><th>&Delta;</th><th>SSIM</th><th>&Delta;</th>");
    if (n_metrics == 3) text_append(t, "<th>LPIPS</th><th>&Delta;</th>");
    text_append(t, "</tr></thead>\n<tbody>\n");
    for (int i = 0; i < m->n_runs; i++) run_rows(t, &m->runs[i], n_metrics);
    text_append(t, "</tbody>\n</table>\n");
}
