/* safetensors files (weights, checkpoints, clips all use it): open and check the header, then
 * look every tensor up by name and read it as the loaders do (float dtypes converted to
 * float32, others copied raw), and look the metadata up. */
#include "fuzz.h"
#include "gaussvid/safetensors.h"

static int fuzz_one(const uint8_t *data, size_t size)
{
    const char *path = fuzz_file("weights.safetensors", data, size);
    gv_st_file f;
    gv_clear_error();
    int rc = gv_st_open(&f, path);
    fuzz_check_failure(rc, "weights.safetensors");
    if (rc) return 0;
    for (int i = 0; i < f.n_tensors; i++) {
        const gv_st_tensor *t = &f.tensors[i];
        if (gv_st_find(&f, t->name) == NULL) abort(); /* every tensor found by its name */
        void *buffer = malloc((size_t)t->n_elements * 4 + (t->end - t->begin) + 1);
        if (!buffer) abort();
        rc = gv_st_read_f32(&f, t->name, buffer, t->shape, t->rank);
        if (rc) {
            fuzz_check_failure(rc, "weights.safetensors");
            rc = gv_st_read_raw(&f, t->name, t->dtype, t->shape, t->rank, buffer);
            if (rc) abort(); /* its own dtype and shape must read */
        }
        free(buffer);
    }
    for (int i = 0; i < f.n_metadata; i++)
        if (gv_st_metadata(&f, f.metadata_keys[i]) == NULL) abort();
    gv_st_close(&f);
    return 0;
}
