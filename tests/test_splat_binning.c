/* Tile binning: getRect by hand, and on random sets: every visible Gaussian is listed in
 * exactly the tiles of its rectangle, each list is sorted by (depth, index), and the
 * per-Gaussian entry map points back to the right entries. Entries hold depth ranks. */
#include <omp.h>

#include "splat_fixtures.h"

static void test_rect_by_hand(void)
{
    int r[4];
    /* mean (24.5, 8.5) -> pixel-index (24, 8), radius 3 on a 5x3 grid:
     * x: trunc(21/16) = 1, trunc(42/16) = 2; y: trunc(5/16) = 0, trunc(26/16) = 1. */
    gv_splat_tile_rect(24.5f, 8.5f, 3, 5, 3, r);
    CHECK(r[0] == 1 && r[1] == 0 && r[2] == 2 && r[3] == 1);
    /* radius 9: x: trunc(15/16) = 0, trunc(48/16) = 3; y: trunc(-1/16) = 0, trunc(32/16) = 2 */
    gv_splat_tile_rect(24.5f, 8.5f, 9, 5, 3, r);
    CHECK(r[0] == 0 && r[1] == 0 && r[2] == 3 && r[3] == 2);
    /* left of the image: x max = trunc((-30.5 + 2 + 15)/16) = trunc(-0.84) = 0: empty */
    gv_splat_tile_rect(-30, 5, 2, 5, 3, r);
    CHECK(r[2] - r[0] == 0);
    /* huge radius and far-away means are clamped to the grid */
    gv_splat_tile_rect(20, 20, 1 << 20, 5, 3, r);
    CHECK(r[0] == 0 && r[1] == 0 && r[2] == 5 && r[3] == 3);
    gv_splat_tile_rect(1e30f, -1e30f, 4, 5, 3, r);
    CHECK(r[0] == 5 && r[2] == 5 && r[1] == 0 && r[3] == 0);
    gv_splat_tile_rect(-1e30f, 1e30f, 4, 5, 3, r);
    CHECK(r[0] == 0 && r[2] == 0 && r[1] == 3 && r[3] == 3);
}

static void check_lists(int n, int width, int height, const float *m2, const int *radii,
                        const float *depth)
{
    gv_splat_tiles t = {0};
    CHECK(gv_splat_tiles_build(&t, n, width, height, m2, radii, depth) == 0);
    int tx = (width + 15) / 16, ty = (height + 15) / 16;
    CHECK(t.tiles_x == tx && t.tiles_y == ty);
    int n_visible = 0, sorted = 1, membership = 1, expected_entries = 0;
    for (int i = 0; i < n; i++) n_visible += radii[i] > 0;
    CHECK(t.n_visible == n_visible);
    for (int k = 1; k < t.n_visible; k++) sorted &= t.visible[k] > t.visible[k - 1];
    for (int k = 1; k < t.n_visible; k++) {
        int a = t.depth_order[k - 1], b = t.depth_order[k];
        sorted &= depth[a] < depth[b] || (depth[a] == depth[b] && a < b);
    }
    /* every tile's list: sorted by (depth, index), members exactly those whose rect holds it */
    for (int tile = 0; tile < tx * ty; tile++) {
        int x = tile % tx, y = tile / tx, listed = 0;
        for (int e = t.tile_offsets[tile]; e < t.tile_offsets[tile + 1]; e++) {
            int g = t.depth_order[t.entries[e]], r[4];
            gv_splat_tile_rect(m2[2 * g], m2[2 * g + 1], radii[g], tx, ty, r);
            membership &= radii[g] > 0 && x >= r[0] && x < r[2] && y >= r[1] && y < r[3];
            if (e > t.tile_offsets[tile]) {
                int p = t.depth_order[t.entries[e - 1]];
                sorted &= depth[p] < depth[g] || (depth[p] == depth[g] && p < g);
            }
            listed++;
        }
        int want = 0;
        for (int g = 0; g < n; g++) {
            int r[4];
            if (radii[g] <= 0) continue;
            gv_splat_tile_rect(m2[2 * g], m2[2 * g + 1], radii[g], tx, ty, r);
            want += x >= r[0] && x < r[2] && y >= r[1] && y < r[3];
        }
        membership &= want == listed;
        expected_entries += want;
    }
    CHECK(sorted);
    CHECK(membership);
    CHECK(t.n_entries == expected_entries);
    CHECK(t.tile_offsets[tx * ty] == t.n_entries);
    /* the per-Gaussian map: rank k owns entries entry_of[off[k] .. off[k+1]) */
    int map_ok = t.gauss_offsets[t.n_visible] == t.n_entries;
    for (int k = 0; k < t.n_visible; k++)
        for (int j = t.gauss_offsets[k]; j < t.gauss_offsets[k + 1]; j++)
            map_ok &= t.entries[t.entry_of[j]] == k;
    CHECK(map_ok);
    gv_splat_tiles_free(&t);
}

static void test_random_lists(void)
{
    enum { N = 3000 };
    static float m2[2 * N], depth[N];
    static int radii[N];
    gv_rng r;
    gv_rng_init(&r, 41);
    for (int round = 0; round < 3; round++) {
        int width = round == 0 ? 40 : round == 1 ? 70 : 200;
        int height = round == 0 ? 24 : round == 1 ? 50 : 33;
        for (int i = 0; i < N; i++) {
            m2[2 * i] = (float)(-20 + (width + 40) * gv_rng_uniform(&r));
            m2[2 * i + 1] = (float)(-20 + (height + 40) * gv_rng_uniform(&r));
            radii[i] = gv_rng_uniform(&r) < 0.1 ? 0 : 1 + (int)(30 * gv_rng_uniform(&r));
            /* many exact ties, and depths spanning several binary exponents */
            depth[i] = gv_rng_uniform(&r) < 0.3 ? 2.5f : (float)(0.2 + 100 * gv_rng_uniform(&r));
        }
        check_lists(N, width, height, m2, radii, depth);
    }
    /* nothing visible */
    for (int i = 0; i < N; i++) radii[i] = 0;
    check_lists(N, 40, 24, m2, radii, depth);
}

/* The lists do not depend on the number of threads that dealt them. */
static void test_thread_independence(void)
{
    /* Above the size where the listing and the depth sort go parallel (16384); every
     * seventh Gaussian culled, a fifth of the depths tied at 5. */
    enum { N = 40000 };
    static float m2[2 * N], depth[N];
    static int radii[N];
    for (int i = 0; i < N; i++) {
        m2[2 * i] = (float)(-20 + 300 * gv_uniform_at(51, 3 * (uint64_t)i));
        m2[2 * i + 1] = (float)(-20 + 190 * gv_uniform_at(51, 3 * (uint64_t)i + 1));
        radii[i] = i % 7 == 0 ? 0 : 1 + i % 20;
        depth[i] = i % 5 == 0 ? 5.0f : (float)(0.3 + 20 * gv_uniform_at(51, 3 * (uint64_t)i + 2));
    }
    gv_splat_tiles a = {0}, b = {0};
    omp_set_num_threads(1);
    CHECK(gv_splat_tiles_build(&a, N, 256, 144, m2, radii, depth) == 0);
    omp_set_num_threads(3);
    CHECK(gv_splat_tiles_build(&b, N, 256, 144, m2, radii, depth) == 0);
    omp_set_num_threads(2);
    CHECK(a.n_entries == b.n_entries && a.n_entries > N);
    CHECK(a.n_visible == b.n_visible && a.n_visible == N - (N + 6) / 7);
    CHECK(memcmp(a.visible, b.visible, (size_t)a.n_visible * sizeof(int)) == 0);
    CHECK(memcmp(a.depth_order, b.depth_order, (size_t)a.n_visible * sizeof(int)) == 0);
    CHECK(memcmp(a.entries, b.entries, (size_t)a.n_entries * sizeof(int)) == 0);
    CHECK(memcmp(a.entry_of, b.entry_of, (size_t)a.n_entries * sizeof(int)) == 0);
    CHECK(memcmp(a.tile_offsets, b.tile_offsets, (size_t)(16 * 9 + 1) * sizeof(int)) == 0);
    check_lists(N, 256, 144, m2, radii, depth);
    gv_splat_tiles_free(&a);
    gv_splat_tiles_free(&b);
}

int main(void)
{
    test_rect_by_hand();
    test_random_lists();
    test_thread_independence();
    return check_summary();
}
