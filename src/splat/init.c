/* Initial Gaussians from a point cloud, or from random points when a scene has none
 * (docs/reference/gaussian-splatting.md section 3; 3DGS gaussian_model.py create_from_pcd,
 * dataset_readers.py). */
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "gaussvid/core/core.h"
#include "gaussvid/splat/splat_train.h"

#define SH_C0 0.28209479177387814 /* Y_0^0, sh_utils.py */
#define INIT_OPACITY 0.1          /* inverse_sigmoid(0.1 * ones) */
#define MIN_SQ_DIST 1e-7          /* torch.clamp_min(distCUDA2(...), 0.0000001) */
#define KNN_K 3                   /* distCUDA2 averages the 3 nearest squared distances */

int gv_splat_init_from_points(gv_gaussians *g, int n, const float *xyz, const uint8_t *rgb,
                              int sh_degree)
{
    memset(g, 0, sizeof *g);
    if (n < 1) return gv_fail("init: no points to initialise the Gaussians from");
    for (long i = 0; i < 3L * n; i++)
        if (!isfinite(xyz[i])) return gv_fail("init: point %ld has a non-finite coordinate", i / 3);
    if (gv_gaussians_alloc(g, n, sh_degree) != 0) return -1;
    float *d2 = malloc((size_t)n * sizeof(float));
    if (!d2) {
        gv_gaussians_free(g);
        return gv_fail("init: out of memory for %d points", n);
    }
    if (gv_knn_mean_sq_dist(n, xyz, KNN_K, d2) != 0) {
        free(d2);
        gv_gaussians_free(g);
        return -1;
    }
    int coeffs = 3 * gv_sh_coefficient_count(sh_degree);
    float opacity_logit = (float)log(INIT_OPACITY / (1.0 - INIT_OPACITY));
    for (int i = 0; i < n; i++) {
        memcpy(g->means + 3 * i, xyz + 3 * i, 3 * sizeof(float));
        float *sh = g->sh + (size_t)coeffs * i; /* zeroed by alloc: only the DC is set */
        for (int c = 0; c < 3; c++) {
            double colour = (rgb ? rgb[3 * i + c] : 128) / 255.0;
            sh[c] = (float)((colour - 0.5) / SH_C0); /* RGB2SH */
        }
        /* log(sqrt(d2)), the scale of create_from_pcd (same in all three axes). */
        float log_scale = (float)(0.5 * log(fmax(d2[i], MIN_SQ_DIST)));
        for (int a = 0; a < 3; a++) g->scales[3 * i + a] = log_scale;
        g->rotations[4 * i] = 1.0f;
        g->opacities[i] = opacity_logit;
    }
    free(d2);
    return 0;
}

int gv_splat_init_random(gv_gaussians *g, int n, const double center[3], double half_size,
                         int sh_degree, uint64_t seed)
{
    memset(g, 0, sizeof *g);
    if (n < 1) return gv_fail("init: %d random points requested; need at least 1", n);
    if (!(half_size > 0) || !isfinite(half_size))
        return gv_fail("init: random points need a positive box size (got %g)", half_size);
    float *xyz = malloc((size_t)n * 3 * sizeof(float));
    if (!xyz) return gv_fail("init: out of memory for %d random points", n);
    gv_rng rng;
    gv_rng_init(&rng, seed);
    for (int i = 0; i < n; i++)
        for (int a = 0; a < 3; a++)
            xyz[3 * i + a] = (float)(center[a] + half_size * (2.0 * gv_rng_uniform(&rng) - 1.0));
    int ok = gv_splat_init_from_points(g, n, xyz, NULL, sh_degree);
    free(xyz);
    if (ok != 0) return -1;
    /* 3DGS draws shs = U(0, 1) / 255 and stores colours SH2RGB(shs), which create_from_pcd
     * maps back to the same shs: nearly grey Gaussians. */
    int coeffs = 3 * gv_sh_coefficient_count(sh_degree);
    for (int i = 0; i < n; i++)
        for (int c = 0; c < 3; c++)
            g->sh[(size_t)coeffs * i + c] = (float)(gv_rng_uniform(&rng) / 255.0);
    return 0;
}
