/* The engine's core: arena, tape, no-grad mode, parameter registry, frozen parameters,
 * error propagation, and the RNG fills giving the same numbers with 1 and 2 threads. */
#include <omp.h>

#include "check.h"
#include "nn_testutil.h"

static void test_arena(void)
{
    gv_arena a;
    gv_arena_init(&a, 1000);
    char *p = gv_arena_alloc(&a, 10), *q = gv_arena_alloc(&a, 3000); /* second block */
    CHECK(p && q && ((uintptr_t)p % 64) == 0 && ((uintptr_t)q % 64) == 0);
    CHECK(a.n_blocks == 2 && a.in_use == 64 + 3008);
    memset(q, 7, 3000);
    gv_arena_mark m = gv_arena_get_mark(&a);
    char *r = gv_arena_alloc(&a, 100000);
    CHECK(r != NULL && a.peak >= a.in_use && a.in_use == 64 + 3008 + 100032);
    gv_arena_rewind(&a, m);
    CHECK(a.in_use == 64 + 3008 && q[2999] == 7);
    size_t capacity = gv_arena_capacity(&a);
    gv_arena_reset(&a); /* blocks folded into one of the same total size */
    CHECK(a.n_blocks == 1 && gv_arena_capacity(&a) == capacity && a.in_use == 0);
    CHECK(a.peak == 64 + 3008 + 100032);
    char *s = gv_arena_calloc(&a, 5000);
    CHECK(s && s[4999] == 0 && a.n_blocks == 1);
    a.limit = 8192;
    CHECK_FAILS_WITH(gv_arena_alloc(&a, 10000) ? 0 : -1, "would pass the limit");
    gv_arena_free(&a);
}

static void test_tape_and_no_grad(void)
{
    gv_params ps;
    gv_params_init(&ps);
    gv_tensor *w = nt_uniform(&ps, "w", 2, (int[]){3, 4}, 1, -1, 1);
    gv_tensor *frozen = gv_params_add(&ps, "frozen", 2, (int[]){3, 4}, 0);
    gv_fill_uniform(frozen->data, 12, 2, 0, -1, 1);
    CHECK(frozen->grad == NULL && !frozen->requires_grad && w->grad != NULL);
    gv_graph g;
    gv_graph_init(&g, 0);
    gv_tensor *x = gv_tensor_new(&g, 2, (int[]){2, 4});
    gv_fill_uniform(x->data, 8, 3, 0, -1, 1);
    /* loss = sum(x W^T) + sum(x F^T): dW[j, i] = sum_r x[r, i]; frozen gets nothing */
    gv_tensor *loss = gv_add(&g, gv_sum_all(&g, gv_linear(&g, x, w, NULL)),
                             gv_sum_all(&g, gv_linear(&g, x, frozen, NULL)));
    CHECK(loss && loss->requires_grad && g.n_tape > 0);
    int tape_before = g.n_tape;
    /* the frozen branch is not recorded: it needs no gradient */
    gv_tensor *only_frozen = gv_linear(&g, x, frozen, NULL);
    CHECK(only_frozen && !only_frozen->requires_grad && g.n_tape == tape_before);
    CHECK(gv_backward(&g, loss) == 0);
    for (int j = 0; j < 3; j++)
        for (int i = 0; i < 4; i++) CHECK_NEAR(w->grad[j * 4 + i], x->data[i] + x->data[4 + i], 1e-6);
    CHECK(frozen->grad == NULL);
    /* a second backward pass on a fresh graph accumulates into the parameter gradients */
    gv_graph_reset(&g);
    x = gv_tensor_new(&g, 2, (int[]){2, 4});
    for (int i = 0; i < 8; i++) x->data[i] = 1.0f;
    CHECK(gv_backward(&g, gv_sum_all(&g, gv_linear(&g, x, w, NULL))) == 0);
    gv_tensor *first = gv_tensor_new(&g, 1, (int[]){1}); /* recompute the first term's value */
    (void)first;
    gv_params_zero_grad(&ps);
    CHECK(w->grad[0] == 0.0f);
    /* no-grad mode: nothing recorded, outputs need no gradient, values are the same */
    gv_graph_reset(&g);
    x = gv_tensor_new(&g, 2, (int[]){2, 4});
    for (int i = 0; i < 8; i++) x->data[i] = (float)i;
    gv_tensor *with = gv_gelu(&g, gv_linear(&g, x, w, NULL));
    int previous = gv_graph_set_grad(&g, 0);
    gv_tensor *without = gv_gelu(&g, gv_linear(&g, x, w, NULL));
    CHECK(previous == 1 && g.n_tape == 2 && !without->requires_grad);
    CHECK(!memcmp(with->data, without->data, 6 * sizeof(float)));
    CHECK_FAILS_WITH(gv_backward(&g, gv_sum_all(&g, without)), "requires a gradient");
    gv_graph_set_grad(&g, 1);
    CHECK_FAILS_WITH(gv_backward(&g, with), "one element");
    /* errors propagate: NULL in, NULL out, first message kept */
    gv_clear_error();
    gv_tensor *bad = gv_add(&g, x, gv_tensor_new(&g, 1, (int[]){3}));
    gv_tensor *chain = gv_sum_all(&g, gv_gelu(&g, gv_scale(&g, bad, 2.0f)));
    CHECK(bad == NULL && chain == NULL && strstr(gv_last_error(), "do not broadcast"));
    CHECK_FAILS_WITH(gv_backward(&g, chain), "an op failed");
    gv_graph_free(&g);
    gv_params_free(&ps);
}

/* Inputs marked with gv_tensor_requires_grad get their gradient in the arena; a reshape
 * view shares data but not gradient. */
static void test_leaf_gradients(void)
{
    gv_graph g;
    gv_graph_init(&g, 0);
    gv_tensor *x = gv_tensor_new(&g, 2, (int[]){2, 3});
    for (int i = 0; i < 6; i++) x->data[i] = (float)(i + 1);
    gv_tensor_requires_grad(x);
    gv_tensor *v = gv_reshape(&g, x, 1, (int[]){6});
    gv_tensor *loss = gv_sum_all(&g, gv_mul(&g, v, v)); /* d/dx = 2x */
    CHECK(gv_backward(&g, loss) == 0 && x->grad != NULL);
    for (int i = 0; i < 6; i++) CHECK_NEAR(x->grad[i], 2.0 * (i + 1), 0);
    CHECK(loss->data[0] == 91.0f);
    /* detach: same values, no gradient through it */
    gv_tensor *dx = gv_detach(&g, x);
    CHECK(dx && dx->data == x->data && !dx->requires_grad && dx->op == GV_OP_LEAF);
    gv_tensor *both = gv_sum_all(&g, gv_mul(&g, x, dx)); /* d/dx = dx only, not 2x */
    for (int i = 0; i < 6; i++) x->grad[i] = 0;
    CHECK(gv_backward(&g, both) == 0);
    for (int i = 0; i < 6; i++) CHECK_NEAR(x->grad[i], i + 1, 0);
    /* A leaf living in a longer-lived graph gets a fresh gradient at every step of the graph
     * that differentiates it (no stale buffer from a reset arena, no accumulation). */
    gv_graph consts;
    gv_graph_init(&consts, 0);
    gv_tensor *c = gv_tensor_from(&consts, 1, (int[]){3}, (float[]){1, 2, 3});
    gv_tensor_requires_grad(c);
    for (int step = 1; step <= 3; step++) {
        gv_graph_reset(&g);
        gv_tensor *junk = gv_tensor_new(&g, 1, (int[]){64}); /* reuse the arena's memory */
        for (int i = 0; i < 64; i++) junk->data[i] = 1000.0f;
        CHECK(gv_backward(&g, gv_sum_all(&g, gv_scale(&g, c, (float)step))) == 0);
        CHECK(c->grad && c->grad[0] == (float)step && c->grad[2] == (float)step);
    }
    gv_graph_free(&consts);
    gv_graph_free(&g);
}

static void test_params(void)
{
    gv_params ps;
    gv_params_init(&ps);
    gv_tensor *a = gv_params_add(&ps, "blocks.0.self_attn.q.weight", 2, (int[]){4, 4}, 1);
    gv_tensor *b = gv_params_add(&ps, "blocks.0.self_attn.q.bias", 1, (int[]){4}, 0);
    CHECK(a && b && ps.n == 2 && !strcmp(a->name, "blocks.0.self_attn.q.weight"));
    CHECK(gv_params_find(&ps, "blocks.0.self_attn.q.bias") && &gv_params_find(&ps, "blocks.0.self_attn.q.bias")->t == b);
    CHECK(gv_params_find(&ps, "missing") == NULL && gv_params_of(&ps, a) == ps.items[0]);
    CHECK(gv_params_count(&ps, 0) == 20 && gv_params_count(&ps, 1) == 16);
    CHECK_FAILS_WITH(gv_params_add(&ps, "blocks.0.self_attn.q.bias", 1, (int[]){4}, 1) ? 0 : -1,
                     "registered twice");
    CHECK_FAILS_WITH(gv_params_add(&ps, "zero", 2, (int[]){4, 0}, 1) ? 0 : -1, "has size 0");
    CHECK_FAILS_WITH(gv_params_add(&ps, "", 1, (int[]){4}, 1) ? 0 : -1, "empty name");
    gv_param *pb = gv_params_find(&ps, "blocks.0.self_attn.q.bias");
    CHECK(pb->m == NULL && pb->v == NULL && b->grad == NULL);
    CHECK(gv_param_set_trainable(pb, 1) == 0 && b->grad && pb->m && pb->v && b->requires_grad);
    CHECK(gv_param_set_trainable(pb, 0) == 0 && !b->grad && !pb->m && !b->requires_grad);
    a->data[5] = NAN;
    CHECK_FAILS_WITH(gv_params_check_finite(&ps, 0), "blocks.0.self_attn.q.weight: value element 5");
    gv_params_free(&ps);
    CHECK(ps.n == 0 && ps.items == NULL);
}

/* The fills depend on (seed, position) only: same numbers with 1 and 2 threads, and an
 * offset continues the same stream. */
static void test_rng_threads(void)
{
    enum { N = 100003 }; /* above GV_OMP_MIN: the fills run on both threads */
    float *one = malloc(N * sizeof *one), *two = malloc(N * sizeof *two), *tail = malloc(N * sizeof *tail);
    omp_set_num_threads(1);
    gv_fill_normal(one, N, 42, 0, 0.5f, 2.0f);
    omp_set_num_threads(2);
    gv_fill_normal(two, N, 42, 0, 0.5f, 2.0f);
    CHECK(!memcmp(one, two, N * sizeof *one));
    gv_fill_normal(tail, N - 100, 42, 100, 0.5f, 2.0f);
    CHECK(!memcmp(one + 100, tail, (N - 100) * sizeof *one));
    double mean = 0, var = 0;
    for (int i = 0; i < N; i++) mean += one[i] / N;
    for (int i = 0; i < N; i++) var += (one[i] - mean) * (one[i] - mean) / N;
    CHECK(fabs(mean - 0.5) < 0.06 && fabs(sqrt(var) - 2.0) < 0.06);
    omp_set_num_threads(1);
    gv_fill_uniform(one, N, 7, 0, -3, 5);
    omp_set_num_threads(2);
    gv_fill_uniform(two, N, 7, 0, -3, 5);
    CHECK(!memcmp(one, two, N * sizeof *one));
    int inside = 1;
    for (int i = 0; i < N; i++) inside &= one[i] >= -3 && one[i] <= 5;
    CHECK(inside);
    CHECK(gv_seed_for_name(1, "a.weight") != gv_seed_for_name(1, "b.weight"));
    CHECK(gv_seed_for_name(1, "a.weight") != gv_seed_for_name(2, "a.weight"));
    CHECK(gv_seed_for_name(3, "a.weight") == gv_seed_for_name(3, "a.weight"));
    /* attention and a layer-norm weight gradient give identical results with 1 and 2 threads */
    float *res[2];
    for (int threads = 1; threads <= 2; threads++) {
        omp_set_num_threads(threads);
        gv_params ps;
        gv_params_init(&ps);
        gv_tensor *x = nt_normal(&ps, "x", 2, (int[]){1500, 48}, 5, 1.0f);
        gv_tensor *w = nt_normal(&ps, "w", 1, (int[]){48}, 6, 1.0f);
        gv_graph g;
        gv_graph_init(&g, 0);
        gv_tensor *h = gv_layer_norm(&g, x, w, NULL, 1e-6f);
        gv_tensor *y = gv_attention(&g, h, h, h, NULL, 1, 0.3f);
        gv_backward(&g, gv_sum_all(&g, gv_mul(&g, y, y)));
        res[threads - 1] = malloc(48 * sizeof(float));
        memcpy(res[threads - 1], w->grad, 48 * sizeof(float));
        gv_graph_free(&g);
        gv_params_free(&ps);
    }
    CHECK(!memcmp(res[0], res[1], 48 * sizeof(float)));
    free(res[0]), free(res[1]);
    free(one), free(two), free(tail);
}

/* A graph of many ops at sizes above GV_OMP_MIN (so their loops really run on 2 threads):
 * every gradient is bit-identical with 1 and 2 threads. A race in a parallel backward
 * (two threads adding into one element) would show here. */
static float *big_graph_gradients(int threads, int64_t *n_out)
{
    omp_set_num_threads(threads);
    gv_params ps;
    gv_params_init(&ps);
    gv_tensor *x = nt_normal(&ps, "x", 5, (int[]){2, 8, 6, 32, 32}, 11, 1.0f);
    gv_tensor *w = nt_normal(&ps, "w", 5, (int[]){8, 8, 3, 3, 3}, 12, 0.1f);
    gv_tensor *b = nt_normal(&ps, "b", 1, (int[]){8}, 13, 0.1f);
    gv_tensor *gamma = nt_normal(&ps, "gamma", 1, (int[]){8}, 14, 1.0f);
    gv_tensor *lw = nt_normal(&ps, "ln.w", 1, (int[]){32}, 15, 1.0f);
    gv_tensor *lb = nt_normal(&ps, "ln.b", 1, (int[]){32}, 16, 1.0f);
    gv_tensor *sc = nt_normal(&ps, "scale", 1, (int[]){32}, 17, 1.0f);
    gv_graph g;
    gv_graph_init(&g, 0);
    gv_conv_geom causal = gv_conv_geom_causal(1, 1, 1, 1, 1);
    gv_tensor *h = gv_silu(&g, gv_rms_norm_axis(&g, gv_conv3d(&g, x, w, b, &causal), gamma, 1, 1e-12f));
    gv_tensor *u = gv_upsample_nearest(&g, gv_pixel_unshuffle(&g, h, 1, 2, 2), 1, 2, 2); /* [2,32,6,32,32] */
    gv_tensor *t = gv_transpose(&g, gv_reshape(&g, u, 3, (int[]){2, 32, -1}), 1, 2);  /* [2,6144,32] */
    t = gv_slice(&g, t, 1, 0, 1024);
    gv_tensor *ln = gv_layer_norm(&g, t, lw, lb, 1e-6f);
    gv_tensor *q = gv_mul(&g, ln, sc);
    gv_tensor *table = gv_rope3d_table_grid(&g, 16, 8, 8, 8);
    gv_tensor *a = gv_attention(&g, gv_rope(&g, q, table, 4), gv_rope(&g, ln, table, 4), ln, NULL, 4, 0.35f);
    gv_tensor *c = gv_concat(&g, (gv_tensor *[]){gv_gelu(&g, gv_softmax(&g, a)), gv_repeat(&g, gv_slice(&g, a, 2, 0, 16), 2, 2)}, 2, 2);
    gv_tensor *target = gv_tensor_new(&g, 3, (int[]){2, 1024, 64});
    gv_tensor *weights = gv_tensor_from(&g, 1, (int[]){2}, (float[]){0.5f, 2.0f});
    gv_tensor *loss = gv_add(&g, gv_l2_loss(&g, c, target, weights), gv_mean_all(&g, gv_sum(&g, gv_mul(&g, t, t), 1, 0)));
    int ok = loss && gv_backward(&g, loss) == 0;
    int64_t n = 0;
    for (int i = 0; i < ps.n; i++) n += ps.items[i]->t.numel;
    float *all = malloc((size_t)(n + 1) * sizeof *all), *p = all;
    for (int i = 0; i < ps.n; i++, p += ps.items[i - 1]->t.numel)
        memcpy(p, ps.items[i]->t.grad, (size_t)ps.items[i]->t.numel * sizeof(float));
    all[n] = ok ? loss->data[0] : NAN;
    *n_out = n + 1;
    gv_graph_free(&g);
    gv_params_free(&ps);
    return all;
}

static void test_threads_same_gradients(void)
{
    int64_t n1, n2;
    float *one = big_graph_gradients(1, &n1), *two = big_graph_gradients(2, &n2);
    int64_t differ = 0;
    for (int64_t i = 0; i < n1 && n1 == n2; i++) differ += one[i] != two[i];
    printf("gradients with 1 and 2 threads: %lld of %lld values differ (loss %g)\n",
           (long long)differ, (long long)n1, one[n1 - 1]);
    CHECK(n1 == n2 && isfinite(one[n1 - 1]) && differ == 0);
    free(one), free(two);
    omp_set_num_threads(2);
}

int main(void)
{
    omp_set_num_threads(2);
    test_arena();
    test_tape_and_no_grad();
    test_leaf_gradients();
    test_params();
    test_rng_threads();
    test_threads_same_gradients();
    return check_summary();
}
