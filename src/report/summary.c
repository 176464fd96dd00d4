/* gv_report_summary: what `gaussvid reconstruct` prints when it is done, read back from
 * metrics.json so that it shows exactly what the report shows: per interval the mean PSNR /
 * SSIM of the sparse, restored and refined frames, in words whether the restorer and the
 * refinement helped, and where the report, the viewers and the videos are. */
#include "report_internal.h"

#include "gaussvid/core/core.h"
#include "gaussvid/report/report.h"

#include <math.h>
#include <stdio.h>
#include <string.h>

/* "better by 0.12 dB", "worse by 0.04 dB" or "unchanged" (below 0.005 dB, the table's rounding). */
static void change_words(double change, char *out, size_t size)
{
    if (change >= 0.005)
        snprintf(out, size, "better by %.2f dB", change);
    else if (change <= -0.005)
        snprintf(out, size, "worse by %.2f dB", -change);
    else
        snprintf(out, size, "unchanged (%+.3f dB)", change);
}

/* A sentence each; a why follows its decision after a colon, not in parentheses, since whys
 * hold parentheses of their own ("the gate is closed (held-back pairs -0.12 dB when restored)"). */
void report_decisions_text(const report_run *run, char *out, size_t size)
{
    static const char *const kept[N_DECISIONS] = {"", " The restored frames are the renders.",
                                                  " The refined model is the sparse model."};
    static const char *const label[N_DECISIONS] = {"Adaptation", "Restoration", "Refinement"};
    size_t used = 0;
    out[0] = '\0';
#define ADD(...) (used < size ? used += (size_t)snprintf(out + used, size - used, __VA_ARGS__) : 0)
    if (!strcmp(run->restore_with, "none")) {
        snprintf(out, size, "No restoration or refinement (--no-restore): the sparse model only.");
        return;
    }
    if (run->restore_with[0]) ADD("Restoration mode %s.", run->restore_with);
    for (int k = 0; k < N_DECISIONS; k++) {
        const report_decision *d = &run->decisions[k];
        if (!d->present) continue;
        if (d->ran) ADD("%s%s ran.", used ? " " : "", label[k]);
        else ADD("%s%s skipped%s%s.%s", used ? " " : "", label[k], d->why[0] ? ": " : "", d->why, kept[k]);
        if (k == DECISION_ADAPTATION && run->gate[0]) ADD(" The gate is %s.", run->gate);
    }
#undef ADD
}

/* Prints path when the file exists, else says it is missing (a stopped run). */
static void where(FILE *out, const char *label, const char *dir, const char *rel)
{
    char path[8192];
    if (gv_path_join(path, sizeof path, dir, rel) != 0) return;
    fprintf(out, "  %-12s %s%s\n", label, path, gv_file_exists(path) ? "" : "  (not written)");
}

void report_consistency_line(const report_run *run, char *out, size_t size)
{
    out[0] = 0;
    if (!run->has_consistency) return;
    char v[N_MODELS][32];
    for (int k = 0; k < N_MODELS; k++)
        if (isnan(run->consistency[k])) snprintf(v[k], sizeof v[k], "-");
        else snprintf(v[k], sizeof v[k], "%.2f", run->consistency[k]);
    snprintf(out, size, "3D consistency (each frame warped into its neighbours by the model's depth, masked PSNR): "
             "sparse %s, restored %s, refined %s dB", v[0], v[1], v[2]);
}

/* What the run decided, one line (the gate alone in a file from before decisions were kept). */
static void decision_lines(FILE *out, const report_run *run)
{
    const char *gate = run->restorer.present ? run->restorer.gate : "";
    char decisions[4096];
    report_decisions_text(run, decisions, sizeof decisions);
    if (decisions[0]) fprintf(out, "  decided: %s\n", decisions);
    else if (!strcmp(gate, "closed"))
        fprintf(out, "  the adaptation's gate is closed (its held-back views did not gain): the renders were kept\n");
    else if (!strcmp(gate, "open"))
        fprintf(out, "  the adaptation's gate is open (its held-back views gained): the renders were restored\n");
}

static void run_summary(FILE *out, const char *dir, const report_run *run)
{
    static const char *const labels[N_MODELS] = {"sparse 3DGS", "restored", "refined 3DGS"};
    if (run->smooth) {
        fprintf(out, "n = %d: a smooth path between the views, no ground truth to score\n", run->interval);
        decision_lines(out, run);
    }
    else if (!run->has_means)
        fprintf(out, "n = %d: not evaluated yet\n", run->interval);
    else {
        fprintf(out, "n = %d, %d held-out frames between the training views:\n", run->interval,
                run->means[MODEL_SPARSE].frames);
        fprintf(out, "  %-14s %9s %8s\n", "", "PSNR (dB)", "SSIM");
        for (int k = 0; k < N_MODELS; k++)
            if (run->means[k].present)
                fprintf(out, "  %-14s %9.2f %8.4f\n", labels[k], run->means[k].psnr, run->means[k].ssim);
        char restored[64], refined[64];
        change_words(run->means[MODEL_RESTORED].psnr - run->means[MODEL_SPARSE].psnr, restored, sizeof restored);
        change_words(run->means[MODEL_REFINED].psnr - run->means[MODEL_SPARSE].psnr, refined, sizeof refined);
        if (run->means[MODEL_RESTORED].present && run->means[MODEL_REFINED].present)
            fprintf(out, "  against the sparse renders the restored frames are %s, the refined model's %s\n", restored,
                    refined);
        decision_lines(out, run);
        if (run->has_all_held_out && run->all_held_out[MODEL_SPARSE].frames > run->means[MODEL_SPARSE].frames) {
            fprintf(out, "  all %d held-out views (also those after the last training view): sparse %.2f",
                    run->all_held_out[MODEL_SPARSE].frames, run->all_held_out[MODEL_SPARSE].psnr);
            if (run->all_held_out[MODEL_REFINED].present)
                fprintf(out, ", refined %.2f", run->all_held_out[MODEL_REFINED].psnr);
            fprintf(out, " dB\n");
        }
    }
    char line[256];
    report_consistency_line(run, line, sizeof line);
    if (line[0]) fprintf(out, "  %s\n", line);
    char rel[64];
    snprintf(rel, sizeof rel, "n%d/viewer.html", run->interval);
    where(out, "viewer", dir, rel);
    snprintf(rel, sizeof rel, "n%d/flythrough.mp4", run->interval);
    where(out, "video", dir, rel);
}

int gv_report_summary(const char *dir, FILE *out)
{
    char path[8192];
    if (gv_path_join(path, sizeof path, dir, "metrics.json") != 0) return -1;
    report_metrics m;
    if (report_metrics_read(path, &m) != 0) return -1;
    int adapted = m.restorer.present && !strcmp(m.restorer.kind, "scene");
    if (m.restorer.present)
        fprintf(out, "\n%s, restorer %s%s:\n", m.scene, m.restorer.checkpoint,
                adapted ? ", adapted to the scene where it has the views for it" : "");
    else
        fprintf(out, "\n%s, the sparse model only (no restorer):\n", m.scene);
    for (int i = 0; i < m.n_runs; i++) run_summary(out, dir, &m.runs[i]);
    where(out, "report", dir, "report.html");
    where(out, "numbers", dir, "metrics.json");
    report_metrics_free(&m);
    return 0;
}
