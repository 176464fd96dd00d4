/* Exact k-nearest-neighbour distances for the initial scales
 * (docs/reference/gaussian-splatting.md section 3.1).
 *
 * 3DGS uses simple-knn's distCUDA2, an approximate search over Morton-sorted boxes; gsplat
 * uses an exact search. This is exact: an implicit kd-tree over an index array (the median
 * of each range at its middle, split on the range's widest axis), then one independent
 * query per point, in parallel. The result does not depend on the thread count. */
#include <float.h>
#include <math.h>
#include <stdlib.h>

#include "gaussvid/core/core.h"
#include "gaussvid/splat/splat_train.h"

#define KNN_MAX_K 16

typedef struct {
    const float *xyz;
    int *index;         /* point of each tree slot */
    unsigned char *axis;/* split axis of the node whose median sits in that slot */
} kdtree;

static float coord(const kdtree *t, int slot, int axis)
{
    return t->xyz[3 * t->index[slot] + axis];
}

static void swap_slots(int *index, int a, int b)
{
    int tmp = index[a];
    index[a] = index[b], index[b] = tmp;
}

/* Rearranges index[lo, hi) so that slot k holds the k-th smallest along axis, with no
 * larger value before it and no smaller after it (Hoare's selection, middle pivot). */
static void select_kth(kdtree *t, int lo, int hi, int k, int axis)
{
    while (hi - lo > 1) {
        float pivot = coord(t, lo + (hi - lo) / 2, axis);
        int i = lo, j = hi - 1;
        while (i <= j) {
            while (coord(t, i, axis) < pivot) i++;
            while (coord(t, j, axis) > pivot) j--;
            if (i <= j) swap_slots(t->index, i++, j--);
        }
        if (k <= j) hi = j + 1;
        else if (k >= i) lo = i;
        else return; /* slots j+1 .. i-1 all equal the pivot */
    }
}

static int widest_axis(const kdtree *t, int lo, int hi)
{
    float mn[3] = {FLT_MAX, FLT_MAX, FLT_MAX}, mx[3] = {-FLT_MAX, -FLT_MAX, -FLT_MAX};
    for (int s = lo; s < hi; s++)
        for (int a = 0; a < 3; a++) {
            float v = coord(t, s, a);
            if (v < mn[a]) mn[a] = v;
            if (v > mx[a]) mx[a] = v;
        }
    int best = 0;
    for (int a = 1; a < 3; a++)
        if (mx[a] - mn[a] > mx[best] - mn[best]) best = a;
    return best;
}

static void build(kdtree *t, int lo, int hi)
{
    /* An explicit stack: the depth is about log2(n), never more than 64 for int ranges. */
    int stack[2 * 128], top = 0;
    stack[top++] = lo, stack[top++] = hi;
    while (top > 0) {
        hi = stack[--top], lo = stack[--top];
        if (hi - lo < 2) continue;
        int mid = lo + (hi - lo) / 2, axis = widest_axis(t, lo, hi);
        select_kth(t, lo, hi, mid, axis);
        t->axis[mid] = (unsigned char)axis;
        stack[top++] = lo, stack[top++] = mid;
        stack[top++] = mid + 1, stack[top++] = hi;
    }
}

/* The k smallest squared distances seen so far, ascending, and their points. */
typedef struct {
    int k, count;
    double d2[KNN_MAX_K];
    int point[KNN_MAX_K];
} best_list;

static void offer(best_list *b, double d2, int point)
{
    if (b->count == b->k && d2 >= b->d2[b->k - 1]) return;
    int i = b->count < b->k ? b->count++ : b->k - 1;
    while (i > 0 && b->d2[i - 1] > d2) b->d2[i] = b->d2[i - 1], b->point[i] = b->point[i - 1], i--;
    b->d2[i] = d2, b->point[i] = point;
}

static double worst(const best_list *b)
{
    return b->count < b->k ? DBL_MAX : b->d2[b->k - 1];
}

static void search(const kdtree *t, int lo, int hi, int self, const float q[3], best_list *b)
{
    while (hi > lo) {
        int mid = lo + (hi - lo) / 2, p = t->index[mid];
        const float *x = t->xyz + 3 * p;
        if (p != self) {
            double dx = (double)x[0] - q[0], dy = (double)x[1] - q[1], dz = (double)x[2] - q[2];
            offer(b, dx * dx + dy * dy + dz * dz, p);
        }
        if (hi - lo == 1) return;
        int axis = t->axis[mid];
        double d = (double)q[axis] - x[axis];
        /* Near side first; the far side only if the splitting plane is closer than the
         * current k-th distance. */
        int near_lo = d < 0 ? lo : mid + 1, near_hi = d < 0 ? mid : hi;
        int far_lo = d < 0 ? mid + 1 : lo, far_hi = d < 0 ? hi : mid;
        search(t, near_lo, near_hi, self, q, b);
        if (d * d >= worst(b)) return;
        lo = far_lo, hi = far_hi; /* tail call on the far side */
    }
}

static int tree_new(kdtree *t, int n, const float *xyz)
{
    *t = (kdtree){xyz, malloc((size_t)(n > 0 ? n : 1) * sizeof(int)), malloc((size_t)(n > 0 ? n : 1))};
    if (!t->index || !t->axis) {
        free(t->index), free(t->axis);
        return gv_fail("knn: out of memory for %d points", n);
    }
    for (int i = 0; i < n; i++) t->index[i] = i, t->axis[i] = 0;
    build(t, 0, n);
    return 0;
}

static int check_args(int n, int k)
{
    if (k < 1 || k > KNN_MAX_K) return gv_fail("knn: k = %d is not in 1..%d", k, KNN_MAX_K);
    if (n < 0) return gv_fail("knn: negative point count %d", n);
    return 0;
}

int gv_knn_mean_sq_dist(int n, const float *xyz, int k, float *out)
{
    if (check_args(n, k) != 0) return -1;
    if (n == 0) return 0;
    kdtree t;
    if (tree_new(&t, n, xyz) != 0) return -1;
#pragma omp parallel for schedule(dynamic, 256)
    for (int i = 0; i < n; i++) {
        best_list b = {.k = k < n - 1 ? k : n - 1, .count = 0};
        if (b.k == 0) { out[i] = 0; continue; }
        search(&t, 0, n, i, xyz + 3 * i, &b);
        double sum = 0;
        for (int j = 0; j < b.count; j++) sum += b.d2[j];
        out[i] = (float)(sum / b.count);
    }
    free(t.index), free(t.axis);
    return 0;
}

int gv_knn_neighbors(int n, const float *xyz, int n_query, const float *query, int k,
                     int *index, double *sq_dist)
{
    if (check_args(n, k) != 0) return -1;
    if (n_query < 0) return gv_fail("knn: negative query count %d", n_query);
    kdtree t;
    if (tree_new(&t, n, xyz) != 0) return -1;
    int self_query = query == NULL;
    if (self_query) query = xyz, n_query = n;
#pragma omp parallel for schedule(dynamic, 256)
    for (int i = 0; i < n_query; i++) {
        best_list b = {.k = k, .count = 0};
        if (n > 0) search(&t, 0, n, self_query ? i : -1, query + 3 * (size_t)i, &b);
        for (int j = 0; j < k; j++) {
            index[(size_t)i * k + j] = j < b.count ? b.point[j] : -1;
            sq_dist[(size_t)i * k + j] = j < b.count ? b.d2[j] : INFINITY;
        }
    }
    free(t.index), free(t.axis);
    return 0;
}
