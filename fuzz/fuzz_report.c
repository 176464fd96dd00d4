/* metrics.json as `gaussvid report` reads it (src/report/metrics_read.c), then the page built
 * from what was read (table and plot; the strips stop at the first image, which the scratch
 * folder does not have). */
#include "fuzz.h"
#include "report/report_internal.h"

static int fuzz_one(const uint8_t *data, size_t size)
{
    gv_clear_error();
    const char *path = fuzz_file("metrics.json", data, size);
    report_metrics m;
    int rc = report_metrics_read(path, &m);
    fuzz_check_failure(rc, "metrics.json");
    if (rc != 0) return 0;
    report_text page = {0};
    gv_clear_error();
    fuzz_check_failure(report_build_page(&page, fuzz_dir(), &m, 0), NULL);
    text_free(&page);
    report_metrics_free(&m);
    return 0;
}
