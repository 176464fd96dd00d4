/* CoR-GS's co-pruning (Zhang et al., "CoR-GS: Sparse-View 3D Gaussian Splatting via
 * Co-Regularization", ECCV 2024, section 4.2). Two fields trained on the same views from the
 * same points but with their own randomness agree where the views constrain them and
 * disagree where they do not: a Gaussian that has no counterpart in the other field within
 * a distance tau is likely one that fits the training views and nothing else, and is
 * pruned. Both fields are judged against each other before either is pruned. The driving
 * loop (two trainers stepped together, co-pruning after each densification step) is
 * gv_splat_corgs_step. CoR-GS's other term: at a camera between two training views (where
 * nothing supervises them) the two fields' renders are pulled together, each towards the
 * other, with the training loss's form; its gradient is added to each field's before the
 * Adam step, on the union of the rows the two renders saw. SE-GS (segs.c) trains the same two
 * fields with the same pseudo-view term, and perturbs the second where the first's renders at
 * pseudo views change over time; co-pruning is CoR-GS's alone. */
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "gaussvid/core/core.h"
#include "gaussvid/splat/splat_train.h"

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

/* ---- the pseudo-view term -------------------------------------------------------------- */

static int ensure_images(gv_splat_corgs *c, long pixels)
{
    if (pixels <= c->pixels) return 0;
    for (int k = 0; k < 2; k++) {
        float *im = realloc(c->image[k], (size_t)pixels * 3 * sizeof(float));
        if (im) c->image[k] = im;
        float *d = realloc(c->d_image[k], (size_t)pixels * 3 * sizeof(float));
        if (d) c->d_image[k] = d;
        if (!im || !d) return gv_fail("corgs: out of memory for %ld pixels", pixels);
    }
    c->pixels = pixels;
    return 0;
}

int gv_splat_corgs_pseudo_grad(gv_splat_corgs *c, const gv_gaussians *g0, const gv_gaussians *g1,
                               const gv_splat_view *view, int active_degree, double lambda,
                               double weight, gv_gaussians *grad0, gv_gaussians *grad1,
                               double *loss)
{
    const gv_gaussians *g[2] = {g0, g1};
    gv_gaussians *grad[2] = {grad0, grad1};
    const float black[3] = {0, 0, 0};
    long pixels = (long)view->width * view->height;
    if (ensure_images(c, pixels) != 0) return -1;
    for (int k = 0; k < 2; k++)
        if (gv_splat_render_forward(&c->renderer[k], g[k], view, active_degree, black, c->image[k]))
            return gv_fail_context("corgs: pseudo view");
    /* The pair's loss is symmetric in its two images, so its gradient with respect to each
     * is the training loss's gradient with the other as the target. */
    gv_splat_loss_value value;
    for (int k = 0; k < 2; k++)
        if (gv_splat_loss(&c->loss_work, c->image[k], c->image[1 - k], view->width, view->height,
                          lambda, c->d_image[k], &value) != 0)
            return gv_fail_context("corgs: pseudo view");
    *loss = weight * value.loss;
    for (int k = 0; k < 2; k++) {
        for (long i = 0; i < pixels * 3; i++) c->d_image[k][i] *= (float)weight;
        if (gv_splat_render_backward(&c->renderer[k], g[k], c->d_image[k], grad[k], NULL))
            return gv_fail_context("corgs: pseudo view");
    }
    return 0;
}

void gv_splat_corgs_free(gv_splat_corgs *c)
{
    for (int k = 0; k < 2; k++) {
        gv_splat_renderer_free(&c->renderer[k]), gv_gaussians_free(&c->grad[k]);
        free(c->image[k]), free(c->d_image[k]), free(c->rows[k]);
    }
    gv_splat_loss_free(&c->loss_work);
    memset(c, 0, sizeof *c);
}

/* A camera between two consecutive training views of a, at a uniform position. */
static int pseudo_view(gv_splat_corgs *c, const gv_splat_trainer *a, gv_splat_view *view)
{
    int k = (int)(gv_rng_uniform(&c->rng) * (a->n_views - 1));
    double s = gv_rng_uniform(&c->rng);
    gv_camera cam;
    gv_camera_interpolate(&a->cameras[k], &a->cameras[k + 1], s, &cam);
    return gv_splat_view_from_camera(view, &cam);
}

static int pseudo_term(gv_splat_corgs *c, gv_splat_trainer *a, gv_splat_trainer *b)
{
    gv_splat_trainer *t[2] = {a, b};
    for (int k = 0; k < 2; k++) {
        gv_gaussians *g = &c->grad[k];
        if (g->capacity == 0 && gv_gaussians_alloc(g, t[k]->params.n, t[k]->params.sh_degree) != 0)
            return -1;
        if (gv_gaussians_reserve(g, t[k]->params.capacity) != 0) return -1;
        g->n = t[k]->params.n;
    }
    gv_splat_view view;
    double loss;
    if (pseudo_view(c, a, &view) != 0 ||
        gv_splat_corgs_pseudo_grad(c, &a->params, &b->params, &view, a->active_degree,
                                   a->opt.lambda_dssim, c->weight, &c->grad[0], &c->grad[1], &loss) != 0)
        return -1;
    for (int k = 0; k < 2; k++) /* each field's pseudo-view gradient and rows to its trainer */
        if (gv_splat_trainer_add_gradient(t[k], &c->grad[k], c->renderer[k].tiles.visible,
                                          c->renderer[k].tiles.n_visible, &c->rows[k],
                                          &c->rows_capacity[k]) != 0)
            return -1;
    c->pseudo_views++;
    return 0;
}

int gv_splat_corgs_step(gv_splat_corgs *c, gv_splat_trainer *a, gv_splat_trainer *b, double tau,
                        long *pruned, gv_splat_segs *segs)
{
    if (gv_splat_trainer_forward_backward(a) != 0 || gv_splat_trainer_forward_backward(b) != 0)
        return -1;
    if (c->weight > 0 && a->iteration > c->from && a->n_views > 1 && pseudo_term(c, a, b) != 0)
        return gv_fail_context("train: iteration %d (pseudo view)", a->iteration);
    if (gv_splat_trainer_update(a) != 0 || gv_splat_trainer_update(b) != 0) return -1;
    int densified = (a->last_control & 1) || (b->last_control & 1);
    if (densified && (a->opt.regularize & GV_REGULARIZE_CORGS)) {
        int pa, pb;
        if (gv_splat_corgs_coprune(&a->params, &a->adam, &b->params, &b->adam, tau * a->extent, &pa,
                                   &pb) != 0 ||
            gv_splat_trainer_rows_changed(a) != 0 || gv_splat_trainer_rows_changed(b) != 0)
            return gv_fail_context("train: iteration %d (co-pruning)", a->iteration);
        pruned[0] += pa, pruned[1] += pb;
    }
    /* SE-GS perturbs the second field after its step (its rows do not change). */
    return segs ? gv_splat_segs_observe(segs, a, b) : 0;
}
