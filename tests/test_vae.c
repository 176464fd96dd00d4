/* The causal 3D VAE (include/gaussvid/model/vae.h): the Wan presets' tensors match the published
 * list exactly (names, shapes, 126.9 M parameters) without allocating them; temporal packing
 * shapes; causality (a latent frame does not depend on later input frames, exactly); chunked
 * encoding and decoding through the caches equal one-shot; a gradient check of the tiny
 * encoder + decoder on parameters and the input; the latent normalisation; files. */
#include <omp.h>

#include "check.h"
#include "nn_testutil.h"
#include "gaussvid/core/core.h"
#include "gaussvid/nn/nn.h"
#include "gaussvid/io/safetensors.h"
#include "gaussvid/model/vae.h"
#include "model/vae_internal.h"

static const char *tmp;

static int tiny(gv_model_config *c)
{
    return gv_model_config_preset(c, "tiny");
}

/* Random video [3, T, H, W] in [-1, 1]. */
static float *random_video(int T, int H, int W, uint64_t seed)
{
    int64_t n = 3LL * T * H * W;
    float *x = malloc((size_t)n * sizeof *x);
    gv_fill_uniform(x, n, seed, 0, -1.0f, 1.0f);
    return x;
}

static double max_abs_diff(const float *a, const float *b, int64_t n)
{
    double m = 0;
    for (int64_t i = 0; i < n; i++) {
        double d = fabs((double)a[i] - b[i]);
        if (!(d <= m)) m = d;
    }
    return m;
}

static double max_abs(const float *a, int64_t n)
{
    double m = 0;
    for (int64_t i = 0; i < n; i++) m = fabs(a[i]) > m ? fabs(a[i]) : m;
    return m;
}

/* ---- layout ---------------------------------------------------------------------------------- */
static void test_layout(void)
{
    /* docs/reference/wan-vace-gaussvid.md 4.1: encoder 53,596,928 + decoder 73,295,603
     * (docs/MODEL.md, test_model_weights) */
    const char *presets[] = {"wan2.1-vace-1.3b", "wan2.1-vace-14b", "small", "tiny"};
    for (int p = 0; p < 4; p++) {
        gv_model_config c;
        CHECK(gv_model_config_preset(&c, presets[p]) == 0);
        gv_weight_list l;
        gv_weight_counts counts;
        CHECK(gv_weight_list_build(&l, &c) == 0);
        gv_weight_list_count(&l, &counts);
        int n_tensors = 0;
        int64_t n_params = 0;
        CHECK(gv_vae_check_layout(&c, &n_tensors, &n_params) == 0);
        int listed = counts.tensors[GV_MODULE_VAE_ENCODER] + counts.tensors[GV_MODULE_VAE_DECODER];
        int64_t listed_params = counts.params[GV_MODULE_VAE_ENCODER] + counts.params[GV_MODULE_VAE_DECODER];
        printf("layout %-18s %4d tensors, %lld parameters (list: %d, %lld)\n", presets[p], n_tensors,
               (long long)n_params, listed, (long long)listed_params);
        CHECK(n_tensors == listed && n_params == listed_params);
        if (p < 2) CHECK(n_params == 53596928LL + 73295603LL);
        gv_weight_list_free(&l);
    }
}

/* A list whose entry disagrees with the network: the binder names the tensor and both shapes;
 * a list entry the network leaves unused is named too. */
static void test_layout_mismatch(void)
{
    gv_model_config c;
    CHECK(tiny(&c) == 0);
    gv_weight_list l;
    CHECK(gv_weight_list_build(&l, &c) == 0);
    gv_weight_spec *w = (gv_weight_spec *)gv_weight_list_find(&l, "decoder.upsamples.0.residual.2.weight");
    CHECK(w != NULL);
    if (!w) return;
    w->shape[1] += 1;
    unsigned char used[4096] = {0};
    CHECK(l.n < 4096);
    gv_vae_binder b = {&l, NULL, used, 0, 0, 0, 0};
    gv_vae_coder dec = {0};
    gv_clear_error();
    CHECK(gv_vae_build_decoder(&b, &c.vae, &dec) != 0);
    CHECK(strstr(gv_last_error(), "decoder.upsamples.0.residual.2.weight") != NULL);
    CHECK(strstr(gv_last_error(), "the network needs [16, 16, 3, 3, 3]") != NULL);
    gv_vae_coder_free(&dec);
    gv_weight_list_free(&l);
}

/* ---- shapes ------------------------------------------------------------------------------------ */
static void test_shapes(void)
{
    gv_model_config c;
    CHECK(tiny(&c) == 0);
    gv_vae v;
    CHECK(gv_vae_init(&v, &c, 0, 7) == 0);
    const int H = 16, W = 24, s = v.cfg.spatial_factor, z = v.cfg.z_dim;
    for (int T = 1; T <= 9; T += 4) {
        int tl = 0;
        CHECK(gv_vae_latent_frames(&v.cfg, T, &tl) == 0 && tl == 1 + (T - 1) / 4);
        float *x = random_video(T, H, W, 1);
        float *lat = malloc(sizeof(float) * z * tl * (H / s) * (W / s));
        float *y = malloc(sizeof(float) * 3 * T * H * W);
        gv_graph g;
        gv_graph_init(&g, 1 << 20);
        const int shape[5] = {1, 3, T, H, W};
        gv_tensor *m = gv_vae_encoder_forward(&g, &v, gv_tensor_from(&g, 5, shape, x), NULL);
        CHECK(m && m->shape[1] == 2 * z && m->shape[2] == tl && m->shape[3] == H / s && m->shape[4] == W / s);
        gv_tensor *d = gv_vae_decoder_forward(&g, &v, gv_slice(&g, m, 1, 0, z), NULL);
        CHECK(d && d->shape[1] == 3 && d->shape[2] == T && d->shape[3] == H && d->shape[4] == W);
        CHECK(gv_vae_encode(&v, x, T, H, W, 0, 0, lat) == 0);
        CHECK(gv_vae_decode(&v, lat, tl, H / s, W / s, 0, 1, y) == 0);
        CHECK(max_abs(y, 3LL * T * H * W) <= 1.0);
        gv_graph_free(&g);
        free(x);
        free(lat);
        free(y);
    }
    int tl;
    CHECK_FAILS_WITH(gv_vae_latent_frames(&v.cfg, 4, &tl), "1 + k x 4");
    CHECK_FAILS_WITH(gv_vae_check_clip(&v.cfg, 5, 12, 16), "spatial factor 8");
    float dummy[1];
    CHECK_FAILS_WITH(gv_vae_encode(&v, dummy, 5, 16, 16, 0, 3, dummy), "multiple of the temporal factor");
    CHECK_FAILS_WITH(gv_vae_encode(&v, dummy, 5, 16, 16, 1, 0, dummy), "no latent statistics");
    gv_vae_free(&v);
}

/* ---- causality and chunking ------------------------------------------------------------------ */
static void encode_latent(gv_vae *v, const float *x, int T, int H, int W, int chunk, float *lat)
{
    CHECK(gv_vae_encode(v, x, T, H, W, 0, chunk, lat) == 0);
}

static void test_causality_and_chunks(void)
{
    gv_model_config c;
    CHECK(tiny(&c) == 0);
    gv_vae v;
    CHECK(gv_vae_init(&v, &c, 0, 11) == 0);
    const int T = 9, H = 16, W = 16, z = v.cfg.z_dim, tl = 3;
    const int64_t per_latent = (int64_t)(H / 8) * (W / 8), n_lat = (int64_t)z * tl * per_latent;
    const int64_t per_frame = (int64_t)H * W;
    float *x = random_video(T, H, W, 3), *lat = malloc(sizeof(float) * n_lat), *lat2 = malloc(sizeof(float) * n_lat);
    encode_latent(&v, x, T, H, W, 0, lat);

    /* changing the last frame (group 2) leaves latent frames 0 and 1 bit-identical */
    float *x2 = malloc(sizeof(float) * 3 * T * per_frame);
    memcpy(x2, x, sizeof(float) * 3 * T * per_frame);
    for (int ch = 0; ch < 3; ch++)
        for (int64_t i = 0; i < per_frame; i++) x2[(ch * T + 8) * per_frame + i] *= -0.5f;
    encode_latent(&v, x2, T, H, W, 0, lat2);
    int same_early = 1;
    double late = 0;
    for (int ch = 0; ch < z; ch++)
        for (int t = 0; t < tl; t++)
            for (int64_t i = 0; i < per_latent; i++) {
                int64_t k = ((int64_t)ch * tl + t) * per_latent + i;
                if (t < 2) same_early &= lat[k] == lat2[k];
                else late = fmax(late, fabs(lat[k] - lat2[k]));
            }
    CHECK(same_early);
    CHECK(late > 1e-4);
    /* changing frame 4 (group 1) leaves latent frame 0 identical and changes frame 1 */
    memcpy(x2, x, sizeof(float) * 3 * T * per_frame);
    for (int64_t i = 0; i < per_frame; i++) x2[(1 * T + 4) * per_frame + i] += 0.25f;
    encode_latent(&v, x2, T, H, W, 0, lat2);
    int same0 = 1;
    double diff1 = 0;
    for (int ch = 0; ch < z; ch++)
        for (int64_t i = 0; i < per_latent; i++) {
            int64_t k0 = ((int64_t)ch * tl + 0) * per_latent + i, k1 = ((int64_t)ch * tl + 1) * per_latent + i;
            same0 &= lat[k0] == lat2[k0];
            diff1 = fmax(diff1, fabs(lat[k1] - lat2[k1]));
        }
    CHECK(same0);
    CHECK(diff1 > 1e-4);

    /* chunked encoding (Wan's 1, 4, 4 and 1, 8) equals one shot */
    for (int chunk = 4; chunk <= 8; chunk += 4) {
        encode_latent(&v, x, T, H, W, chunk, lat2);
        double d = max_abs_diff(lat, lat2, n_lat), scale = max_abs(lat, n_lat);
        printf("chunked encode (1 + %d...) vs one shot: max |diff| %.3g (latent max %.3g)\n", chunk, d, scale);
        CHECK(d <= 1e-5 * (1 + scale));
    }
    /* decoding: one latent frame at a time equals one shot; output frames of latent group k
     * do not depend on later latent frames */
    float *y = malloc(sizeof(float) * 3 * T * per_frame), *y2 = malloc(sizeof(float) * 3 * T * per_frame);
    CHECK(gv_vae_decode(&v, lat, tl, H / 8, W / 8, 0, 0, y) == 0);
    CHECK(gv_vae_decode(&v, lat, tl, H / 8, W / 8, 0, 1, y2) == 0);
    double dd = max_abs_diff(y, y2, 3LL * T * per_frame);
    printf("chunked decode vs one shot: max |diff| %.3g\n", dd);
    CHECK(dd <= 1e-5);
    for (int ch = 0; ch < z; ch++)
        for (int64_t i = 0; i < per_latent; i++) lat[((int64_t)ch * tl + 2) * per_latent + i] += 1.0f;
    CHECK(gv_vae_decode(&v, lat, tl, H / 8, W / 8, 0, 0, y2) == 0);
    int same_frames = 1;
    double changed = 0;
    for (int ch = 0; ch < 3; ch++)
        for (int t = 0; t < T; t++)
            for (int64_t i = 0; i < per_frame; i++) {
                int64_t k = ((int64_t)ch * T + t) * per_frame + i;
                if (t < 5) same_frames &= y[k] == y2[k];
                else changed = fmax(changed, fabs(y[k] - y2[k]));
            }
    CHECK(same_frames);
    CHECK(changed > 1e-5);
    /* a stream refuses a chunk of another size */
    gv_vae_stream s;
    CHECK(gv_vae_stream_init(&s, v.encoder.n_slots) == 0);
    gv_graph g;
    gv_graph_init(&g, 1 << 20);
    gv_graph_set_grad(&g, 0);
    const int first[5] = {1, 3, 1, 16, 16}, other[5] = {1, 3, 4, 24, 16};
    CHECK(gv_vae_encoder_forward(&g, &v, gv_tensor_new(&g, 5, first), &s) != NULL);
    gv_clear_error();
    CHECK(gv_vae_encoder_forward(&g, &v, gv_tensor_new(&g, 5, other), &s) == NULL);
    CHECK(strstr(gv_last_error(), "does not continue the stream") != NULL);
    gv_graph_free(&g);
    gv_vae_stream_free(&s);
    free(x);
    free(x2);
    free(lat);
    free(lat2);
    free(y);
    free(y2);
    gv_vae_free(&v);
}

/* ---- gradient check -------------------------------------------------------------------------- */
typedef struct {
    gv_vae *v;
    gv_tensor *input;
} grad_ctx;

/* encoder moments and the decoded mean, side by side */
static gv_tensor *autoencode(gv_graph *g, void *p)
{
    grad_ctx *c = p;
    gv_tensor *m = gv_vae_encoder_forward(g, c->v, c->input, NULL);
    gv_tensor *y = gv_vae_decoder_forward(g, c->v, gv_slice(g, m, 1, 0, c->v->cfg.z_dim), NULL);
    const int flat_m[1] = {-1};
    gv_tensor *parts[2] = {gv_reshape(g, m, 1, flat_m), gv_reshape(g, y, 1, flat_m)};
    return gv_concat(g, parts, 2, 0);
}

static void test_gradients(void)
{
    gv_model_config c;
    CHECK(tiny(&c) == 0);
    gv_vae v;
    CHECK(gv_vae_init(&v, &c, 1, 5) == 0);
    /* the attention's zero-initialised proj would hide the attention path: make it non-zero */
    gv_param *proj[2] = {gv_params_find(&v.params, "encoder.middle.1.proj.weight"),
                         gv_params_find(&v.params, "decoder.middle.1.proj.weight")};
    for (int k = 0; k < 2; k++) {
        CHECK(proj[k] != NULL);
        if (proj[k]) gv_fill_uniform(proj[k]->t.data, proj[k]->t.numel, 40 + k, 0, -0.3f, 0.3f);
    }
    const int shape[5] = {1, 3, 5, 16, 16};
    grad_ctx ctx = {&v, gv_params_add(&v.params, "test.input", 5, shape, 1)};
    CHECK(ctx.input != NULL);
    gv_fill_uniform(ctx.input->data, ctx.input->numel, 9, 0, -1.0f, 1.0f);
    /* a few parameters: freeze all but one tensor of each kind of block, and the input */
    const char *checked[] = {"encoder.conv1.weight", "encoder.downsamples.0.residual.0.gamma",
                             "encoder.downsamples.1.resample.1.weight", "encoder.downsamples.3.time_conv.weight",
                             "encoder.middle.1.to_qkv.weight", "encoder.head.2.bias", "conv1.weight", "conv2.weight",
                             "decoder.middle.1.proj.weight", "decoder.upsamples.2.time_conv.weight",
                             "decoder.upsamples.2.resample.1.bias", "decoder.upsamples.6.shortcut.weight",
                             "decoder.upsamples.8.resample.1.weight", "decoder.head.2.weight", "test.input"};
    const int n_checked = sizeof checked / sizeof checked[0];
    for (int i = 0; i < v.params.n; i++) {
        int keep = 0;
        for (int k = 0; k < n_checked; k++) keep |= !strcmp(v.params.items[i]->t.name, checked[k]);
        gv_param_set_trainable(v.params.items[i], keep);
    }
    CHECK(gv_params_count(&v.params, 1) > 0);
    for (int k = 0; k < n_checked; k++) CHECK(gv_params_find(&v.params, checked[k]) != NULL);
    gv_gradcheck_opts o = gv_gradcheck_defaults();
    o.max_per_tensor = 4;
    o.h = 1e-2; /* a bias moves thousands of outputs: larger steps see the curvature */
    o.atol = 1e-2; /* float32 noise of the numeric side at this step */
    o.rtol = 3e-2;
    nt_gradcheck("vae encoder + decoder (tiny)", &v.params, autoencode, &ctx, &o);
    gv_vae_free(&v);
}

/* ---- normalisation ------------------------------------------------------------------------------ */
static void test_normalisation(void)
{
    gv_model_config c;
    CHECK(tiny(&c) == 0);
    gv_vae v;
    CHECK(gv_vae_init(&v, &c, 0, 3) == 0);
    double mean[4] = {0.5, -1.25, 2.0, 0.0}, std[4] = {2.0, 0.5, 1.5, 3.0}, bad[4] = {1, 1, 0, 1};
    CHECK_FAILS_WITH(gv_vae_set_stats(&v, mean, bad), "channel 2");
    CHECK(gv_vae_set_stats(&v, mean, std) == 0);
    const int T = 5, H = 16, W = 16, tl = 2, n = 4 * tl * 4;
    float *x = random_video(T, H, W, 8), raw[32], z[32], back[32];
    CHECK(gv_vae_encode(&v, x, T, H, W, 0, 0, raw) == 0);
    CHECK(gv_vae_encode(&v, x, T, H, W, 1, 4, z) == 0);
    double worst = 0;
    for (int i = 0; i < n; i++) {
        int ch = i / (tl * 4);
        worst = fmax(worst, fabs(z[i] - (raw[i] - mean[ch]) / std[ch]));
    }
    CHECK(worst < 1e-5);
    gv_graph g;
    gv_graph_init(&g, 1 << 16);
    const int shape[5] = {1, 4, tl, 2, 2};
    gv_tensor *r = gv_vae_denormalize(&g, &v, gv_vae_normalize(&g, &v, gv_tensor_from(&g, 5, shape, raw)));
    CHECK(r != NULL);
    if (r) memcpy(back, r->data, sizeof back);
    CHECK(r && max_abs_diff(back, raw, n) < 1e-5);
    /* decoding a normalised latent undoes the normalisation first */
    float *y1 = malloc(sizeof(float) * 3 * T * H * W), *y2 = malloc(sizeof(float) * 3 * T * H * W);
    CHECK(gv_vae_decode(&v, raw, tl, 2, 2, 0, 0, y1) == 0);
    CHECK(gv_vae_decode(&v, z, tl, 2, 2, 1, 0, y2) == 0);
    CHECK(max_abs_diff(y1, y2, 3LL * T * H * W) < 1e-4);
    gv_graph_free(&g);
    free(x);
    free(y1);
    free(y2);
    gv_vae_free(&v);
}

/* ---- files --------------------------------------------------------------------------------------- */
static int write_without(const gv_vae *v, const char *path, const char *drop, const char *reshape,
                         const char *extra, const char *mean_text)
{
    gv_st_builder b;
    gv_st_builder_init(&b);
    int rc = 0;
    for (int i = 0; i < v->params.n && rc == 0; i++) {
        const gv_tensor *x = &v->params.items[i]->t;
        if (drop && !strcmp(x->name, drop)) continue;
        int64_t shape[5];
        for (int k = 0; k < x->ndim; k++) shape[k] = x->shape[k];
        int64_t flat[1] = {x->numel};
        if (reshape && !strcmp(x->name, reshape)) rc = gv_st_add_f32(&b, x->name, GV_ST_F32, flat, 1, x->data);
        else rc = gv_st_add_f32(&b, x->name, GV_ST_BF16, shape, x->ndim, x->data);
    }
    float one = 1;
    int64_t s1[1] = {1};
    if (extra) rc |= gv_st_add_f32(&b, extra, GV_ST_F32, s1, 1, &one);
    if (mean_text) {
        rc |= gv_st_add_metadata(&b, "latent_mean", mean_text);
        rc |= gv_st_add_metadata(&b, "latent_std", "[1, 1, 1, 1]");
    }
    if (rc == 0) rc = gv_st_write(&b, path);
    gv_st_builder_free(&b);
    return rc;
}

static void test_files(void)
{
    gv_model_config c;
    CHECK(tiny(&c) == 0);
    gv_vae a, b;
    CHECK(gv_vae_init(&a, &c, 1, 21) == 0);
    CHECK(gv_vae_init(&b, &c, 0, 22) == 0);
    double mean[4] = {0.1, 0.2, 0.3, 0.4}, std[4] = {1, 2, 3, 4};
    CHECK(gv_vae_set_stats(&a, mean, std) == 0);
    char path[4200];
    snprintf(path, sizeof path, "%s/vae.safetensors", tmp);
    const char *keys[1] = {"step"}, *values[1] = {"12"};
    CHECK(gv_vae_save(&a, &c, path, keys, values, 1) == 0);
    CHECK(gv_vae_load(&b, path, 0) == 0);
    int same = a.params.n == b.params.n;
    for (int i = 0; same && i < a.params.n; i++)
        same = !memcmp(a.params.items[i]->t.data, gv_params_find(&b.params, a.params.items[i]->t.name)->t.data,
                       sizeof(float) * a.params.items[i]->t.numel);
    CHECK(same);
    CHECK(b.has_stats && b.std[3] == 4.0f && b.mean[2] == 0.3f);
    gv_model_config back;
    CHECK(gv_vae_file_config(path, &back) == 0);
    CHECK(back.vae.has_latent_stats && back.vae.latent_std[1] == 2.0 && back.vae.dim == c.vae.dim);

    /* the same weights as BF16 load (rounded) */
    snprintf(path, sizeof path, "%s/bf16.safetensors", tmp);
    CHECK(write_without(&a, path, NULL, NULL, NULL, NULL) == 0);
    CHECK(gv_vae_load(&b, path, 0) == 0);
    CHECK_FAILS_WITH(gv_vae_file_config(path, &back), "no \"config\" metadata");
    /* missing, unexpected, mis-shaped tensors and bad statistics fail naming them */
    snprintf(path, sizeof path, "%s/missing.safetensors", tmp);
    CHECK(write_without(&a, path, "decoder.head.2.bias", NULL, NULL, NULL) == 0);
    CHECK_FAILS_WITH(gv_vae_load(&b, path, 0), "1 missing (decoder.head.2.bias)");
    snprintf(path, sizeof path, "%s/extra.safetensors", tmp);
    CHECK(write_without(&a, path, NULL, NULL, "blocks.0.modulation", NULL) == 0);
    CHECK_FAILS_WITH(gv_vae_load(&b, path, 0), "1 unexpected (blocks.0.modulation)");
    CHECK(gv_vae_load(&b, path, 1) == 0);
    snprintf(path, sizeof path, "%s/shape.safetensors", tmp);
    CHECK(write_without(&a, path, NULL, "encoder.conv1.weight", NULL, NULL) == 0);
    CHECK_FAILS_WITH(gv_vae_load(&b, path, 0), "encoder.conv1.weight is F32 [648]");
    snprintf(path, sizeof path, "%s/stats.safetensors", tmp);
    CHECK(write_without(&a, path, NULL, NULL, NULL, "[1, 2, 3]") == 0);
    CHECK_FAILS_WITH(gv_vae_load(&b, path, 0), "latent_mean is not an array of 4 numbers");
    snprintf(path, sizeof path, "%s/none.safetensors", tmp);
    CHECK_FAILS_WITH(gv_vae_load(&b, path, 0), "none.safetensors");
    gv_vae_free(&a);
    gv_vae_free(&b);
}

int main(void)
{
    tmp = check_tmp_dir();
    omp_set_num_threads(1); /* tensors this small only lose time to thread hand-offs */
    test_layout();
    test_layout_mismatch();
    test_shapes();
    test_causality_and_chunks();
    test_gradients();
    test_normalisation();
    test_files();
    return check_summary();
}
