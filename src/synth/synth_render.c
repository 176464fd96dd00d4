/* Rendering a frame with adaptive supersampling: one sample at every pixel corner (shared by
 * the four pixels around it); a pixel whose corners see different faces or differ in colour
 * is re-rendered with a K x K stratified grid, the others take the mean of their corners.
 * Textures are band-limited to the pixel footprint, so flat regions need no more; edges get
 * K x K. Rows are spread over OpenMP threads (unless the caller already runs frames in
 * parallel); every pixel depends only on its own samples, so the image is the same with any
 * number of threads. */
#include "synth/synth_internal.h"

#include <omp.h>
#include <stdlib.h>

#define REFINE_CONTRAST 0.08     /* in sqrt of exposed radiance (about perceptual) */
#define BAND 64                  /* pixel rows rendered together */

void sy_camera_ray(const gv_camera *cam, double px, double py, sy_vec *o, sy_vec *d)
{
    const double *R = cam->R, *t = cam->t;
    /* centre C = -R^T t; direction R^T K^-1 (px, py, 1) */
    *o = sy_v(-(R[0] * t[0] + R[3] * t[1] + R[6] * t[2]), -(R[1] * t[0] + R[4] * t[1] + R[7] * t[2]),
              -(R[2] * t[0] + R[5] * t[1] + R[8] * t[2]));
    double x = (px - cam->cx) / cam->fx, y = (py - cam->cy) / cam->fy;
    *d = sy_normalize(sy_v(R[0] * x + R[3] * y + R[6], R[1] * x + R[4] * y + R[7], R[2] * x + R[5] * y + R[8]));
}

typedef struct { sy_vec L; int id; } sample;

static sample shade(const gv_synth_world *w, const gv_camera *cam, double px, double py)
{
    sy_vec o, d;
    sample s;
    sy_camera_ray(cam, px, py, &o, &d);
    s.L = sy_radiance(w, o, d, 1.0 / cam->fx, &s.id, NULL);
    return s;
}

static int needs_refinement(const gv_synth_world *w, const sample *c[4])
{
    if (c[0]->id != c[1]->id || c[0]->id != c[2]->id || c[0]->id != c[3]->id) return 1;
    for (int k = 0; k < 3; k++) {
        double lo = INFINITY, hi = -INFINITY;
        for (int i = 0; i < 4; i++) {
            double v = k == 0 ? c[i]->L.x : k == 1 ? c[i]->L.y : c[i]->L.z;
            v = sqrt(fmax(v * w->exposure, 0));
            lo = fmin(lo, v);
            hi = fmax(hi, v);
        }
        if (hi - lo > REFINE_CONTRAST) return 1;
    }
    return 0;
}

static sy_vec supersample(const gv_synth_world *w, const gv_camera *cam, int i, int j, int K)
{
    sy_vec sum = sy_v(0, 0, 0);
    for (int b = 0; b < K; b++)
        for (int a = 0; a < K; a++)
            sum = sy_add(sum, shade(w, cam, i + (a + 0.5) / K, j + (b + 0.5) / K).L);
    return sy_scale(sum, 1.0 / (K * K));
}

/* A pixel from its four corner samples (c points at the top-left one, rows `stride` apart):
 * their mean, or a K x K grid when they disagree. */
static void render_pixel(const gv_synth_world *w, const gv_camera *cam, const sample *c, int stride, int i, int j,
                         int K, uint8_t *rgb)
{
    const sample *corner[4] = {c, c + 1, c + stride, c + stride + 1};
    sy_vec L;
    if (needs_refinement(w, corner)) L = supersample(w, cam, i, j, K);
    else L = sy_scale(sy_add(sy_add(c[0].L, c[1].L), sy_add(c[stride].L, c[stride + 1].L)), 0.25);
    sy_tone_map(w, L, rgb);
}

int gv_synth_render(const gv_synth_world *w, int frame, gv_image *out)
{
    if (frame < 0 || frame >= w->params.n_frames)
        return gv_fail("scene synth: frame %d is out of range (0 to %d)", frame, w->params.n_frames - 1);
    const gv_camera *cam = &w->cameras[frame];
    int W = cam->width, H = cam->height, K = w->params.samples;
    if (gv_image_alloc(out, W, H, 3)) return -1;
    if (K == 1) {
        #pragma omp parallel for schedule(dynamic, 1) if (!omp_in_parallel())
        for (int j = 0; j < H; j++)
            for (int i = 0; i < W; i++)
                sy_tone_map(w, shade(w, cam, i + 0.5, j + 0.5).L, out->pixels + 3 * ((size_t)j * W + i));
        return 0;
    }
    /* bands of BAND pixel rows, so that memory stays small at any size; the corner rows
     * between bands are computed twice, with identical results */
    sample *corners = malloc((size_t)(W + 1) * (BAND + 1) * sizeof *corners);
    if (!corners) {
        gv_image_free(out);
        return gv_fail("scene synth: out of memory for a %dx%d frame", W, H);
    }
    for (int top = 0; top < H; top += BAND) {
        int rows = H - top < BAND ? H - top : BAND;
        #pragma omp parallel for schedule(dynamic, 1) if (!omp_in_parallel())
        for (int j = 0; j <= rows; j++)
            for (int i = 0; i <= W; i++) corners[(size_t)j * (W + 1) + i] = shade(w, cam, i, top + j);
        #pragma omp parallel for schedule(dynamic, 1) if (!omp_in_parallel())
        for (int j = 0; j < rows; j++)
            for (int i = 0; i < W; i++)
                render_pixel(w, cam, corners + (size_t)j * (W + 1) + i, W + 1, i, top + j, K,
                             out->pixels + 3 * ((size_t)(top + j) * W + i));
    }
    free(corners);
    return 0;
}

/* A fixed exposure for the whole video (so a surface keeps its colour from frame to frame):
 * the log-average luminance over a coarse grid of rays in up to 16 frames is mapped to a
 * seeded key value, as a photographer metering the room would. */
int sy_choose_exposure(gv_synth_world *w, gv_rng *r)
{
    enum { GX = 32, GY = 18, MAX_PROBES = 16 };
    int n_frames = w->params.n_frames, probes = n_frames < MAX_PROBES ? n_frames : MAX_PROBES;
    double *logs = malloc((size_t)probes * GX * GY * sizeof *logs);
    if (!logs) return gv_fail("scene synth: out of memory");
    #pragma omp parallel for schedule(dynamic, 1)
    for (int k = 0; k < probes * GY; k++) {
        int p = k / GY, y = k % GY;
        const gv_camera *cam = &w->cameras[probes > 1 ? (int)((long)p * (n_frames - 1) / (probes - 1)) : 0];
        for (int x = 0; x < GX; x++) {
            sample s = shade(w, cam, (x + 0.5) * cam->width / GX, (y + 0.5) * cam->height / GY);
            double lum = 0.2126 * s.L.x + 0.7152 * s.L.y + 0.0722 * s.L.z;
            logs[(size_t)k * GX + x] = log(lum + 1e-4);
        }
    }
    double sum = 0;
    for (long i = 0; i < (long)probes * GX * GY; i++) sum += logs[i];
    free(logs);
    double key = sy_uniform(r, 0.15, 0.24);
    w->exposure = key / exp(sum / ((double)probes * GX * GY));
    return 0;
}
