/* A bounding volume hierarchy over all primitives, so that a ray meets a few boxes instead
 * of every object: built once with the surface area heuristic, traversed nearest child first
 * with an explicit stack. The build is a pure function of the primitive list (ties broken by
 * index), so every run gets the same tree. */
#include "synth/synth_internal.h"

#include <stdlib.h>

#define LEAF_SIZE 2
#define STACK_SIZE 64

static double axis_of(sy_vec v, int a) { return a == 0 ? v.x : a == 1 ? v.y : v.z; }

/* Sorts items[0..n) by the centre coordinate on `axis`, then by index (a total order). */
static void sort_by_center(int *items, int n, const sy_vec *centers, int axis)
{
    for (int i = 1; i < n; i++) {
        int x = items[i], j = i - 1;
        double cx = axis_of(centers[x], axis);
        while (j >= 0) {
            double cj = axis_of(centers[items[j]], axis);
            if (cj < cx || (cj == cx && items[j] < x)) break;
            items[j + 1] = items[j];
            j--;
        }
        items[j + 1] = x;
    }
}

static double half_area(sy_vec lo, sy_vec hi)
{
    sy_vec e = sy_sub(hi, lo);
    return e.x * e.y + e.y * e.z + e.z * e.x;
}

static void grow_box(sy_vec *blo, sy_vec *bhi, sy_vec lo, sy_vec hi)
{
    *blo = sy_v(fmin(blo->x, lo.x), fmin(blo->y, lo.y), fmin(blo->z, lo.z));
    *bhi = sy_v(fmax(bhi->x, hi.x), fmax(bhi->y, hi.y), fmax(bhi->z, hi.z));
}

/* Surface area heuristic (MacDonald and Booth 1990): on each axis, sort by centre and try
 * every split; cost = area(left) n(left) + area(right) n(right). Returns the best cost and
 * sets *axis, *split; right_area is scratch of count doubles. */
static double best_split(int *items, int count, const sy_vec *lo, const sy_vec *hi, const sy_vec *centers,
                         double *right_area, int *axis, int *split)
{
    double best = INFINITY;
    for (int a = 0; a < 3; a++) {
        sort_by_center(items, count, centers, a);
        sy_vec blo = sy_v(INFINITY, INFINITY, INFINITY), bhi = sy_scale(blo, -1);
        for (int i = count - 1; i > 0; i--) {
            grow_box(&blo, &bhi, lo[items[i]], hi[items[i]]);
            right_area[i] = half_area(blo, bhi);
        }
        blo = sy_v(INFINITY, INFINITY, INFINITY), bhi = sy_scale(blo, -1);
        for (int i = 1; i < count; i++) {
            grow_box(&blo, &bhi, lo[items[i - 1]], hi[items[i - 1]]);
            double cost = half_area(blo, bhi) * i + right_area[i] * (count - i);
            if (cost < best) { best = cost; *axis = a; *split = i; }
        }
    }
    return best;
}

static void build_node(gv_synth_world *w, int node, int first, int count, const sy_vec *lo, const sy_vec *hi,
                       const sy_vec *centers, double *scratch)
{
    sy_bvh_node *nd = &w->bvh[node];
    sy_vec blo = sy_v(INFINITY, INFINITY, INFINITY), bhi = sy_scale(blo, -1);
    for (int i = first; i < first + count; i++) grow_box(&blo, &bhi, lo[w->bvh_prims[i]], hi[w->bvh_prims[i]]);
    nd->lo = blo;
    nd->hi = bhi;
    int axis = 0, split = count / 2;
    double cost = count > LEAF_SIZE ? best_split(w->bvh_prims + first, count, lo, hi, centers, scratch, &axis, &split) : 0;
    /* a leaf when small, or when splitting would not pay (traversal step costs ~1 test) */
    if (count <= LEAF_SIZE || (count <= 4 && cost >= half_area(blo, bhi) * (count - 1))) {
        nd->first = first;
        nd->count = count;
        return;
    }
    sort_by_center(w->bvh_prims + first, count, centers, axis);
    int left = w->n_bvh;
    w->n_bvh += 2;
    nd->count = 0;
    nd->first = left;
    build_node(w, left, first, split, lo, hi, centers, scratch);
    build_node(w, left + 1, first + split, count - split, lo, hi, centers, scratch);
}

int sy_build_bvh(gv_synth_world *w)
{
    int n = w->n_prims;
    sy_vec *lo = malloc((size_t)n * 3 * sizeof *lo + (size_t)(n + 1) * sizeof(double));
    w->bvh = malloc((size_t)(2 * n + 1) * sizeof *w->bvh);
    w->bvh_prims = malloc((size_t)(n + 1) * sizeof *w->bvh_prims);
    if (!lo || !w->bvh || !w->bvh_prims) {
        free(lo);
        return gv_fail("scene synth: out of memory (%d primitives)", n);
    }
    sy_vec *hi = lo + n, *centers = lo + 2 * n;
    for (int i = 0; i < n; i++) {
        sy_prim_bounds(&w->prims[i], &lo[i], &hi[i]);
        centers[i] = sy_scale(sy_add(lo[i], hi[i]), 0.5);
        w->bvh_prims[i] = i;
    }
    w->n_bvh = 1;
    if (n > 0) build_node(w, 0, 0, n, lo, hi, centers, (double *)(lo + 3 * n));
    free(lo);
    return 0;
}

/* Entry distance of a ray into a box, or INFINITY when it misses or enters beyond tmax. */
static inline double box_entry(const sy_bvh_node *nd, sy_vec o, sy_vec inv, double tmax)
{
    double t0 = 0, t1 = tmax, a, b;
    a = (nd->lo.x - o.x) * inv.x, b = (nd->hi.x - o.x) * inv.x;
    if (a > b) { double t = a; a = b; b = t; }
    t0 = a > t0 ? a : t0, t1 = b < t1 ? b : t1;
    a = (nd->lo.y - o.y) * inv.y, b = (nd->hi.y - o.y) * inv.y;
    if (a > b) { double t = a; a = b; b = t; }
    t0 = a > t0 ? a : t0, t1 = b < t1 ? b : t1;
    a = (nd->lo.z - o.z) * inv.z, b = (nd->hi.z - o.z) * inv.z;
    if (a > b) { double t = a; a = b; b = t; }
    t0 = a > t0 ? a : t0, t1 = b < t1 ? b : t1;
    return t0 <= t1 ? t0 : INFINITY;
}

/* 1 / d with zero components replaced by a huge finite number, so that no 0 * inf appears. */
static inline sy_vec safe_inverse(sy_vec d)
{
    return sy_v(fabs(d.x) > 1e-30 ? 1.0 / d.x : 1e30, fabs(d.y) > 1e-30 ? 1.0 / d.y : 1e30,
                fabs(d.z) > 1e-30 ? 1.0 / d.z : 1e30);
}

/* Walks the tree; any_hit stops at the first shadow-casting hit (returns 1). */
int sy_bvh_traverse(const gv_synth_world *w, sy_vec o, sy_vec d, double tmin, sy_hit *hit, int any_hit)
{
    if (w->n_prims == 0 || !w->bvh) return 0;
    sy_vec inv = safe_inverse(d);
    int stack[STACK_SIZE], sp = 0;
    double entry[STACK_SIZE];
    int node = 0;
    double t_node = box_entry(&w->bvh[0], o, inv, hit->t);
    if (t_node == INFINITY) return 0;
    for (;;) {
        const sy_bvh_node *nd = &w->bvh[node];
        if (nd->count > 0) {
            for (int i = nd->first; i < nd->first + nd->count; i++) {
                int p = w->bvh_prims[i];
                const sy_prim *prim = &w->prims[p];
                double t;
                int face;
                if (any_hit && prim->light >= 0) continue;
                if (sy_prim_intersect(prim, o, d, tmin, hit->t, &t, &face)) {
                    hit->t = t;
                    hit->prim = p;
                    hit->face = face;
                    if (any_hit) return 1;
                }
            }
        } else {
            int l = nd->first, r = l + 1;
            double tl = box_entry(&w->bvh[l], o, inv, hit->t), tr = box_entry(&w->bvh[r], o, inv, hit->t);
            if (tr < tl) { int s = l; l = r; r = s; double t = tl; tl = tr; tr = t; }
            if (tl < INFINITY) {
                if (tr < INFINITY && sp < STACK_SIZE) { stack[sp] = r; entry[sp++] = tr; }
                node = l;
                continue;
            }
        }
        do { /* pop the next box still in front of the closest hit */
            if (sp == 0) return hit->prim >= 0;
            sp--;
            node = stack[sp];
            t_node = entry[sp];
        } while (t_node > hit->t);
    }
}
