/* VAE training (include/gaussvid/train/vae_train.h): a few dozen steps of the tiny VAE on a simple
 * moving image lower the reconstruction loss; a run interrupted and resumed from its
 * checkpoint ends with the same weights bit for bit; a checkpoint of other options is
 * refused; the latent statistics are the moments of the latents; clip extraction;
 * evaluation; bad inputs. */
#include <omp.h>

#include "check.h"
#include "gaussvid/core/core.h"
#include "gaussvid/nn/nn.h"
#include "gaussvid/eval/eval.h"
#include "train/vae_train_internal.h"

static const char *tmp;

/* One scene of T frames w x h: a colour ramp with a dark disc moving right by 1 pixel a
 * frame (symmetric = 1: a left-right symmetric image that does not move). */
static void make_scene(gv_vae_frames *f, int T, int w, int h, int symmetric)
{
    memset(f, 0, sizeof *f);
    f->n = 1;
    f->scenes = calloc(1, sizeof *f->scenes);
    gv_vae_scene *s = &f->scenes[0];
    snprintf(s->dir, sizeof s->dir, "synthetic");
    s->n_frames = T;
    s->width = w;
    s->height = h;
    s->pixels = malloc((size_t)T * w * h * 3);
    f->total_frames = T;
    for (int t = 0; t < T; t++)
        for (int y = 0; y < h; y++)
            for (int x = 0; x < w; x++) {
                uint8_t *p = s->pixels + (((size_t)t * h + y) * w + x) * 3;
                double cx = symmetric ? (w - 1) / 2.0 : 8 + t, dx = x - cx, dy = y - h / 2.0;
                int disc = dx * dx + dy * dy < 30;
                int u = symmetric ? abs(2 * x - (w - 1)) * 4 : x * 6;
                p[0] = (uint8_t)(disc ? 30 : 60 + u);
                p[1] = (uint8_t)(disc ? 40 : 50 + y * 5);
                p[2] = (uint8_t)(disc ? 200 : 180 - y * 3);
            }
}

static void test_clip_extract(void)
{
    gv_vae_frames f;
    make_scene(&f, 9, 32, 16, 0);
    const gv_vae_scene *s = &f.scenes[0];
    float clip[3 * 3 * 4 * 5];
    /* frames 7, 5, 3 (reversed, spacing 2), window 5 x 4 at (6, 2), mirrored */
    gv_vae_clip_extract(s, 7, -2, 3, 6, 2, 5, 4, 1, clip);
    int ok = 1;
    for (int c = 0; c < 3; c++)
        for (int t = 0; t < 3; t++)
            for (int y = 0; y < 4; y++)
                for (int x = 0; x < 5; x++) {
                    int frame = 7 - 2 * t, sx = 6 + (4 - x), sy = 2 + y;
                    float want = s->pixels[(((size_t)frame * 16 + sy) * 32 + sx) * 3 + c] / 127.5f - 1.0f;
                    ok &= fabsf(clip[((c * 3 + t) * 4 + y) * 5 + x] - want) < 1e-6f;
                }
    CHECK(ok);
    gv_vae_frames_free(&f);
}

static double fixed_loss(gv_vae *v, const gv_vae_frames *f)
{
    /* the same 4 clips before and after training: every 16 x 16 crop corner, frames 0..4 */
    const int T = 5, h = 16, w = 16;
    float x[4 * 3 * 5 * 16 * 16];
    for (int k = 0; k < 4; k++)
        gv_vae_clip_extract(&f->scenes[0], k, 1, T, (k & 1) * 16, 0, w, h, 0, x + k * 3 * T * h * w);
    gv_graph g;
    gv_graph_init(&g, 1 << 22);
    gv_graph_set_grad(&g, 0);
    const int shape[5] = {4, 3, T, h, w};
    gv_tensor *loss = gv_vae_loss(&g, v, gv_tensor_from(&g, 5, shape, x), NULL, 1.0, 0.0, NULL);
    double value = loss ? loss->data[0] : NAN;
    gv_graph_free(&g);
    return value;
}

static int same_weights(const char *a_path, const char *b_path, const gv_model_config *c)
{
    gv_vae a, b;
    if (gv_vae_init(&a, c, 0, 1) || gv_vae_init(&b, c, 0, 2)) return 0;
    int same = gv_vae_load(&a, a_path, 0) == 0 && gv_vae_load(&b, b_path, 0) == 0;
    for (int i = 0; same && i < a.params.n; i++)
        same = !memcmp(a.params.items[i]->t.data, b.params.items[i]->t.data, sizeof(float) * a.params.items[i]->t.numel);
    same = same && !memcmp(a.mean, b.mean, sizeof a.mean) && !memcmp(a.std, b.std, sizeof a.std);
    gv_vae_free(&a);
    gv_vae_free(&b);
    return same;
}

static void options(gv_vae_train_options *o, const char *out, long steps)
{
    gv_vae_train_defaults(o);
    o->steps = steps;
    o->crop_h = o->crop_w = 16;
    o->lr = 2e-3;
    o->warmup = 5;
    o->min_lr = 2e-4;
    o->checkpoint_every = 10;
    o->stats_clips = 4;
    o->max_stride = 2;
    o->seed = 3;
    o->out = out;
}

static void test_training(void)
{
    gv_model_config c;
    CHECK(gv_model_config_preset(&c, "tiny") == 0);
    gv_vae_frames f;
    make_scene(&f, 9, 32, 16, 0);
    gv_vae v;
    CHECK(gv_vae_init(&v, &c, 0, 3) == 0); /* gv_vae_train initialises with the same seed */
    double before = fixed_loss(&v, &f);
    gv_vae_free(&v);

    char full[4200], part[4200];
    snprintf(full, sizeof full, "%s/full.safetensors", tmp);
    snprintf(part, sizeof part, "%s/part.safetensors", tmp);
    gv_vae_train_options o;
    options(&o, full, 30);
    CHECK(gv_vae_train(&c, &f, NULL, &o) == 0);
    CHECK(gv_vae_init(&v, &c, 0, 9) == 0);
    CHECK(gv_vae_load(&v, full, 0) == 0);
    double after = fixed_loss(&v, &f);
    printf("tiny VAE, 30 steps: loss %.4f -> %.4f\n", before, after);
    CHECK(after < 0.6 * before);
    CHECK(v.has_stats);
    gv_vae_free(&v);

    /* interrupted after step 20, resumed to 30: the same weights */
    options(&o, part, 30);
    o.stop_after = 20;
    CHECK(gv_vae_train(&c, &f, NULL, &o) == 0);
    CHECK(gv_vae_init(&v, &c, 0, 9) == 0);
    CHECK(gv_vae_load(&v, part, 0) == 0 && !v.has_stats); /* no statistics before the end */
    gv_vae_free(&v);
    o.stop_after = 0;
    o.resume = 1;
    CHECK(gv_vae_train(&c, &f, NULL, &o) == 0);
    CHECK(same_weights(full, part, &c));
    /* a checkpoint written with other options is refused */
    o.lr = 1e-3;
    CHECK_FAILS_WITH(gv_vae_train(&c, &f, NULL, &o), "written with other training options");
    /* a crop larger than the frames, or not a multiple of the spatial factor */
    options(&o, part, 5);
    o.crop_w = 40;
    CHECK_FAILS_WITH(gv_vae_train(&c, &f, NULL, &o), "smaller than a 5-frame 40x16 crop");
    o.crop_w = 12;
    CHECK_FAILS_WITH(gv_vae_train(&c, &f, NULL, &o), "spatial factor 8");
    gv_vae_frames_free(&f);
}

/* Every clip of a still, mirror-symmetric scene cropped to its full size is the same clip, so
 * the stored statistics must be the moments of that clip's latents. */
static void test_statistics(void)
{
    gv_model_config c;
    CHECK(gv_model_config_preset(&c, "tiny") == 0);
    gv_vae_frames f;
    make_scene(&f, 5, 32, 16, 1);
    gv_vae v;
    CHECK(gv_vae_init(&v, &c, 0, 4) == 0);
    gv_vae_train_options o;
    options(&o, "unused", 1);
    o.crop_w = 32;
    CHECK(gv_vae_compute_stats(&v, &f, &o) == 0);
    float x[3 * 5 * 16 * 32], mu[4 * 2 * 2 * 4];
    gv_vae_clip_extract(&f.scenes[0], 0, 1, 5, 0, 0, 32, 16, 0, x);
    CHECK(gv_vae_encode(&v, x, 5, 16, 32, 0, 0, mu) == 0);
    double worst = 0;
    for (int ch = 0; ch < 4; ch++) {
        double s = 0, s2 = 0;
        for (int i = 0; i < 16; i++) s += mu[ch * 16 + i];
        double m = s / 16;
        for (int i = 0; i < 16; i++) s2 += (mu[ch * 16 + i] - m) * (mu[ch * 16 + i] - m);
        worst = fmax(worst, fabs(v.mean[ch] - m) + fabs(v.std[ch] - sqrt(s2 / 16)));
    }
    printf("latent statistics vs the clip's moments: max |diff| %.2e\n", worst);
    CHECK(worst < 1e-4);
    gv_vae_free(&v);
    gv_vae_frames_free(&f);
}

static void test_evaluation(void)
{
    gv_model_config c;
    CHECK(gv_model_config_preset(&c, "tiny") == 0);
    gv_vae v;
    CHECK(gv_vae_init(&v, &c, 0, 5) == 0);
    gv_vae_frames f;
    make_scene(&f, 11, 32, 20, 0); /* height 20: evaluated on the centred 32 x 16 window */
    gv_vae_eval_result r;
    CHECK(gv_vae_evaluate(&v, &f, 5, 1, 0, &r) == 0);
    CHECK(r.n_clips == 2 && r.n_frames == 10); /* 11 frames hold two 5-frame clips */
    CHECK(r.psnr > 0 && r.psnr < 60 && r.ssim > -1 && r.ssim < 1);
    CHECK_NEAR(r.psnr, (r.psnr_first * 2 + r.psnr_grouped * 8) / 10, 1e-9);
    CHECK(gv_vae_evaluate(&v, &f, 9, 1, 0, &r) == 0 && r.n_clips == 1);
    CHECK_FAILS_WITH(gv_vae_evaluate(&v, &f, 4, 1, 0, &r), "1 + k x 4");
    CHECK_FAILS_WITH(gv_vae_evaluate(&v, &f, 9, 2, 0, &r), "hold no 9-frame clip");
    gv_vae_frames_free(&f);
    const char *missing[1] = {"/nonexistent/scene"};
    CHECK_FAILS_WITH(gv_vae_frames_load(&f, missing, 1, 1), "/nonexistent/scene");
    gv_vae_free(&v);
}

int main(void)
{
    tmp = check_tmp_dir();
    omp_set_num_threads(1); /* small tensors; and the resume check compares bits */
    gv_log_set_level(GV_LOG_QUIET);
    test_clip_extract();
    test_training();
    test_statistics();
    test_evaluation();
    return check_summary();
}
