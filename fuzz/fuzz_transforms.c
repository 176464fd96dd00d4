/* transforms.json (nerfstudio / NeRF-synthetic), as `scene info` and `splat train` read it.
 * Without w and h the reader opens the first frame's image: none exists in the scratch folder,
 * which is one more failure path. */
#include "fuzz.h"
#include "gaussvid/io/transforms.h"

static int fuzz_one(const uint8_t *data, size_t size)
{
    const char *path = fuzz_file("transforms.json", data, size);
    gv_transforms t;
    memset(&t, 0, sizeof t);
    gv_clear_error();
    int rc = gv_transforms_read(path, &t);
    fuzz_check_failure(rc, NULL); /* a missing image is named instead of the JSON file */
    if (rc == 0) gv_transforms_free(&t);
    return 0;
}
