/* FSGS's proximity-guided unpooling (src/splat/fsgs.c) and the neighbour search it uses
 * (src/splat/knn.c): the neighbours against brute force (self and cross queries, 1 and 2
 * threads alike); on hand-built point sets the exact new positions, attributes, row order,
 * one Gaussian per mutual edge, untouched old rows and zero Adam moments for new ones. */
#include <omp.h>

#include "check.h"
#include "gaussvid/core/core.h"
#include "gaussvid/splat/splat_train.h"

static void test_neighbors(void)
{
    enum { N = 700, Q = 90, KK = 4 };
    static float xyz[3 * N], query[3 * Q];
    static int index[N * KK], index2[N * KK], qindex[Q * KK];
    static double d2[N * KK], d22[N * KK], qd2[Q * KK];
    for (int i = 0; i < 3 * N; i++) xyz[i] = (float)gv_uniform_at(5, (uint64_t)i);
    for (int i = 0; i < 3 * Q; i++) query[i] = (float)(1.4 * gv_uniform_at(6, (uint64_t)i) - 0.2);
    omp_set_num_threads(1);
    CHECK(gv_knn_neighbors(N, xyz, 0, NULL, KK, index, d2) == 0);
    omp_set_num_threads(2);
    CHECK(gv_knn_neighbors(N, xyz, 0, NULL, KK, index2, d22) == 0);
    CHECK(memcmp(index, index2, sizeof index) == 0 && memcmp(d2, d22, sizeof d2) == 0);
    CHECK(gv_knn_neighbors(N, xyz, Q, query, KK, qindex, qd2) == 0);
    /* Brute force: the k-th distance of each and that every listed point has its distance. */
    for (int pass = 0; pass < 2; pass++) {
        int nq = pass ? Q : N;
        const float *q = pass ? query : xyz;
        const int *idx = pass ? qindex : index;
        const double *dd = pass ? qd2 : d2;
        for (int i = 0; i < nq; i++) {
            double best[KK];
            for (int j = 0; j < KK; j++) best[j] = INFINITY;
            for (int p = 0; p < N; p++) {
                if (!pass && p == i) continue;
                double d = 0;
                for (int a = 0; a < 3; a++) d += ((double)xyz[3 * p + a] - q[3 * i + a]) * ((double)xyz[3 * p + a] - q[3 * i + a]);
                for (int j = 0; j < KK; j++)
                    if (d < best[j]) {
                        for (int m = KK - 1; m > j; m--) best[m] = best[m - 1];
                        best[j] = d;
                        break;
                    }
            }
            for (int j = 0; j < KK; j++) {
                CHECK(dd[i * KK + j] == best[j]);
                int p = idx[i * KK + j];
                CHECK(p >= 0 && p < N && (pass || p != i));
                double d = 0;
                for (int a = 0; a < 3; a++) d += ((double)xyz[3 * p + a] - q[3 * i + a]) * ((double)xyz[3 * p + a] - q[3 * i + a]);
                CHECK(d == best[j]);
            }
        }
    }
    /* Fewer points than k: -1 and infinity. */
    CHECK(gv_knn_neighbors(3, xyz, 0, NULL, KK, index, d2) == 0);
    CHECK(index[2] == -1 && index[3] == -1 && isinf(d2[3]) && index[1] >= 0);
    CHECK_FAILS_WITH(gv_knn_neighbors(N, xyz, 0, NULL, 17, index, d2), "k = 17");
}

enum { W = 12 }; /* SH floats per Gaussian at degree 1 */

static void set_row(gv_gaussians *g, int i, float x, float y, float z)
{
    g->means[3 * i] = x, g->means[3 * i + 1] = y, g->means[3 * i + 2] = z;
    for (int a = 0; a < 3; a++) g->scales[3 * i + a] = -2.0f - 0.1f * i - 0.01f * a;
    g->opacities[i] = 0.1f * i - 0.3f;
    g->rotations[4 * i] = 1, g->rotations[4 * i + 1] = 0.1f * i;
    g->rotations[4 * i + 2] = 0.2f, g->rotations[4 * i + 3] = 0;
    for (int c = 0; c < W; c++) g->sh[W * i + c] = (float)(i + 0.25 * c);
}

static void make(gv_gaussians *g, gv_splat_adam *adam, int n, const float (*xyz)[3])
{
    CHECK(gv_gaussians_alloc(g, n, 1) == 0);
    for (int i = 0; i < n; i++) set_row(g, i, xyz[i][0], xyz[i][1], xyz[i][2]);
    gv_splat_adam_config c;
    gv_splat_adam_defaults(&c);
    CHECK(gv_splat_adam_init(adam, &c, g, 1.0) == 0);
    for (int i = 0; i < n; i++) adam->m.means[3 * i] = adam->v.opacities[i] = 1; /* kept */
}

/* Row r is the midpoint of s and d with s's scale, opacity, rotation and the mean SH. */
static void check_new_row(const gv_gaussians *g, int r, int s, int d, const float at[3])
{
    for (int a = 0; a < 3; a++) CHECK(g->means[3 * r + a] == at[a]);
    CHECK(memcmp(g->scales + 3 * r, g->scales + 3 * s, 3 * sizeof(float)) == 0);
    CHECK(memcmp(g->rotations + 4 * r, g->rotations + 4 * s, 4 * sizeof(float)) == 0);
    CHECK(g->opacities[r] == g->opacities[s]);
    for (int c = 0; c < W; c++) CHECK(g->sh[W * r + c] == (float)(0.5 * (s + d) + 0.25 * c));
}

static void test_far_point(void)
{
    /* A cluster of four points (spacing 0.1-0.16) and one point 2 away. The far one's three
     * nearest: row 1 (d^2 3.61), row 0 (4), row 2 (4.01), and not row 3 (4.0144); its score
     * sqrt(11.62 / 3) = 1.97 > 0.5. The cluster's scores are below 0.17. New rows 5, 6, 7:
     * the midpoints (1.05, 0, 0), (1, 0, 0), (1, 0.05, 0) in that order. */
    const float xyz[5][3] = {{0, 0, 0}, {0.1f, 0, 0}, {0, 0.1f, 0}, {0, 0, 0.12f}, {2, 0, 0}};
    gv_gaussians g;
    gv_splat_adam adam;
    make(&g, &adam, 5, xyz);
    float means[15], sh[5 * W];
    memcpy(means, g.means, sizeof means), memcpy(sh, g.sh, sizeof sh);
    /* A score above 10 x the threshold is an isolated floater: with threshold 0.15 the far
     * point (1.97) is left alone, and the cluster's scores (0.107-0.145) are below it. */
    int added = -1;
    CHECK(gv_splat_fsgs_unpool(&g, &adam, 0.15, &added) == 0 && added == 0 && g.n == 5);
    CHECK(gv_splat_fsgs_unpool(&g, &adam, 0.5, &added) == 0);
    CHECK(added == 3 && g.n == 8 && adam.m.n == 8 && adam.v.n == 8);
    CHECK(memcmp(g.means, means, sizeof means) == 0); /* old rows unchanged */
    CHECK(memcmp(g.sh, sh, sizeof sh) == 0);
    const float at[3][3] = {{0.5f * (2 + 0.1f), 0, 0}, {1, 0, 0}, {1, 0.5f * 0.1f, 0}};
    check_new_row(&g, 5, 4, 1, at[0]);
    check_new_row(&g, 6, 4, 0, at[1]);
    check_new_row(&g, 7, 4, 2, at[2]);
    CHECK_NEAR(g.means[15], 1.05, 1e-7);
    CHECK_NEAR(g.means[22], 0.05, 1e-9);
    for (int r = 5; r < 8; r++) CHECK(adam.m.means[3 * r] == 0 && adam.v.opacities[r] == 0);
    for (int r = 0; r < 5; r++) CHECK(adam.m.means[3 * r] == 1 && adam.v.opacities[r] == 1);
    /* A threshold above every score: nothing. */
    int again = -1;
    CHECK(gv_splat_fsgs_unpool(&g, &adam, 3.0, &again) == 0 && again == 0 && g.n == 8);
    gv_gaussians_free(&g);
    gv_splat_adam_free(&adam);
}

static void test_mutual_edges(void)
{
    /* A regular tetrahedron of edge 2: every vertex qualifies (score 2) and sees the other
     * three, so each of the 6 edges is grown once, from its lower row: rows 4..9 are the
     * midpoints of 0-1, 0-2, 0-3, 1-2, 1-3, 2-3 (row 0's neighbours are equidistant: the
     * order among them is the search's, so the test matches by position). */
    const float xyz[4][3] = {{1, 1, 1}, {1, -1, -1}, {-1, 1, -1}, {-1, -1, 1}};
    gv_gaussians g;
    gv_splat_adam adam;
    make(&g, &adam, 4, xyz);
    int added = -1;
    CHECK(gv_splat_fsgs_unpool(&g, &adam, 1.0, &added) == 0);
    CHECK(added == 6 && g.n == 10);
    int seen[4][4] = {{0}};
    for (int r = 4; r < 10; r++) {
        int found = 0;
        for (int s = 0; s < 4; s++)
            for (int d = s + 1; d < 4; d++) {
                float at[3];
                for (int a = 0; a < 3; a++) at[a] = 0.5f * (xyz[s][a] + xyz[d][a]);
                if (memcmp(at, g.means + 3 * r, sizeof at) == 0) {
                    check_new_row(&g, r, s, d, at); /* grown from the lower row s */
                    seen[s][d]++, found = 1;
                }
            }
        CHECK(found);
    }
    for (int s = 0; s < 4; s++)
        for (int d = s + 1; d < 4; d++) CHECK(seen[s][d] == 1);
    /* Rows 4..6 come from row 0 (three of its edges), then 1's two, then 2's one. */
    CHECK(g.opacities[4] == g.opacities[0] && g.opacities[6] == g.opacities[0]);
    CHECK(g.opacities[7] == g.opacities[1] && g.opacities[8] == g.opacities[1]);
    CHECK(g.opacities[9] == g.opacities[2]);
    gv_gaussians_free(&g);
    gv_splat_adam_free(&adam);
}

int main(void)
{
    test_neighbors();
    test_far_point();
    test_mutual_edges();
    return check_summary();
}
