/* CoR-GS's co-pruning (Zhang et al., "CoR-GS: Sparse-View 3D Gaussian Splatting via
 * Co-Regularization", ECCV 2024, section 4.2). Two fields trained on the same views from the
 * same points but with their own randomness agree where the views constrain them and
 * disagree where they do not: a Gaussian that has no counterpart in the other field within
 * a distance tau is likely one that fits the training views and nothing else, and is
 * pruned. Both fields are judged against each other before either is pruned. The driving
 * loop (two trainers stepped together, co-pruning after each densification step) is
 * gv_splat_corgs_step. CoR-GS's other term, the two fields' renders at pseudo-views pulled
 * together, is not implemented (docs/SPLAT_TRAINING.md). */
#include <math.h>
#include <stdlib.h>

#include "gaussvid/core.h"
#include "gaussvid/splat_train.h"

/* far[i] = 1 when row i of g has no row of other within tau. */
static int mark_unmatched(const gv_gaussians *g, const gv_gaussians *other, double tau,
                          unsigned char *far)
{
    int *index = malloc((size_t)(g->n > 0 ? g->n : 1) * sizeof(int));
    double *sq_dist = malloc((size_t)(g->n > 0 ? g->n : 1) * sizeof(double));
    int rc = index && sq_dist ? 0 : gv_fail("corgs: out of memory for %d Gaussians", g->n);
    if (rc == 0) rc = gv_knn_neighbors(other->n, other->means, g->n, g->means, 1, index, sq_dist);
    for (int i = 0; rc == 0 && i < g->n; i++) far[i] = sq_dist[i] > tau * tau;
    free(index), free(sq_dist);
    return rc;
}

/* Removes the marked rows of the model and of its Adam moments, keeping the order. */
static int remove_rows(gv_gaussians *g, gv_splat_adam *adam, const unsigned char *far)
{
    int n = 0;
    for (int i = 0; i < g->n; i++)
        if (!far[i]) {
            if (n != i) {
                gv_gaussians_copy_row(g, n, i);
                gv_gaussians_copy_row(&adam->m, n, i), gv_gaussians_copy_row(&adam->v, n, i);
            }
            n++;
        }
    int removed = g->n - n;
    g->n = adam->m.n = adam->v.n = n;
    return removed;
}

int gv_splat_corgs_coprune(gv_gaussians *a, gv_splat_adam *adam_a, gv_gaussians *b,
                           gv_splat_adam *adam_b, double tau, int *pruned_a, int *pruned_b)
{
    *pruned_a = *pruned_b = 0;
    if (a->n == 0 || b->n == 0) return 0; /* nothing to compare with */
    unsigned char *far_a = malloc((size_t)a->n), *far_b = malloc((size_t)b->n);
    int rc = far_a && far_b ? 0 : gv_fail("corgs: out of memory for %d + %d Gaussians", a->n, b->n);
    if (rc == 0) rc = mark_unmatched(a, b, tau, far_a);
    if (rc == 0) rc = mark_unmatched(b, a, tau, far_b);
    if (rc == 0) {
        *pruned_a = remove_rows(a, adam_a, far_a);
        *pruned_b = remove_rows(b, adam_b, far_b);
    }
    free(far_a), free(far_b);
    return rc;
}

int gv_splat_corgs_step(gv_splat_trainer *a, gv_splat_trainer *b, double tau, long *pruned)
{
    if (gv_splat_trainer_step(a) != 0 || gv_splat_trainer_step(b) != 0) return -1;
    if (!(a->last_control & 1) && !(b->last_control & 1)) return 0; /* not a densification */
    int pa, pb;
    if (gv_splat_corgs_coprune(&a->params, &a->adam, &b->params, &b->adam, tau * a->extent, &pa,
                               &pb) != 0 ||
        gv_splat_trainer_rows_changed(a) != 0 || gv_splat_trainer_rows_changed(b) != 0)
        return gv_fail_context("train: iteration %d (co-pruning)", a->iteration);
    pruned[0] += pa, pruned[1] += pb;
    return 0;
}
