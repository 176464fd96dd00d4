/* PLY files: the first byte picks the 3DGS model reader (`splat render/eval/export`) or the
 * point-cloud reader (points3D.ply of a scene), the rest is the file. */
#include "fuzz.h"
#include "gaussvid/io/gaussians.h"
#include "gaussvid/io/ply.h"

static int fuzz_one(const uint8_t *data, size_t size)
{
    if (size < 1) return 0;
    const char *path = fuzz_file("model.ply", data + 1, size - 1);
    gv_clear_error();
    if (data[0] & 1) {
        int n = 0;
        float *xyz = NULL;
        uint8_t *rgb = NULL;
        int rc = gv_points_read_ply(path, &n, &xyz, &rgb);
        fuzz_check_failure(rc, "model.ply");
        free(xyz);
        free(rgb);
    } else {
        gv_gaussians g;
        int rc = gv_gaussians_read_ply(path, &g);
        fuzz_check_failure(rc, "model.ply");
        if (rc == 0) gv_gaussians_free(&g);
    }
    return 0;
}
