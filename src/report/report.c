/* gv_report_write: the report and a viewer per run, the pipeline's last stage and what
 * `gaussvid report DIR` does. The viewers come first so the report can link to them. */
#include "report_internal.h"

#include "gaussvid/core.h"
#include "gaussvid/report.h"

#include <stdio.h>

/* DIR/nN/viewer.html for one run: the refined model when it exists, else the sparse one;
 * nothing when neither exists yet. */
static int run_viewer(const char *dir, const report_metrics *m, const report_run *run)
{
    char model[8192], out[8192], rel[64], title[512];
    const char *chosen = NULL;
    static const char *const models[2] = {"refined", "sparse"};
    for (int k = 0; k < 2 && !chosen; k++) {
        snprintf(rel, sizeof rel, "n%d/%s.splat", run->interval, models[k]);
        if (gv_path_join(model, sizeof model, dir, rel) != 0) return -1;
        if (gv_file_exists(model)) chosen = models[k];
    }
    if (!chosen) return 0;
    snprintf(rel, sizeof rel, "n%d/viewer.html", run->interval);
    if (gv_path_join(out, sizeof out, dir, rel) != 0) return -1;
    snprintf(title, sizeof title, "%s, n = %d, %s model", m->scene, run->interval, chosen);
    if (gv_viewer_write(model, m->scene_dir, run->interval, title, out) != 0) return -1;
    gv_info("%s: %s", out, title);
    return 0;
}

int gv_report_write(const char *dir)
{
    char metrics_path[8192];
    if (gv_path_join(metrics_path, sizeof metrics_path, dir, "metrics.json") != 0) return -1;
    if (!gv_dir_exists(dir)) return gv_fail("%s: no such folder", dir);
    if (!gv_file_exists(metrics_path)) return gv_fail("%s: missing (not a folder written by gaussvid reconstruct?)", metrics_path);
    report_metrics m;
    if (report_metrics_read(metrics_path, &m) != 0) return -1;
    int rc = 0;
    if (!gv_viewer_available())
        gv_warn("viewer.html not written: this gaussvid was built without the viewer's JavaScript (run scripts/setup.sh, then rebuild)");
    else
        for (int i = 0; i < m.n_runs && rc == 0; i++) rc = run_viewer(dir, &m, &m.runs[i]);
    report_metrics_free(&m);
    return rc == 0 ? gv_report_write_html(dir) : -1;
}
