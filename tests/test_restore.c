/* Restoration (restore.h): the samplers' time grids against the reference's table, their math
 * on exact velocities (one step returns z0*; Euler ends at (1 - t0) z-hat + t0 z0*, docs/ARCHITECTURE.md 7),
 * noise averaging, reproducibility, the camera cache, both compositions against our own
 * decoding, the identity check (residual composition gives the baseline exactly), the
 * evaluation table against PSNR computed here, its JSON and Markdown, bad inputs, and clips of
 * odd sizes (padded to the network's block and cropped back). */
#include <cjson/cJSON.h>

#include <omp.h>

#include "check.h"
#include "model_testutil.h"
#include "test_restore_fixtures.h"
#include "gaussvid/eval/eval.h"
#include "gaussvid/io/metrics.h"
#include "gaussvid/restore/restore.h"

#define W 32
#define H 32

/* ---- fake networks ------------------------------------------------------------------------ */
typedef struct {
    const float *z_hat, *z_star;
    int64_t n;
    uint64_t seed;   /* the noise stream, for the fakes that know the noise */
    int samples;
    int calls;
    int fail_at;     /* return -1 at this call (0: never) */
} fake;

/* Exact for the training path: eps recovered from x = (1 - s) z-hat + s eps, v = eps - z0*. */
static int fake_from_x(void *ctx, const float *x, double sigma, float *v)
{
    fake *f = ctx;
    f->calls++;
    for (int64_t i = 0; i < f->n; i++) v[i] = (float)((x[i] - (1 - sigma) * f->z_hat[i]) / sigma - f->z_star[i]);
    return 0;
}

/* Knows the noise of call k (restore.h: position k n of the stream): v = eps_k - z0*. */
static int fake_knows_noise(void *ctx, const float *x, double sigma, float *v)
{
    fake *f = ctx;
    if (++f->calls == f->fail_at) return gv_fail("fake network failed");
    gv_fill_normal(v, f->n, f->seed, (uint64_t)(f->calls - 1) * (uint64_t)f->n, 0.0f, 1.0f);
    for (int64_t i = 0; i < f->n; i++) v[i] -= f->z_star[i];
    return 0;
}

/* The noise of the first call at every call: the constant velocity of an ODE path. */
static int fake_knows_noise_const(void *ctx, const float *x, double sigma, float *v)
{
    fake *f = ctx;
    f->calls++;
    gv_fill_normal(v, f->n, f->seed, 0, 0.0f, 1.0f);
    for (int64_t i = 0; i < f->n; i++) v[i] -= f->z_star[i];
    return 0;
}

static int fake_half_x(void *ctx, const float *x, double sigma, float *v)
{
    fake *f = ctx;
    f->calls++;
    for (int64_t i = 0; i < f->n; i++) v[i] = 0.5f * x[i];
    return 0;
}

static void test_sigmas(void)
{
    /* docs/reference/wan-vace-gaussvid.md 5.4: strength 0.2, shift 5, 10 steps */
    const double table[11] = {0.55556, 0.52326, 0.48780, 0.44872, 0.40541, 0.35714,
                              0.30303, 0.24194, 0.17241, 0.09259, 0.0};
    gv_sampler s;
    double sig[GV_SAMPLER_MAX_STEPS + 1];
    CHECK(gv_sampler_from_name("released", &s) == 0 && s.kind == GV_SAMPLER_EULER && s.steps == 10);
    CHECK(gv_sampler_sigmas(&s, sig) == 0);
    for (int k = 0; k < 11; k++) CHECK_NEAR(sig[k], table[k], 5e-6);
    CHECK(gv_sampler_from_name("iterate", &s) == 0);
    s.t0 = 0.3, s.steps = 3, s.shift = 1;
    CHECK(gv_sampler_sigmas(&s, sig) == 0);
    CHECK_NEAR(sig[0], 0.3, 0);
    CHECK_NEAR(sig[1], 0.2, 1e-12);
    CHECK_NEAR(sig[2], 0.1, 1e-12);
    CHECK_NEAR(sig[3], 0.0, 0);
    s = gv_sampler_default();
    CHECK(s.kind == GV_SAMPLER_ONESTEP && gv_sampler_sigmas(&s, sig) == 0 && sig[0] == s.t0 && sig[1] == 0);
}

static void test_sampler_math(void)
{
    enum { N = 300 };
    float z_hat[N], z_star[N], out[N], eps[N];
    gv_fill_normal(z_hat, N, 1, 0, 0.2f, 1.0f);
    gv_fill_normal(z_star, N, 2, 0, -0.1f, 0.8f);
    fake f = {z_hat, z_star, N, 77, 1, 0, 0};
    gv_sampler s = gv_sampler_default();
    s.samples = 1; /* the fake knows the noise of the first draw only */
    /* one step of an exact network gives z0* */
    for (int k = 0; k < 3; k++) {
        s.t0 = 0.1 + 0.15 * k;
        f.calls = 0;
        CHECK(gv_sample(&s, fake_from_x, &f, z_hat, N, 77, out) == 0 && f.calls == 1);
        CHECK_NEAR(rf_max_diff(out, z_star, N), 0, 2e-5);
    }
    /* blend 0.25: a quarter of the way from z-hat to z0* */
    s.t0 = 0.3, s.blend = 0.25;
    CHECK(gv_sample(&s, fake_from_x, &f, z_hat, N, 77, out) == 0);
    double far = 0;
    for (int i = 0; i < N; i++) far = fmax(far, fabs(out[i] - (z_hat[i] + 0.25 * (z_star[i] - z_hat[i]))));
    CHECK_NEAR(far, 0, 1e-5);
    /* iterate: every step gives z0* again */
    CHECK(gv_sampler_from_name("iterate", &s) == 0);
    s.steps = 4;
    f.calls = 0;
    CHECK(gv_sample(&s, fake_knows_noise, &f, z_hat, N, 77, out) == 0 && f.calls == 4);
    CHECK_NEAR(rf_max_diff(out, z_star, N), 0, 1e-6);
    /* Euler on the same velocity stops at (1 - t0) z-hat + t0 z0*, not z0* (docs/ARCHITECTURE.md 7) */
    CHECK(gv_sampler_from_name("released", &s) == 0);
    f.calls = 0;
    CHECK(gv_sample(&s, fake_knows_noise_const, &f, z_hat, N, 77, out) == 0 && f.calls == 10);
    double worst = 0;
    for (int i = 0; i < N; i++) {
        double want = (1 - s.t0) * z_hat[i] + s.t0 * z_star[i];
        if (fabs(out[i] - want) > worst) worst = fabs(out[i] - want);
    }
    CHECK_NEAR(worst, 0, 1e-5);
    CHECK(rf_max_diff(out, z_star, N) > 0.1);
    /* two noise draws averaged: z = mean_j (eps_j - 0.5 x_j), x_j = (1 - t) z-hat + t eps_j */
    CHECK(gv_sampler_from_name("onestep", &s) == 0);
    s.samples = 2, s.t0 = 0.25;
    CHECK(gv_sample(&s, fake_half_x, &f, z_hat, N, 5, out) == 0);
    double want[N] = {0};
    for (int j = 0; j < 2; j++) {
        gv_fill_normal(eps, N, 5, (uint64_t)j * N, 0.0f, 1.0f);
        for (int i = 0; i < N; i++) want[i] += 0.5 * (eps[i] - 0.5 * (0.75 * z_hat[i] + 0.25 * eps[i]));
    }
    worst = 0;
    for (int i = 0; i < N; i++)
        if (fabs(out[i] - want[i]) > worst) worst = fabs(out[i] - want[i]);
    CHECK_NEAR(worst, 0, 1e-5);
    /* identity: z-hat itself, the network never called */
    CHECK(gv_sampler_from_name("identity", &s) == 0);
    f.calls = 0;
    CHECK(gv_sample(&s, fake_from_x, &f, z_hat, N, 5, out) == 0 && f.calls == 0 && !memcmp(out, z_hat, sizeof out));
    /* a failing network fails the sampler */
    CHECK(gv_sampler_from_name("iterate", &s) == 0);
    f.calls = 0, f.fail_at = 2;
    CHECK_FAILS_WITH(gv_sample(&s, fake_knows_noise, &f, z_hat, N, 77, out), "fake network failed");
}

/* ---- the tiny network on a clip ------------------------------------------------------------- */
typedef struct {
    gv_restorer r; /* cfg, vae and net made here instead of loaded */
    gv_clip clip;
    gv_clip_latents l;
} setup;

static int setup_make(setup *s, const char *variant, uint64_t seed)
{
    memset(s, 0, sizeof *s);
    if (rf_tiny(&s->r.cfg, &s->r.vae, variant, seed) || gv_dit_init(&s->r.net, &s->r.cfg, seed)) return -1;
    mt_randomize(&s->r.net, MT_ALL, seed + 1); /* a stand-in for trained weights */
    if (rf_make_clip(&s->clip, "room", "eval", 6, W, H, 40, seed)) return -1;
    return gv_clip_latents_prepare(&s->r.vae, &s->r.cfg, &s->clip, &s->l);
}

static void setup_free(setup *s)
{
    gv_clip_latents_free(&s->l);
    gv_clip_free(&s->clip);
    gv_restorer_free(&s->r);
}

static void test_network(void)
{
    const char *variants[3] = {NULL, "none", "per-frame"};
    for (int k = 0; k < 3; k++) {
        setup s;
        CHECK(setup_make(&s, variants[k], 20 + k) == 0);
        int64_t n = gv_clip_latents_z_count(&s.l);
        float *a = malloc((size_t)n * 4), *b = malloc((size_t)n * 4), *c = malloc((size_t)n * 4);
        gv_sampler sp;
        CHECK(gv_sampler_from_name("iterate", &sp) == 0);
        sp.steps = 2;
        /* reproducible; another seed gives another result */
        CHECK(gv_restore_latent(&s.r.net, &s.l, &sp, 11, a) == 0 && gv_restore_latent(&s.r.net, &s.l, &sp, 11, b) == 0);
        CHECK(!memcmp(a, b, (size_t)n * 4));
        CHECK(gv_restore_latent(&s.r.net, &s.l, &sp, 12, c) == 0 && memcmp(a, c, (size_t)n * 4));
        CHECK(rf_max_diff(a, s.l.z_corrupt, n) > 1e-3);
        /* the camera stream computed once gives the recomputed result bit for bit */
        gv_restore_net net;
        CHECK(gv_restore_net_init(&net, &s.r.net, &s.l, 0) == 0 && net.has_cache == 0);
        CHECK(gv_sample(&sp, gv_restore_net_velocity, &net, s.l.z_corrupt, n, 11, c) == 0 && net.evaluations == 2);
        CHECK(!memcmp(a, c, (size_t)n * 4));
        gv_restore_net_free(&net);
        CHECK(gv_restore_net_init(&net, &s.r.net, &s.l, 1) == 0 && net.has_cache == (k != 1));
        gv_restore_net_free(&net);
        /* identity: z-hat */
        CHECK(gv_sampler_from_name("identity", &sp) == 0);
        CHECK(gv_restore_latent(&s.r.net, &s.l, &sp, 11, c) == 0 && !memcmp(c, s.l.z_corrupt, (size_t)n * 4));
        free(a), free(b), free(c);
        setup_free(&s);
    }
}

/* Decoded and residual composition against our own decoding of the latents. */
static void test_compose(void)
{
    const char *variants[2] = {NULL, "per-frame"};
    for (int k = 0; k < 2; k++) {
        setup s;
        CHECK(setup_make(&s, variants[k], 30 + k) == 0);
        const int64_t n = gv_clip_latents_z_count(&s.l), plane = W * H, fb = plane * 3;
        float *z = malloc((size_t)n * 4);
        for (int64_t i = 0; i < n; i++) z[i] = s.l.z_corrupt[i] + 0.3f * (float)sin(0.37 * (double)i);
        uint8_t *dec = malloc((size_t)(5 * fb)), *res = malloc((size_t)(5 * fb)), *ident = malloc((size_t)(5 * fb));
        CHECK(gv_restore_compose(&s.r.vae, &s.clip, &s.l, z, GV_COMPOSE_DECODED, 0, dec) == 0);
        CHECK(gv_restore_compose(&s.r.vae, &s.clip, &s.l, z, GV_COMPOSE_RESIDUAL, 0, res) == 0);
        CHECK(gv_restore_compose(&s.r.vae, &s.clip, &s.l, s.l.z_corrupt, GV_COMPOSE_RESIDUAL, 0, ident) == 0);
        /* identity under residual composition: the input clip, exactly */
        CHECK(!memcmp(ident, s.clip.inputs, (size_t)(5 * fb)));
        /* anchors are the input's */
        CHECK(!memcmp(dec, s.clip.inputs, (size_t)fb) && !memcmp(dec + 4 * fb, s.clip.inputs + 4 * fb, (size_t)fb));
        CHECK(!memcmp(res, s.clip.inputs, (size_t)fb) && !memcmp(res + 4 * fb, s.clip.inputs + 4 * fb, (size_t)fb));
        /* the intermediates, from decodings made here */
        int frames = k == 0 ? 5 : 1, videos = k == 0 ? 1 : 3;
        float *d1 = malloc((size_t)(3 * frames * plane) * 4), *d2 = malloc((size_t)(3 * frames * plane) * 4);
        int bad_dec = 0, bad_res = 0, changed = 0;
        for (int b = 0; b < videos; b++) {
            int64_t per = n / videos;
            CHECK(gv_vae_decode(&s.r.vae, z + b * per, s.l.latent_frames, 4, 4, 1, 0, d1) == 0);
            CHECK(gv_vae_decode(&s.r.vae, s.l.z_corrupt + b * per, s.l.latent_frames, 4, 4, 1, 0, d2) == 0);
            for (int f = 1; f <= 3; f++) {
                if (k == 1 && f != 1 + b) continue;
                int vf = k == 0 ? f : 0;
                for (int64_t p = 0; p < plane; p++)
                    for (int c = 0; c < 3; c++) {
                        double x = d1[((int64_t)c * frames + vf) * plane + p], e = d2[((int64_t)c * frames + vf) * plane + p];
                        double r = s.clip.inputs[f * fb + p * 3 + c];
                        double want_dec = fmin(255, fmax(0, floor((x + 1) * 127.5 + 0.5)));
                        double want_res = fmin(255, fmax(0, floor(r + (x - e) * 127.5 + 0.5)));
                        /* one-shot here, chunked there: allow one 8-bit step where rounding differs */
                        bad_dec += fabs(dec[f * fb + p * 3 + c] - want_dec) > 1;
                        bad_res += fabs(res[f * fb + p * 3 + c] - want_res) > 1;
                        changed += res[f * fb + p * 3 + c] != r;
                    }
            }
        }
        CHECK(bad_dec == 0 && bad_res == 0 && changed > 100);
        /* unseen: residual's bytes where no anchor sees the pixel, the render's where one does */
        uint8_t *uns = malloc((size_t)(5 * fb));
        CHECK_FAILS_WITH(gv_restore_compose(&s.r.vae, &s.clip, &s.l, z, GV_COMPOSE_UNSEEN, 0, uns), "coverage plane");
        s.clip.coverage = malloc((size_t)(3 * plane));
        for (int64_t i = 0; i < 3 * plane; i++) s.clip.coverage[i] = (uint8_t)((i * 7 + i / 5) % 4); /* 0..3: a quarter unseen */
        CHECK(gv_restore_compose(&s.r.vae, &s.clip, &s.l, z, GV_COMPOSE_UNSEEN, 0, uns) == 0);
        int bad_uns = 0, unseen_changed = 0;
        for (int f = 0; f < 5; f++)
            for (int64_t p = 0; p < plane; p++) {
                int kept = f == 0 || f == 4 || s.clip.coverage[(f - 1) * plane + p];
                const uint8_t *want = kept ? s.clip.inputs + f * fb + p * 3 : res + f * fb + p * 3;
                bad_uns += memcmp(uns + f * fb + p * 3, want, 3) != 0;
                unseen_changed += !kept && memcmp(want, s.clip.inputs + f * fb + p * 3, 3) != 0;
            }
        CHECK(bad_uns == 0 && unseen_changed > 20);
        free(uns);
        free(d1), free(d2), free(z), free(dec), free(res), free(ident);
        setup_free(&s);
    }
}

/* PSNR of two 8-bit frames computed here: -10 log10(mean ((a - b) / 255)^2). */
static double psnr_here(const uint8_t *a, const uint8_t *b, int64_t count)
{
    double se = 0;
    for (int64_t i = 0; i < count; i++) se += ((a[i] - b[i]) / 255.0) * ((a[i] - b[i]) / 255.0);
    return -10 * log10(se / count);
}

static void test_eval_table(const char *tmp)
{
    /* three clips at n = 8, 6, 6 with a "restored" version each: the targets with a little noise */
    gv_eval_table t;
    gv_eval_init(&t, NULL);
    const int ns[3] = {8, 6, 6};
    const int64_t fb = (int64_t)W * H * 3;
    double want[3][2] = {{0}}; /* per row (n = 6, n = 8, mean): baseline, restored PSNR sums */
    double ssim_rest_sum = 0;
    for (int k = 0; k < 3; k++) {
        gv_clip clip;
        CHECK(rf_make_clip(&clip, "room", "eval", ns[k], W, H, 30 + 20 * k, 40 + k) == 0);
        uint8_t *rest = malloc((size_t)(5 * fb));
        for (int64_t i = 0; i < 5 * fb; i++) rest[i] = (uint8_t)(clip.targets[i] ^ (i % 7 == k ? 3 : 0));
        CHECK(gv_eval_add(&t, &clip, rest) == 0);
        int row = ns[k] == 6 ? 0 : 1;
        for (int f = 1; f <= 3; f++) {
            double pb = psnr_here(clip.inputs + f * fb, clip.targets + f * fb, fb);
            double pr = psnr_here(rest + f * fb, clip.targets + f * fb, fb);
            want[row][0] += pb, want[row][1] += pr, want[2][0] += pb, want[2][1] += pr;
            float *x = malloc((size_t)fb * 4), *y = malloc((size_t)fb * 4);
            for (int64_t i = 0; i < fb; i++) x[i] = rest[f * fb + i] / 255.0f, y[i] = clip.targets[f * fb + i] / 255.0f;
            ssim_rest_sum += gv_ssim(x, y, W, H, 3);
            free(x), free(y);
        }
        free(rest);
        gv_clip_free(&clip);
    }
    gv_eval_finish(&t);
    CHECK(t.n_rows == 2 && t.rows[0].interval == 6 && t.rows[1].interval == 8 && t.rows[0].clips == 2 && t.rows[1].clips == 1);
    CHECK(t.mean.clips == 3 && t.mean.frames == 9);
    CHECK_NEAR(t.rows[0].psnr_base, want[0][0] / 6, 1e-5);
    CHECK_NEAR(t.rows[0].psnr_rest, want[0][1] / 6, 1e-5);
    CHECK_NEAR(t.rows[1].psnr_base, want[1][0] / 3, 1e-5);
    CHECK_NEAR(t.mean.psnr_base, want[2][0] / 9, 1e-5);
    CHECK_NEAR(t.mean.psnr_rest, want[2][1] / 9, 1e-5);
    CHECK_NEAR(t.mean.ssim_rest, ssim_rest_sum / 9, 1e-12);
    CHECK(t.mean.psnr_rest > t.mean.psnr_base && t.mean.ssim_rest > t.mean.ssim_base);
    CHECK_FAILS_WITH(gv_eval_add(&t, NULL, NULL), "already finished");
    /* a clip with frames without ground truth (target_mask): only frame 2 is measured */
    gv_eval_table masked;
    gv_eval_init(&masked, NULL);
    gv_clip clip;
    CHECK(rf_make_clip(&clip, "room", "train", 12, W, H, 30, 41) == 0);
    clip.info.no_target[1] = clip.info.no_target[3] = 1;
    CHECK(gv_eval_add(&masked, &clip, clip.targets) == 0);
    gv_eval_finish(&masked);
    CHECK(masked.mean.clips == 1 && masked.mean.frames == 1);
    CHECK_NEAR(masked.mean.psnr_base, psnr_here(clip.inputs + 2 * fb, clip.targets + 2 * fb, fb), 1e-5);
    gv_clip_free(&clip);
    /* JSON: the means and the per-n table */
    char path[4200];
    snprintf(path, sizeof path, "%s/eval.json", tmp);
    const char *keys[1] = {"sampler"}, *values[1] = {"onestep t0=0.3"};
    CHECK(gv_eval_write_json(&t, path, keys, values, 1) == 0);
    char *text;
    size_t size;
    CHECK(gv_read_file(path, &text, &size) == 0);
    cJSON *root = cJSON_Parse(text);
    free(text);
    const cJSON *b = cJSON_GetObjectItem(root, "baseline"), *r = cJSON_GetObjectItem(root, "restored");
    const cJSON *per_n = cJSON_GetObjectItem(root, "per_n");
    CHECK(cJSON_IsObject(b) && cJSON_IsObject(r) && cJSON_GetArraySize(per_n) == 2);
    CHECK_NEAR(cJSON_GetObjectItem(b, "psnr")->valuedouble, t.mean.psnr_base, 1e-9);
    CHECK_NEAR(cJSON_GetObjectItem(r, "ssim")->valuedouble, t.mean.ssim_rest, 1e-12);
    CHECK(cJSON_GetObjectItem(r, "clips")->valueint == 3);
    const cJSON *row8 = cJSON_GetArrayItem(per_n, 1);
    CHECK(cJSON_GetObjectItem(row8, "n")->valueint == 8 && cJSON_GetObjectItem(row8, "clips")->valueint == 1);
    CHECK_NEAR(cJSON_GetObjectItem(cJSON_GetObjectItem(row8, "restored"), "psnr")->valuedouble, t.rows[1].psnr_rest, 1e-9);
    CHECK(!strcmp(cJSON_GetObjectItem(root, "sampler")->valuestring, "onestep t0=0.3"));
    CHECK(cJSON_GetObjectItem(b, "lpips") == NULL);
    cJSON_Delete(root);
    /* Markdown: header, separator, one line per n, the mean */
    FILE *md = tmpfile();
    gv_eval_print_markdown(&t, md);
    rewind(md);
    char line[512];
    int lines = 0, mean_ok = 0;
    while (fgets(line, sizeof line, md)) {
        lines++;
        if (strstr(line, "| **mean** | 3 |")) mean_ok = 1;
    }
    fclose(md);
    CHECK(lines == 5 && mean_ok);
    snprintf(path, sizeof path, "%s/missing/eval.json", tmp);
    CHECK_FAILS_WITH(gv_eval_write_json(&t, path, NULL, NULL, 0), "missing");
    gv_eval_table open;
    gv_eval_init(&open, NULL);
    CHECK_FAILS_WITH(gv_eval_write_json(&open, path, NULL, NULL, 0), "not finished");
}

/* AlexNet-LPIPS with random weights (lpips.h layout), in memory: He-scaled convolutions,
 * non-negative heads. */
static int random_lpips(gv_lpips *net, uint64_t seed)
{
    static const int c_in[5] = {3, 64, 192, 384, 256}, c_out[5] = {64, 192, 384, 256, 256}, k[5] = {11, 5, 3, 3, 3};
    memset(net, 0, sizeof *net);
    size_t total = 0;
    for (int l = 0; l < 5; l++) total += (size_t)c_out[l] * c_in[l] * k[l] * k[l] + 2 * (size_t)c_out[l];
    if (!(net->params = malloc(total * sizeof(float)))) return -1;
    net->n_params = total;
    float *p = net->params;
    for (int l = 0; l < 5; l++) {
        int64_t nw = (int64_t)c_out[l] * c_in[l] * k[l] * k[l];
        net->conv_weight[l] = p, gv_fill_normal(p, nw, seed, 0, 0.0f, sqrtf(2.0f / (c_in[l] * k[l] * k[l]))), p += nw;
        net->conv_bias[l] = p, gv_fill_normal(p, c_out[l], seed + 1, 0, 0.0f, 0.1f), p += c_out[l];
        net->lin_weight[l] = p, gv_fill_uniform(p, c_out[l], seed + 2, 0, 0.0f, 1.0f), p += c_out[l];
        seed += 3;
    }
    return 0;
}

/* With LPIPS weights the table averages each frame's LPIPS, computed here per frame. */
static void test_eval_lpips(const char *tmp)
{
    gv_lpips net;
    CHECK(random_lpips(&net, 9) == 0);
    gv_eval_table t;
    gv_eval_init(&t, &net);
    double want[2] = {0, 0};
    const int64_t fb = (int64_t)W * H * 3;
    for (int k = 0; k < 2; k++) {
        gv_clip clip;
        CHECK(rf_make_clip(&clip, "room", "eval", 6 + 2 * k, W, H, 50, 60 + k) == 0);
        uint8_t *rest = malloc((size_t)(5 * fb));
        for (int64_t i = 0; i < 5 * fb; i++) rest[i] = (uint8_t)((clip.targets[i] + clip.inputs[i] + 1) / 2);
        CHECK(gv_eval_add(&t, &clip, rest) == 0);
        for (int f = 1; f <= 3; f++) {
            gv_image truth = {W, H, 3, clip.targets + f * fb}, in = {W, H, 3, clip.inputs + f * fb}, re = {W, H, 3, rest + f * fb};
            double a = -1, b = -1;
            CHECK(gv_lpips_distance(&net, &in, &truth, &a) == 0 && gv_lpips_distance(&net, &re, &truth, &b) == 0);
            want[0] += a, want[1] += b;
        }
        free(rest);
        gv_clip_free(&clip);
    }
    gv_eval_finish(&t);
    CHECK_NEAR(t.mean.lpips_base, want[0] / 6, 1e-12);
    CHECK_NEAR(t.mean.lpips_rest, want[1] / 6, 1e-12);
    CHECK(t.mean.lpips_base > 0 && t.mean.lpips_rest < t.mean.lpips_base && t.rows[1].lpips_rest > 0);
    char path[4200];
    snprintf(path, sizeof path, "%s/lpips.json", tmp);
    CHECK(gv_eval_write_json(&t, path, NULL, NULL, 0) == 0);
    char *text;
    size_t size;
    CHECK(gv_read_file(path, &text, &size) == 0);
    cJSON *root = cJSON_Parse(text);
    free(text);
    CHECK_NEAR(cJSON_GetObjectItem(cJSON_GetObjectItem(root, "restored"), "lpips")->valuedouble, t.mean.lpips_rest, 1e-12);
    cJSON_Delete(root);
    FILE *md = tmpfile();
    gv_eval_print_markdown(&t, md);
    rewind(md);
    char line[512];
    CHECK(fgets(line, sizeof line, md) && strstr(line, "| baseline LPIPS |") && strstr(line, "| restored LPIPS |"));
    fclose(md);
    gv_lpips_free(&net);
}

/* o with each restored clip added to t. */
static gv_restore_options *into(gv_restore_options *o, gv_eval_table *t)
{
    o->each = gv_eval_add_restored, o->each_ctx = t;
    return o;
}

/* Whole runs on a dataset folder and on clip files. */
static void test_runs(const char *tmp)
{
    char dir[4096], out[4096], path[4400];
    snprintf(dir, sizeof dir, "%s/data", tmp);
    snprintf(out, sizeof out, "%s/out", tmp);
    const rf_clip_spec specs[3] = {{"alpha", "train", 6}, {"beta", "eval", 6}, {"beta", "eval", 8}};
    CHECK(rf_make_dataset(dir, specs, 3, W, H, 40) == 0);
    setup s;
    CHECK(setup_make(&s, NULL, 50) == 0);
    gv_restore_options o = {.sampler = gv_sampler_default(), .compose = GV_COMPOSE_RESIDUAL, .split = "eval", .use_cache = 1};
    /* identity + residual: the restored numbers are the baseline's, exactly */
    CHECK(gv_sampler_from_name("identity", &o.sampler) == 0);
    gv_eval_table t;
    gv_eval_init(&t, NULL);
    CHECK(gv_restore_dataset(&s.r, dir, into(&o, &t)) == 0);
    gv_eval_finish(&t);
    CHECK(t.mean.clips == 2 && t.n_rows == 2 && t.mean.psnr_rest == t.mean.psnr_base && t.mean.ssim_rest == t.mean.ssim_base);
    /* the network: with and without the latent cache the same numbers; clip files too */
    o.sampler = gv_sampler_default();
    gv_eval_table a, b, c;
    gv_eval_init(&a, NULL), gv_eval_init(&b, NULL), gv_eval_init(&c, NULL);
    CHECK(gv_restore_dataset(&s.r, dir, into(&o, &a)) == 0);
    o.use_cache = 0, o.out_dir = out, o.save_clips = 1;
    CHECK(gv_restore_dataset(&s.r, dir, into(&o, &b)) == 0);
    char p1[4200], p2[4200];
    snprintf(p1, sizeof p1, "%s/clips/beta_n06_001.safetensors", dir);
    snprintf(p2, sizeof p2, "%s/clips/beta_n08_002.safetensors", dir);
    const char *paths[2] = {p1, p2};
    o.out_dir = NULL;
    CHECK(gv_restore_files(&s.r, paths, 2, into(&o, &c)) == 0);
    gv_eval_finish(&a), gv_eval_finish(&b), gv_eval_finish(&c);
    CHECK(a.mean.clips == 2 && a.mean.psnr_rest == b.mean.psnr_rest && a.mean.psnr_rest == c.mean.psnr_rest &&
          a.mean.ssim_rest == c.mean.ssim_rest);
    CHECK(a.mean.psnr_rest != a.mean.psnr_base);
    /* a scene and an interval select clips, from the cache and from the manifest alike; a clip
     * file of another run is refused, and a selection that matches nothing fails */
    for (int cached = 0; cached <= 1; cached++) {
        gv_restore_options sel = o;
        sel.use_cache = cached, sel.out_dir = NULL, sel.split = NULL, sel.scene = "beta", sel.interval = 8;
        gv_eval_table d;
        gv_eval_init(&d, NULL);
        CHECK(gv_restore_dataset(&s.r, dir, into(&sel, &d)) == 0);
        gv_eval_finish(&d);
        CHECK(d.mean.clips == 1 && d.n_rows == 1 && d.rows[0].interval == 8 && d.mean.psnr_rest == c.rows[1].psnr_rest);
        sel.scene = "alpha";
        gv_eval_init(&d, NULL);
        CHECK(gv_restore_dataset(&s.r, dir, into(&sel, &d)) == -1 && strstr(gv_last_error(), "no alpha clips at n = 8"));
        sel.interval = 0;
        gv_eval_init(&d, NULL);
        CHECK(gv_restore_dataset(&s.r, dir, into(&sel, &d)) == 0);
        gv_eval_finish(&d);
        CHECK(d.mean.clips == 1 && d.rows[0].interval == 6);
        sel.scene = "beta", sel.interval = 6;
        gv_eval_init(&d, NULL);
        CHECK(gv_restore_files(&s.r, paths + 1, 1, into(&sel, &d)) == -1 && strstr(gv_last_error(), "not of beta at n = 6"));
    }
    /* the written frames and clip: the restored clip's inputs are the PNGs, its targets the clip's */
    gv_clip orig, saved;
    snprintf(path, sizeof path, "%s/beta_n08_002.safetensors", out);
    CHECK(gv_clip_read(p2, &orig) == 0 && gv_clip_read(path, &saved) == 0);
    CHECK(!memcmp(orig.targets, saved.targets, (size_t)5 * W * H * 3) && !memcmp(orig.inputs, saved.inputs, (size_t)W * H * 3));
    CHECK(memcmp(orig.inputs, saved.inputs, (size_t)5 * W * H * 3) && saved.info.id.interval == 8);
    for (int f = 0; f < 5; f++) {
        gv_image img;
        snprintf(path, sizeof path, "%s/beta_n08_002/f%d.png", out, f);
        CHECK(gv_image_read(path, &img) == 0 && img.width == W && img.channels == 3 &&
              !memcmp(img.pixels, gv_clip_frame(saved.inputs, &saved.info, f), (size_t)W * H * 3));
        gv_image_free(&img);
    }
    gv_clip_free(&orig), gv_clip_free(&saved);
    /* keep_renders (a scene checkpoint's closed gate): no network, no VAE, no cache; the
     * written clip is the input file byte for byte, and the table's restored = baseline */
    gv_restore_options keep = o;
    char kept[4096];
    snprintf(kept, sizeof kept, "%s/kept", tmp);
    keep.keep_renders = 1, keep.use_cache = 1, keep.out_dir = kept, keep.save_clips = 1;
    gv_eval_table k;
    gv_eval_init(&k, NULL);
    CHECK(gv_restore_dataset(NULL, dir, into(&keep, &k)) == 0);
    gv_eval_finish(&k);
    CHECK(k.mean.clips == 2 && k.mean.psnr_rest == k.mean.psnr_base && k.mean.ssim_rest == k.mean.ssim_base);
    char *x, *y;
    size_t nx, ny;
    snprintf(path, sizeof path, "%s/beta_n08_002.safetensors", kept);
    CHECK(gv_read_file(path, &x, &nx) == 0 && gv_read_file(p2, &y, &ny) == 0);
    CHECK(nx == ny && !memcmp(x, y, nx));
    free(x), free(y);
    gv_eval_init(&k, NULL);
    keep.out_dir = NULL;
    CHECK(gv_restore_files(NULL, paths, 2, into(&keep, &k)) == 0 && k.mean.clips == 2);
    /* bad inputs name the file and the problem */
    o.each = NULL;
    snprintf(path, sizeof path, "%s/nothing.safetensors", tmp);
    const char *missing[1] = {path};
    CHECK_FAILS_WITH(gv_restore_files(&s.r, missing, 1, &o), "nothing.safetensors");
    /* a clip off the network's block (refused before padding) restores at its own size */
    gv_clip odd;
    CHECK(rf_make_clip(&odd, "room", "eval", 6, 21, 33, 5, 1) == 0);
    snprintf(path, sizeof path, "%s/odd.safetensors", tmp);
    CHECK(gv_clip_write(path, &odd) == 0);
    gv_clip_free(&odd);
    const char *odd_path[1] = {path};
    o.out_dir = out;
    CHECK(gv_restore_files(&s.r, odd_path, 1, &o) == 0);
    gv_image img;
    snprintf(path, sizeof path, "%s/odd/f2.png", out);
    CHECK(gv_image_read(path, &img) == 0 && img.width == 21 && img.height == 33);
    gv_image_free(&img);
    o.out_dir = NULL;
    o.split = "test";
    CHECK_FAILS_WITH(gv_restore_dataset(&s.r, dir, &o), "no test clips");
    o.split = "eval";
    o.sampler.t0 = 1.5;
    CHECK_FAILS_WITH(gv_restore_dataset(&s.r, dir, &o), "t0 1.5");
    o.sampler.t0 = 0.3;
    CHECK_FAILS_WITH(gv_restore_dataset(&s.r, tmp, &o), "no manifest.json");
    setup_free(&s);
}

static void test_bad_specs(void)
{
    gv_sampler s;
    double sig[GV_SAMPLER_MAX_STEPS + 1];
    CHECK_FAILS_WITH(gv_sampler_from_name("heun", &s), "sampler 'heun'");
    s = gv_sampler_default(), s.t0 = 0;
    CHECK_FAILS_WITH(gv_sampler_check(&s), "t0 0 is not in (0, 1)");
    s.t0 = 1;
    CHECK_FAILS_WITH(gv_sampler_sigmas(&s, sig), "t0 1 is not in (0, 1)");
    s = gv_sampler_default(), s.steps = 2;
    CHECK_FAILS_WITH(gv_sampler_check(&s), "it takes one");
    CHECK(gv_sampler_from_name("iterate", &s) == 0);
    s.steps = 0;
    CHECK_FAILS_WITH(gv_sampler_check(&s), "steps 0");
    s.steps = GV_SAMPLER_MAX_STEPS + 1;
    CHECK_FAILS_WITH(gv_sampler_check(&s), "steps 1001");
    s.steps = 2, s.shift = 0.5;
    CHECK_FAILS_WITH(gv_sampler_check(&s), "shift 0.5");
    s.shift = 1, s.samples = 0;
    CHECK_FAILS_WITH(gv_sampler_check(&s), "samples 0");
    CHECK(gv_sampler_from_name("euler", &s) == 0);
    s.samples = 2;
    CHECK_FAILS_WITH(gv_sampler_check(&s), "one noise draw");
    s.samples = 1, s.blend = 0.5;
    CHECK_FAILS_WITH(gv_sampler_check(&s), "whole steps");
    s = gv_sampler_default(), s.blend = 0;
    CHECK_FAILS_WITH(gv_sampler_check(&s), "blend 0 is not in (0, 1]");
    s.blend = 1.5;
    CHECK_FAILS_WITH(gv_sampler_check(&s), "blend 1.5");
    CHECK(gv_sampler_configure("iterate", 0.4, 2, 0, 3, 0.5, 9, &s) == 0 && s.kind == GV_SAMPLER_ITERATE && s.t0 == 0.4 &&
          s.steps == 2 && s.shift == 1 && s.samples == 3 && s.blend == 0.5 && s.seed == 9);
    CHECK_FAILS_WITH(gv_sampler_configure("onestep", 0, 3, 0, 0, 0, 0, &s), "it takes one");
    gv_compose c;
    CHECK(gv_compose_from_name("residual", &c) == 0 && c == GV_COMPOSE_RESIDUAL && !strcmp(gv_compose_name(c), "residual"));
    CHECK(gv_compose_from_name("unseen", &c) == 0 && c == GV_COMPOSE_UNSEEN && !strcmp(gv_compose_name(c), "unseen"));
    CHECK_FAILS_WITH(gv_compose_from_name("blend", &c), "expected decoded, residual or unseen");
    char text[128];
    CHECK(gv_sampler_from_name("released", &s) == 0);
    gv_sampler_describe(&s, text, sizeof text);
    CHECK(!strcmp(text, "euler t0=0.5556 steps=10 shift=5 samples=1 blend=1 seed=0"));
    /* latents that do not fit the network, and a camera model without a ray field */
    setup st;
    CHECK(setup_make(&st, NULL, 60) == 0);
    gv_restore_net net;
    gv_clip_latents l = st.l;
    l.vace_dim = 40;
    CHECK_FAILS_WITH(gv_restore_net_init(&net, &st.r.net, &l, 1), "do not fit");
    gv_restore_net_free(&net);
    l = st.l;
    l.plucker = NULL;
    CHECK_FAILS_WITH(gv_restore_net_init(&net, &st.r.net, &l, 1), "Plücker field");
    gv_restore_net_free(&net);
    setup_free(&st);
}

/* Any size (condition.h): clips of odd sizes and 1-pixel edges restored by the network come
 * back at their own size; the identity under residual composition is the input exactly (the
 * crop undoes the padding); decoded composition equals that of the clip padded by hand,
 * cropped; the unseen composition keeps the render where an anchor sees the pixel. */
static void test_odd_sizes(void)
{
    const int sizes[][2] = {{37, 23}, {1, 1}, {1, 17}, {17, 1}};
    const char *variants[2] = {NULL, "per-frame"};
    for (int v = 0; v < 2; v++)
        for (int k = 0; k < 4; k++) {
            setup s;
            memset(&s, 0, sizeof s);
            const int w = sizes[k][0], h = sizes[k][1];
            const int64_t fb = (int64_t)w * h * 3;
            CHECK(rf_tiny(&s.r.cfg, &s.r.vae, variants[v], 50 + k) == 0 && gv_dit_init(&s.r.net, &s.r.cfg, 50 + k) == 0);
            mt_randomize(&s.r.net, MT_ALL, 51 + k);
            CHECK(rf_make_clip(&s.clip, "room", "eval", 6, w, h, 40, 9 + k) == 0);
            CHECK(gv_clip_latents_prepare(&s.r.vae, &s.r.cfg, &s.clip, &s.l) == 0);
            const int64_t n = gv_clip_latents_z_count(&s.l);
            float *z = malloc((size_t)n * 4);
            uint8_t *out = malloc((size_t)(5 * fb)), *want = malloc((size_t)(5 * fb));
            gv_sampler sp;
            CHECK(gv_sampler_from_name("identity", &sp) == 0 && gv_restore_latent(&s.r.net, &s.l, &sp, 3, z) == 0);
            CHECK(gv_restore_compose(&s.r.vae, &s.clip, &s.l, z, GV_COMPOSE_RESIDUAL, 0, out) == 0);
            CHECK(!memcmp(out, s.clip.inputs, (size_t)(5 * fb)));
            /* the network's restoration: anchors kept, intermediates changed somewhere */
            CHECK(gv_sampler_from_name("onestep", &sp) == 0 && gv_restore_latent(&s.r.net, &s.l, &sp, 3, z) == 0);
            CHECK(gv_restore_compose(&s.r.vae, &s.clip, &s.l, z, GV_COMPOSE_DECODED, 0, out) == 0);
            CHECK(!memcmp(out, s.clip.inputs, (size_t)fb) && !memcmp(out + 4 * fb, s.clip.inputs + 4 * fb, (size_t)fb));
            CHECK(memcmp(out + fb, s.clip.inputs + fb, (size_t)(3 * fb)) != 0);
            /* the same as composing the clip padded by hand, then cropping */
            gv_clip padded;
            CHECK(gv_clip_pad(&s.clip, s.l.width, s.l.height, &padded) == 0);
            uint8_t *big = malloc((size_t)(5 * 3 * s.l.width * s.l.height));
            CHECK(gv_restore_compose(&s.r.vae, &padded, &s.l, z, GV_COMPOSE_DECODED, 0, big) == 0);
            CHECK(gv_clip_crop_frames(big, s.l.width, s.l.height, &s.clip.info, want) == 0 &&
                  !memcmp(out, want, (size_t)(5 * fb)));
            /* unseen: the render wherever an anchor sees the pixel */
            s.clip.coverage = malloc((size_t)(3 * w * h));
            for (int64_t i = 0; i < 3 * w * h; i++) s.clip.coverage[i] = (uint8_t)(i % 3 == 0 ? 0 : 1 + i % 2);
            CHECK(gv_restore_compose(&s.r.vae, &s.clip, &s.l, z, GV_COMPOSE_UNSEEN, 0, out) == 0);
            int bad = 0;
            for (int f = 1; f < 4; f++)
                for (int64_t p = 0; p < (int64_t)w * h; p++)
                    if (s.clip.coverage[(f - 1) * w * h + p])
                        bad += memcmp(out + f * fb + p * 3, s.clip.inputs + f * fb + p * 3, 3) != 0;
            CHECK(bad == 0);
            /* latents of another clip's size are refused */
            gv_clip small;
            CHECK(rf_make_clip(&small, "room", "eval", 6, s.l.width + 1, h, 40, 1) == 0);
            CHECK_FAILS_WITH(gv_restore_compose(&s.r.vae, &small, &s.l, z, GV_COMPOSE_DECODED, 0, big), "latents of a");
            gv_clip_free(&small), gv_clip_free(&padded);
            free(z), free(out), free(want), free(big);
            setup_free(&s);
        }
}

int main(void)
{
    const char *tmp = check_tmp_dir();
    gv_log_set_level(GV_LOG_QUIET);
    omp_set_num_threads(1); /* tiny shapes: threads only add synchronisation on a busy machine */
    test_sigmas();
    test_sampler_math();
    test_network();
    test_compose();
    test_eval_table(tmp);
    test_eval_lpips(tmp);
    test_runs(tmp);
    test_bad_specs();
    test_odd_sizes();
    return check_summary();
}
