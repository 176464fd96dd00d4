/* Training schedules (include/gaussvid/train/train.h) on hand-derived values: the flow-matching
 * path and target, the shift, the reference's pretraining grid and weights, the progressive latent
 * weight, the curriculum's difficulty, threshold, soft weight and batch choice, and the data
 * order's permutations, and a step's draws. */
#include <string.h>

#include "check.h"
#include "gaussvid/core/core.h"
#include "gaussvid/train/train.h"
#include "train/train_internal.h"

static void test_flow(void)
{
    const float z[3] = {1.0f, 2.0f, -4.0f}, eps[3] = {3.0f, -1.0f, 0.5f};
    float x[3], v[3];
    gv_flow_noisy(z, eps, 0.25f, 3, x);
    CHECK_NEAR(x[0], 1.5, 1e-7);   /* 0.75 * 1 + 0.25 * 3 */
    CHECK_NEAR(x[1], 1.25, 1e-7);  /* 0.75 * 2 - 0.25 */
    CHECK_NEAR(x[2], -2.875, 1e-7);/* -3 + 0.125 */
    gv_flow_noisy(z, eps, 0.0f, 3, x);
    CHECK(x[0] == 1.0f && x[1] == 2.0f && x[2] == -4.0f); /* no noise at t = 0 (paper eq. 6) */
    gv_flow_target(z, eps, 3, v);
    CHECK(v[0] == 2.0f && v[1] == -3.0f && v[2] == 4.5f);
    /* x_t - t v = (1 - t) z + t eps - t (eps - z) = z: the clean latent when started at z */
    gv_flow_noisy(z, eps, 0.4f, 3, x);
    for (int i = 0; i < 3; i++) CHECK_NEAR(x[i] - 0.4f * v[i], z[i], 1e-6);
}

static void test_shift_and_grid(void)
{
    /* docs/reference/wan-vace-gaussvid.md 5.4: strength 0.2 with shift 5 starts at sigma 0.5556 */
    CHECK_NEAR(gv_flow_shift(0.2, 5.0), 1.0 / 1.8, 1e-12);
    CHECK_NEAR(gv_flow_shift(0.7, 1.0), 0.7, 1e-15);
    CHECK_NEAR(gv_flow_shift(1.0, 5.0), 1.0, 1e-15);
    gv_pretrain_schedule s;
    gv_pretrain_schedule_init(&s, 5.0);
    CHECK_NEAR(s.sigma[0], 1.0, 1e-15);
    /* shift(0.001) ~ 0.005 (docs/reference/wan-vace-gaussvid.md 5.5) */
    CHECK_NEAR(s.sigma[999], 0.005 / 1.004, 1e-12);
    CHECK_NEAR(s.sigma[500], 2.5 / 3.0, 1e-12);       /* shift(0.5) = 2.5 / 3 */
    double sum = 0, max = 0;
    int decreasing = 1, k_max = 0;
    for (int k = 0; k < GV_FLOW_GRID; k++) {
        sum += s.weight[k];
        if (s.weight[k] > max) max = s.weight[k], k_max = k;
        if (k && s.sigma[k] >= s.sigma[k - 1]) decreasing = 0;
    }
    CHECK(decreasing);
    CHECK_NEAR(sum, 1000.0, 1e-9);                    /* mean weight 1 */
    CHECK_NEAR(s.weight[0], 0.0, 1e-12);              /* timestep 1000 is the bell's minimum */
    CHECK(max > 2.0 && max < 2.15);                   /* reference: max ~ 2.08 near t = 500 */
    CHECK(fabs(s.sigma[k_max] - 0.5) < 0.01);
    /* without shift the grid is linspace(1, 0, 1001)[:-1] */
    gv_pretrain_schedule u;
    gv_pretrain_schedule_init(&u, 1.0);
    CHECK_NEAR(u.sigma[250], 0.75, 1e-15);
    CHECK(u.weight[500] > u.weight[100] && u.weight[500] > u.weight[900]);
    CHECK(gv_pretrain_index(0.0) == 0 && gv_pretrain_index(0.9999999) == 999 && gv_pretrain_index(0.5) == 500);
}

static void test_progressive_weight(void)
{
    /* lambda 0.1, S_w 1000, tau_p 0.3 (paper 4.1) */
    CHECK_NEAR(gv_progressive_weight(0, 1000, 0.0, 0.3, 0.1), 0.0, 1e-15);
    CHECK_NEAR(gv_progressive_weight(1000, 1000, 0.0, 0.3, 0.1), 0.0, 1e-15);
    CHECK_NEAR(gv_progressive_weight(1500, 1000, 0.0, 0.3, 0.1), 0.05, 1e-15);
    CHECK_NEAR(gv_progressive_weight(1750, 1000, 0.06, 0.3, 0.1), 0.1 * 0.75 * 0.8, 1e-15);
    CHECK_NEAR(gv_progressive_weight(2000, 1000, 0.15, 0.3, 0.1), 0.05, 1e-15);
    CHECK_NEAR(gv_progressive_weight(9000, 1000, 0.0, 0.3, 0.1), 0.1, 1e-15);
    CHECK_NEAR(gv_progressive_weight(9000, 1000, 0.3, 0.3, 0.1), 0.0, 1e-15);
    CHECK_NEAR(gv_progressive_weight(9000, 1000, 0.45, 0.3, 0.1), 0.0, 1e-15); /* above tau_p */
    CHECK_NEAR(gv_progressive_weight(60, 25, 0.1, 0.3, 0.1), 0.1 * 1.0 * (2.0 / 3.0), 1e-15);
}

static void test_curriculum_values(void)
{
    CHECK_NEAR(gv_curriculum_difficulty(6, 6, 26), 0.0, 0);
    CHECK_NEAR(gv_curriculum_difficulty(16, 6, 26), 0.5, 1e-15);
    CHECK_NEAR(gv_curriculum_difficulty(8, 6, 26), 0.1, 1e-15);
    CHECK_NEAR(gv_curriculum_difficulty(26, 6, 26), 1.0, 0);
    CHECK_NEAR(gv_curriculum_difficulty(4, 6, 26), 0.0, 0);  /* outside the paper's range: clamped */
    CHECK_NEAR(gv_curriculum_difficulty(30, 6, 26), 1.0, 0);
    /* S = 20000, p_w = 0.05: warm-up to 0.2 over 1000 steps, then to 1 at 20000 (paper 3.4) */
    CHECK_NEAR(gv_curriculum_threshold(0, 20000, 0.05), 0.0, 0);
    CHECK_NEAR(gv_curriculum_threshold(500, 20000, 0.05), 0.1, 1e-15);
    CHECK_NEAR(gv_curriculum_threshold(1000, 20000, 0.05), 0.2, 1e-15);
    CHECK_NEAR(gv_curriculum_threshold(10500, 20000, 0.05), 0.6, 1e-15);
    CHECK_NEAR(gv_curriculum_threshold(19999, 20000, 0.05), 0.2 + 0.8 * 18999.0 / 19000.0, 1e-12);
    CHECK_NEAR(gv_curriculum_threshold(20000, 20000, 0.05), 1.0, 0);
    CHECK_NEAR(gv_curriculum_threshold(25000, 20000, 0.05), 1.0, 0);
    /* a 400-step run: warm-up over 20 steps */
    CHECK_NEAR(gv_curriculum_threshold(10, 400, 0.05), 0.1, 1e-15);
    CHECK_NEAR(gv_curriculum_threshold(210, 400, 0.05), 0.2 + 0.8 * 190.0 / 380.0, 1e-12);
    CHECK_NEAR(gv_curriculum_weight(0.5, 0.6), 1.0 - 0.4 * 0.5 / 0.6, 1e-15);
    CHECK_NEAR(gv_curriculum_weight(0.6, 0.6), 0.6, 1e-15); /* 0.6 at the boundary */
    CHECK_NEAR(gv_curriculum_weight(0.0, 0.6), 1.0, 0);
    CHECK_NEAR(gv_curriculum_weight(0.7, 0.6), 0.0, 0);      /* skipped */
    CHECK_NEAR(gv_curriculum_weight(0.0, 0.0), 1.0, 0);      /* delta = delta_max = 0 */
    CHECK_NEAR(gv_curriculum_weight(0.1, 0.0), 0.0, 0);
}

static void test_data_order(void)
{
    gv_data_order a, b, c;
    CHECK(gv_data_order_init(&a, 7, 42) == 0);
    CHECK(gv_data_order_init(&b, 7, 42) == 0);
    CHECK(gv_data_order_init(&c, 7, 43) == 0);
    int ok_perm = 1, same = 1, differ_seed = 0, differ_epoch = 0;
    for (long e = 0; e < 4; e++) {
        int seen[7] = {0};
        for (int i = 0; i < 7; i++) {
            int k = gv_data_order_at(&a, e * 7 + i);
            if (k < 0 || k >= 7 || seen[k]++) ok_perm = 0;
        }
    }
    /* random access in any order gives the same stream */
    for (long p = 27; p >= 0; p--) {
        int ka = gv_data_order_at(&a, p);
        if (ka != gv_data_order_at(&b, p)) same = 0;
        if (ka != gv_data_order_at(&c, p)) differ_seed = 1;
        if (p >= 7 && ka != gv_data_order_at(&a, p - 7)) differ_epoch = 1;
    }
    CHECK(ok_perm);
    CHECK(same);
    CHECK(differ_seed);
    CHECK(differ_epoch);
    CHECK_FAILS_WITH(gv_data_order_at(&a, -1), "position");
    gv_data_order_free(&a);
    gv_data_order_free(&b);
    gv_data_order_free(&c);
    gv_data_order e;
    CHECK_FAILS_WITH(gv_data_order_init(&e, 0, 1), "no clips");
    gv_data_order_free(&e);
}

static void test_curriculum_batch(void)
{
    const int n[6] = {6, 8, 16, 26, 6, 10};
    double delta[6];
    for (int i = 0; i < 6; i++) delta[i] = gv_curriculum_difficulty(n[i], 6, 26);
    gv_data_order d, ref;
    gv_data_order_init(&d, 6, 9);
    gv_data_order_init(&ref, 6, 9);
    long pos = 0, ref_pos = 0;
    int ok = 1, total_skipped = 0;
    for (int step = 0; step < 5; step++) {
        int index[3], skipped;
        double weight[3];
        CHECK(gv_curriculum_batch(&d, delta, 0.1, 3, &pos, index, weight, &skipped) == 0);
        total_skipped += skipped;
        /* an independent walk: the next three clips with n <= 8 */
        int taken = 0, ref_skipped = 0;
        while (taken < 3) {
            int k = gv_data_order_at(&ref, ref_pos++);
            if (n[k] > 8) { ref_skipped++; continue; }
            double want = n[k] == 6 ? 1.0 : 0.6; /* delta 0.1 = delta_max: 1 - 0.4 */
            if (index[taken] != k || fabs(weight[taken] - want) > 1e-12) ok = 0;
            taken++;
        }
        if (ref_skipped != skipped || ref_pos != pos) ok = 0;
    }
    CHECK(ok);
    CHECK(total_skipped > 0);
    /* no curriculum: every clip in stream order, weight 1 */
    long p2 = 0;
    int index[6], skipped = -1;
    double weight[6];
    CHECK(gv_curriculum_batch(&d, delta, -1, 6, &p2, index, weight, &skipped) == 0);
    int all = skipped == 0 && p2 == 6;
    for (int i = 0; i < 6; i++) all &= index[i] == gv_data_order_at(&ref, i) && weight[i] == 1.0;
    CHECK(all);
    /* threshold below every clip's difficulty: raised to the easiest (n = 8 here) */
    const double hard[3] = {0.3, 0.1, 0.5};
    gv_data_order h;
    gv_data_order_init(&h, 3, 1);
    long p3 = 0;
    CHECK(gv_curriculum_batch(&h, hard, 0.0, 2, &p3, index, weight, &skipped) == 0);
    CHECK(index[0] == 1 && index[1] == 1 && fabs(weight[0] - 0.6) < 1e-12 && skipped == p3 - 2 && skipped >= 2);
    gv_data_order_free(&h);
    gv_data_order_free(&d);
    gv_data_order_free(&ref);
}

/* Pretraining with renders in the context: the share of such samples is the option's, and
 * the timestep and noise of every sample are those of a run without them. */
static void test_render_context_draws(void)
{
    gv_train_options off, half, all;
    gv_train_defaults(&off, GV_OBJECTIVE_PRETRAIN);
    off.seed = 5;
    half = off, all = off;
    half.render_context = 0.5, all.render_context = 1.0;
    gv_pretrain_schedule grid;
    gv_pretrain_schedule_init(&grid, off.shift);
    enum { STEPS = 500, BATCH = 2, N = 8 };
    int with = 0, none_off = 1, all_all = 1, same = 1;
    for (long s = 0; s < STEPS; s++)
        for (int b = 0; b < BATCH; b++) {
            float e0[N], e1[N], e2[N];
            gv_sample_draw d0, d1, d2;
            gv_train_window w0, w1, w2;
            gv_train_draw(&off, &grid, s, b, 1.0, 9, 16, &d0, &w0);
            gv_train_noise(&off, s, b, N, e0);
            gv_train_draw(&half, &grid, s, b, 1.0, 9, 16, &d1, &w1);
            gv_train_noise(&half, s, b, N, e1);
            gv_train_draw(&all, &grid, s, b, 1.0, 9, 16, &d2, &w2);
            gv_train_noise(&all, s, b, N, e2);
            with += d1.renders, none_off &= !d0.renders, all_all &= d2.renders;
            same &= d0.t == d1.t && d0.w_t == d1.w_t && !memcmp(e0, e1, sizeof e0) && !memcmp(e0, e2, sizeof e0);
        }
    CHECK(none_off && all_all && same);
    CHECK(with > 450 && with < 550); /* 1000 draws of p = 0.5: 6 standard deviations is 95 */
    gv_train_options ft;
    gv_train_defaults(&ft, GV_OBJECTIVE_FINETUNE);
    gv_sample_draw d;
    gv_train_window w;
    gv_train_draw(&ft, &grid, 0, 0, 1.0, 9, 16, &d, &w);
    CHECK(d.renders == 1); /* fine-tuning always restores from the renders */
    half.out = "x";
    CHECK(gv_train_check_options(&half) == 0);
    half.render_context = 1.5;
    CHECK(gv_train_check_options(&half) != 0);
}

/* Crops: every window position of the grid is drawn about equally often and none outside
 * it; the timestep, weights and noise are those of the run without crops; a crop as large as
 * the grid (or larger) is the whole grid, with no draw. */
static void test_crop_draws(void)
{
    gv_train_options whole, crop, big;
    gv_train_defaults(&whole, GV_OBJECTIVE_FINETUNE);
    whole.seed = 11;
    crop = whole, big = whole;
    crop.crop_h = 4, crop.crop_w = 6;
    big.crop_h = 9, big.crop_w = 20;
    gv_pretrain_schedule grid;
    gv_pretrain_schedule_init(&grid, whole.shift);
    enum { STEPS = 2000, ROWS = 9, COLS = 16 };
    int count[ROWS - 4 + 1][COLS - 6 + 1] = {{0}}, inside = 1, same = 1, uncropped = 1;
    for (long s = 0; s < STEPS; s++) {
        gv_sample_draw a, b, c;
        gv_train_window wa, wb, wc;
        gv_train_draw(&whole, &grid, s, 1, 1.0, ROWS, COLS, &a, &wa);
        gv_train_draw(&crop, &grid, s, 1, 1.0, ROWS, COLS, &b, &wb);
        gv_train_draw(&big, &grid, s, 1, 1.0, ROWS, COLS, &c, &wc);
        same &= a.t == b.t && a.w_lat == b.w_lat && a.t == c.t;
        uncropped &= wa.y == 0 && wa.x == 0 && wa.h == ROWS && wa.w == COLS;
        uncropped &= wc.y == 0 && wc.x == 0 && wc.h == ROWS && wc.w == COLS;
        inside &= wb.h == 4 && wb.w == 6 && wb.y >= 0 && wb.y + 4 <= ROWS && wb.x >= 0 && wb.x + 6 <= COLS;
        if (inside) count[wb.y][wb.x]++;
    }
    CHECK(same && uncropped && inside);
    int least = STEPS, most = 0; /* 66 positions, about 30 draws each */
    for (int y = 0; y < ROWS - 4 + 1; y++)
        for (int x = 0; x < COLS - 6 + 1; x++) least = count[y][x] < least ? count[y][x] : least, most = count[y][x] > most ? count[y][x] : most;
    CHECK(least >= 10 && most <= 60);
    crop.out = "x";
    CHECK(gv_train_check_options(&crop) == 0);
    crop.crop_w = -1;
    CHECK(gv_train_check_options(&crop) != 0);
}

int main(void)
{
    test_flow();
    test_shift_and_grid();
    test_progressive_weight();
    test_curriculum_values();
    test_data_order();
    test_curriculum_batch();
    test_render_context_draws();
    test_crop_draws();
    return check_summary();
}
