/* The training objectives (train.h, train_step.c) on hand-made latents and the tiny model: x_t
 * and the velocity target of both objectives, the VACE context each allows, the losses of one
 * sample against an independent computation from the network's own forward pass, how the
 * weights w_cur, w_t, w_lat and the batch scale enter the gradient, and which tensors receive
 * gradients in fine-tuning; the `skip` and `residual` output parameterisations in training and
 * restoration. */
#include "check.h"
#include "model_testutil.h"
#include "gaussvid/restore/restore.h"
#include "gaussvid/train/train.h"

/* A clip's latents for the tiny preset (32 x 32 pixels: latent 4 x 2 x 4 x 4), random values,
 * the Plücker field of a real camera path; batch 3 for the per-frame layout. */
static void make_latents(gv_clip_latents *l, const gv_model_config *c, int batch, uint64_t seed)
{
    memset(l, 0, sizeof *l);
    l->interval = 10, l->frames = 5, l->height = 32, l->width = 32, l->batch = batch;
    l->z_dim = c->vae.z_dim, l->latent_frames = batch == 1 ? 2 : 1, l->lh = 4, l->lw = 4;
    l->vace_dim = c->dit.vace_in_dim;
    l->plucker_frames = gv_plucker_packed_frames(batch == 1 ? 5 : 1, c->vae.temporal_factor);
    CHECK(gv_clip_latents_alloc(l, 1) == 0);
    gv_fill_normal(l->z_clean, gv_clip_latents_z_count(l), seed, 0, 0.0f, 1.0f);
    gv_fill_normal(l->z_corrupt, gv_clip_latents_z_count(l), seed + 1, 0, 0.0f, 1.0f);
    gv_fill_normal(l->vace, gv_clip_latents_vace_count(l), seed + 2, 0, 0.0f, 1.0f);
    gv_camera cams[5];
    mt_cameras(cams, 5, 32, 32, 0.1 * (double)(seed % 7));
    int64_t per = gv_clip_latents_plucker_count(l) / batch;
    for (int b = 0; b < batch; b++)
        CHECK(gv_plucker_field(batch == 1 ? cams : cams + 1 + b, batch == 1 ? 5 : 1, 32, 32, c->vae.temporal_factor,
                               l->plucker + b * per, NULL) == 0);
}

/* n standard normal values from seed (malloc'd), the noise eps of a sample. */
static float *noise(int64_t n, uint64_t seed)
{
    float *eps = malloc((size_t)n * sizeof *eps);
    CHECK(eps != NULL);
    gv_fill_normal(eps, n, seed, 0, 0.0f, 1.0f);
    return eps;
}

static void test_inputs_and_context(void)
{
    /* hand-made: 2 latent values, batch 3, z_dim 2, vace_dim 5, one latent position */
    float zc[6] = {1, -2, 3, 0.5f, 0, 4}, zh[6] = {2, 2, -1, 0, 1, 3}, eps[6] = {0.5f, 1, -1, 2, 0, -3};
    float vace[15], out[15], x[6], v[6];
    for (int i = 0; i < 15; i++) vace[i] = (float)(i + 1);
    gv_clip_latents l;
    memset(&l, 0, sizeof l);
    l.batch = 3, l.z_dim = 2, l.latent_frames = 1, l.lh = 1, l.lw = 1, l.vace_dim = 5;
    l.z_clean = zc, l.z_corrupt = zh, l.vace = vace;
    gv_objective_inputs(&l, GV_OBJECTIVE_FINETUNE, 0.25f, eps, x, v);
    int ok = 1;
    for (int i = 0; i < 6; i++) ok &= fabsf(x[i] - (0.75f * zh[i] + 0.25f * eps[i])) < 1e-7f && v[i] == eps[i] - zc[i];
    CHECK(ok);                                                /* paper eq. 6, 7: from z-hat, target eps - z0* */
    CHECK_NEAR(x[2], 0.75 * -1 + 0.25 * -1, 1e-7);
    gv_objective_inputs(&l, GV_OBJECTIVE_PRETRAIN, 0.25f, eps, x, v);
    ok = 1;
    for (int i = 0; i < 6; i++) ok &= fabsf(x[i] - (0.75f * zc[i] + 0.25f * eps[i])) < 1e-7f && v[i] == eps[i] - zc[i];
    CHECK(ok);                                                /* standard flow matching from z0 */
    gv_objective_vace(&l, 1, out);
    CHECK(memcmp(out, vace, sizeof vace) == 0);
    gv_objective_vace(&l, 0, out);
    ok = 1;
    for (int b = 0; b < 3; b++)
        for (int c = 0; c < 5; c++) {
            float want = c == 2 || c == 3 ? 0.0f : vace[b * 5 + c]; /* reactive channels z..2z-1 zeroed */
            ok &= out[b * 5 + c] == want;
        }
    CHECK(ok);
}

/* The forward pass the test builds itself: the velocity for x_t of a fine-tuning sample. */
static float *independent_velocity(gv_dit *m, const gv_clip_latents *l, float t, const float *x_t, gv_objective obj)
{
    gv_graph g;
    gv_graph_init(&g, 0);
    gv_graph_set_grad(&g, 0);
    const gv_model_config *c = &m->cfg;
    int B = l->batch, shape[5] = {B, l->z_dim, l->latent_frames, l->lh, l->lw};
    float ts[3] = {1000 * t, 1000 * t, 1000 * t};
    gv_dit_inputs in = gv_dit_inputs_default();
    in.latent = gv_tensor_from(&g, 5, shape, x_t);
    in.timestep = ts;
    in.vace = gv_tensor_from(&g, 5, (int[]){B, c->dit.vace_in_dim, l->latent_frames, 4, 4}, l->vace);
    if (obj == GV_OBJECTIVE_PRETRAIN) /* reactive channels 4..7 zeroed by hand */
        for (int b = 0; b < B; b++) memset(in.vace->data + (b * 72 + 4) * l->latent_frames * 16, 0, 4 * l->latent_frames * 16 * sizeof(float));
    in.text = gv_tensor_new(&g, 3, (int[]){B, c->dit.text_len, c->dit.text_dim});
    in.plucker = gv_tensor_from(&g, 5, (int[]){B, 6, l->plucker_frames, 32, 32}, l->plucker);
    gv_tensor *v = gv_dit_forward(m, &g, &in);
    CHECK(v != NULL);
    int64_t n = gv_clip_latents_z_count(l);
    float *out = malloc((size_t)n * sizeof *out);
    memcpy(out, v->data, (size_t)n * sizeof *out);
    gv_graph_free(&g);
    return out;
}

static void test_sample_losses(void)
{
    gv_dit m;
    CHECK(mt_model(&m, NULL, 3) == 0);
    gv_clip_latents l;
    make_latents(&l, &m.cfg, 1, 11);
    int64_t n = gv_clip_latents_z_count(&l);
    float *eps = noise(n, 99), *x = malloc((size_t)n * sizeof *x), *v = malloc((size_t)n * sizeof *v);
    gv_graph g;
    gv_graph_init(&g, 0);
    gv_sample_draw d = {0.2f, 1.0, 1.0, 0.1, 0};
    gv_sample_losses s;
    /* Wan's zero-initialised head: v = 0, so L_FM = mean (eps - z0*)^2 and L_lat = mean |x_t - z0*| */
    CHECK(gv_train_sample(&m, &g, &l, GV_OBJECTIVE_FINETUNE, &d, eps, 1.0, 0, &s) == 0);
    gv_objective_inputs(&l, GV_OBJECTIVE_FINETUNE, 0.2f, eps, x, v);
    double fm = 0, lat = 0;
    for (int64_t i = 0; i < n; i++) fm += (double)v[i] * v[i], lat += fabs(x[i] - l.z_clean[i]);
    CHECK_NEAR(s.fm, fm / n, 1e-5 * fm / n);
    CHECK_NEAR(s.latent, lat / n, 1e-5 * lat / n);
    CHECK_NEAR(s.loss, s.fm + 0.1 * s.latent, 1e-9);
    /* a "pretrained" network: the losses from its own forward pass, computed here */
    mt_randomize(&m, MT_ALL, 5);
    for (int obj = 0; obj < 2; obj++) {
        gv_sample_draw e = {0.37f, obj == GV_OBJECTIVE_PRETRAIN ? 1.7 : 1.0, 0.8, 0.05, 0};
        CHECK(gv_train_sample(&m, &g, &l, (gv_objective)obj, &e, eps, 1.0, 0, &s) == 0);
        gv_objective_inputs(&l, (gv_objective)obj, 0.37f, eps, x, v);
        float *vel = independent_velocity(&m, &l, 0.37f, x, (gv_objective)obj);
        double want_fm = 0, want_lat = 0;
        for (int64_t i = 0; i < n; i++) {
            want_fm += ((double)vel[i] - v[i]) * ((double)vel[i] - v[i]);
            want_lat += fabs((double)x[i] - 0.37 * vel[i] - l.z_clean[i]);
        }
        want_fm /= n, want_lat /= n;
        printf("objective %d: L_FM %.6f (independent %.6f), L_lat %.6f (%.6f)\n", obj, s.fm, want_fm, s.latent, want_lat);
        CHECK_NEAR(s.fm, want_fm, 1e-5 * want_fm);
        CHECK_NEAR(s.latent, want_lat, 1e-5 * want_lat);
        CHECK_NEAR(s.loss, e.w_cur * (e.w_t * want_fm + e.w_lat * want_lat), 1e-5 * s.loss);
        free(vel);
    }
    /* pretraining ignores the renders: z-hat and the reactive context do not change its loss */
    gv_sample_losses p1, p2, f1, f2;
    gv_sample_draw e = {0.3f, 1.0, 1.0, 0.1, 0};
    CHECK(gv_train_sample(&m, &g, &l, GV_OBJECTIVE_PRETRAIN, &e, eps, 1.0, 0, &p1) == 0);
    CHECK(gv_train_sample(&m, &g, &l, GV_OBJECTIVE_FINETUNE, &e, eps, 1.0, 0, &f1) == 0);
    gv_fill_normal(l.z_corrupt, n, 1234, 0, 0.0f, 1.0f);
    for (int c = 4; c < 8; c++) gv_fill_normal(l.vace + c * 32, 32, 77 + (uint64_t)c, 0, 0.0f, 1.0f);
    CHECK(gv_train_sample(&m, &g, &l, GV_OBJECTIVE_PRETRAIN, &e, eps, 1.0, 0, &p2) == 0);
    CHECK(gv_train_sample(&m, &g, &l, GV_OBJECTIVE_FINETUNE, &e, eps, 1.0, 0, &f2) == 0);
    CHECK(p1.fm == p2.fm && p1.latent == p2.latent);
    CHECK(f1.fm != f2.fm);
    gv_graph_free(&g);
    gv_clip_latents_free(&l);
    free(eps), free(x), free(v);
    gv_dit_free(&m);
}

/* Gradients of all trainable tensors, concatenated. */
static double *grads(gv_dit *m, gv_graph *g, const gv_clip_latents *l, const gv_sample_draw *d, const float *eps,
                     double scale, int64_t *count)
{
    gv_params_zero_grad(&m->params);
    CHECK(gv_train_sample(m, g, l, GV_OBJECTIVE_FINETUNE, d, eps, scale, 1, NULL) == 0);
    int64_t total = gv_params_count(&m->params, 1), k = 0;
    double *out = malloc((size_t)total * sizeof *out);
    for (int i = 0; i < m->params.n; i++) {
        const gv_param *p = m->params.items[i];
        if (!p->trainable) continue;
        for (int64_t j = 0; j < p->t.numel; j++) out[k++] = p->t.grad ? p->t.grad[j] : 0.0;
    }
    *count = total;
    return out;
}

static void test_gradient_weights(void)
{
    gv_dit m;
    CHECK(mt_model(&m, NULL, 4) == 0);
    mt_randomize(&m, MT_ALL, 8);
    CHECK(gv_dit_set_train_mode(&m, GV_DIT_FINETUNE) == 0);
    gv_clip_latents l;
    make_latents(&l, &m.cfg, 1, 21);
    int64_t n = gv_clip_latents_z_count(&l), k = 0;
    float *eps = noise(n, 5);
    gv_graph g;
    gv_graph_init(&g, 0);
    gv_sample_draw d0 = {0.1f, 1.0, 1.0, 0.0, 0}, d1 = d0, d2 = d0, dc = d0;
    d1.w_lat = 0.1, d2.w_lat = 0.2, dc.w_cur = 0.6;
    double *g0 = grads(&m, &g, &l, &d0, eps, 1.0, &k), *g1 = grads(&m, &g, &l, &d1, eps, 1.0, &k);
    double *g2 = grads(&m, &g, &l, &d2, eps, 1.0, &k), *gs = grads(&m, &g, &l, &d0, eps, 0.5, &k);
    double *gc = grads(&m, &g, &l, &dc, eps, 1.0, &k);
    /* the loss is linear in the weights: g(w_lat) = g_FM + w_lat g_lat, g(scale) = scale g,
     * g(w_cur) = w_cur g */
    double lin = 0, sc = 0, cur = 0, norm = 0, lat = 0;
    for (int64_t i = 0; i < k; i++) {
        lin = fmax(lin, fabs((g2[i] - g1[i]) - (g1[i] - g0[i])));
        sc = fmax(sc, fabs(gs[i] - 0.5 * g0[i]));
        cur = fmax(cur, fabs(gc[i] - 0.6 * g0[i]));
        norm = fmax(norm, fabs(g0[i]));
        lat = fmax(lat, fabs(g1[i] - g0[i]));
    }
    printf("gradients: max |g| %.3g, latent part %.3g, linearity error %.2g, scale %.2g, w_cur %.2g\n", norm, lat, lin,
           sc, cur);
    CHECK(norm > 0 && lat > 1e-4 * norm);
    CHECK(lin <= 1e-5 * norm && sc <= 1e-6 * norm && cur <= 1e-6 * norm);
    /* fine-tuning: LoRA and the camera encoder get gradients, the frozen base has none */
    int base_grad = 0, lora_b = 0, camera = 0;
    for (int i = 0; i < m.params.n; i++) {
        const gv_param *p = m.params.items[i];
        const gv_weight_spec *s = gv_weight_list_find(&m.weights, p->t.name);
        double mx = 0;
        for (int64_t j = 0; p->t.grad && j < p->t.numel; j++) mx = fmax(mx, fabs(p->t.grad[j]));
        if (!p->trainable && p->t.grad) base_grad = 1;
        if (strstr(p->t.name, "lora_B") && mx > 0) lora_b = 1;
        if (s->module == GV_MODULE_CAMERA && mx > 0) camera = 1;
    }
    CHECK(!base_grad && lora_b && camera);
    free(g0), free(g1), free(g2), free(gs), free(gc), free(eps);
    gv_graph_free(&g);
    gv_clip_latents_free(&l);
    gv_dit_free(&m);
}

static void test_per_frame_sample(void)
{
    gv_dit m;
    CHECK(mt_model(&m, "per-frame", 6) == 0);
    mt_randomize(&m, MT_ALL, 9);
    gv_clip_latents l;
    make_latents(&l, &m.cfg, 3, 31);
    int64_t n = gv_clip_latents_z_count(&l);
    CHECK(n == 3 * 4 * 16);
    float *eps = noise(n, 8), *x = malloc((size_t)n * sizeof *x), *v = malloc((size_t)n * sizeof *v);
    gv_graph g;
    gv_graph_init(&g, 0);
    gv_sample_draw d = {0.25f, 1.0, 1.0, 0.0, 0};
    gv_sample_losses s;
    CHECK(gv_train_sample(&m, &g, &l, GV_OBJECTIVE_FINETUNE, &d, eps, 1.0, 0, &s) == 0);
    gv_objective_inputs(&l, GV_OBJECTIVE_FINETUNE, 0.25f, eps, x, v);
    float *vel = independent_velocity(&m, &l, 0.25f, x, GV_OBJECTIVE_FINETUNE);
    double want = 0;
    for (int64_t i = 0; i < n; i++) want += ((double)vel[i] - v[i]) * ((double)vel[i] - v[i]);
    CHECK_NEAR(s.fm, want / n, 1e-5 * want / n);
    /* a clip prepared without cameras cannot feed a camera variant */
    float *keep = l.plucker;
    l.plucker = NULL;
    CHECK_FAILS_WITH(gv_train_sample(&m, &g, &l, GV_OBJECTIVE_FINETUNE, &d, eps, 1.0, 0, &s), "Plücker");
    l.plucker = keep;
    l.z_dim = 5;
    CHECK_FAILS_WITH(gv_train_sample(&m, &g, &l, GV_OBJECTIVE_FINETUNE, &d, eps, 1.0, 0, &s), "channels");
    l.z_dim = 4;
    free(vel), free(eps), free(x), free(v);
    gv_graph_free(&g);
    gv_clip_latents_free(&l);
    gv_dit_free(&m);
}

/* Frames without ground truth (a clip's target_mask): the clip's mask reaches the latent frames
 * that pack a masked frame; a masked latent frame adds nothing to the losses, and its target
 * does not change the gradient (bit for bit); the losses are means over the frames kept. */
static void test_masked_frames(void)
{
    /* the mapping from the clip's frames to latent frames */
    gv_model_config small, tiny;
    CHECK(gv_model_config_preset(&small, "small") == 0 && gv_model_config_preset(&tiny, "tiny") == 0);
    gv_clip_info info;
    memset(&info, 0, sizeof info);
    info.width = info.height = 32, info.id.interval = 6;
    info.no_target[1] = info.no_target[3] = 1;
    gv_vae vae;
    memset(&vae, 0, sizeof vae);
    vae.has_stats = 1;
    gv_clip_latents shape;
    vae.cfg = small.vae;                          /* temporal factor 1: one latent frame per frame */
    CHECK(gv_clip_latents_shape(&vae, &small, &info, &shape) == 0 && shape.latent_frames == 5);
    CHECK(!memcmp(shape.no_target, ((uint8_t[]){0, 1, 0, 1, 0}), 5) && gv_clip_latents_masked(&shape));
    vae.cfg = tiny.vae;                           /* factor 4: frames 1-4 share latent frame 1 */
    CHECK(gv_clip_latents_shape(&vae, &tiny, &info, &shape) == 0 && shape.latent_frames == 2);
    CHECK(!memcmp(shape.no_target, ((uint8_t[]){0, 1, 0, 0, 0}), 5));
    CHECK(gv_model_config_set_variant(&tiny, "per-frame", "test") == 0);
    CHECK(gv_clip_latents_shape(&vae, &tiny, &info, &shape) == 0 && shape.batch == 3); /* intermediates 1-3 */
    CHECK(!memcmp(shape.no_target, ((uint8_t[]){1, 0, 1, 0, 0}), 5));
    memset(info.no_target, 0, sizeof info.no_target);
    CHECK(gv_clip_latents_shape(&vae, &tiny, &info, &shape) == 0 && !gv_clip_latents_masked(&shape));

    /* the losses and the gradient: tiny preset, latent frame 1 of 2 masked */
    gv_dit m;
    CHECK(mt_model(&m, NULL, 4) == 0);
    mt_randomize(&m, MT_ALL, 8);
    CHECK(gv_dit_set_train_mode(&m, GV_DIT_FINETUNE) == 0);
    gv_clip_latents l;
    make_latents(&l, &m.cfg, 1, 41);
    int64_t n = gv_clip_latents_z_count(&l), k = 0, plane = 16;
    float *eps = noise(n, 6), *x = malloc((size_t)n * sizeof *x), *v = malloc((size_t)n * sizeof *v);
    gv_graph g;
    gv_graph_init(&g, 0);
    gv_sample_draw d = {0.2f, 1.0, 1.0, 0.1, 0};
    double *whole = grads(&m, &g, &l, &d, eps, 1.0, &k);
    l.no_target[1] = 1;
    double *masked = grads(&m, &g, &l, &d, eps, 1.0, &k);
    /* another target on the masked frame: z0* of latent frame 1 of every channel */
    for (int c = 0; c < l.z_dim; c++)
        for (int64_t i = 0; i < plane; i++) l.z_clean[(c * 2 + 1) * plane + i] += 3.0f * (float)((i % 5) - 2);
    double *moved = grads(&m, &g, &l, &d, eps, 1.0, &k);
    CHECK(!memcmp(masked, moved, (size_t)k * sizeof *masked)); /* bit for bit */
    double differ = 0;
    for (int64_t i = 0; i < k; i++) differ = fmax(differ, fabs(masked[i] - whole[i]));
    CHECK(differ > 0); /* the mask does change what is learned */
    /* the losses: means over latent frame 0 alone, against the network's own velocity */
    gv_sample_losses s;
    CHECK(gv_train_sample(&m, &g, &l, GV_OBJECTIVE_FINETUNE, &d, eps, 1.0, 0, &s) == 0);
    gv_objective_inputs(&l, GV_OBJECTIVE_FINETUNE, 0.2f, eps, x, v);
    float *vel = independent_velocity(&m, &l, 0.2f, x, GV_OBJECTIVE_FINETUNE);
    double fm = 0, lat = 0, id = 0, kept = 0;
    for (int c = 0; c < l.z_dim; c++)
        for (int64_t i = c * 2 * plane; i < (c * 2 + 1) * plane; i++) {
            fm += ((double)vel[i] - v[i]) * ((double)vel[i] - v[i]);
            lat += fabs((double)x[i] - 0.2 * vel[i] - l.z_clean[i]);
            id += ((double)l.z_clean[i] - l.z_corrupt[i]) * ((double)l.z_clean[i] - l.z_corrupt[i]);
            kept++;
        }
    printf("masked: L_FM %.6f (independent %.6f over %g values), L_lat %.6f (%.6f)\n", s.fm, fm / kept, kept, s.latent,
           lat / kept);
    CHECK(kept == n / 2);
    CHECK_NEAR(s.fm, fm / kept, 1e-5 * fm / kept);
    CHECK_NEAR(s.latent, lat / kept, 1e-5 * lat / kept);
    CHECK_NEAR(gv_clip_latents_identity_loss(&l), id / kept, 1e-9 * id / kept);
    free(whole), free(masked), free(moved), free(vel), free(eps), free(x), free(v);
    gv_graph_free(&g);
    gv_clip_latents_free(&l);
    gv_dit_free(&m);
}

/* The restorer's velocity at (x, t) on clip l: the largest |(eps - v) - want| over the latent. */
static double restore_error(gv_dit *m, const gv_clip_latents *l, const float *eps, const float *x, float t,
                            const double *want)
{
    int64_t n = gv_clip_latents_z_count(l);
    float *v = malloc((size_t)n * sizeof *v);
    gv_restore_net net;
    CHECK(v && gv_restore_net_init(&net, m, l, 1) == 0);
    CHECK(gv_restore_net_velocity(&net, x, t, v) == 0);
    double worst = 0;
    for (int64_t i = 0; i < n; i++) worst = fmax(worst, fabs(((double)eps[i] - v[i]) - want[i]));
    gv_restore_net_free(&net);
    free(v);
    return worst;
}

/* The analytic skip (train.h): both forms by hand, then with the tiny model: fine-tuning's
 * L_FM is the squared error of x_t - t F (F the network's raw output), pretraining ignores
 * the skip, and the restorer's velocity gives eps - v = x - sigma F. */
static void test_skip_output(void)
{
    float zh[3] = {2, -1, 0.5f}, eps[3] = {0.5f, 1, -2}, x[3], s1[3], s2[3];
    gv_flow_noisy(zh, eps, 0.25f, 3, x);
    gv_flow_skip_from_noise(zh, eps, 0.25f, 3, s1);
    gv_flow_skip_from_x(zh, x, 0.25, 3, s2);
    CHECK_NEAR(s1[0], 0.75 * (0.5 - 2), 1e-7); /* -1.125 */
    CHECK_NEAR(s2[0], 3.0 * (1.625 - 2), 1e-6);
    CHECK_NEAR(s1[1], 1.5, 1e-7);
    CHECK_NEAR(s2[2], s1[2], 1e-6);
    gv_flow_skip_from_noise(zh, eps, 0.0f, 3, s1); /* t = 0: eps - z_hat */
    CHECK(s1[0] == -1.5f && s1[1] == 2.0f && s1[2] == -2.5f);

    gv_dit m;
    CHECK(mt_model(&m, "skip", 8) == 0);
    CHECK(m.cfg.variant.skip == 1);
    mt_randomize(&m, MT_ALL, 9);
    gv_clip_latents l;
    make_latents(&l, &m.cfg, 1, 21);
    int64_t n = gv_clip_latents_z_count(&l);
    float *e = noise(n, 77), *xt = malloc((size_t)n * sizeof *xt), *v = malloc((size_t)n * sizeof *v);
    gv_graph g;
    gv_graph_init(&g, 0);
    const float t = 0.3f;
    gv_sample_draw d = {t, 1.0, 1.0, 0.1, 0};
    gv_sample_losses fine, pre, plain;
    CHECK(gv_train_sample(&m, &g, &l, GV_OBJECTIVE_FINETUNE, &d, e, 1.0, 0, &fine) == 0);
    gv_objective_inputs(&l, GV_OBJECTIVE_FINETUNE, t, e, xt, v);
    float *F = independent_velocity(&m, &l, t, xt, GV_OBJECTIVE_FINETUNE);
    double want_fm = 0, want_lat = 0;
    for (int64_t i = 0; i < n; i++) {
        double est = (double)xt[i] - t * F[i] - l.z_clean[i];
        double vel = (1.0 - t) * ((double)e[i] - l.z_corrupt[i]) + t * F[i];
        want_fm += est * est;
        want_lat += fabs((double)xt[i] - t * vel - l.z_clean[i]);
    }
    want_fm /= n, want_lat /= n;
    CHECK_NEAR(fine.fm, want_fm, 1e-5 * want_fm);
    CHECK_NEAR(fine.latent, want_lat, 1e-5 * want_lat);
    CHECK(gv_train_sample(&m, &g, &l, GV_OBJECTIVE_PRETRAIN, &d, e, 1.0, 0, &pre) == 0);
    m.cfg.variant.skip = 0;
    CHECK(gv_train_sample(&m, &g, &l, GV_OBJECTIVE_PRETRAIN, &d, e, 1.0, 0, &plain) == 0);
    CHECK(pre.fm == plain.fm && pre.latent == plain.latent);
    m.cfg.variant.skip = 1;

    double *want = malloc((size_t)n * sizeof *want);
    for (int64_t i = 0; i < n; i++) want[i] = (double)xt[i] - t * F[i];
    double worst = restore_error(&m, &l, e, xt, t, want);
    printf("skip: L_FM %.6f (independent %.6f), restore |(eps - v) - (x - t F)| max %.2e\n", fine.fm, want_fm, worst);
    CHECK(worst < 1e-5);
    free(F), free(e), free(xt), free(v), free(want);
    gv_graph_free(&g);
    gv_clip_latents_free(&l);
    gv_dit_free(&m);
}

/* The residual output (train.h): both forms by hand, then with the tiny model: fine-tuning's
 * L_FM is the squared error of z_hat + F, the output layer is trainable and receives gradient,
 * and the restorer's velocity gives eps - v = z_hat + F at any sigma. */
static void test_residual_output(void)
{
    float zh[3] = {2, -1, 0.5f}, eps[3] = {0.5f, 1, -2}, x[3], r1[3], r2[3];
    gv_flow_noisy(zh, eps, 0.25f, 3, x);
    gv_flow_residual_from_noise(zh, eps, 3, r1);
    gv_flow_residual_from_x(zh, x, 0.25, 3, r2);
    CHECK(r1[0] == -1.5f && r1[1] == 2.0f && r1[2] == -2.5f);
    CHECK_NEAR(r2[0], 4.0 * (1.625 - 2), 1e-6); /* x0 = 0.75 * 2 + 0.25 * 0.5 */
    CHECK_NEAR(r2[1], r1[1], 1e-6);
    CHECK_NEAR(r2[2], r1[2], 1e-6);

    gv_dit m;
    CHECK(mt_model(&m, "residual", 8) == 0);
    CHECK(m.cfg.variant.residual == 1 && m.cfg.variant.skip == 0);
    const gv_weight_spec *head = gv_weight_list_find(&m.weights, "head.head.weight");
    const gv_weight_spec *mod = gv_weight_list_find(&m.weights, "head.modulation");
    CHECK(head && head->trainable && mod && !mod->trainable);
    mt_randomize(&m, MT_ALL, 9);
    CHECK(gv_dit_set_train_mode(&m, GV_DIT_FINETUNE) == 0);
    gv_clip_latents l;
    make_latents(&l, &m.cfg, 1, 23);
    int64_t n = gv_clip_latents_z_count(&l);
    float *e = noise(n, 78), *xt = malloc((size_t)n * sizeof *xt), *v = malloc((size_t)n * sizeof *v);
    gv_graph g;
    gv_graph_init(&g, 0);
    const float t = 0.2f;
    gv_sample_draw d = {t, 1.0, 1.0, 0.1, 0};
    gv_sample_losses fine;
    gv_params_zero_grad(&m.params);
    CHECK(gv_train_sample(&m, &g, &l, GV_OBJECTIVE_FINETUNE, &d, e, 1.0, 1, &fine) == 0);
    gv_objective_inputs(&l, GV_OBJECTIVE_FINETUNE, t, e, xt, v);
    float *F = independent_velocity(&m, &l, t, xt, GV_OBJECTIVE_FINETUNE);
    double want_fm = 0, want_lat = 0;
    for (int64_t i = 0; i < n; i++) {
        double est = (double)l.z_corrupt[i] + F[i] - l.z_clean[i];
        double vel = (double)e[i] - l.z_corrupt[i] - F[i];
        want_fm += est * est;
        want_lat += fabs((double)xt[i] - t * vel - l.z_clean[i]);
    }
    want_fm /= n, want_lat /= n;
    CHECK_NEAR(fine.fm, want_fm, 1e-5 * want_fm);
    CHECK_NEAR(fine.latent, want_lat, 1e-5 * want_lat);
    const gv_param *hp = gv_params_find(&m.params, "head.head.weight");
    double grad = 0;
    for (int64_t i = 0; hp && hp->t.grad && i < hp->t.numel; i++) grad += fabs(hp->t.grad[i]);
    CHECK(hp && hp->trainable && grad > 0);

    double *want = malloc((size_t)n * sizeof *want);
    for (int64_t i = 0; i < n; i++) want[i] = (double)l.z_corrupt[i] + F[i];
    double worst = restore_error(&m, &l, e, xt, t, want);
    printf("residual: L_FM %.6f (independent %.6f), restore |(eps - v) - (z_hat + F)| max %.2e\n", fine.fm, want_fm, worst);
    CHECK(worst < 2e-5);
    free(F), free(e), free(xt), free(v), free(want);
    gv_graph_free(&g);
    gv_clip_latents_free(&l);
    gv_dit_free(&m);
}

int main(void)
{
    test_inputs_and_context();
    test_sample_losses();
    test_gradient_weights();
    test_per_frame_sample();
    test_masked_frames();
    test_skip_output();
    test_residual_output();
    return check_summary();
}
