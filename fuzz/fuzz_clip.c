/* Dataset clip files (safetensors with the clip's metadata), as `train` and `dataset show`
 * read them: the first byte picks the full read or the info-only read. */
#include "fuzz.h"
#include "gaussvid/data/dataset.h"

static int fuzz_one(const uint8_t *data, size_t size)
{
    if (size < 1) return 0;
    const char *path = fuzz_file("clip.safetensors", data + 1, size - 1);
    gv_clear_error();
    if (data[0] & 1) {
        gv_clip_info info;
        fuzz_check_failure(gv_clip_read_info(path, &info), "clip.safetensors");
    } else {
        gv_clip clip;
        int rc = gv_clip_read(path, &clip);
        fuzz_check_failure(rc, "clip.safetensors");
        if (rc == 0) gv_clip_free(&clip);
    }
    return 0;
}
