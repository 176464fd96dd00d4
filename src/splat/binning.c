/* Tile binning: which 16x16 tiles each visible Gaussian touches, and per-tile lists sorted
 * front to back (docs/reference/gaussian-splatting.md sections 6.2 and 7; [RAST] auxiliary.h
 * getRect, rasterizer_impl.cu duplicateWithKeys / identifyTileRanges).
 *
 * The reference sorts (tile << 32 | depth bits) keys with a stable radix sort of the
 * Gaussians in index order, so each tile's list is ordered by (depth, index). Here the
 * visible Gaussians are sorted once by depth (stable LSD radix sort on the float bits,
 * which are monotone for positive floats) and then dealt into the tiles in that order,
 * which gives exactly the same lists. */
#include <limits.h>
#include <math.h>
#include <omp.h>
#include <stdlib.h>
#include <string.h>

#include "gaussvid/core/core.h"
#include "gaussvid/splat/splat.h"

/* Reference clamp of a float tile coordinate: truncation towards zero, then [0, grid].
 * The float is bounded first so that the conversion is always defined. */
static int tile_coord(float v, int grid)
{
    v = v > -1.0f ? v : -1.0f; /* NaN becomes -1 */
    v = v < (float)grid + 1.0f ? v : (float)grid + 1.0f;
    int i = (int)v;
    return i < 0 ? 0 : i > grid ? grid : i;
}

void gv_splat_tile_rect(float mean_x, float mean_y, int radius, int tiles_x, int tiles_y,
                        int rect[4])
{
    /* The reference samples pixel (i, j) at (i, j); our centres are at +0.5. */
    float px = mean_x - 0.5f, py = mean_y - 0.5f, r = (float)radius;
    rect[0] = tile_coord((px - r) / GV_SPLAT_TILE, tiles_x);
    rect[1] = tile_coord((py - r) / GV_SPLAT_TILE, tiles_y);
    rect[2] = tile_coord((px + r + GV_SPLAT_TILE - 1) / GV_SPLAT_TILE, tiles_x);
    rect[3] = tile_coord((py + r + GV_SPLAT_TILE - 1) / GV_SPLAT_TILE, tiles_y);
}

/* Grows *array to `bytes` bytes with realloc. */
static int grow(void **array, size_t bytes)
{
    void *p = realloc(*array, bytes > 0 ? bytes : 1);
    if (!p) return -1;
    *array = p;
    return 0;
}

/* Amortised capacity for `count` elements. */
static long capacity_for(long count)
{
    long cap = count + count / 2 + 16;
    return cap > INT_MAX / 9 ? count : cap;
}

static int ensure_gaussians(gv_splat_tiles *t, int n)
{
    if (n + 1 <= t->cap_gaussians) return 0;
    size_t cap = (size_t)capacity_for(n + 1);
    /* On failure the arrays that did grow are just larger than recorded. */
    if (grow((void **)&t->visible, cap * sizeof(int)) ||
        grow((void **)&t->depth_order, cap * sizeof(int)) ||
        grow((void **)&t->gauss_offsets, cap * sizeof(int)) ||
        grow((void **)&t->sort_tmp, cap * sizeof(int)) ||
        grow((void **)&t->rects, cap * 4 * sizeof(int)) ||
        grow((void **)&t->splats, cap * 12 * sizeof(float)) ||
        grow((void **)&t->sort_keys, 2 * cap * sizeof(uint32_t)))
        return gv_fail("splat: out of memory for %d Gaussians", n);
    t->cap_gaussians = (int)cap;
    return 0;
}

static int ensure_tiles(gv_splat_tiles *t, int n_tiles)
{
    if (n_tiles + 1 <= t->cap_tiles) return 0;
    if (grow((void **)&t->tile_offsets, (size_t)(n_tiles + 1) * sizeof(int)))
        return gv_fail("splat: out of memory for %d tiles", n_tiles);
    t->cap_tiles = n_tiles + 1;
    return 0;
}

static int ensure_counts(gv_splat_tiles *t, long count)
{
    if (count <= t->cap_counts) return 0;
    if (grow((void **)&t->tile_counts, (size_t)count * sizeof(int)))
        return gv_fail("splat: out of memory for %ld tile counters", count);
    t->cap_counts = (int)count;
    return 0;
}

static int ensure_entries(gv_splat_tiles *t, long n_entries)
{
    if (n_entries <= t->cap_entries) return 0;
    size_t cap = (size_t)capacity_for(n_entries);
    if (grow((void **)&t->entries, cap * sizeof(int)) ||
        grow((void **)&t->entry_of, cap * sizeof(int)) ||
        grow((void **)&t->entry_grads, cap * 9 * sizeof(float)))
        return gv_fail("splat: out of memory for %ld tile entries", n_entries);
    t->cap_entries = (int)cap;
    return 0;
}

/* Per-thread scratch of the parallel passes: RADIX counters per thread. */
enum { RADIX = 256 };
static int ensure_thread_scratch(gv_splat_tiles *t, int threads)
{
    if (threads * RADIX <= t->cap_thread_counts) return 0;
    if (grow((void **)&t->thread_counts, (size_t)threads * RADIX * sizeof(int)))
        return gv_fail("splat: out of memory for %d threads' counters", threads);
    t->cap_thread_counts = threads * RADIX;
    return 0;
}

/* The contiguous range [*k0, *k1) of n items that thread `me` of `n_threads` takes. */
static void thread_range(int n, int me, int n_threads, int *k0, int *k1)
{
    *k0 = (int)((long)n * me / n_threads), *k1 = (int)((long)n * (me + 1) / n_threads);
}

/* t->visible = the Gaussians with radius > 0, ascending. Each thread counts its range, then
 * writes after the threads before it: the same list for any thread count. Must be called
 * by every thread of a parallel region. */
static void list_visible(gv_splat_tiles *t, int n, const int *radii)
{
    int me = omp_get_thread_num(), n_threads = omp_get_num_threads(), i0, i1, count = 0;
    thread_range(n, me, n_threads, &i0, &i1);
    for (int i = i0; i < i1; i++) count += radii[i] > 0;
    t->thread_counts[me] = count;
#pragma omp barrier
    int pos = 0;
    for (int th = 0; th < me; th++) pos += t->thread_counts[th];
    for (int i = i0; i < i1; i++)
        if (radii[i] > 0) t->visible[pos++] = i;
    if (me == n_threads - 1) t->n_visible = pos;
#pragma omp barrier
}

/* Stable LSD radix sort of t->visible by depth into t->depth_order, 8 bits per pass. Each
 * pass counts the digits of each thread's contiguous range and scatters the range after
 * the same digits of the threads before it, which is the order of the one-thread sort: the
 * result does not depend on the thread count. Must be called by every thread of a parallel
 * region, after list_visible. */
static void sort_by_depth(gv_splat_tiles *t, const float *depths)
{
    int n = t->n_visible, me = omp_get_thread_num(), n_threads = omp_get_num_threads(), k0, k1;
    thread_range(n, me, n_threads, &k0, &k1);
    uint32_t *keys = t->sort_keys, *keys2 = t->sort_keys + t->cap_gaussians;
    int *vals = t->depth_order, *vals2 = t->sort_tmp;
    for (int k = k0; k < k1; k++) {
        uint32_t bits;
        memcpy(&bits, &depths[t->visible[k]], sizeof bits);
        keys[k] = bits;
        vals[k] = t->visible[k];
    }
    int *count = t->thread_counts + (size_t)me * RADIX;
    for (int shift = 0; shift < 32; shift += 8) {
        memset(count, 0, RADIX * sizeof(int));
        for (int k = k0; k < k1; k++) count[(keys[k] >> shift) & (RADIX - 1)]++;
#pragma omp barrier
        /* Every thread turns the counts into its own start positions, reading all of them
         * (the same sums in every thread), so no thread has to wait for another to write. */
        int start[RADIX], pos = 0, buckets = 0;
        for (int b = 0; b < RADIX; b++) {
            int in_bucket = 0;
            for (int th = 0; th < n_threads; th++) {
                int c = t->thread_counts[(size_t)th * RADIX + b];
                if (th == me) start[b] = pos + in_bucket;
                in_bucket += c;
            }
            pos += in_bucket;
            buckets += in_bucket > 0;
        }
#pragma omp barrier
        if (buckets <= 1) continue; /* one digit for all: the pass would keep the order */
        for (int k = k0; k < k1; k++) {
            int dst = start[(keys[k] >> shift) & (RADIX - 1)]++;
            keys2[dst] = keys[k];
            vals2[dst] = vals[k];
        }
        uint32_t *kt = keys; keys = keys2; keys2 = kt;
        int *vt = vals; vals = vals2; vals2 = vt;
#pragma omp barrier
    }
    if (vals != t->depth_order) memcpy(t->depth_order + k0, vals + k0, (size_t)(k1 - k0) * sizeof(int));
#pragma omp barrier
}

int gv_splat_tiles_build(gv_splat_tiles *t, int n, int width, int height,
                         const float *means2d, const int *radii, const float *depths)
{
    t->tiles_x = (width + GV_SPLAT_TILE - 1) / GV_SPLAT_TILE;
    t->tiles_y = (height + GV_SPLAT_TILE - 1) / GV_SPLAT_TILE;
    int n_tiles = t->tiles_x * t->tiles_y;
    if (ensure_gaussians(t, n) || ensure_tiles(t, n_tiles)) return -1;

    int max_threads = omp_get_max_threads();
    if (ensure_thread_scratch(t, max_threads)) return -1;
    /* a dozen barriers: below some ten thousand Gaussians one thread is faster */
#pragma omp parallel num_threads(max_threads) if (n >= 16384)
    {
        list_visible(t, n, radii);
        sort_by_depth(t, depths);
    }

    /* Tile rectangle and entry count of every rank. */
    int nv = t->n_visible;
#pragma omp parallel for schedule(static)
    for (int k = 0; k < nv; k++) {
        int g = t->depth_order[k], *rect = t->rects + 4 * k;
        gv_splat_tile_rect(means2d[2 * g], means2d[2 * g + 1], radii[g], t->tiles_x,
                           t->tiles_y, rect);
        t->gauss_offsets[k + 1] = (rect[2] - rect[0]) * (rect[3] - rect[1]);
    }
    long total = 0;
    t->gauss_offsets[0] = 0;
    for (int k = 0; k < nv; k++) {
        total += t->gauss_offsets[k + 1];
        if (total > INT_MAX / 12) return gv_fail("splat: %ld tile entries are too many", total);
        t->gauss_offsets[k + 1] = (int)total;
    }
    if (ensure_entries(t, total) || ensure_counts(t, (long)max_threads * n_tiles)) return -1;
    t->n_entries = (int)total;

    /* Deal the ranks into the tiles front to back. Each thread takes a contiguous range of
     * ranks, counts its entries per tile, and then writes them after those of the threads
     * with lower ranks: the lists come out in rank order whatever the thread count. */
#pragma omp parallel num_threads(max_threads)
    {
        int n_threads = omp_get_num_threads(), me = omp_get_thread_num();
        int k0 = (int)((long)nv * me / n_threads), k1 = (int)((long)nv * (me + 1) / n_threads);
        int *count = t->tile_counts + (size_t)me * n_tiles;
        memset(count, 0, (size_t)n_tiles * sizeof(int));
        for (int k = k0; k < k1; k++) {
            const int *rect = t->rects + 4 * k;
            for (int ty = rect[1]; ty < rect[3]; ty++)
                for (int tx = rect[0]; tx < rect[2]; tx++) count[ty * t->tiles_x + tx]++;
        }
#pragma omp barrier
#pragma omp single
        {
            /* turn the counts into each thread's first position in each tile */
            int pos = 0;
            for (int i = 0; i < n_tiles; i++) {
                t->tile_offsets[i] = pos;
                for (int th = 0; th < n_threads; th++) {
                    int *c = t->tile_counts + (size_t)th * n_tiles + i, n_here = *c;
                    *c = pos;
                    pos += n_here;
                }
            }
            t->tile_offsets[n_tiles] = pos;
        }
        for (int k = k0; k < k1; k++) {
            const int *rect = t->rects + 4 * k;
            int j = t->gauss_offsets[k];
            for (int ty = rect[1]; ty < rect[3]; ty++)
                for (int tx = rect[0]; tx < rect[2]; tx++) {
                    int pos = count[ty * t->tiles_x + tx]++;
                    t->entries[pos] = k;
                    t->entry_of[j++] = pos;
                }
        }
    }
    return 0;
}

void gv_splat_tiles_free(gv_splat_tiles *t)
{
    free(t->visible);
    free(t->depth_order);
    free(t->tile_offsets);
    free(t->entries);
    free(t->gauss_offsets);
    free(t->entry_of);
    free(t->entry_grads);
    free(t->rects);
    free(t->splats);
    free(t->tile_counts);
    free(t->sort_keys);
    free(t->sort_tmp);
    free(t->thread_counts);
    memset(t, 0, sizeof *t);
}
