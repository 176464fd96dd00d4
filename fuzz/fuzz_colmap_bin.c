/* COLMAP binary sparse model files, as `scene info` and `splat train` read them: the first
 * byte picks cameras.bin, images.bin or points3D.bin, the rest is the file. */
#include "fuzz.h"
#include "gaussvid/io/colmap.h"

static int fuzz_one(const uint8_t *data, size_t size)
{
    static const char *names[3] = {"cameras.bin", "images.bin", "points3D.bin"};
    if (size < 1) return 0;
    int kind = data[0] % 3;
    const char *path = fuzz_file(names[kind], data + 1, size - 1);
    gv_colmap_model model;
    memset(&model, 0, sizeof model);
    gv_clear_error();
    int rc = kind == 0 ? gv_colmap_read_cameras_bin(path, &model)
             : kind == 1 ? gv_colmap_read_images_bin(path, &model)
                         : gv_colmap_read_points3d_bin(path, &model);
    fuzz_check_failure(rc, names[kind]);
    gv_colmap_free(&model);
    return 0;
}
