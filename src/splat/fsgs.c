/* FSGS's proximity-guided Gaussian unpooling (Zhu et al., "FSGS: Real-Time Few-shot View
 * Synthesis using Gaussian Splatting", ECCV 2024, section 3.2). From a few views the
 * initial points are sparse and the reference control only grows Gaussians where the
 * training views' gradient asks for it, so empty stretches between surfaces stay empty.
 * Unpooling fills them geometrically: a Gaussian whose K = 3 nearest neighbours are far
 * away (proximity score, the root mean square of the three distances, above a threshold)
 * (and at most 10 times it: farther, it is an isolated floater) gets a new Gaussian at the
 * midpoint of each edge to them. The new one takes the source's
 * scale, opacity and rotation (it continues the source's surface) and the mean of the two
 * ends' SH coefficients (its colour lies between them). An edge whose two ends both
 * qualify and see each other is grown once, from the lower row. The new rows are appended
 * with zero Adam moments, as the reference's clones are. FSGS's other term, the
 * pseudo-view depth loss, needs a monocular depth network and is not here
 * (docs/SPLAT_TRAINING.md says what a user with depth maps would need). */
#include <math.h>
#include <stdlib.h>

#include "gaussvid/core/core.h"
#include "gaussvid/splat/splat_train.h"

enum { K = GV_FSGS_NEIGHBORS };

/* A Gaussian whose neighbours are farther than this many times the threshold is an isolated
 * floater, not a sparse surface: unpooling it would fill the empty space between it and the
 * scene, tripling at every step (measured: a 2000-iteration run on a synthesised room grew
 * to 579 000 Gaussians without the bound, from floaters up to 11 units out). */
#define ISOLATED_FACTOR 10.0

/* Proximity score of row i from its neighbours' squared distances (INFINITY when fewer). */
static double score(const double *sq_dist, int i)
{
    double sum = 0;
    for (int j = 0; j < K; j++) sum += sq_dist[(size_t)i * K + j];
    return sqrt(sum / K);
}

/* 1 when the edge i - j (j a neighbour of i) is grown from j instead: j qualifies, j < i,
 * and i is among j's neighbours. */
static int grown_from_other_end(const int *index, const unsigned char *far, int i, int j)
{
    if (!far[j] || j > i) return 0;
    for (int m = 0; m < K; m++)
        if (index[(size_t)j * K + m] == i) return 1;
    return 0;
}

/* Row dst: the midpoint of src and other, src's scale, opacity and rotation, the mean SH. */
static void midpoint_row(gv_gaussians *g, int dst, int src, int other)
{
    gv_gaussians_copy_row(g, dst, src);
    for (int a = 0; a < 3; a++)
        g->means[3 * (size_t)dst + a] =
            0.5f * (g->means[3 * (size_t)src + a] + g->means[3 * (size_t)other + a]);
    int w = 3 * gv_sh_coefficient_count(g->sh_degree);
    for (int c = 0; c < w; c++)
        g->sh[(size_t)dst * w + c] = 0.5f * (g->sh[(size_t)src * w + c] + g->sh[(size_t)other * w + c]);
}

int gv_splat_fsgs_unpool(gv_gaussians *g, gv_splat_adam *adam, double threshold, int *added)
{
    *added = 0;
    int n = g->n;
    if (n <= K) return 0; /* fewer than K neighbours: no score */
    int *index = malloc((size_t)n * K * sizeof(int));
    double *sq_dist = malloc((size_t)n * K * sizeof(double));
    unsigned char *far = malloc((size_t)n);
    int rc = -1, n_new = 0;
    if (!index || !sq_dist || !far) {
        gv_fail("fsgs: out of memory for %d Gaussians", n);
        goto done;
    }
    if (gv_knn_neighbors(n, g->means, 0, NULL, K, index, sq_dist) != 0) goto done;
    for (int i = 0; i < n; i++) {
        double p = score(sq_dist, i);
        far[i] = p > threshold && p <= ISOLATED_FACTOR * threshold;
    }
    for (int i = 0; i < n; i++)
        for (int m = 0; m < K && far[i]; m++)
            n_new += !grown_from_other_end(index, far, i, index[(size_t)i * K + m]);
    if (n_new > 0 && (gv_gaussians_reserve(g, n + n_new) || gv_gaussians_reserve(&adam->m, n + n_new) ||
                      gv_gaussians_reserve(&adam->v, n + n_new))) {
        gv_fail_context("fsgs");
        goto done;
    }
    int row = n;
    g->n = n + n_new;
    for (int i = 0; i < n; i++)
        for (int m = 0; m < K && far[i]; m++) {
            int j = index[(size_t)i * K + m];
            if (!grown_from_other_end(index, far, i, j)) midpoint_row(g, row++, i, j);
        }
    gv_gaussians_zero_rows(&adam->m, n, n + n_new), gv_gaussians_zero_rows(&adam->v, n, n + n_new);
    adam->m.n = adam->v.n = n + n_new;
    *added = n_new;
    rc = 0;
done:
    free(index), free(sq_dist), free(far);
    return rc;
}
