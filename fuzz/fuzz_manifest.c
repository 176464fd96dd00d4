/* Dataset folder files, as `dataset build` (resuming), `dataset stats` and `train` read them:
 * the first byte picks manifest.json, a run record runs/<scene>_n<NN>.json, or the whole
 * folder through `dataset stats` (the input as manifest.json, beside one fixed run record). */
#include "fuzz.h"
#include "gaussvid/data/dataset.h"

static int fuzz_one(const uint8_t *data, size_t size)
{
    if (size < 1) return 0;
    gv_clear_error();
    int kind = data[0] % 3;
    if (kind == 1) {
        const char *path = fuzz_file("run.json", data + 1, size - 1);
        gv_run_record r;
        int rc = gv_run_record_read(path, &r);
        fuzz_check_failure(rc, "run.json");
        if (rc == 0) gv_run_record_free(&r);
        return 0;
    }
    fuzz_file("manifest.json", data + 1, size - 1);
    if (kind == 0) {
        gv_manifest m;
        int found = 0;
        int rc = gv_manifest_read(fuzz_dir(), &m, &found);
        fuzz_check_failure(rc, "manifest.json");
        if (rc == 0) gv_manifest_free(&m);
    } else {
        gv_dataset_stats stats;
        fuzz_check_failure(gv_dataset_stats_read(fuzz_dir(), &stats), NULL);
    }
    return 0;
}
