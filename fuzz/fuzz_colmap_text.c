/* COLMAP text sparse model files, as `scene info` and `splat train` read them: the first
 * byte picks cameras.txt, images.txt or points3D.txt, the rest is the file. */
#include "fuzz.h"
#include "gaussvid/io/colmap.h"

static int fuzz_one(const uint8_t *data, size_t size)
{
    static const char *names[3] = {"cameras.txt", "images.txt", "points3D.txt"};
    if (size < 1) return 0;
    int kind = data[0] % 3;
    const char *path = fuzz_file(names[kind], data + 1, size - 1);
    gv_colmap_model model;
    memset(&model, 0, sizeof model);
    gv_clear_error();
    int rc = kind == 0 ? gv_colmap_read_cameras_text(path, &model)
             : kind == 1 ? gv_colmap_read_images_text(path, &model)
                         : gv_colmap_read_points3d_text(path, &model);
    fuzz_check_failure(rc, names[kind]);
    gv_colmap_free(&model);
    return 0;
}
