/* safetensors files (weights, checkpoints, clips all use it): open and check the header, then
 * look every tensor up by name and read it as the loaders do (float dtypes converted to
 * float32, others copied raw), and look the metadata up (fuzz_weights.h). */
#include "fuzz_weights.h"

static int fuzz_one(const uint8_t *data, size_t size)
{
    const char *path = fuzz_file("weights.safetensors", data, size);
    gv_st_file f;
    gv_clear_error();
    int rc = gv_st_open(&f, path);
    fuzz_check_failure(rc, "weights.safetensors");
    if (rc) return fuzz_report(rc, NULL), 0;
    fuzz_read_tensors(&f, "weights.safetensors");
    char what[64];
    snprintf(what, sizeof what, "opened: %d tensors", f.n_tensors);
    fuzz_report(0, what);
    gv_st_close(&f);
    return 0;
}
