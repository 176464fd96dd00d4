/* Embeddings that are inputs of the network rather than learned: Wan's sinusoidal timestep
 * embedding (docs/reference/wan-vace-gaussvid.md section 2.3). */
#include "nn/nn_internal.h"

gv_tensor *gv_timestep_embedding(gv_graph *g, const float *t, int n, int dim)
{
    if (n < 1 || dim < 2 || dim % 2) {
        gv_fail("timestep_embedding: need n >= 1 and an even dimension, got %d x %d", n, dim);
        return NULL;
    }
    gv_tensor *out = gv_tensor_new(g, 2, (int[]){n, dim});
    if (!out) return NULL;
    int half = dim / 2;
    for (int k = 0; k < n; k++)
        for (int i = 0; i < half; i++) { /* cos first, then sin; in double as in Wan */
            double angle = (double)t[k] * pow(10000.0, -(double)i / half);
            out->data[(int64_t)k * dim + i] = (float)cos(angle);
            out->data[(int64_t)k * dim + half + i] = (float)sin(angle);
        }
    return out;
}
