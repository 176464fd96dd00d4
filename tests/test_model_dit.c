/* The DiT with VACE and dual-stream camera injection on the tiny preset (docs/ARCHITECTURE.md 6.3-6.6):
 * shapes of every variant, the zero-initialised paths, the camera stream's exact independence
 * from the noisy latent and t, the asymmetric mask, the camera cache, RoPE positions of camera
 * tokens, the per-frame restorer, the VACE context and bad inputs. */
#include <omp.h>

#include "check.h"
#include "gaussvid/model/vae.h"
#include "model_testutil.h"

/* One no-grad forward; returns a malloc'd copy of the output (numel in *n), or NULL. */
static float *run(gv_dit *m, const gv_dit_inputs *in, int64_t *n)
{
    gv_graph g;
    gv_graph_init(&g, 0);
    gv_graph_set_grad(&g, 0);
    gv_tensor *y = gv_dit_forward(m, &g, in);
    float *out = NULL;
    if (y) {
        out = malloc((size_t)y->numel * sizeof *out);
        memcpy(out, y->data, (size_t)y->numel * sizeof *out);
        *n = y->numel;
    } else {
        fprintf(stderr, "forward failed: %s\n", gv_last_error());
    }
    gv_graph_free(&g);
    return out;
}

static int all_finite(const float *x, int64_t n)
{
    for (int64_t i = 0; i < n; i++)
        if (!isfinite(x[i])) return 0;
    return 1;
}

static void test_shapes(void)
{
    const char *variants[] = {"decomposed", "monolithic", "early", "none", "anchors=first", "camera=none,lora=0"};
    for (int v = 0; v < 6; v++) {
        gv_dit m;
        CHECK(mt_model(&m, variants[v], 1) == 0);
        mt_randomize(&m, MT_ALL, 2);
        gv_graph g;
        gv_graph_init(&g, 0);
        mt_inputs in;
        CHECK(mt_make_inputs(&m, &g, NULL, 2, 5, 32, 32, 3, &in) == 0);
        gv_dit_inputs d = mt_dit_inputs(&in);
        gv_tensor *y = gv_dit_forward(&m, &g, &d);
        CHECK(y && y->ndim == 5 && y->shape[0] == 2 && y->shape[1] == 4 && y->shape[2] == 2 && y->shape[3] == 4 &&
              y->shape[4] == 4);
        CHECK(y && all_finite(y->data, y->numel) && mt_max_abs(y->data, y->numel) > 0);
        gv_graph_free(&g);
        gv_dit_free(&m);
    }
}

/* Unpatchify (docs/reference/wan-vace-gaussvid.md 2.7): with a zero head weight every token outputs
 * the head bias, and out[c, f, 2h + dy, 2w + dx] = bias[(dy 2 + dx) C + c] (C = 4 channels, patch
 * 1x2x2). */
static void test_head_layout(void)
{
    gv_dit m;
    CHECK(mt_model(&m, "none", 3) == 0);
    mt_randomize(&m, MT_BASE, 4);
    memset(m.head.w->data, 0, (size_t)m.head.w->numel * sizeof(float));
    for (int k = 0; k < 16; k++) m.head.b->data[k] = (float)k;
    gv_graph g;
    gv_graph_init(&g, 0);
    mt_inputs in;
    CHECK(mt_make_inputs(&m, &g, NULL, 2, 5, 32, 64, 3, &in) == 0);
    gv_dit_inputs d = mt_dit_inputs(&in);
    gv_tensor *y = gv_dit_forward(&m, &g, &d);
    int ok = y && y->shape[3] == 4 && y->shape[4] == 8;
    for (int64_t i = 0; ok && i < y->numel; i++) {
        int x = (int)(i % 8), row = (int)(i / 8 % 4), c = (int)(i / (8 * 4 * 2) % 4);
        ok = y->data[i] == (float)(((row % 2) * 2 + x % 2) * 4 + c);
    }
    CHECK(ok);
    gv_graph_free(&g);
    gv_dit_free(&m);
}

/* Paper eq. (3) and docs/reference/wan-vace-gaussvid.md 3.1: at initialisation the camera encoder's
 * output and the VACE hints are exactly zero, so cameras cannot change the output and zero hints
 * equal no VACE; the camera tokens still take part in attention (docs/ARCHITECTURE.md 6.5): measure
 * that difference. */
static void test_zero_init(void)
{
    gv_dit m;
    CHECK(mt_model(&m, NULL, 11) == 0);
    gv_graph g;
    gv_graph_init(&g, 0);
    gv_graph_set_grad(&g, 0);
    mt_inputs in;
    CHECK(mt_make_inputs(&m, &g, NULL, 1, 5, 32, 32, 4, &in) == 0);
    gv_dit_trace tr;
    gv_dit_inputs d = mt_dit_inputs(&in);
    d.trace = &tr;
    CHECK(gv_dit_forward(&m, &g, &d) != NULL);
    CHECK(tr.camera_tokens && mt_max_abs(tr.camera_tokens->data, tr.camera_tokens->numel) == 0.0);
    CHECK(tr.hints[0] && tr.hints[1] && mt_max_abs(tr.hints[0]->data, tr.hints[0]->numel) == 0.0 &&
          mt_max_abs(tr.hints[1]->data, tr.hints[1]->numel) == 0.0);
    /* a "pretrained" base (every base tensor random, after_proj and head included); camera
     * encoder and LoRA as initialised, except after_proj kept zero for the VACE check */
    mt_randomize(&m, MT_BASE, 12);
    for (int j = 0; j < m.cfg.dit.n_vace_layers; j++) {
        memset(m.vace_blocks[j].after_proj.w->data, 0, (size_t)m.vace_blocks[j].after_proj.w->numel * sizeof(float));
        memset(m.vace_blocks[j].after_proj.b->data, 0, (size_t)m.vace_blocks[j].after_proj.b->numel * sizeof(float));
    }
    int64_t n = 0, n2 = 0;
    d.trace = NULL;
    float *with_vace = run(&m, &d, &n);
    d.vace = NULL;
    float *without_vace = run(&m, &d, &n2);
    CHECK(with_vace && without_vace && n == n2 && !memcmp(with_vace, without_vace, (size_t)n * sizeof(float)));
    free(with_vace), free(without_vace);
    mt_randomize(&m, MT_BASE, 12);
    d = mt_dit_inputs(&in);
    float *cams_a = run(&m, &d, &n);
    gv_camera cams[5];
    mt_cameras(cams, 5, 32, 32, 0.7); /* a different camera path */
    float *saved = malloc((size_t)in.plucker->numel * sizeof *saved);
    memcpy(saved, in.plucker->data, (size_t)in.plucker->numel * sizeof *saved);
    CHECK(gv_plucker_field(cams, 5, 32, 32, 4, in.plucker->data, NULL) == 0);
    CHECK(memcmp(saved, in.plucker->data, (size_t)in.plucker->numel * sizeof *saved) != 0);
    float *cams_b = run(&m, &d, &n2);
    CHECK(cams_a && cams_b && !memcmp(cams_a, cams_b, (size_t)n * sizeof(float)));
    d.plucker = NULL;
    float *no_stream = run(&m, &d, &n2);
    double diff = 0, ref = 0, worst = 0;
    for (int64_t i = 0; no_stream && cams_a && i < n; i++) {
        double e = (double)cams_a[i] - no_stream[i];
        diff += e * e, ref += (double)no_stream[i] * no_stream[i];
        if (fabs(e) > worst) worst = fabs(e);
    }
    printf("at initialisation, with vs without the camera stream (tiny, random base): max |diff| %.3e, "
           "relative L2 %.3e (output RMS %.3e)\n", worst, sqrt(diff / ref), sqrt(ref / (double)n));
    CHECK(worst > 0 && isfinite(worst)); /* docs/ARCHITECTURE.md 6.5: only approximately equal */
    free(cams_a), free(cams_b), free(no_stream), free(saved);
    gv_graph_free(&g);
    gv_dit_free(&m);
}

/* Copies every camera-stream tensor of a trace into one buffer. */
static float *camera_activations(const gv_dit_trace *tr, int L, int64_t *n)
{
    int64_t total = tr->camera_tokens->numel;
    for (int i = 0; i < L; i++)
        total += (tr->camera_x[i] ? tr->camera_x[i]->numel : 0) + tr->camera_k[i]->numel + tr->camera_v[i]->numel;
    float *out = malloc((size_t)total * sizeof *out), *p = out;
    memcpy(p, tr->camera_tokens->data, (size_t)tr->camera_tokens->numel * sizeof *p);
    p += tr->camera_tokens->numel;
    for (int i = 0; i < L; i++) {
        const gv_tensor *ts[3] = {tr->camera_x[i], tr->camera_k[i], tr->camera_v[i]};
        for (int k = 0; k < 3; k++)
            if (ts[k]) memcpy(p, ts[k]->data, (size_t)ts[k]->numel * sizeof *p), p += ts[k]->numel;
    }
    *n = total;
    return out;
}

/* docs/ARCHITECTURE.md 6.5: the camera stream never depends on the noisy latent or on t (bit-identical),
 * while the video output does depend on the cameras once the encoder is trained. */
static void test_camera_stream_invariance(void)
{
    gv_dit m;
    CHECK(mt_model(&m, NULL, 21) == 0);
    mt_randomize(&m, MT_ALL, 22);
    int L = m.cfg.dit.num_layers;
    gv_graph g, g2;
    gv_graph_init(&g, 0);
    gv_graph_init(&g2, 0);
    mt_inputs in;
    CHECK(mt_make_inputs(&m, &g, NULL, 2, 5, 32, 32, 5, &in) == 0);
    gv_dit_trace tr;
    gv_dit_inputs d = mt_dit_inputs(&in);
    d.trace = &tr;
    gv_tensor *y = gv_dit_forward(&m, &g2, &d);
    CHECK(y != NULL && tr.camera_x[L - 1] == NULL && tr.camera_k[L - 1] != NULL);
    int64_t n1 = 0, n2 = 0;
    float *before = y ? camera_activations(&tr, L, &n1) : NULL;
    float y0 = y ? y->data[7] : 0;
    for (int64_t i = 0; i < in.latent->numel; i++) in.latent->data[i] = 0.5f * in.latent->data[i] + 0.3f;
    for (int64_t i = 0; i < in.vace->numel; i++) in.vace->data[i] *= -1.0f;
    in.t[0] = 999.0f, in.t[1] = 3.0f;
    gv_graph_reset(&g2);
    y = gv_dit_forward(&m, &g2, &d);
    float *after = y ? camera_activations(&tr, L, &n2) : NULL;
    CHECK(before && after && n1 == n2 && !memcmp(before, after, (size_t)n1 * sizeof(float)));
    CHECK(y && y->data[7] != y0); /* the video did change */
    /* a camera change reaches the video output */
    gv_graph_reset(&g2);
    y = gv_dit_forward(&m, &g2, &d);
    float y1 = y ? y->data[7] : 0;
    gv_camera cams[5];
    mt_cameras(cams, 5, 32, 32, 0.5);
    CHECK(gv_plucker_field(cams, 5, 32, 32, 4, in.plucker->data, NULL) == 0);
    gv_graph_reset(&g2);
    y = gv_dit_forward(&m, &g2, &d);
    CHECK(y && y->data[7] != y1);
    free(before), free(after);
    gv_graph_free(&g2);
    gv_graph_free(&g);
    gv_dit_free(&m);
}

/* Paper eq. (4) computed literally (one attention over [video; camera] with the -inf block):
 * camera tokens are unaffected by the video tokens (bit-identical), and the two-call form the
 * model uses gives the same outputs. */
static void test_asymmetric_mask(void)
{
    gv_dit m;
    CHECK(mt_model(&m, NULL, 31) == 0);
    mt_randomize(&m, MT_ALL, 32);
    int L = m.cfg.dit.num_layers;
    gv_graph g, g2;
    gv_graph_init(&g, 0);
    gv_graph_init(&g2, 0);
    gv_graph_set_grad(&g2, 0);
    mt_inputs in;
    CHECK(mt_make_inputs(&m, &g, NULL, 1, 5, 32, 32, 6, &in) == 0);
    gv_dit_trace tr;
    gv_dit_inputs d = mt_dit_inputs(&in);
    d.trace = &tr;
    gv_tensor *split = gv_dit_forward(&m, &g2, &d);
    int64_t n = split ? split->numel : 0;
    float *split_out = malloc((size_t)n * sizeof(float) + 1);
    if (split) memcpy(split_out, split->data, (size_t)n * sizeof(float));
    int64_t n0 = tr.camera_x[0]->numel;
    float *split_cam = malloc((size_t)n0 * sizeof(float));
    memcpy(split_cam, tr.camera_x[0]->data, (size_t)n0 * sizeof(float));
    m.joint_attention = 1;
    gv_graph_reset(&g2);
    gv_tensor *joint = gv_dit_forward(&m, &g2, &d);
    CHECK(joint && joint->numel == n);
    double scale = mt_max_abs(split_out, n), dy = joint ? mt_max_abs_diff(joint->data, split_out, n) : 1;
    double dc = mt_max_abs_diff(tr.camera_x[0]->data, split_cam, n0);
    printf("joint masked attention vs the two-call form: output max |diff| %.2e (scale %.2e), camera block 0 %.2e\n",
           dy, scale, dc);
    CHECK(dy <= 1e-5 * (1 + scale) && dc <= 1e-5);
    int64_t nc = tr.camera_x[L - 1]->numel;
    float *cam_last = malloc((size_t)nc * sizeof(float));
    memcpy(cam_last, tr.camera_x[L - 1]->data, (size_t)nc * sizeof(float));
    for (int64_t i = 0; i < in.latent->numel; i++) in.latent->data[i] = -2.0f * in.latent->data[i];
    in.t[0] = 17.0f;
    gv_graph_reset(&g2);
    CHECK(gv_dit_forward(&m, &g2, &d) != NULL);
    CHECK(!memcmp(cam_last, tr.camera_x[L - 1]->data, (size_t)nc * sizeof(float)));
    free(split_out), free(split_cam), free(cam_last);
    gv_graph_free(&g2);
    gv_graph_free(&g);
    gv_dit_free(&m);
}

/* docs/ARCHITECTURE.md 6.5: the camera stream computed once per clip and reused across sampling steps gives
 * the outputs of recomputing it, bit for bit, at every step. */
static void test_camera_cache(void)
{
    const char *variants[] = {"decomposed", "monolithic", "early"};
    for (int v = 0; v < 3; v++) {
        gv_dit m;
        CHECK(mt_model(&m, variants[v], 41) == 0);
        mt_randomize(&m, MT_ALL, 42);
        gv_graph g;
        gv_graph_init(&g, 0);
        mt_inputs in;
        CHECK(mt_make_inputs(&m, &g, NULL, 2, 9, 32, 64, 7, &in) == 0);
        gv_dit_camera_cache cache;
        CHECK(gv_dit_camera_cache_build(&m, in.plucker, &cache) == 0);
        for (int step = 0; step < 3; step++) {
            in.t[0] = 900.0f - 300.0f * step, in.t[1] = 500.0f - 100.0f * step;
            for (int64_t i = 0; i < in.latent->numel; i++) in.latent->data[i] *= 0.8f;
            gv_dit_inputs d = mt_dit_inputs(&in);
            int64_t n1 = 0, n2 = 0;
            float *fresh = run(&m, &d, &n1);
            d.plucker = NULL;
            d.camera_cache = &cache;
            float *cached = run(&m, &d, &n2);
            CHECK(fresh && cached && n1 == n2 && !memcmp(fresh, cached, (size_t)n1 * sizeof(float)));
            free(fresh), free(cached);
        }
        /* a cache of another grid is refused */
        mt_inputs other;
        CHECK(mt_make_inputs(&m, &g, NULL, 2, 5, 32, 64, 8, &other) == 0);
        gv_dit_inputs d = mt_dit_inputs(&other);
        d.plucker = NULL;
        d.camera_cache = &cache;
        gv_graph g2;
        gv_graph_init(&g2, 0);
        gv_clear_error();
        CHECK(gv_dit_forward(&m, &g2, &d) == NULL && strstr(gv_last_error(), "camera cache"));
        gv_graph_free(&g2);
        gv_dit_camera_cache_free(&cache);
        gv_graph_free(&g);
        gv_dit_free(&m);
    }
    /* an early-fusion cache holds no per-block stream: a dual-stream model refuses it */
    gv_dit early, dual;
    CHECK(mt_model(&early, "early", 43) == 0 && mt_model(&dual, NULL, 44) == 0);
    gv_graph g;
    gv_graph_init(&g, 0);
    mt_inputs in;
    CHECK(mt_make_inputs(&dual, &g, NULL, 1, 5, 32, 32, 9, &in) == 0);
    gv_dit_camera_cache cache;
    CHECK(gv_dit_camera_cache_build(&early, in.plucker, &cache) == 0 && cache.n_layers == 0);
    gv_dit_inputs d = mt_dit_inputs(&in);
    d.plucker = NULL;
    d.camera_cache = &cache;
    gv_clear_error();
    CHECK(gv_dit_forward(&dual, &g, &d) == NULL && strstr(gv_last_error(), "another model"));
    gv_dit_camera_cache_free(&cache);
    CHECK_FAILS_WITH(gv_dit_camera_cache_build(&dual, NULL, &cache), "no ray field");
    gv_graph_free(&g);
    gv_dit_free(&early);
    gv_dit_free(&dual);
}

/* Camera token i takes the RoPE position of video token i (docs/ARCHITECTURE.md 6.5). */
static void test_rope_positions(void)
{
    int pos[3 * 12], cam[3 * 12];
    gv_dit_video_positions(2, 2, 3, pos);
    gv_dit_camera_positions(2, 2, 3, cam);
    for (int n = 0; n < 12; n++) { /* frame-major, then row, then column
                                      (docs/reference/wan-vace-gaussvid.md 2.2) */
        CHECK(pos[3 * n] == n / 6 && pos[3 * n + 1] == (n / 3) % 2 && pos[3 * n + 2] == n % 3);
        CHECK(cam[3 * n] == pos[3 * n] && cam[3 * n + 1] == pos[3 * n + 1] && cam[3 * n + 2] == pos[3 * n + 2]);
    }
    gv_dit m;
    CHECK(mt_model(&m, NULL, 51) == 0);
    gv_graph g;
    gv_graph_init(&g, 0);
    mt_inputs in;
    CHECK(mt_make_inputs(&m, &g, NULL, 1, 9, 32, 64, 9, &in) == 0);
    gv_dit_trace tr;
    gv_dit_inputs d = mt_dit_inputs(&in);
    d.trace = &tr;
    CHECK(gv_dit_forward(&m, &g, &d) != NULL);
    gv_tensor *grid = gv_rope3d_table_grid(&g, 3, 2, 4, m.cfg.dit.dim / m.cfg.dit.num_heads);
    CHECK(tr.rope_video && tr.rope_camera && grid && gv_same_shape(tr.rope_video, grid) &&
          gv_same_shape(tr.rope_camera, grid));
    CHECK(tr.rope_video && !memcmp(tr.rope_video->data, grid->data, (size_t)grid->numel * sizeof(float)));
    CHECK(tr.rope_camera && !memcmp(tr.rope_camera->data, grid->data, (size_t)grid->numel * sizeof(float)));
    CHECK(tr.camera_tokens && tr.camera_tokens->shape[1] == 3 * 2 * 4);
    gv_graph_free(&g);
    gv_dit_free(&m);
}

/* The per-frame restorer: frames are the batch; each frame's output equals its output alone
 * (no temporal attention); more than one latent frame is refused. */
static void test_per_frame(void)
{
    gv_dit m;
    CHECK(mt_model(&m, "per-frame", 61) == 0);
    mt_randomize(&m, MT_ALL, 62);
    gv_graph g;
    gv_graph_init(&g, 0);
    mt_inputs in, one;
    CHECK(mt_make_inputs(&m, &g, NULL, 3, 1, 32, 32, 10, &in) == 0);
    CHECK(mt_make_inputs(&m, &g, NULL, 1, 1, 32, 32, 10, &one) == 0);
    int64_t n = 0, n1 = 0;
    gv_dit_inputs d = mt_dit_inputs(&in);
    float *all = run(&m, &d, &n);
    int64_t per = in.latent->numel / 3;
    memcpy(one.latent->data, in.latent->data + per, (size_t)per * sizeof(float));
    memcpy(one.text->data, in.text->data + in.text->numel / 3, (size_t)(in.text->numel / 3) * sizeof(float));
    memcpy(one.vace->data, in.vace->data + in.vace->numel / 3, (size_t)(in.vace->numel / 3) * sizeof(float));
    memcpy(one.plucker->data, in.plucker->data + in.plucker->numel / 3, (size_t)(in.plucker->numel / 3) * sizeof(float));
    one.t[0] = in.t[1];
    gv_dit_inputs d1 = mt_dit_inputs(&one);
    float *alone = run(&m, &d1, &n1);
    CHECK(all && alone && n1 * 3 == n);
    double diff = all && alone ? mt_max_abs_diff(all + n1, alone, n1) : 1;
    CHECK(diff <= 1e-5 * (1 + mt_max_abs(alone, n1)));
    free(all), free(alone);
    mt_inputs clip;
    CHECK(mt_make_inputs(&m, &g, NULL, 1, 5, 32, 32, 11, &clip) == 0);
    d = mt_dit_inputs(&clip);
    gv_clear_error();
    CHECK(gv_dit_forward(&m, &g, &d) == NULL && strstr(gv_last_error(), "per-frame"));
    gv_graph_free(&g);
    gv_dit_free(&m);
}

/* One camera token per video token for T in {1, 5, 9} and several resolutions. */
static void test_token_count(void)
{
    const char *variants[] = {"decomposed", "monolithic", "early"};
    int sizes[3][2] = {{32, 32}, {32, 64}, {64, 48}}, frames[3] = {1, 5, 9};
    for (int v = 0; v < 3; v++) {
        gv_dit m;
        CHECK(mt_model(&m, variants[v], 71) == 0);
        for (int s = 0; s < 3; s++)
            for (int f = 0; f < 3; f++) {
                gv_graph g;
                gv_graph_init(&g, 0);
                mt_inputs in;
                CHECK(mt_make_inputs(&m, &g, NULL, 1, frames[f], sizes[s][0], sizes[s][1], 12, &in) == 0);
                gv_tensor *xc = gv_camera_encoder_forward(&m, &g, in.plucker);
                int video_tokens = in.T * (in.H / 2) * (in.W / 2);
                CHECK(xc && xc->ndim == 3 && xc->shape[1] == video_tokens && xc->shape[2] == m.cfg.dit.dim);
                gv_graph_free(&g);
            }
        gv_dit_free(&m);
    }
}

/* Reference 3.3 step 4 and docs/ARCHITECTURE.md 6.3 / 6.6. */
static void test_vace_context(void)
{
    float mask[9];
    CHECK(gv_vace_frame_mask(GV_ANCHORS_BOTH, 5, mask) == 0);
    CHECK(mask[0] == 0 && mask[1] == 1 && mask[2] == 1 && mask[3] == 1 && mask[4] == 0);
    CHECK(gv_vace_frame_mask(GV_ANCHORS_FIRST, 5, mask) == 0 && mask[0] == 0 && mask[4] == 1);
    CHECK(gv_vace_frame_mask(GV_ANCHORS_NONE, 5, mask) == 0 && mask[0] == 1 && mask[4] == 1);
    /* pixel mask value = 100 frame + 10 row + column on 4x4 pixels, factor 2 */
    const int expect[3][5] = {{1, 3}, {1, 4, 7}, {1, 5, 8, 11, 15}}, T[3] = {5, 9, 17}, Tl[3] = {2, 3, 5};
    for (int c = 0; c < 3; c++) {
        float pix[17 * 16], out[4 * 5 * 4];
        for (int f = 0; f < T[c]; f++)
            for (int y = 0; y < 4; y++)
                for (int x = 0; x < 4; x++) pix[(f * 4 + y) * 4 + x] = (float)(100 * f + 10 * y + x);
        CHECK(gv_vace_mask_latent(pix, T[c], 4, 4, Tl[c], 2, out) == 0);
        int ok = 1;
        for (int dy = 0; dy < 2; dy++)
            for (int dx = 0; dx < 2; dx++)
                for (int k = 0; k < Tl[c]; k++)
                    for (int y = 0; y < 2; y++)
                        for (int x = 0; x < 2; x++)
                            ok &= out[(((dy * 2 + dx) * Tl[c] + k) * 2 + y) * 2 + x] ==
                                  (float)(100 * expect[c][k] + 10 * (2 * y + dy) + 2 * x + dx);
        CHECK(ok);
    }
    float pix[5 * 16] = {0}, out[16];
    CHECK_FAILS_WITH(gv_vace_mask_latent(pix, 5, 4, 4, 2, 3, out), "vace mask");
    float zi[2] = {1, 2}, zr[2] = {3, 4}, ml[1] = {5}, ctx[5];
    CHECK(gv_vace_context_concat(zi, zr, ml, 2, 1, 1, 1, 1, ctx) == 0);
    CHECK(ctx[0] == 1 && ctx[1] == 2 && ctx[2] == 3 && ctx[3] == 4 && ctx[4] == 5);
}

/* The whole context from frames: [E(V (1 - M)) | E(V M) | mask], each part as computed here
 * with the VAE alone; with 5 frames and anchors at both ends the mask channels sample frames
 * 1 and 3 (docs/reference/wan-vace-gaussvid.md 3.3 step 4), so they are all ones. */
static void test_vace_context_build(void)
{
    gv_model_config c;
    CHECK(gv_model_config_preset(&c, "tiny") == 0);
    gv_vae v;
    CHECK(gv_vae_init(&v, &c, 0, 3) == 0);
    enum { T = 5, H = 16, W = 24 };
    const int z = c.vae.z_dim, sf = c.vae.spatial_factor, h = H / sf, w = W / sf, mc = sf * sf;
    const int64_t plane = (int64_t)H * W, n = 3 * T * plane, nz = (int64_t)z * 2 * h * w;
    float *video = malloc(n * sizeof(float)), *part = malloc(n * sizeof(float)), *zi = malloc(nz * sizeof(float));
    float *zr = malloc(nz * sizeof(float)), *ctx = malloc((2 * nz + (int64_t)mc * 2 * h * w) * sizeof(float));
    gv_fill_uniform(video, n, 4, 0, -1.0f, 1.0f);
    CHECK(gv_vace_context_build(&v, video, T, H, W, GV_ANCHORS_BOTH, ctx) == 0);
    for (int k = 0; k < 2; k++) {
        for (int64_t i = 0; i < n; i++) {
            int f = (int)(i / plane % T), anchor = f == 0 || f == T - 1;
            part[i] = (k == 0) == anchor ? video[i] : 0.0f; /* inactive: anchors kept; reactive: the rest */
        }
        CHECK(gv_vae_encode(&v, part, T, H, W, 0, 4, k ? zr : zi) == 0);
    }
    CHECK(!memcmp(ctx, zi, nz * sizeof(float)) && !memcmp(ctx + nz, zr, nz * sizeof(float)));
    int ones = 1;
    for (int64_t i = 2 * nz; i < 2 * nz + (int64_t)mc * 2 * h * w; i++) ones &= ctx[i] == 1.0f;
    CHECK(ones);
    CHECK(mt_max_abs(zi, nz) > 0 && mt_max_abs_diff(zi, zr, nz) > 1e-3);
    CHECK_FAILS_WITH(gv_vace_context_build(&v, video, 4, H, W, GV_ANCHORS_BOTH, ctx), "1 + k x 4");
    CHECK_FAILS_WITH(gv_vace_context_build(&v, video, T, 12, W, GV_ANCHORS_BOTH, ctx), "spatial factor");
    free(video), free(part), free(zi), free(zr), free(ctx);
    gv_vae_free(&v);
}

static void expect_null(gv_dit *m, gv_dit_inputs *d, const char *needle)
{
    gv_graph g;
    gv_graph_init(&g, 0);
    gv_clear_error();
    gv_tensor *y = gv_dit_forward(m, &g, d);
    int ok = y == NULL && strstr(gv_last_error(), needle) != NULL;
    if (!ok) fprintf(stderr, "expected a failure mentioning '%s', got '%s'\n", needle, gv_last_error());
    CHECK(ok);
    gv_graph_free(&g);
}

static void test_bad_inputs(void)
{
    gv_dit m;
    CHECK(mt_model(&m, NULL, 81) == 0);
    gv_graph g;
    gv_graph_init(&g, 0);
    mt_inputs in, wide;
    CHECK(mt_make_inputs(&m, &g, NULL, 1, 5, 32, 32, 13, &in) == 0);
    CHECK(mt_make_inputs(&m, &g, NULL, 1, 5, 32, 64, 13, &wide) == 0);
    gv_dit_inputs d = mt_dit_inputs(&in);
    d.text = NULL;
    expect_null(&m, &d, "text context");
    d = mt_dit_inputs(&in);
    d.vace = wide.vace;
    expect_null(&m, &d, "VACE context");
    d = mt_dit_inputs(&in);
    d.plucker = wide.plucker;
    expect_null(&m, &d, "ray field");
    d = mt_dit_inputs(&in);
    d.latent = gv_tensor_new(&g, 5, (int[]){1, 4, 2, 3, 4});
    expect_null(&m, &d, "patch");
    d.latent = gv_tensor_new(&g, 4, (int[]){4, 2, 4, 4});
    expect_null(&m, &d, "latent");
    d = mt_dit_inputs(&in);
    d.timestep = NULL;
    expect_null(&m, &d, "timestep");
    gv_dit none;
    CHECK(mt_model(&none, "none", 82) == 0);
    d = mt_dit_inputs(&in);
    expect_null(&none, &d, "takes no cameras");
    gv_graph_free(&g);
    gv_dit_free(&none);
    gv_dit_free(&m);
}

int main(void)
{
    omp_set_num_threads(2);
    test_shapes();
    test_head_layout();
    test_zero_init();
    test_camera_stream_invariance();
    test_asymmetric_mask();
    test_camera_cache();
    test_rope_positions();
    test_per_frame();
    test_token_count();
    test_vace_context();
    test_vace_context_build();
    test_bad_inputs();
    return check_summary();
}
