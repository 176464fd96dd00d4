/* report.html: the page a user opens after `gaussvid reconstruct` (docs/REPORT.md). One file
 * with everything inside (styles, images as data URIs, the plot as SVG; no script, no
 * network), written atomically from metrics.json and the images it names. */
#include "report_internal.h"

#include "gaussvid/core/core.h"
#include "gaussvid/report/report.h"

#include <stdio.h>
#include <string.h>

static const char STYLE[] =
    "body{font:14px/1.45 system-ui,sans-serif;margin:24px auto;max-width:1100px;padding:0 16px;color:#222}\n"
    "h1{font-size:22px}h2{font-size:18px;margin-top:32px;border-bottom:1px solid #ddd}\n"
    "table{border-collapse:collapse;margin:8px 0}td,th{padding:3px 10px;border-bottom:1px solid #eee;text-align:left}\n"
    "td.num{text-align:right;font-variant-numeric:tabular-nums}td.better{color:#17823b}td.worse{color:#c0392b}\n"
    ".note{color:#666}.warn{background:#fff4e0;border-left:4px solid #e6a23c;padding:6px 10px}\n"
    ".row{display:flex;flex-wrap:wrap;gap:6px;margin:4px 0}.cell{flex:0 0 auto}\n"
    ".cell img{display:block;width:256px;height:auto;image-rendering:pixelated}\n"
    ".caption{font-size:12px;color:#444;max-width:256px}figure{margin:12px 0}figcaption{font-weight:600}\n"
    ".bar{background:#3182bd;height:10px}\n";

/* 1 when the comma-separated list (metrics.json's training_scenes) names scene. */
static int list_names(const char *list, const char *scene)
{
    size_t len = strlen(scene);
    for (const char *p = list; *p;) {
        const char *comma = strchr(p, ',');
        size_t item = comma ? (size_t)(comma - p) : strlen(p);
        if (item == len && !strncmp(p, scene, len)) return 1;
        p += item + (comma != NULL);
    }
    return 0;
}

/* The restorer's checkpoint, kind, gate and training scenes, in words; a warning when the
 * scene is one of them. */
static void restorer_table(report_text *t, const report_restorer *r, const char *scene)
{
    text_append(t, "<table class=\"restorer\"><tr><th>checkpoint</th><td>");
    text_escaped(t, r->checkpoint[0] ? r->checkpoint : "(none)");
    text_append(t, "</td></tr>\n<tr><th>kind</th><td>");
    text_escaped(t, r->kind[0] ? r->kind : "(unknown)");
    /* reconstruct --adapt: the document's restorer is the base, adapted once per n */
    int per_n = !strcmp(r->kind, "scene") && !r->gate[0];
    text_append(t, per_n ? " (the checkpoint above, adapted to this scene at each n where it has the views for it: "
                           "see each n's decisions)"
                   : !strcmp(r->kind, "scene") ? " (adapted to this scene from its own training views)"
                   : !strcmp(r->kind, "cross-scene") ? " (trained on other scenes, used as released)" : "");
    text_append(t, "</td></tr>\n<tr><th>gate</th><td>");
    if (per_n) text_append(t, "one per n: see each interval's restorer below");
    else if (!r->gate[0]) text_append(t, "none (only a scene checkpoint has one)");
    else {
        text_escaped(t, r->gate);
        text_append(t, !strcmp(r->gate, "open") ? ": the scene's held-back pairs said restoring helps, so the restored frames are used"
                       : !strcmp(r->gate, "closed") ? ": the scene's held-back pairs said restoring hurts, so the renders pass through unchanged"
                       : "");
    }
    text_append(t, "</td></tr>\n<tr><th>trained on</th><td>");
    text_escaped(t, r->training_scenes[0] ? r->training_scenes : "(not recorded by the checkpoint)");
    text_append(t, "</td></tr></table>\n");
    if (r->training_scenes[0] && list_names(r->training_scenes, scene)) {
        text_append(t, "<p class=\"warn\"><b>Warning:</b> the scene ");
        text_escaped(t, scene);
        text_append(t, " was in the restorer's training set: its numbers do not measure generalisation.</p>\n");
    }
}

static int same_restorer(const report_restorer *a, const report_restorer *b)
{
    return !strcmp(a->checkpoint, b->checkpoint) && !strcmp(a->kind, b->kind) && !strcmp(a->gate, b->gate);
}

static void restorer_section(report_text *t, const report_metrics *m)
{
    text_append(t, "<h2>Restorer</h2>\n");
    if (m->restorer.present) restorer_table(t, &m->restorer, m->scene);
    else text_append(t, "<p class=\"note\">No restorer recorded for the whole folder; see each n.</p>\n");
}

static void timings(report_text *t, const report_run *run)
{
    if (run->n_stages == 0) return;
    double total = 0, total_cpu = 0, longest = 0;
    int with_cpu = 0;
    for (int i = 0; i < run->n_stages; i++) {
        total += run->stages[i].seconds;
        if (run->stages[i].cpu_seconds >= 0) total_cpu += run->stages[i].cpu_seconds, with_cpu = 1;
        if (run->stages[i].seconds > longest) longest = run->stages[i].seconds;
    }
    text_append(t, "<h3>Time per stage</h3>\n<table class=\"timings\">\n<tr><th>stage</th><th>seconds</th>");
    if (with_cpu) text_append(t, "<th>CPU seconds</th>");
    text_append(t, "<th></th><th>summary</th></tr>\n");
    for (int i = 0; i < run->n_stages; i++) {
        const report_stage *s = &run->stages[i];
        text_append(t, "<tr><td>");
        text_escaped(t, s->name);
        text_printf(t, "</td><td class=\"num\" data-value=\"%.17g\">%.1f</td>", s->seconds, s->seconds);
        if (with_cpu && s->cpu_seconds >= 0)
            text_printf(t, "<td class=\"num\" data-value=\"%.17g\">%.1f</td>", s->cpu_seconds, s->cpu_seconds);
        else if (with_cpu)
            text_append(t, "<td>&ndash;</td>");
        text_printf(t, "<td><div class=\"bar\" style=\"width:%.0fpx\"></div></td><td class=\"note\">",
                    longest > 0 ? 240 * s->seconds / longest : 0);
        text_escaped(t, s->summary);
        text_append(t, "</td></tr>\n");
    }
    text_printf(t, "<tr><th>total</th><td class=\"num\">%.1f</td>", total);
    if (with_cpu) text_printf(t, "<td class=\"num\">%.1f</td>", total_cpu);
    text_append(t, "<td></td><td class=\"note\">wall-clock seconds on a machine that may be shared; CPU seconds are the process's</td></tr>\n</table>\n");
}

/* A link to a file of the run's folder, when it exists. */
static void link_if_present(report_text *t, const char *dir, const report_run *run, const char *file, const char *what)
{
    char rel[64], path[8192];
    snprintf(rel, sizeof rel, "n%d/%s", run->interval, file);
    if (gv_path_join(path, sizeof path, dir, rel) != 0 || !gv_file_exists(path)) return;
    text_printf(t, " <a href=\"%s\">%s</a>", rel, what);
}

int report_run_model(const char *dir, const report_run *run, char *path, size_t size, const char **which)
{
    static const char *const models[2] = {"refined", "sparse"};
    /* A skipped refinement leaves a copy of the sparse model as refined.splat: name it sparse. */
    for (int k = report_skipped(run, DECISION_REFINEMENT); k < 2; k++) {
        char rel[64];
        snprintf(rel, sizeof rel, "n%d/%s.splat", run->interval, models[k]);
        if (gv_path_join(path, size, dir, rel) != 0) return 0;
        if (gv_file_exists(path)) {
            *which = models[k];
            return 1;
        }
    }
    return 0;
}

static int run_section(report_text *t, const char *dir, const report_metrics *m, const report_run *run, int viewers)
{
    text_printf(t, "<section class=\"run\" id=\"n%d\">\n<h2>n = %d</h2>\n<p>", run->interval, run->interval);
    text_printf(t, "%d training views (every %d-th frame); %d %s frames", run->n_train, run->interval, run->n_frames,
                run->smooth ? "path" : "held-out");
    if (run->gaussians[0] >= 0) text_printf(t, "; %ld Gaussians sparse", run->gaussians[0]);
    if (run->gaussians[1] >= 0 && !report_skipped(run, DECISION_REFINEMENT)) /* skipped: the sparse model */
        text_printf(t, ", %ld refined", run->gaussians[1]);
    text_append(t, ".");
    char model[8192];
    const char *which;
    if (viewers && report_run_model(dir, run, model, sizeof model, &which))
        text_printf(t, " <a href=\"n%d/viewer.html\">Open the %s model in the viewer.</a>", run->interval, which);
    link_if_present(t, dir, run, "flythrough.mp4", "Fly-through video.");
    text_append(t, "</p>\n");
    if (run->inputs[0]) {
        text_append(t, "<p class=\"note\">Options: ");
        text_escaped(t, run->inputs);
        text_append(t, "</p>\n");
    }
    char decisions[4096];
    report_decisions_text(run, decisions, sizeof decisions);
    if (decisions[0]) {
        text_append(t, "<p class=\"decisions\"><b>Decided:</b> ");
        text_escaped(t, decisions);
        text_append(t, "</p>\n");
    }
    if (run->restorer.present && !(m->restorer.present && same_restorer(&run->restorer, &m->restorer))) {
        text_append(t, "<h3>Restorer of this run</h3>\n");
        restorer_table(t, &run->restorer, m->scene);
    }
    char consistency[256];
    report_consistency_line(run, consistency, sizeof consistency);
    if (consistency[0]) {
        text_printf(t, "<p class=\"consistency\" data-key=\"n%d.consistency\">", run->interval);
        text_escaped(t, consistency);
        text_append(t, " (docs/METRICS.md).</p>\n");
    }
    if (run->smooth)
        text_append(t, "<p class=\"note\">The frames follow a smooth path between the training views: there is no ground truth, so no PSNR.</p>\n");
    else report_plot(t, run);

    if (report_frame_lists(t, dir, run) != 0) return -1;
    int picked[2];
    const char *rule = "", *labels[2];
    if (report_pick_frames(dir, run, picked, &rule, labels) != 0) return -1;
    if (picked[0] >= 0) {
        text_append(t, "<h3>Frames</h3>\n<p class=\"note\">Shown: ");
        text_escaped(t, rule);
        int worst = report_worst_frame(run);
        if (worst >= 0 && worst != picked[0] && worst != picked[1])
            text_append(t, "; and the worst frame by the PSNR of what the run ends with");
        text_append(t, ".</p>\n");
        for (int k = 0; k < 2; k++)
            if ((k == 0 || picked[1] != picked[0]) && report_strip(t, dir, run, picked[k], labels[k]) != 0) return -1;
        if (worst >= 0 && worst != picked[0] && worst != picked[1] &&
            report_strip(t, dir, run, worst, "worst final PSNR") != 0)
            return -1;
    }
    timings(t, run);
    text_append(t, "</section>\n");
    return 0;
}

/* The error maps' colour bar: the stops of gv_error_colour, labelled in 8-bit levels. */
static void colour_bar(report_text *t)
{
    text_append(t, "<p>Error maps: per pixel the mean over R, G, B of the absolute difference, in 8-bit levels:</p>\n"
                   "<svg class=\"colour-bar\" width=\"460\" height=\"40\" viewBox=\"0 0 460 40\">"
                   "<defs><linearGradient id=\"error-colours\">");
    for (int k = 0; k <= 4; k++) {
        uint8_t rgb[3];
        gv_error_colour(GV_ERROR_MAP_FULL_SCALE * k / 4, rgb);
        text_printf(t, "<stop offset=\"%d%%\" stop-color=\"#%02x%02x%02x\"/>", 25 * k, rgb[0], rgb[1], rgb[2]);
    }
    text_append(t, "</linearGradient></defs><rect x=\"20\" y=\"2\" width=\"400\" height=\"18\" fill=\"url(#error-colours)\" stroke=\"#999\"/>");
    for (int k = 0; k <= 4; k++)
        text_printf(t, "<text x=\"%d\" y=\"34\" font-size=\"11\" text-anchor=\"middle\">%s%g</text>", 20 + 100 * k,
                    k == 4 ? "&#8805; " : "", GV_ERROR_MAP_FULL_SCALE * k / 4);
    text_append(t, "</svg>\n");
}

int report_build_page(report_text *t, const char *dir, const report_metrics *m, int viewers)
{
    text_append(t, "<!DOCTYPE html>\n<html lang=\"en\">\n<head>\n<meta charset=\"utf-8\">\n<title>gaussvid report: ");
    text_escaped(t, m->scene);
    text_printf(t, "</title>\n<style>\n%s</style>\n</head>\n<body>\n<h1>Reconstruction of ", STYLE);
    text_escaped(t, m->scene);
    text_append(t, "</h1>\n<p class=\"note\">Scene folder ");
    text_escaped(t, m->scene_dir);
    text_printf(t, ", %d&times;%d pixels. Sparse: 3DGS trained on every n-th view; restored: its renders after the "
                   "video restorer; refined: the 3DGS re-optimised with the restored frames as extra supervision.</p>\n",
                m->width, m->height);
    restorer_section(t, m);
    text_append(t, "<h2>Quality</h2>\n<p class=\"note\">Means over the evaluated frames against the scene's images; "
                   "&Delta; is the change against the sparse model (green better, red worse).</p>\n");
    report_table(t, m);
    for (int i = 0; i < m->n_runs; i++)
        if (run_section(t, dir, m, &m->runs[i], viewers) != 0) return -1;
    text_append(t, "<h2>Legend</h2>\n");
    colour_bar(t);
    text_append(t, "<p class=\"note\">Written by gaussvid report from metrics.json (docs/REPORT.md).</p>\n</body>\n</html>\n");
    return 0;
}

