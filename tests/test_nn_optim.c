/* AdamW against hand-computed steps, gradient clipping, learning-rate schedules, and a small
 * regression that the engine and AdamW must fit. */
#include <omp.h>

#include "check.h"
#include "nn_testutil.h"

static void test_adamw_by_hand(void)
{
    gv_params ps;
    gv_params_init(&ps);
    gv_tensor *p = gv_params_add(&ps, "p", 1, (int[]){2}, 1);
    gv_tensor *nd = gv_params_add(&ps, "no_decay", 1, (int[]){1}, 1);
    gv_tensor *fz = gv_params_add(&ps, "frozen", 1, (int[]){1}, 0);
    gv_params_find(&ps, "no_decay")->decay = 0;
    p->data[0] = 1.0f, p->data[1] = -2.0f, nd->data[0] = 1.0f, fz->data[0] = 3.0f;
    gv_adamw_config c = {0.9f, 0.999f, 1e-8f, 0.01f};
    /* step 1: m_hat = g, v_hat = g^2, so p1 = p0 (1 - lr wd) - lr g / (|g| + eps) */
    p->grad[0] = 0.5f, p->grad[1] = 3.0f, nd->grad[0] = 0.5f;
    CHECK(gv_adamw_step(&ps, &c, 0.1f) == 0 && ps.step == 1);
    CHECK_NEAR(p->data[0], 0.999 - 0.1, 1e-6);
    CHECK_NEAR(p->data[1], -2.0 * 0.999 - 0.1, 1e-6);
    CHECK_NEAR(nd->data[0], 1.0 - 0.1, 1e-6);
    CHECK(fz->data[0] == 3.0f);
    /* step 2 with g = -0.25: m = 0.02, v = 0.00031225, m_hat = 0.02 / 0.19,
     * v_hat = 0.00031225 / 0.001999; p2 = 0.899 * 0.999 - 0.1 * m_hat / sqrt(v_hat) */
    p->grad[0] = -0.25f;
    CHECK(gv_adamw_step(&ps, &c, 0.1f) == 0 && ps.step == 2);
    CHECK_NEAR(p->data[0], 0.8714673, 2e-6);
    double m = 0.9 * 0.05 - 0.1 * 0.25, v = 0.999 * 0.00025 + 0.001 * 0.0625;
    double expect = 0.899 * 0.999 - 0.1 * (m / 0.19) / (sqrt(v / (1 - 0.999 * 0.999)) + 1e-8);
    CHECK_NEAR(p->data[0], expect, 1e-6);
    CHECK_NEAR(gv_params_find(&ps, "p")->m[0], 0.02, 1e-8);
    CHECK_NEAR(gv_params_find(&ps, "p")->v[0], 0.00031225, 1e-8); /* float rounding */
    /* a non-finite gradient fails and changes nothing */
    float before = p->data[0];
    p->grad[1] = INFINITY;
    CHECK_FAILS_WITH(gv_adamw_step(&ps, &c, 0.1f), "p: gradient element 1");
    CHECK(p->data[0] == before && ps.step == 2);
    gv_params_free(&ps);
}

static void test_clip_and_schedule(void)
{
    gv_params ps;
    gv_params_init(&ps);
    gv_tensor *a = gv_params_add(&ps, "a", 1, (int[]){1}, 1), *b = gv_params_add(&ps, "b", 1, (int[]){1}, 1);
    gv_params_add(&ps, "frozen", 1, (int[]){1}, 0);
    a->grad[0] = 3.0f, b->grad[0] = 4.0f;
    CHECK_NEAR(gv_grad_norm(&ps), 5.0, 1e-12);
    CHECK_NEAR(gv_clip_grad_norm(&ps, 10.0), 5.0, 1e-12);
    CHECK(a->grad[0] == 3.0f && b->grad[0] == 4.0f);
    CHECK_NEAR(gv_clip_grad_norm(&ps, 1.0), 5.0, 1e-12);
    CHECK_NEAR(a->grad[0], 0.6, 1e-6);
    CHECK_NEAR(b->grad[0], 0.8, 1e-6);
    CHECK_NEAR(gv_grad_norm(&ps), 1.0, 1e-6);
    /* a long gradient summed in chunks */
    gv_tensor *big = gv_params_add(&ps, "big", 1, (int[]){200001}, 1);
    for (int i = 0; i < 200001; i++) big->grad[i] = 0.01f;
    CHECK_NEAR(gv_grad_norm(&ps), sqrt(1.0 + 200001 * (double)0.01f * 0.01f), 1e-6);
    gv_params_free(&ps);

    gv_lr_schedule s = {GV_LR_CONSTANT, 1e-3, 1e-5, 10, 110};
    CHECK_NEAR(gv_lr_at(&s, 0), 1e-4, 1e-12);
    CHECK_NEAR(gv_lr_at(&s, 4), 5e-4, 1e-12);
    CHECK_NEAR(gv_lr_at(&s, 9), 1e-3, 1e-12);
    CHECK_NEAR(gv_lr_at(&s, 500), 1e-3, 1e-12);
    s.kind = GV_LR_COSINE;
    CHECK_NEAR(gv_lr_at(&s, 10), 1e-3, 1e-12);
    CHECK_NEAR(gv_lr_at(&s, 60), (1e-3 + 1e-5) / 2, 1e-12);
    CHECK_NEAR(gv_lr_at(&s, 35), 1e-5 + 0.5 * (1e-3 - 1e-5) * (1 + cos(M_PI / 4)), 1e-12);
    CHECK_NEAR(gv_lr_at(&s, 110), 1e-5, 1e-12);
    CHECK_NEAR(gv_lr_at(&s, 1000), 1e-5, 1e-12);
    s.warmup_steps = 0;
    CHECK_NEAR(gv_lr_at(&s, 0), 1e-3, 1e-12);

    /* linear to 0 over S = 110 steps after 10 of warm-up: lr (S - s) / (S - 10) */
    gv_lr_schedule lin = {GV_LR_LINEAR, 1e-3, 0.0, 10, 110};
    CHECK_NEAR(gv_lr_at(&lin, 4), 5e-4, 1e-12);               /* the warm-up is unchanged */
    CHECK_NEAR(gv_lr_at(&lin, 10), 1e-3, 1e-12);
    CHECK_NEAR(gv_lr_at(&lin, 35), 7.5e-4, 1e-12);
    CHECK_NEAR(gv_lr_at(&lin, 60), 5e-4, 1e-12);
    CHECK_NEAR(gv_lr_at(&lin, 109), 1e-5, 1e-12);             /* the last step: 1/100 of the peak */
    CHECK(gv_lr_at(&lin, 110) == 0.0 && gv_lr_at(&lin, 500) == 0.0);
    lin.min_lr = 1e-4;
    CHECK_NEAR(gv_lr_at(&lin, 60), 1e-4 + 0.5 * 9e-4, 1e-12);
    /* cosine to 0, no warm-up, S = 4 (the values a 4-step run logs) */
    gv_lr_schedule cos4 = {GV_LR_COSINE, 1e-4, 0.0, 0, 4};
    CHECK_NEAR(gv_lr_at(&cos4, 0), 1e-4, 1e-15);
    CHECK_NEAR(gv_lr_at(&cos4, 1), 0.5e-4 * (1 + cos(M_PI / 4)), 1e-15);
    CHECK_NEAR(gv_lr_at(&cos4, 2), 0.5e-4, 1e-15);
    CHECK_NEAR(gv_lr_at(&cos4, 4), 0.0, 1e-20);
    /* names */
    gv_lr_kind k = GV_LR_CONSTANT;
    CHECK(gv_lr_kind_from_name("linear", &k) == 0 && k == GV_LR_LINEAR);
    CHECK(gv_lr_kind_from_name("cosine", &k) == 0 && k == GV_LR_COSINE);
    CHECK(gv_lr_kind_from_name("constant", &k) == 0 && k == GV_LR_CONSTANT);
    CHECK(!strcmp(gv_lr_kind_name(GV_LR_LINEAR), "linear"));
    CHECK_FAILS_WITH(gv_lr_kind_from_name("step", &k), "expected constant, cosine or linear");
}

/* y = x A^T + c from 64 samples; a linear layer trained with AdamW must recover A and c. */
static void test_fit(void)
{
    gv_params ps;
    gv_params_init(&ps);
    gv_tensor *w = gv_params_add(&ps, "w", 2, (int[]){3, 5}, 1), *b = gv_params_add(&ps, "b", 1, (int[]){3}, 1);
    gv_fill_normal(w->data, 15, 1, 0, 0, 0.1f);
    float A[15], cvec[3] = {0.5f, -1.0f, 2.0f};
    gv_fill_uniform(A, 15, 2, 0, -1, 1);
    gv_graph g;
    gv_graph_init(&g, 0);
    gv_adamw_config c = gv_adamw_defaults();
    c.weight_decay = 0;
    gv_lr_schedule s = {GV_LR_COSINE, 0.05, 0.001, 20, 600};
    float first = 0, last = 0;
    for (long step = 0; step < 600; step++) {
        gv_graph_reset(&g);
        gv_tensor *x = gv_tensor_new(&g, 2, (int[]){64, 5}), *y = gv_tensor_new(&g, 2, (int[]){64, 3});
        gv_fill_normal(x->data, 320, 3, (uint64_t)step * 320, 0, 1);
        for (int r = 0; r < 64; r++)
            for (int j = 0; j < 3; j++) {
                float acc = cvec[j];
                for (int i = 0; i < 5; i++) acc += A[j * 5 + i] * x->data[r * 5 + i];
                y->data[r * 3 + j] = acc;
            }
        gv_tensor *loss = gv_l2_loss(&g, gv_linear(&g, x, w, b), y, NULL);
        gv_params_zero_grad(&ps);
        if (!loss || gv_backward(&g, loss) != 0) break;
        gv_clip_grad_norm(&ps, 5.0);
        gv_adamw_step(&ps, &c, (float)gv_lr_at(&s, step));
        if (step == 0) first = loss->data[0];
        last = loss->data[0];
    }
    double werr = 0;
    for (int i = 0; i < 15; i++) werr = fmax(werr, fabs(w->data[i] - A[i]));
    for (int j = 0; j < 3; j++) werr = fmax(werr, fabs(b->data[j] - cvec[j]));
    printf("regression: loss %.4g -> %.3g, max parameter error %.2e\n", first, last, werr);
    CHECK(last < 1e-4 * first && werr < 1e-2);
    gv_graph_free(&g);
    gv_params_free(&ps);
}

int main(void)
{
    omp_set_num_threads(2);
    test_adamw_by_hand();
    test_clip_and_schedule();
    test_fit();
    return check_summary();
}
