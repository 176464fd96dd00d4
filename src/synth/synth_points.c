/* The sparse point cloud, made as the shared scenes' are: rays through every few pixels of
 * every few frames, each first hit a point coloured with its shaded colour (the same
 * view-independent value the frames show), then thinned to one point per voxel (the first
 * in frame, row, column order). The sky gives no points. */
#include "synth/synth_internal.h"

#include <stdlib.h>

#define FRAMES_USED 20           /* about this many frames cast rays */
#define VOXELS_ACROSS 90         /* voxel = room diagonal / this */

typedef struct {
    int64_t key;                 /* voxel index, or INT64_MAX for no point */
    long order;
} candidate;

static int by_key_then_order(const void *a, const void *b)
{
    const candidate *x = a, *y = b;
    if (x->key != y->key) return x->key < y->key ? -1 : 1;
    return (x->order > y->order) - (x->order < y->order);
}

static int64_t voxel_key(sy_vec p, double size)
{
    int64_t ix = (int64_t)floor(p.x / size) + (1 << 20), iy = (int64_t)floor(p.y / size) + (1 << 20);
    int64_t iz = (int64_t)floor(p.z / size) + (1 << 20);
    return (ix & 0x1fffff) << 42 | (iy & 0x1fffff) << 21 | (iz & 0x1fffff);
}

int gv_synth_points(const gv_synth_world *w, float **xyz, uint8_t **rgb, int *n)
{
    *xyz = NULL;
    *rgb = NULL;
    *n = 0;
    int W = w->params.width, H = w->params.height, F = w->params.n_frames;
    int frame_step = F / FRAMES_USED > 1 ? F / FRAMES_USED : 1;
    int step = (int)lround(W / 85.0) > 1 ? (int)lround(W / 85.0) : 1;
    int n_frames = (F + frame_step - 1) / frame_step, cols = (W + step - 1) / step, rows = (H + step - 1) / step;
    long total = (long)n_frames * rows * cols;
    double voxel = hypot(w->room_hi.x - w->room_lo.x, w->room_hi.y - w->room_lo.y) / VOXELS_ACROSS;
    candidate *cand = malloc((size_t)total * sizeof *cand);
    float *pos = malloc((size_t)total * 3 * sizeof *pos);
    uint8_t *col = malloc((size_t)total * 3);
    if (!cand || !pos || !col) {
        free(cand), free(pos), free(col);
        return gv_fail("scene synth: out of memory (%ld candidate points)", total);
    }
    #pragma omp parallel for schedule(dynamic, 1)
    for (long job = 0; job < (long)n_frames * rows; job++) {
        const gv_camera *cam = &w->cameras[(job / rows) * frame_step];
        int j = (int)(job % rows) * step;
        for (int c = 0; c < cols; c++) {
            long k = job * cols + c;
            sy_vec o, d, p = sy_v(0, 0, 0);
            int id;
            sy_camera_ray(cam, c * step + 0.5, j + 0.5, &o, &d);
            sy_vec L = sy_radiance(w, o, d, 1.0 / cam->fx, &id, &p);
            cand[k].order = k;
            cand[k].key = id == -1 ? INT64_MAX : voxel_key(p, voxel);
            pos[3 * k] = (float)p.x, pos[3 * k + 1] = (float)p.y, pos[3 * k + 2] = (float)p.z;
            sy_tone_map(w, L, col + 3 * k);
        }
    }
    qsort(cand, (size_t)total, sizeof *cand, by_key_then_order);
    /* keep the first of each voxel, then put them back in casting order */
    long kept = 0;
    for (long i = 0; i < total; i++)
        if (cand[i].key != INT64_MAX && (i == 0 || cand[i].key != cand[i - 1].key)) cand[kept++] = cand[i];
    for (long i = 0; i < kept; i++) cand[i].key = 0;
    qsort(cand, (size_t)kept, sizeof *cand, by_key_then_order);
    *xyz = malloc((size_t)(kept ? kept : 1) * 3 * sizeof **xyz);
    *rgb = malloc((size_t)(kept ? kept : 1) * 3);
    if (!*xyz || !*rgb) {
        free(*xyz), free(*rgb), free(cand), free(pos), free(col);
        *xyz = NULL, *rgb = NULL;
        return gv_fail("scene synth: out of memory");
    }
    for (long i = 0; i < kept; i++)
        for (int c = 0; c < 3; c++) {
            (*xyz)[3 * i + c] = pos[3 * cand[i].order + c];
            (*rgb)[3 * i + c] = col[3 * cand[i].order + c];
        }
    *n = (int)kept;
    free(cand), free(pos), free(col);
    return 0;
}
