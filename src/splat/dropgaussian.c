/* DropGaussian (Park, Ryu and Kim, "DropGaussian: Structural Regularization for
 * Sparse-view Gaussian Splatting", CVPR 2025). With few views a Gaussian near the training
 * cameras can explain a pixel alone while the ones behind it get no gradient, and what
 * overfits the training views shows at the others. Leaving a random share of the Gaussians
 * out of each training render lets the ones behind be seen and trained. Compensation keeps
 * the render unbiased: the front-to-back blend is multilinear in the Gaussians' alphas, the
 * drop decisions are independent, and each kept alpha is alpha / (1 - rate), so each term
 * of the blend has the expectation of the full render's (away from the 0.99 clamp and the
 * 1/255 cut; tests/test_splat_dropgaussian.c checks it). The trainer passes the scales to
 * gv_splat_render_forward_scaled; nothing changes at render or test time. */
#include "gaussvid/core/core.h"
#include "gaussvid/splat/splat_train.h"

double gv_splat_drop_rate(int iteration, int iterations, double final)
{
    if (iterations < 1 || iteration < 0) return 0;
    if (iteration > iterations) iteration = iterations;
    return final * (double)iteration / (double)iterations;
}

int gv_splat_drop_draw(int n, double rate, uint64_t seed, float *scale)
{
    float keep = (float)(1.0 / (1.0 - rate));
    int dropped = 0;
#pragma omp parallel for schedule(static) reduction(+ : dropped)
    for (int i = 0; i < n; i++) {
        int drop = gv_uniform_at(seed, (uint64_t)i) < rate;
        scale[i] = drop ? 0.0f : keep;
        dropped += drop;
    }
    return dropped;
}
