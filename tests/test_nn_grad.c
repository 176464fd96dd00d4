/* Gradient checks (central finite differences) and forward values of the element-wise,
 * reduction, shape, matrix, normalisation, activation and loss ops, on awkward shapes (sizes
 * that are not multiples of the SIMD width, broadcasting, -inf entries). */
#include <omp.h>

#include "check.h"
#include "nn_testutil.h"

typedef struct {
    gv_tensor *a, *b, *c, *d, *e;
    int mode, axis, flag;
} ctx_t;

/* ---- element-wise --------------------------------------------------------------------- */
static gv_tensor *build_binary(gv_graph *g, void *p)
{
    ctx_t *c = p;
    switch (c->mode) {
    case 0: return gv_add(g, c->a, c->b);
    case 1: return gv_sub(g, c->a, c->b);
    case 2: return gv_mul(g, c->a, c->b);
    case 3: return gv_div(g, c->a, c->b);
    default: return gv_affine(g, gv_mul(g, c->a, c->b), -1.5f, 0.25f);
    }
}

static void test_binary(void)
{
    static const char *names[] = {"add", "sub", "mul", "div", "mul+affine"};
    /* (shape a, shape b): broadcast of b over two axes; both broadcast; same shape. */
    int sa[3][3] = {{3, 5, 7}, {2, 1, 7}, {3, 5, 7}}, sb[3][3] = {{5, 1, 0}, {3, 1, 0}, {3, 5, 7}};
    int nb[3] = {2, 2, 3};
    for (int s = 0; s < 3; s++)
        for (int mode = 0; mode < 5; mode++) {
            gv_params ps;
            gv_params_init(&ps);
            ctx_t c = {0};
            c.mode = mode;
            c.a = nt_uniform(&ps, "a", 3, sa[s], 11, -1, 1);
            c.b = nt_uniform(&ps, "b", nb[s], sb[s], 12, 0.5f, 1.5f); /* away from 0 for div */
            char label[64];
            snprintf(label, sizeof label, "%s (shapes %d)", names[mode], s);
            nt_gradcheck(label, &ps, build_binary, &c, NULL);
            gv_params_free(&ps);
        }
    /* Forward values of a broadcast add: [2,1,3] + [2,1] -> [2,2,3]. */
    gv_graph g;
    gv_graph_init(&g, 0);
    float av[6] = {1, 2, 3, 4, 5, 6}, bv[2] = {10, 20};
    gv_tensor *a = gv_tensor_from(&g, 3, (int[]){2, 1, 3}, av), *b = gv_tensor_from(&g, 2, (int[]){2, 1}, bv);
    gv_tensor *y = gv_add(&g, a, b);
    float expect[12] = {11, 12, 13, 21, 22, 23, 14, 15, 16, 24, 25, 26};
    CHECK(y && y->ndim == 3 && y->shape[0] == 2 && y->shape[1] == 2 && y->shape[2] == 3);
    for (int i = 0; y && i < 12; i++) CHECK_NEAR(y->data[i], expect[i], 0);
    CHECK_FAILS_WITH(gv_add(&g, a, gv_tensor_new(&g, 1, (int[]){2})) ? 0 : -1, "do not broadcast");
    gv_graph_free(&g);
}

/* ---- reductions ----------------------------------------------------------------------- */
static gv_tensor *build_reduce(gv_graph *g, void *p)
{
    ctx_t *c = p;
    gv_tensor *x = gv_mul(g, c->a, c->a); /* nonlinear before, so the check sees the shape */
    switch (c->mode) {
    case 0: return gv_sum(g, x, c->axis, c->flag);
    case 1: return gv_mean(g, x, c->axis, c->flag);
    case 2: return gv_sum_all(g, x);
    default: return gv_mean_all(g, x);
    }
}

static void test_reduce(void)
{
    for (int mode = 0; mode < 4; mode++)
        for (int axis = -1; axis < 3; axis++) {
            if (mode >= 2 && axis != 0) continue;
            gv_params ps;
            gv_params_init(&ps);
            ctx_t c = {.mode = mode, .axis = axis, .flag = axis == 1};
            c.a = nt_uniform(&ps, "x", 3, (int[]){3, 5, 7}, 21, -1, 1);
            char label[64];
            snprintf(label, sizeof label, "%s axis %d", (const char *[]){"sum", "mean", "sum_all", "mean_all"}[mode], axis);
            nt_gradcheck(label, &ps, build_reduce, &c, NULL);
            gv_params_free(&ps);
        }
    gv_graph g;
    gv_graph_init(&g, 0);
    float v[6] = {1, 2, 3, 4, 5, 6};
    gv_tensor *x = gv_tensor_from(&g, 2, (int[]){2, 3}, v);
    gv_tensor *s0 = gv_sum(&g, x, 0, 0), *m1 = gv_mean(&g, x, 1, 1), *all = gv_sum_all(&g, x);
    CHECK(s0 && s0->ndim == 1 && s0->shape[0] == 3 && s0->data[0] == 5 && s0->data[2] == 9);
    CHECK(m1 && m1->ndim == 2 && m1->shape[1] == 1 && m1->data[0] == 2 && m1->data[1] == 5);
    CHECK(all && all->numel == 1 && all->data[0] == 21);
    /* A long sum is exact to float rounding (accumulated in double). */
    gv_tensor *big = gv_tensor_new(&g, 1, (int[]){100003});
    for (int i = 0; i < 100003; i++) big->data[i] = 0.1f;
    CHECK_NEAR(gv_sum_all(&g, big)->data[0], 100003 * (double)0.1f, 1e-3);
    CHECK_FAILS_WITH(gv_sum(&g, x, 2, 0) ? 0 : -1, "out of range");
    gv_graph_free(&g);
}

/* ---- shapes ------------------------------------------------------------------------- */
static gv_tensor *build_shape(gv_graph *g, void *p)
{
    ctx_t *c = p;
    gv_tensor *x = gv_mul(g, c->a, c->a);
    switch (c->mode) {
    case 0: return gv_reshape(g, x, 3, (int[]){4, -1, 3});
    case 1: return gv_permute(g, x, (int[]){3, 1, 0, 2});
    case 2: return gv_transpose(g, x, 1, -1);
    case 3: return gv_concat(g, (gv_tensor *[]){x, gv_silu(g, c->b), c->c}, 3, 1);
    case 4: return gv_slice(g, x, 2, 1, 3);
    default: return gv_repeat(g, x, 1, 3);
    }
}

static void test_shape(void)
{
    static const char *names[] = {"reshape", "permute", "transpose", "concat", "slice", "repeat"};
    for (int mode = 0; mode < 6; mode++) {
        gv_params ps;
        gv_params_init(&ps);
        ctx_t c = {.mode = mode};
        c.a = nt_uniform(&ps, "a", 4, (int[]){2, 3, 4, 5}, 31, -1, 1);
        c.b = nt_uniform(&ps, "b", 4, (int[]){2, 1, 4, 5}, 32, -1, 1);
        c.c = nt_uniform(&ps, "c", 4, (int[]){2, 2, 4, 5}, 33, -1, 1);
        nt_gradcheck(names[mode], &ps, build_shape, &c, NULL);
        gv_params_free(&ps);
    }
    gv_graph g;
    gv_graph_init(&g, 0);
    float v[6] = {0, 1, 2, 3, 4, 5};
    gv_tensor *x = gv_tensor_from(&g, 2, (int[]){2, 3}, v);
    gv_tensor *t = gv_transpose(&g, x, 0, 1);
    float tv[6] = {0, 3, 1, 4, 2, 5};
    for (int i = 0; i < 6; i++) CHECK(t->data[i] == tv[i]);
    gv_tensor *cat = gv_concat(&g, (gv_tensor *[]){x, x}, 2, 1);
    float cv[12] = {0, 1, 2, 0, 1, 2, 3, 4, 5, 3, 4, 5};
    for (int i = 0; i < 12; i++) CHECK(cat->data[i] == cv[i]);
    gv_tensor *rep = gv_repeat(&g, x, 0, 2);
    for (int i = 0; i < 12; i++) CHECK(rep->data[i] == v[i % 6]);
    gv_tensor *sl = gv_slice(&g, x, 1, 1, 2);
    CHECK(sl->data[0] == 1 && sl->data[1] == 2 && sl->data[2] == 4 && sl->data[3] == 5);
    gv_tensor *r = gv_reshape(&g, x, 1, (int[]){-1});
    CHECK(r && r->shape[0] == 6 && r->data == x->data); /* a view */
    CHECK_FAILS_WITH(gv_reshape(&g, x, 2, (int[]){4, -1}) ? 0 : -1, "does not split");
    CHECK_FAILS_WITH(gv_slice(&g, x, 1, 2, 2) ? 0 : -1, "is not inside");
    CHECK_FAILS_WITH(gv_permute(&g, x, (int[]){0, 0}) ? 0 : -1, "not a permutation");
    CHECK_FAILS_WITH(gv_concat(&g, (gv_tensor *[]){x, t}, 2, 0) ? 0 : -1, "only axis 0 may differ");
    gv_graph_free(&g);
}

/* ---- matmul and linear ------------------------------------------------------------------ */
static gv_tensor *build_matmul(gv_graph *g, void *p)
{
    ctx_t *c = p;
    if (c->mode == 4) return gv_linear(g, c->a, c->b, c->c);
    return gv_matmul(g, c->a, c->b, c->mode & 1, c->mode >> 1 & 1);
}

/* Reference op(A) op(B) in double for one batch. */
static void naive_matmul(const float *A, const float *B, int M, int N, int K, int ta, int tb, double *C)
{
    for (int i = 0; i < M; i++)
        for (int j = 0; j < N; j++) {
            double s = 0;
            for (int k = 0; k < K; k++)
                s += (double)(ta ? A[k * M + i] : A[i * K + k]) * (tb ? B[j * K + k] : B[k * N + j]);
            C[i * N + j] = s;
        }
}

static void test_matmul(void)
{
    const int M = 5, K = 7, N = 3;
    for (int shared = 0; shared < 2; shared++)
        for (int mode = 0; mode < 4; mode++) {
            int ta = mode & 1, tb = mode >> 1 & 1;
            gv_params ps;
            gv_params_init(&ps);
            ctx_t c = {.mode = mode};
            c.a = nt_uniform(&ps, "a", 4, (int[]){2, 3, ta ? K : M, ta ? M : K}, 41, -1, 1);
            if (shared) c.b = nt_uniform(&ps, "b", 2, (int[]){tb ? N : K, tb ? K : N}, 42, -1, 1);
            else c.b = nt_uniform(&ps, "b", 4, (int[]){2, 3, tb ? N : K, tb ? K : N}, 42, -1, 1);
            char label[64];
            snprintf(label, sizeof label, "matmul ta %d tb %d%s", ta, tb, shared ? " shared b" : "");
            nt_gradcheck(label, &ps, build_matmul, &c, NULL);
            /* forward against the naive product */
            gv_graph g;
            gv_graph_init(&g, 0);
            gv_tensor *y = gv_matmul(&g, c.a, c.b, ta, tb);
            double ref[M * N], worst = 0;
            for (int b = 0; b < 6; b++) {
                naive_matmul(c.a->data + b * M * K, c.b->data + (shared ? 0 : b * K * N), M, N, K, ta, tb, ref);
                double d = nt_max_diff(y->data + b * M * N, ref, M * N);
                worst = d > worst ? d : worst;
            }
            CHECK(worst < 1e-5);
            gv_graph_free(&g);
            gv_params_free(&ps);
        }
    /* linear with bias, without bias, and with a frozen weight */
    for (int variant = 0; variant < 3; variant++) {
        gv_params ps;
        gv_params_init(&ps);
        ctx_t c = {.mode = 4};
        c.a = nt_uniform(&ps, "x", 3, (int[]){2, 5, 7}, 43, -1, 1);
        c.b = nt_uniform(&ps, "w", 2, (int[]){9, 7}, 44, -1, 1);
        if (variant != 1) c.c = nt_uniform(&ps, "bias", 1, (int[]){9}, 45, -1, 1);
        if (variant == 2) gv_param_set_trainable(gv_params_find(&ps, "w"), 0);
        nt_gradcheck((const char *[]){"linear", "linear no bias", "linear frozen weight"}[variant], &ps,
                     build_matmul, &c, NULL);
        if (variant == 2) CHECK(c.b->grad == NULL); /* no buffer, no work */
        gv_graph g;
        gv_graph_init(&g, 0);
        gv_tensor *y = gv_linear(&g, c.a, c.b, c.c);
        double ref[10 * 9];
        naive_matmul(c.a->data, c.b->data, 10, 9, 7, 0, 1, ref);
        for (int i = 0; i < 90 && c.c; i++) ref[i] += c.c->data[i % 9];
        CHECK(nt_max_diff(y->data, ref, 90) < 1e-5);
        CHECK_FAILS_WITH(gv_linear(&g, c.b, c.a, NULL) ? 0 : -1, "does not match weight");
        gv_graph_free(&g);
        gv_params_free(&ps);
    }
}

/* LoRA: frozen base weight (no gradient buffer), gradients for x, A and B; merging gives the
 * same layer as the adapter. */
static gv_tensor *build_lora(gv_graph *g, void *p)
{
    ctx_t *c = p;
    return gv_lora_linear(g, c->a, c->b, c->c, c->d, (gv_tensor *)c->e, 0.7f);
}

static void test_lora(void)
{
    gv_params ps;
    gv_params_init(&ps);
    ctx_t c = {0};
    c.a = nt_uniform(&ps, "x", 2, (int[]){6, 11}, 46, -1, 1);
    c.b = gv_params_add(&ps, "w", 2, (int[]){9, 11}, 0);
    gv_fill_uniform(c.b->data, c.b->numel, 47, 0, -1, 1);
    c.c = gv_params_add(&ps, "bias", 1, (int[]){9}, 0);
    gv_fill_uniform(c.c->data, 9, 48, 0, -1, 1);
    c.d = nt_uniform(&ps, "lora_A", 2, (int[]){3, 11}, 49, -1, 1);
    c.e = nt_uniform(&ps, "lora_B", 2, (int[]){9, 3}, 50, -1, 1);
    nt_gradcheck("lora linear (frozen base)", &ps, build_lora, &c, NULL);
    CHECK(c.b->grad == NULL && c.c->grad == NULL);
    gv_graph g;
    gv_graph_init(&g, 0);
    gv_tensor *y = build_lora(&g, &c);
    CHECK(gv_lora_merge(c.b, c.d, c.e, 0.7f) == 0);
    gv_tensor *merged = gv_linear(&g, c.a, c.b, c.c);
    double worst = 0;
    for (int i = 0; i < 54; i++) worst = fmax(worst, fabs(y->data[i] - merged->data[i]));
    CHECK(worst < 1e-5);
    CHECK_FAILS_WITH(gv_lora_linear(&g, c.a, c.b, NULL, c.e, c.d, 1.0f) ? 0 : -1, "do not fit weight");
    gv_graph_free(&g);
    gv_params_free(&ps);
}

/* ---- normalisation ---------------------------------------------------------------------- */
static gv_tensor *build_norm(gv_graph *g, void *p)
{
    ctx_t *c = p;
    switch (c->mode) {
    case 0: return gv_layer_norm(g, c->a, c->b, c->c, 1e-5f);
    case 1: return gv_layer_norm(g, c->a, NULL, NULL, 1e-6f);
    case 2: return gv_rms_norm(g, c->a, c->b, 1e-6f);
    case 3: return gv_rms_norm(g, c->a, NULL, 1e-6f);
    case 4: return gv_rms_norm_axis(g, c->a, c->b, 1, 1e-12f);
    default: return gv_rms_norm_axis(g, c->a, c->b, 1, 10.0f); /* clamped: norm below floor */
    }
}

static void test_norm(void)
{
    static const char *names[] = {"layer_norm affine", "layer_norm plain", "rms_norm weight",
                                  "rms_norm plain", "rms_norm_axis (VAE)", "rms_norm_axis clamped"};
    for (int mode = 0; mode < 6; mode++) {
        gv_params ps;
        gv_params_init(&ps);
        ctx_t c = {.mode = mode};
        if (mode < 4) {
            c.a = nt_uniform(&ps, "x", 3, (int[]){3, 4, 37}, 51, -2, 2);
            c.b = nt_uniform(&ps, "w", 1, (int[]){37}, 52, 0.5f, 1.5f);
            c.c = nt_uniform(&ps, "b", 1, (int[]){37}, 53, -1, 1);
        } else {
            float range = mode == 5 ? 0.1f : 2.0f;
            c.a = nt_uniform(&ps, "x", 4, (int[]){2, 6, 3, 67}, 54, -range, range); /* [B, C, H, W] */
            c.b = nt_uniform(&ps, "gamma", 1, (int[]){6}, 55, 0.5f, 1.5f);
        }
        gv_gradcheck_opts o = gv_gradcheck_defaults();
        o.h = 1e-3; /* the normalisations are strongly curved for small rows */
        nt_gradcheck(names[mode], &ps, build_norm, &c, &o);
        /* forward against a double computation */
        gv_graph g;
        gv_graph_init(&g, 0);
        gv_tensor *y = build_norm(&g, &c);
        double worst = 0;
        if (mode < 4) {
            for (int r = 0; r < 12; r++) {
                const float *x = c.a->data + r * 37;
                double mean = 0, ms = 0, var = 0;
                for (int i = 0; i < 37; i++) mean += x[i] / 37.0, ms += (double)x[i] * x[i] / 37.0;
                for (int i = 0; i < 37; i++) var += (x[i] - mean) * (x[i] - mean) / 37.0;
                for (int i = 0; i < 37; i++) {
                    double ref = mode < 2 ? (x[i] - mean) / sqrt(var + (mode == 0 ? 1e-5 : 1e-6))
                                          : x[i] / sqrt(ms + 1e-6);
                    if (mode == 0) ref = ref * c.b->data[i] + c.c->data[i];
                    if (mode == 2) ref *= c.b->data[i];
                    double d = fabs(ref - y->data[r * 37 + i]);
                    worst = d > worst ? d : worst;
                }
            }
        } else {
            for (int b = 0; b < 2; b++)
                for (int pos = 0; pos < 3 * 67; pos++) {
                    double n2 = 0;
                    for (int ch = 0; ch < 6; ch++) {
                        double v = c.a->data[(b * 6 + ch) * 201 + pos];
                        n2 += v * v;
                    }
                    double den = sqrt(n2) > (mode == 5 ? 10.0 : 1e-12) ? sqrt(n2) : (mode == 5 ? 10.0 : 1e-12);
                    for (int ch = 0; ch < 6; ch++) {
                        int64_t i = (b * 6 + ch) * 201 + pos;
                        double ref = c.a->data[i] / den * sqrt(6.0) * c.b->data[ch];
                        double d = fabs(ref - y->data[i]);
                        worst = d > worst ? d : worst;
                    }
                }
        }
        CHECK(worst < 2e-6);
        gv_graph_free(&g);
        gv_params_free(&ps);
    }
}

/* ---- activations ------------------------------------------------------------------------ */
static gv_tensor *build_activation(gv_graph *g, void *p)
{
    ctx_t *c = p;
    switch (c->mode) {
    case 0: return gv_gelu(g, c->a);
    case 1: return gv_silu(g, c->a);
    case 2: return gv_sigmoid(g, c->a);
    case 3: return gv_softmax(g, c->a);
    default: return gv_softmax(g, gv_add(g, c->a, c->d)); /* with a mask of -inf entries */
    }
}

static void test_activation(void)
{
    static const char *names[] = {"gelu", "silu", "sigmoid", "softmax", "softmax -inf mask"};
    for (int mode = 0; mode < 5; mode++) {
        gv_params ps;
        gv_params_init(&ps);
        ctx_t c = {.mode = mode};
        c.a = nt_uniform(&ps, "x", 3, (int[]){2, 3, 19}, 61, -4, 4);
        gv_graph mg;
        gv_graph_init(&mg, 0);
        c.d = gv_tensor_new(&mg, 2, (int[]){3, 19});
        for (int i = 0; i < 3 * 19; i++) /* row 0 partly masked, row 2 fully masked */
            c.d->data[i] = (i < 19 && i % 3 == 0) || i >= 38 ? -INFINITY : 0.0f;
        nt_gradcheck(names[mode], &ps, build_activation, &c, NULL);
        gv_graph g;
        gv_graph_init(&g, 0);
        gv_tensor *y = build_activation(&g, &c);
        double worst = 0;
        for (int i = 0; i < 2 * 3 * 19; i++) {
            double x = c.a->data[i], ref;
            if (mode == 0) ref = 0.5 * x * (1 + tanh(sqrt(2 / M_PI) * (x + 0.044715 * x * x * x)));
            else if (mode == 1) ref = x / (1 + exp(-x));
            else if (mode == 2) ref = 1 / (1 + exp(-x));
            else {
                int row = i / 19, r3 = row % 3;
                double max = -INFINITY, sum = 0;
                for (int j = 0; j < 19; j++) {
                    double m = mode == 4 ? c.d->data[r3 * 19 + j] : 0;
                    if (c.a->data[row * 19 + j] + m > max) max = c.a->data[row * 19 + j] + m;
                }
                for (int j = 0; j < 19; j++) {
                    double m = mode == 4 ? c.d->data[r3 * 19 + j] : 0;
                    sum += exp(c.a->data[row * 19 + j] + m - max);
                }
                double m = mode == 4 ? c.d->data[i % 57] : 0;
                ref = max == -INFINITY ? 0 : exp(x + m - max) / sum;
            }
            double d = fabs(ref - y->data[i]);
            worst = d > worst ? d : worst;
        }
        printf("%s forward max |err| %.2e\n", names[mode], worst);
        CHECK(worst < 1e-6);
        gv_graph_free(&g);
        gv_graph_free(&mg);
        gv_params_free(&ps);
    }
    /* exp at the edges: exactly 0 for -inf, inf for +inf, exact at 0 */
    gv_graph g;
    gv_graph_init(&g, 0);
    float v[4] = {-INFINITY, -100.0f, 0.0f, 100.0f};
    gv_tensor *s = gv_sigmoid(&g, gv_tensor_from(&g, 1, (int[]){4}, v));
    CHECK(s->data[0] == 0.0f && s->data[1] == 0.0f && s->data[2] == 0.5f && s->data[3] == 1.0f);
    gv_graph_free(&g);
}

/* ---- losses ------------------------------------------------------------------------------- */
static gv_tensor *build_loss(gv_graph *g, void *p)
{
    ctx_t *c = p;
    return c->mode ? gv_l2_loss(g, c->a, c->b, c->d) : gv_l1_loss(g, c->a, c->b, c->d);
}

static void test_loss(void)
{
    for (int mode = 0; mode < 2; mode++) {
        gv_params ps;
        gv_params_init(&ps);
        ctx_t c = {.mode = mode};
        c.a = nt_uniform(&ps, "pred", 3, (int[]){3, 4, 5}, 71, -1, 1);
        c.b = nt_uniform(&ps, "target", 3, (int[]){3, 4, 5}, 72, -1, 1);
        for (int i = 0; i < 60; i++) /* keep |pred - target| > 0.1 so L1 has no kink nearby */
            if (fabsf(c.a->data[i] - c.b->data[i]) < 0.1f) c.a->data[i] = c.b->data[i] + 0.3f;
        gv_graph wg;
        gv_graph_init(&wg, 0);
        c.d = gv_tensor_from(&wg, 1, (int[]){3}, (float[]){0.5f, 1.0f, 2.0f});
        nt_gradcheck(mode ? "l2_loss weighted" : "l1_loss weighted", &ps, build_loss, &c, NULL);
        /* value against a direct sum */
        gv_graph g;
        gv_graph_init(&g, 0);
        gv_tensor *l = build_loss(&g, &c);
        double ref = 0;
        for (int i = 0; i < 60; i++) {
            double d = (double)c.a->data[i] - c.b->data[i];
            ref += c.d->data[i / 20] * (mode ? d * d : fabs(d));
        }
        CHECK_NEAR(l->data[0], ref / 60, 1e-6);
        CHECK_FAILS_WITH(gv_l1_loss(&g, c.a, gv_tensor_new(&g, 2, (int[]){3, 20}), NULL) ? 0 : -1,
                         "differ");
        CHECK_FAILS_WITH(gv_l2_loss(&g, c.a, c.b, gv_tensor_new(&g, 1, (int[]){4})) ? 0 : -1,
                         "4 weights for 3 samples");
        gv_graph_free(&g);
        gv_graph_free(&wg);
        gv_params_free(&ps);
    }
}

int main(void)
{
    omp_set_num_threads(2);
    test_binary();
    test_reduce();
    test_shape();
    test_matmul();
    test_lora();
    test_norm();
    test_activation();
    test_loss();
    return check_summary();
}
