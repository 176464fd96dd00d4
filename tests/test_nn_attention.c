/* Attention against a naive double-precision computation and finite differences (masks with
 * -inf entries, rows that see no key, query blocks that straddle the 64-row block, both
 * backward schedules), and Wan's 3D RoPE table and rotation. */
#include <omp.h>

#include "check.h"
#include "nn_testutil.h"

typedef struct {
    gv_tensor *q, *k, *v, *mask, *table;
    int heads;
    float scale;
} attn_ctx;

static gv_tensor *build_attention(gv_graph *g, void *p)
{
    attn_ctx *c = p;
    return gv_attention(g, c->q, c->k, c->v, c->mask, c->heads, c->scale);
}

/* out [B, Nq, H*Dv] by the definition, in double. */
static void naive_attention(const attn_ctx *c, int B, int Nq, int Nk, int Dk, int Dv, double *out)
{
    int H = c->heads;
    double *s = malloc((size_t)Nk * sizeof *s);
    for (int b = 0; b < B; b++)
        for (int h = 0; h < H; h++)
            for (int i = 0; i < Nq; i++) {
                double max = -INFINITY, sum = 0;
                for (int j = 0; j < Nk; j++) {
                    double dot = 0;
                    for (int d = 0; d < Dk; d++)
                        dot += (double)c->q->data[((int64_t)b * Nq + i) * H * Dk + h * Dk + d] *
                               c->k->data[((int64_t)b * Nk + j) * H * Dk + h * Dk + d];
                    s[j] = c->scale * dot + (c->mask ? c->mask->data[(int64_t)i * Nk + j] : 0.0);
                    if (s[j] > max) max = s[j];
                }
                for (int j = 0; j < Nk; j++) sum += max == -INFINITY ? 0 : exp(s[j] - max);
                for (int d = 0; d < Dv; d++) {
                    double o = 0;
                    for (int j = 0; j < Nk && max > -INFINITY; j++)
                        o += exp(s[j] - max) / sum * c->v->data[((int64_t)b * Nk + j) * H * Dv + h * Dv + d];
                    out[((int64_t)b * Nq + i) * H * Dv + h * Dv + d] = o;
                }
            }
    free(s);
}

/* mask_kind 0: none; 1: video queries (first half) see every key, the others only the last
 * `block` keys, plus scattered -inf entries and one row that sees nothing. */
static void attention_case(const char *label, int B, int H, int Nq, int Nk, int Dk, int Dv,
                           int mask_kind, int batch_dims)
{
    gv_params ps;
    gv_params_init(&ps);
    gv_graph mg;
    gv_graph_init(&mg, 0);
    attn_ctx c = {.heads = H, .scale = 1.0f / sqrtf((float)Dk)};
    if (batch_dims) {
        c.q = nt_uniform(&ps, "q", 3, (int[]){B, Nq, H * Dk}, 101, -1, 1);
        c.k = nt_uniform(&ps, "k", 3, (int[]){B, Nk, H * Dk}, 102, -1, 1);
        c.v = nt_uniform(&ps, "v", 3, (int[]){B, Nk, H * Dv}, 103, -1, 1);
    } else {
        c.q = nt_uniform(&ps, "q", 2, (int[]){Nq, H * Dk}, 101, -1, 1);
        c.k = nt_uniform(&ps, "k", 2, (int[]){Nk, H * Dk}, 102, -1, 1);
        c.v = nt_uniform(&ps, "v", 2, (int[]){Nk, H * Dv}, 103, -1, 1);
    }
    if (mask_kind) {
        c.mask = gv_tensor_new(&mg, 2, (int[]){Nq, Nk});
        int block = Nk / 3 + 1;
        for (int i = 0; i < Nq; i++)
            for (int j = 0; j < Nk; j++) {
                float m = (i >= Nq / 2 && j < Nk - block) ? -INFINITY : 0.0f;
                if ((i * 7 + j * 3) % 11 == 0 && j != Nk - 1) m = -INFINITY;
                if (i == 3) m = -INFINITY; /* attends to nothing: output 0 */
                if (i == 5 && j == 2) m = 0.75f; /* a finite bias */
                c.mask->data[(int64_t)i * Nk + j] = m;
            }
    }
    gv_graph g;
    gv_graph_init(&g, 0);
    gv_tensor *y = build_attention(&g, &c);
    int64_t n = (int64_t)B * Nq * H * Dv;
    double *ref = malloc((size_t)n * sizeof *ref);
    naive_attention(&c, B, Nq, Nk, Dk, Dv, ref);
    double err = y ? nt_max_diff(y->data, ref, n) : 1;
    printf("attention %-28s forward max |err| %.2e\n", label, err);
    CHECK(err < 2e-6);
    if (mask_kind) {
        int zero = 1;
        for (int b = 0; b < B; b++)
            for (int j = 0; j < H * Dv; j++) zero &= y->data[((int64_t)b * Nq + 3) * H * Dv + j] == 0.0f;
        CHECK(zero);
    }
    free(ref);
    gv_graph_free(&g);
    nt_gradcheck(label, &ps, build_attention, &c, NULL);
    gv_graph_free(&mg);
    gv_params_free(&ps);
}

static void test_attention(void)
{
    /* Query blocks hold up to 256 rows here (few keys): 300 rows are a full and a partial
     * block. B*H >= 8: one (batch, head) pair per thread. The sizes keep these checks below
     * GV_OMP_MIN (fast on a busy machine); test_nn_core runs both schedules on 2 threads at
     * larger sizes and compares them bit for bit with 1 thread. */
    attention_case("B2 H4 300x6 masked", 2, 4, 300, 6, 5, 4, 1, 1);
    /* B*H < 8: the query blocks of a pair split in groups with private dK/dV partials. */
    attention_case("B2 H3 300x7 masked", 2, 3, 300, 7, 5, 4, 1, 1);
    attention_case("B1 H1 600x9 masked", 1, 1, 600, 9, 6, 3, 1, 1);
    /* no mask, no batch axis, queries and keys of different counts */
    attention_case("H2 9x21 unmasked 2-D", 1, 2, 9, 21, 7, 5, 0, 0);

    gv_graph g;
    gv_graph_init(&g, 0);
    gv_tensor *q = gv_tensor_new(&g, 2, (int[]){4, 6}), *k = gv_tensor_new(&g, 2, (int[]){5, 6});
    gv_tensor *m = gv_tensor_new(&g, 2, (int[]){5, 4});
    CHECK_FAILS_WITH(gv_attention(&g, q, k, k, NULL, 4, 1.0f) ? 0 : -1, "do not fit 4 heads");
    CHECK_FAILS_WITH(gv_attention(&g, q, k, k, m, 2, 1.0f) ? 0 : -1, "is not [4, 5]");
    gv_graph_free(&g);
}

/* ---- RoPE ------------------------------------------------------------------------------ */
static gv_tensor *build_rope(gv_graph *g, void *p)
{
    attn_ctx *c = p;
    return gv_rope(g, c->q, c->table, c->heads);
}

static void test_rope(void)
{
    gv_graph g;
    gv_graph_init(&g, 0);
    /* head_dim 12: 2 frame pairs, 2 row pairs, 2 column pairs; axis dim 4 each, so the
     * frequencies are 1 and 10000^(-2/4) = 0.01. */
    int pos[6] = {0, 0, 0, 3, 5, 7};
    gv_tensor *t = gv_rope3d_table(&g, pos, 2, 12);
    double angles[6] = {3, 0.03, 5, 0.05, 7, 0.07};
    for (int j = 0; j < 6; j++) {
        CHECK_NEAR(t->data[j * 2], 1.0, 0);
        CHECK_NEAR(t->data[j * 2 + 1], 0.0, 0);
        CHECK_NEAR(t->data[12 + j * 2], cos(angles[j]), 1e-7);
        CHECK_NEAR(t->data[12 + j * 2 + 1], sin(angles[j]), 1e-7);
    }
    /* Wan's head_dim 128: pairs 0-21 frame (base 44), 22-42 height, 43-63 width (base 42). */
    int pos128[9] = {1, 0, 0, 0, 1, 0, 0, 0, 1};
    gv_tensor *w = gv_rope3d_table(&g, pos128, 3, 128);
    int frame_ok = 1, height_ok = 1, width_ok = 1;
    for (int j = 0; j < 64; j++) {
        double fa = j < 22 ? pow(10000.0, -2.0 * j / 44) : 0;
        double ha = j >= 22 && j < 43 ? pow(10000.0, -2.0 * (j - 22) / 42) : 0;
        double wa = j >= 43 ? pow(10000.0, -2.0 * (j - 43) / 42) : 0;
        frame_ok &= fabs(w->data[j * 2] - cos(fa)) < 1e-7 && fabs(w->data[j * 2 + 1] - sin(fa)) < 1e-7;
        height_ok &= fabs(w->data[128 + j * 2] - cos(ha)) < 1e-7 && fabs(w->data[128 + j * 2 + 1] - sin(ha)) < 1e-7;
        width_ok &= fabs(w->data[256 + j * 2] - cos(wa)) < 1e-7 && fabs(w->data[256 + j * 2 + 1] - sin(wa)) < 1e-7;
    }
    CHECK(frame_ok && height_ok && width_ok);
    /* the grid table enumerates frame, then row, then column */
    gv_tensor *grid = gv_rope3d_table_grid(&g, 2, 3, 4, 12);
    int pos_last[3] = {1, 2, 3};
    gv_tensor *last = gv_rope3d_table(&g, pos_last, 1, 12);
    CHECK(grid && grid->shape[0] == 24 && !memcmp(grid->data + 23 * 12, last->data, 12 * sizeof(float)));
    CHECK_FAILS_WITH(gv_rope3d_table(&g, pos, 2, 7) ? 0 : -1, "must be even");
    gv_graph_free(&g);

    /* rotation: forward by hand, pair norms preserved, gradient */
    gv_params ps;
    gv_params_init(&ps);
    gv_graph tg;
    gv_graph_init(&tg, 0);
    attn_ctx c = {.heads = 2};
    c.q = nt_uniform(&ps, "x", 3, (int[]){2, 6, 24}, 111, -1, 1);
    int gpos[18];
    for (int i = 0; i < 6; i++) gpos[3 * i] = i / 3, gpos[3 * i + 1] = i % 3, gpos[3 * i + 2] = (i * 5) % 4;
    c.table = gv_rope3d_table(&tg, gpos, 6, 12);
    gv_graph fg;
    gv_graph_init(&fg, 0);
    gv_tensor *y = build_rope(&fg, &c);
    double worst = 0, norm_err = 0;
    for (int b = 0; b < 2; b++)
        for (int n = 0; n < 6; n++)
            for (int h = 0; h < 2; h++)
                for (int j = 0; j < 6; j++) {
                    int64_t i = ((b * 6 + n) * 2 + h) * 12 + 2 * j;
                    double co = c.table->data[(n * 6 + j) * 2], si = c.table->data[(n * 6 + j) * 2 + 1];
                    double a = c.q->data[i], bb = c.q->data[i + 1];
                    double r0 = a * co - bb * si, r1 = a * si + bb * co;
                    worst = fmax(worst, fmax(fabs(r0 - y->data[i]), fabs(r1 - y->data[i + 1])));
                    norm_err = fmax(norm_err, fabs(hypot(a, bb) - hypot(y->data[i], y->data[i + 1])));
                }
    CHECK(worst < 1e-6 && norm_err < 1e-6);
    nt_gradcheck("rope 3d", &ps, build_rope, &c, NULL);
    gv_graph_free(&fg);
    gv_graph_free(&tg);
    gv_params_free(&ps);
}

int main(void)
{
    omp_set_num_threads(2);
    test_attention();
    test_rope();
    return check_summary();
}
