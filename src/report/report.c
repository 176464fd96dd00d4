/* gv_report_write: the report and a viewer per run, the pipeline's last stage and what
 * `gaussvid report DIR` does. The page is built in memory first, so a bad metrics.json or a
 * missing image stops everything before a file is written; then the viewers, then the page
 * that links to them. */
#include "report_internal.h"

#include "gaussvid/core/core.h"
#include "gaussvid/report/report.h"

#include <stdio.h>

static int read_metrics(const char *dir, report_metrics *m)
{
    char path[8192];
    if (gv_path_join(path, sizeof path, dir, "metrics.json") != 0) return -1;
    if (!gv_dir_exists(dir)) return gv_fail("%s: no such folder", dir);
    if (!gv_file_exists(path)) return gv_fail("%s: missing (not a folder written by gaussvid reconstruct?)", path);
    return report_metrics_read(path, m);
}

/* DIR/nN/viewer.html for one run, when it has a model. */
static int run_viewer(const char *dir, const report_metrics *m, const report_run *run)
{
    char model[8192], out[8192], rel[64], title[512];
    const char *which;
    if (!report_run_model(dir, run, model, sizeof model, &which)) return 0;
    snprintf(rel, sizeof rel, "n%d/viewer.html", run->interval);
    if (gv_path_join(out, sizeof out, dir, rel) != 0) return -1;
    snprintf(title, sizeof title, "%s, n = %d, %s model", m->scene, run->interval, which);
    if (gv_viewer_write(model, m->scene_dir, run->interval, title, out) != 0) return -1;
    gv_info("%s: %s", out, title);
    return 0;
}

static int write_all(const char *dir, int viewers)
{
    char out[8192];
    if (gv_path_join(out, sizeof out, dir, "report.html") != 0) return -1;
    report_metrics m;
    if (read_metrics(dir, &m) != 0) return -1;
    report_text page = {0};
    int rc = report_build_page(&page, dir, &m, viewers);
    for (int i = 0; i < m.n_runs && rc == 0 && viewers; i++) rc = run_viewer(dir, &m, &m.runs[i]);
    if (rc == 0) rc = text_write_atomic(&page, out);
    text_free(&page);
    report_metrics_free(&m);
    return rc;
}

int gv_report_write(const char *dir)
{
    int viewers = gv_viewer_available();
    if (!viewers)
        gv_warn("viewer.html not written: this gaussvid was built without the viewer's JavaScript (run scripts/setup.sh, then rebuild)");
    return write_all(dir, viewers);
}

int gv_report_write_html(const char *dir) { return write_all(dir, 0); }
