/* SE-GS's uncertainty-aware perturbation (Zhao, Wang, Zhang, Javed and Salzmann,
 * "Self-Ensembling Gaussian Splatting for Few-Shot Novel View Synthesis", ICCV 2025;
 * docs/SPLAT_TRAINING.md, "Sparse-view regularisers"). Two fields train on the training views:
 * the Sigma-model (the model written) and the Delta-model. Every `interval` iterations the
 * Sigma-model is rendered at fixed pseudo views near the training cameras and the last
 * GV_SEGS_STACK renders of each view are kept; where they disagree (their per-pixel standard
 * deviation, box-filtered) the scene is not pinned down by the views, and the Delta-model's
 * Gaussians that cover those pixels get random noise on their position, opacity, scale and
 * rotation. The Delta-model so visits many nearby models over the run, and the pseudo-view
 * term the two fields share (corgs.c) pulls the Sigma-model towards them: the ensemble. */
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "gaussvid/core/core.h"
#include "gaussvid/io/colmap.h"
#include "gaussvid/splat/splat_train.h"

/* ---- the uncertainty map ---------------------------------------------------------------- */

void gv_splat_segs_uncertainty(const float *const *renders, int k, int width, int height,
                               float *scratch, float *out)
{
    long pixels = (long)width * height;
    for (long p = 0; p < pixels; p++) { /* unbiased std over the k renders, mean of channels */
        double sum = 0;
        for (int c = 0; c < 3; c++) {
            double mean = 0, sq = 0;
            for (int j = 0; j < k; j++) mean += renders[j][3 * p + c];
            mean /= k;
            for (int j = 0; j < k; j++) {
                double d = renders[j][3 * p + c] - mean;
                sq += d * d;
            }
            sum += k > 1 ? sqrt(sq / (k - 1)) : 0;
        }
        scratch[p] = (float)(sum / 3);
    }
    /* The mean over a 5 x 5 window, zeros outside the image (the release's conv2d with
     * padding 2, divided by 25 everywhere, the border included). */
    int r = GV_SEGS_BOX / 2;
    for (int y = 0; y < height; y++)
        for (int x = 0; x < width; x++) {
            double sum = 0;
            for (int dy = -r; dy <= r; dy++)
                for (int dx = -r; dx <= r; dx++) {
                    int u = x + dx, v = y + dy;
                    if (u >= 0 && u < width && v >= 0 && v < height) sum += scratch[(long)v * width + u];
                }
            out[(long)y * width + x] = (float)(sum / (GV_SEGS_BOX * GV_SEGS_BOX));
        }
}

static int descending(const void *a, const void *b)
{
    float x = *(const float *)a, y = *(const float *)b;
    return (x < y) - (x > y);
}

double gv_splat_segs_threshold(const float *u, long pixels, float *scratch)
{
    memcpy(scratch, u, (size_t)pixels * sizeof(float));
    qsort(scratch, (size_t)pixels, sizeof(float), descending);
    long at = (long)(GV_SEGS_TOP_SHARE * (double)pixels);
    if (at >= pixels) at = pixels - 1;
    return fmax(scratch[at], GV_SEGS_MIN_STD);
}

/* ---- which Gaussians cover the uncertain pixels ----------------------------------------- */

/* Squared distance transform of one line (Felzenszwalb and Huttenlocher's lower envelope of
 * parabolas): d[q] = min_p (q - p)^2 + f[p]; v, z are scratch of n and n + 1. */
static void distance_1d(const float *f, int n, int stride, float *d, int *v, float *z, float *line)
{
    for (int q = 0; q < n; q++) line[q] = f[(long)q * stride];
    int k = 0;
    v[0] = 0, z[0] = -INFINITY, z[1] = INFINITY;
    for (int q = 1; q < n; q++) {
        float s;
        for (;;) { /* z[0] = -inf ends the loop at k = 0 at the latest */
            int p = v[k];
            s = ((line[q] + (float)q * q) - (line[p] + (float)p * p)) / (2.0f * (float)(q - p));
            if (s > z[k]) break;
            k--;
        }
        k++;
        v[k] = q, z[k] = s, z[k + 1] = INFINITY;
    }
    k = 0;
    for (int q = 0; q < n; q++) {
        while (z[k + 1] < (float)q) k++;
        float dq = (float)(q - v[k]);
        d[(long)q * stride] = dq * dq + line[v[k]];
    }
}

int gv_splat_segs_distance(const float *u, int width, int height, double threshold, float *dist2)
{
    int n = width > height ? width : height;
    int *v = malloc((size_t)n * sizeof(int));
    float *z = malloc((size_t)(n + 1) * sizeof(float)), *line = malloc((size_t)n * sizeof(float));
    float *tmp = malloc((size_t)width * height * sizeof(float));
    int rc = v && z && line && tmp ? 0 : gv_fail("segs: out of memory for a %dx%d map", width, height);
    /* "Far": larger than any squared distance in the image, small enough to add to. */
    float far = 4.0f * ((float)width * width + (float)height * height) + 1;
    for (long p = 0; rc == 0 && p < (long)width * height; p++) tmp[p] = u[p] > threshold ? 0 : far;
    for (int y = 0; rc == 0 && y < height; y++)
        distance_1d(tmp + (long)y * width, width, 1, tmp + (long)y * width, v, z, line);
    for (int x = 0; rc == 0 && x < width; x++)
        distance_1d(tmp + x, height, width, dist2 + x, v, z, line);
    free(v), free(z), free(line), free(tmp);
    return rc;
}

int gv_splat_segs_mark(const float *dist2, int width, int height, int n, const float *means2d,
                       const int *radii, unsigned char *mark)
{
    int marked = 0;
    for (int i = 0; i < n; i++) {
        if (radii[i] <= 0) continue; /* not in this view */
        double x = floor(means2d[2 * i]), y = floor(means2d[2 * i + 1]); /* its pixel */
        if (x < 0 || x >= width || y < 0 || y >= height) continue;
        /* The release compares the squared distance with the radius (pytorch3d's knn_points
         * returns squared distances): a centre within sqrt(radius) pixels of an uncertain
         * pixel. Kept: the release's numbers were measured with it, and the literal reading
         * (within the radius) perturbed half of a 2000-iteration field at once. */
        if (dist2[(long)y * width + (long)x] < (double)radii[i]) {
            marked += !mark[i];
            mark[i] = 1;
        }
    }
    return marked;
}

/* ---- the perturbation ------------------------------------------------------------------- */

double gv_splat_segs_noise_ratio(int iteration, int iterations, int from, int interval)
{
    /* The release's get_expon_noise_ration_func: log-linear from max to min, from the first
     * perturbation (from + interval x stack) to the last (iterations - interval). */
    double start = from + (double)interval * GV_SEGS_STACK, steps = iterations - interval - start;
    double t = steps > 0 ? fmin(fmax((iteration - start) / steps, 0), 1) : 1;
    return exp((1 - t) * log(GV_SEGS_NOISE_MAX) + t * log(GV_SEGS_NOISE_MIN));
}

/* The first two rows of R(q) (the 6-D rotation representation) and back by Gram-Schmidt. */
static void quat_to_6d(const float q[4], double r6[6])
{
    double qd[4] = {q[0], q[1], q[2], q[3]}, R[9];
    if (qd[0] == 0 && qd[1] == 0 && qd[2] == 0 && qd[3] == 0) qd[0] = 1;
    gv_colmap_qvec_to_rotmat(qd, R);
    for (int j = 0; j < 6; j++) r6[j] = R[j];
}

static void quat_from_6d(const double r6[6], float q[4])
{
    double b1[3], b2[3], n1 = 0, dot = 0, n2 = 0, R[9], qd[4];
    for (int a = 0; a < 3; a++) n1 += r6[a] * r6[a];
    n1 = sqrt(n1) > 1e-12 ? sqrt(n1) : 1e-12;
    for (int a = 0; a < 3; a++) b1[a] = r6[a] / n1, dot += b1[a] * r6[3 + a];
    for (int a = 0; a < 3; a++) b2[a] = r6[3 + a] - dot * b1[a], n2 += b2[a] * b2[a];
    n2 = sqrt(n2) > 1e-12 ? sqrt(n2) : 1e-12;
    for (int a = 0; a < 3; a++) b2[a] /= n2, R[a] = b1[a], R[3 + a] = b2[a];
    R[6] = b1[1] * b2[2] - b1[2] * b2[1], R[7] = b1[2] * b2[0] - b1[0] * b2[2];
    R[8] = b1[0] * b2[1] - b1[1] * b2[0];
    gv_colmap_rotmat_to_qvec(R, qd);
    for (int a = 0; a < 4; a++) q[a] = (float)qd[a];
}

/* The noise scale of each perturbed value (the release's reset_attributes): the mean
 * magnitude of that column over the whole field, at least 1. Columns: 3 position, 1 opacity
 * logit, 3 log-scale, 6 rotation (6-D). Departure: the position's is the scene extent (the
 * scale of the position learning rate); the release's mean |x|, at least 1, is the distance
 * from the world origin in the reconstruction's units, and on a synthesised room (extent 1.8)
 * far floaters made even the mean distance from the centroid 10-16. */
static void noise_scales(const gv_gaussians *g, double extent, double scale[13])
{
    double sum[13] = {0};
    for (int i = 0; i < g->n; i++) {
        double r6[6];
        quat_to_6d(g->rotations + 4 * i, r6);
        for (int a = 0; a < 3; a++) sum[4 + a] += fabs(g->scales[3 * i + a]);
        sum[3] += fabs(g->opacities[i]);
        for (int j = 0; j < 6; j++) sum[7 + j] += fabs(r6[j]);
    }
    for (int j = 0; j < 13; j++) scale[j] = j < 3 ? extent : fmax(g->n > 0 ? sum[j] / g->n : 0, 1.0);
}

int gv_splat_segs_perturb(gv_gaussians *g, gv_splat_adam *adam, const unsigned char *mark,
                          double ratio, double extent, uint64_t seed, double scale_out[13])
{
    double scale[13];
    noise_scales(g, extent, scale);
    if (scale_out) memcpy(scale_out, scale, sizeof scale);
    int perturbed = 0;
    gv_gaussians *moments[2] = {&adam->m, &adam->v};
    for (int i = 0; i < g->n; i++) {
        if (!mark[i]) continue;
        double e[13];
        for (int j = 0; j < 13; j++) e[j] = ratio * scale[j] * gv_normal_at(seed, 13 * (uint64_t)i + (uint64_t)j);
        for (int a = 0; a < 3; a++) g->means[3 * i + a] += (float)e[a], g->scales[3 * i + a] += (float)e[4 + a];
        g->opacities[i] += (float)e[3];
        double r6[6];
        quat_to_6d(g->rotations + 4 * i, r6);
        for (int j = 0; j < 6; j++) r6[j] += e[7 + j];
        quat_from_6d(r6, g->rotations + 4 * i);
        /* A perturbed Gaussian starts its moments anew, as a densified one does. */
        for (int k = 0; k < 2; k++) {
            memset(moments[k]->means + 3 * i, 0, 3 * sizeof(float));
            memset(moments[k]->scales + 3 * i, 0, 3 * sizeof(float));
            memset(moments[k]->rotations + 4 * i, 0, 4 * sizeof(float));
            moments[k]->opacities[i] = 0;
        }
        perturbed++;
    }
    return perturbed;
}

/* ---- the pseudo views and the schedule -------------------------------------------------- */

static double rotation_angle(const gv_camera *a, const gv_camera *b)
{
    double tr = 0; /* trace of Ra Rb^T */
    for (int r = 0; r < 3; r++)
        for (int c = 0; c < 3; c++) tr += a->R[3 * r + c] * b->R[3 * r + c];
    return acos(fmin(fmax((tr - 1) / 2, -1), 1));
}

static double centre_distance(const gv_camera *a, const gv_camera *b)
{
    double ca[3], cb[3], d = 0;
    gv_camera_center(a, ca), gv_camera_center(b, cb);
    for (int k = 0; k < 3; k++) d += (ca[k] - cb[k]) * (ca[k] - cb[k]);
    return sqrt(d);
}

double gv_splat_segs_near_share(const gv_camera *cameras, int n_views, int k)
{
    double closest = INFINITY; /* the closest two training cameras */
    for (int i = 0; i < n_views; i++)
        for (int j = i + 1; j < n_views; j++) {
            double d = centre_distance(&cameras[i], &cameras[j]);
            if (d > 0 && d < closest) closest = d;
        }
    double d = centre_distance(&cameras[k], &cameras[k + 1]);
    double angle = rotation_angle(&cameras[k], &cameras[k + 1]);
    double share = 0.5;
    if (d > 0 && isfinite(closest)) share = fmin(share, GV_SEGS_NEAR_DISTANCE * closest / d);
    if (angle > 0) share = fmin(share, GV_SEGS_NEAR_DEGREES * M_PI / 180 / angle);
    return share;
}

int gv_splat_segs_init(gv_splat_segs *s, int n_views, const gv_camera *cameras, int interval,
                       uint64_t seed)
{
    memset(s, 0, sizeof *s);
    if (n_views < 2) return gv_fail("segs: %d training views; the pseudo views need two", n_views);
    if (interval < 1) return gv_fail("segs: interval %d; it must be at least 1", interval);
    s->interval = interval, s->seed = seed;
    gv_rng rng;
    gv_rng_init(&rng, seed);
    for (int i = 0; i < GV_SEGS_VIEWS; i++) {
        /* Every gap in turn; a position within the near share of either end. */
        int k = i % (n_views - 1);
        double a = gv_splat_segs_near_share(cameras, n_views, k), w = gv_rng_uniform(&rng);
        double t = w < 0.5 ? 2 * w * a : 1 - 2 * (w - 0.5) * a;
        gv_camera_interpolate(&cameras[k], &cameras[k + 1], t, &s->cameras[i]);
        if (gv_splat_view_from_camera(&s->views[i], &s->cameras[i]) != 0)
            return gv_fail_context("segs: pseudo view %d", i);
        long pixels = (long)s->cameras[i].width * s->cameras[i].height;
        if (pixels > s->pixels) s->pixels = pixels;
        for (int j = 0; j < GV_SEGS_STACK; j++)
            if (!(s->renders[i][j] = malloc((size_t)pixels * 3 * sizeof(float)))) goto out_of_memory;
    }
    s->image = malloc((size_t)s->pixels * 3 * sizeof(float));
    s->map = malloc((size_t)s->pixels * sizeof(float));
    s->scratch = malloc((size_t)s->pixels * sizeof(float));
    s->dist2 = malloc((size_t)s->pixels * sizeof(float));
    if (s->image && s->map && s->scratch && s->dist2) return 0;
out_of_memory:
    gv_splat_segs_free(s);
    return gv_fail("segs: out of memory for %d pseudo views", GV_SEGS_VIEWS);
}

/* Marks the Delta-model's Gaussians covering the uncertain pixels of pseudo view i. */
static int mark_view(gv_splat_segs *s, int i, const gv_gaussians *delta, int degree)
{
    const gv_camera *cam = &s->cameras[i];
    const float *stack[GV_SEGS_STACK];
    for (int j = 0; j < GV_SEGS_STACK; j++) stack[j] = s->renders[i][j];
    gv_splat_segs_uncertainty(stack, GV_SEGS_STACK, cam->width, cam->height, s->scratch, s->map);
    double thr = gv_splat_segs_threshold(s->map, (long)cam->width * cam->height, s->scratch);
    const float black[3] = {0, 0, 0};
    if (gv_splat_segs_distance(s->map, cam->width, cam->height, thr, s->dist2) != 0 ||
        gv_splat_render_forward(&s->renderer, delta, &s->views[i], degree, black, s->image) != 0)
        return -1;
    gv_splat_segs_mark(s->dist2, cam->width, cam->height, delta->n, s->renderer.means2d,
                       s->renderer.radii, s->mark);
    return 0;
}

int gv_splat_segs_observe(gv_splat_segs *s, gv_splat_trainer *sigma, gv_splat_trainer *delta)
{
    int it = sigma->iteration, from = sigma->opt.schedule.densify_from;
    if (!(it > from && it < sigma->opt.iterations - s->interval && it % s->interval == 0)) return 0;
    const float black[3] = {0, 0, 0};
    int slot = s->stored % GV_SEGS_STACK; /* the oldest render of each view is replaced */
    for (int i = 0; i < GV_SEGS_VIEWS; i++)
        if (gv_splat_render_forward(&s->renderer, &sigma->params, &s->views[i], sigma->active_degree,
                                    black, s->renders[i][slot]) != 0)
            return gv_fail_context("segs: iteration %d", it);
    s->stored++;
    if (s->stored < GV_SEGS_STACK) return 0;
    gv_gaussians *g = &delta->params;
    if (g->n > s->mark_capacity) {
        unsigned char *m = realloc(s->mark, (size_t)g->n);
        if (!m) return gv_fail("segs: out of memory for %d Gaussians", g->n);
        s->mark = m, s->mark_capacity = g->n;
    }
    memset(s->mark, 0, (size_t)g->n);
    for (int i = 0; i < GV_SEGS_VIEWS; i++)
        if (mark_view(s, i, g, delta->active_degree) != 0) return gv_fail_context("segs: iteration %d", it);
    s->ratio = gv_splat_segs_noise_ratio(it, sigma->opt.iterations, from, s->interval);
    s->perturbed += gv_splat_segs_perturb(g, &delta->adam, s->mark, s->ratio, delta->extent,
                                          s->seed + (uint64_t)it, s->noise_scale);
    s->perturbations++;
    return 0;
}

void gv_splat_segs_free(gv_splat_segs *s)
{
    for (int i = 0; i < GV_SEGS_VIEWS; i++)
        for (int j = 0; j < GV_SEGS_STACK; j++) free(s->renders[i][j]);
    free(s->image), free(s->map), free(s->scratch), free(s->dist2), free(s->mark);
    gv_splat_renderer_free(&s->renderer);
    memset(s, 0, sizeof *s);
}
