/* Training the VAE from scratch on scene frames (the small preset's VAE; docs/ARCHITECTURE.md 6.2):
 * random crops of clips (random frame spacing, mirroring and time reversal), the objective
 * of vae_train.h, AdamW with warm-up and cosine decay, gradient clipping, atomic checkpoints
 * with the optimiser state, an optional held-out evaluation, and the latent statistics at
 * the end. Every random draw of step k is a function of (seed, k), so a resumed run takes
 * the same steps as an uninterrupted one. */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "gaussvid/core/core.h"
#include "gaussvid/nn/nn.h"
#include "gaussvid/train/vae_train.h"
#include "train/vae_train_internal.h"

void gv_vae_train_defaults(gv_vae_train_options *o)
{
    memset(o, 0, sizeof *o);
    o->steps = 2000;
    o->batch = 1;
    o->frames = 5;
    o->crop_h = o->crop_w = 64;
    o->max_stride = 3;
    o->image_every = 4;
    o->lr = 3e-4;
    o->min_lr = 1e-5;
    o->warmup = 100;
    o->clip_norm = 1.0;
    o->l2_weight = 1.0;
    o->kl_weight = 1e-6;
    o->seed = 0;
    o->checkpoint_every = 100;
    o->eval_every = 0;
    o->eval_clips = 4;
    o->stats_clips = 64;
}

/* A stream of the Philox generator for (seed, step, purpose). */
static void step_rng(gv_rng *r, uint64_t seed, long step, uint64_t purpose)
{
    gv_rng_init(r, seed * 0x9E3779B97F4A7C15ULL + (uint64_t)step * 0xD1B54A32D192ED03ULL + purpose);
}

static int uniform_int(gv_rng *r, int n) /* 0 .. n-1 */
{
    int k = (int)(gv_rng_uniform(r) * n);
    return k < n ? k : n - 1;
}

int gv_vae_sample_clip(const gv_vae_frames *f, gv_rng *r, int T, int max_stride, int h, int w, float *out)
{
    /* a scene with probability proportional to its frames */
    int64_t pick = (int64_t)(gv_rng_uniform(r) * (double)f->total_frames);
    int i = 0;
    while (i < f->n - 1 && pick >= f->scenes[i].n_frames) pick -= f->scenes[i++].n_frames;
    const gv_vae_scene *s = &f->scenes[i];
    if (s->width < w || s->height < h || s->n_frames < T)
        return gv_fail("%s: %d frames of %dx%d cannot give a %d-frame %dx%d crop", s->dir, s->n_frames, s->width,
                       s->height, T, w, h);
    int stride = T > 1 ? 1 + uniform_int(r, max_stride) : 1;
    while (stride > 1 && (T - 1) * stride >= s->n_frames) stride--;
    int t0 = uniform_int(r, s->n_frames - (T - 1) * stride);
    int x0 = uniform_int(r, s->width - w + 1), y0 = uniform_int(r, s->height - h + 1);
    int flip = uniform_int(r, 2), reverse = uniform_int(r, 2);
    if (reverse) gv_vae_clip_extract(s, t0 + (T - 1) * stride, -stride, T, x0, y0, w, h, flip, out);
    else gv_vae_clip_extract(s, t0, stride, T, x0, y0, w, h, flip, out);
    return 0;
}

/* exp(a) from the engine's ops: sigmoid(a) / sigmoid(-a). */
static gv_tensor *exp_op(gv_graph *g, gv_tensor *a)
{
    return gv_div(g, gv_sigmoid(g, a), gv_sigmoid(g, gv_scale(g, a, -1.0f)));
}

gv_tensor *gv_vae_loss(gv_graph *g, gv_vae *v, gv_tensor *x, const float *eps, double l2_weight, double kl_weight,
                       gv_tensor **l2_out)
{
    int z = v->cfg.z_dim;
    gv_tensor *m = gv_vae_encoder_forward(g, v, x, NULL);
    if (!m) return NULL;
    gv_tensor *mu = gv_slice(g, m, 1, 0, z), *latent = mu, *kl = NULL;
    if (kl_weight > 0) {
        gv_tensor *logvar = gv_slice(g, m, 1, z, z);
        gv_tensor *sigma = exp_op(g, gv_scale(g, logvar, 0.5f));
        gv_tensor *noise = gv_tensor_from(g, mu->ndim, mu->shape, eps);
        latent = gv_add(g, mu, gv_mul(g, noise, sigma));
        /* KL(N(mu, sigma^2) || N(0, 1)) = 0.5 (mu^2 + sigma^2 - 1 - log sigma^2) per value */
        gv_tensor *terms = gv_sub(g, gv_add(g, gv_mul(g, mu, mu), gv_mul(g, sigma, sigma)), logvar);
        double per_pixel = (double)mu->numel / (double)x->numel; /* sum over latents / pixel values */
        kl = gv_scale(g, gv_mean_all(g, gv_affine(g, terms, 0.5f, -0.5f)), (float)(kl_weight * per_pixel));
    }
    gv_tensor *y = gv_vae_decoder_forward(g, v, latent, NULL);
    gv_tensor *l2 = gv_l2_loss(g, y, x, NULL);
    gv_tensor *loss = gv_add(g, gv_l1_loss(g, y, x, NULL), gv_scale(g, l2, (float)l2_weight));
    if (kl) loss = gv_add(g, loss, kl);
    if (l2_out) *l2_out = l2;
    return loss;
}

/* PSNR of images in [0, 1] from the mean squared error of values in [-1, 1]. */
static double psnr_of(double mse_pm1)
{
    return mse_pm1 > 0 ? 10.0 * log10(4.0 / mse_pm1) : INFINITY;
}

static int check_options(const gv_vae_config *c, const gv_vae_frames *f, const gv_vae_train_options *o)
{
    if (o->steps < 1 || o->batch < 1 || o->max_stride < 1 || o->checkpoint_every < 1 || o->stats_clips < 1)
        return gv_fail("vae train: steps, batch, max stride, checkpoint interval and statistics clips must be positive");
    if (gv_vae_check_clip(c, o->frames, o->crop_h, o->crop_w)) return gv_fail_context("vae train");
    if (!(o->lr > 0) || o->min_lr < 0 || o->l2_weight < 0 || o->kl_weight < 0 || o->clip_norm < 0)
        return gv_fail("vae train: learning rates and loss weights must be non-negative (lr positive)");
    for (int i = 0; i < f->n; i++)
        if (f->scenes[i].width < o->crop_w || f->scenes[i].height < o->crop_h || f->scenes[i].n_frames < o->frames)
            return gv_fail("%s: %d frames of %dx%d are smaller than a %d-frame %dx%d crop", f->scenes[i].dir,
                           f->scenes[i].n_frames, f->scenes[i].width, f->scenes[i].height, o->frames, o->crop_w, o->crop_h);
    return 0;
}

/* One optimiser step on the batch of step `step`; returns the loss and the batch's MSE. */
static int train_step(gv_graph *g, gv_vae *v, const gv_vae_frames *f, const gv_vae_train_options *o,
                      const gv_lr_schedule *lr, long step, float *x, float *eps, double *loss_out, double *mse_out)
{
    int T = o->image_every > 0 && step % o->image_every == o->image_every - 1 ? 1 : o->frames;
    int64_t clip = 3LL * T * o->crop_h * o->crop_w;
    gv_rng r;
    step_rng(&r, o->seed, step, 1);
    for (int b = 0; b < o->batch; b++)
        if (gv_vae_sample_clip(f, &r, T, o->max_stride, o->crop_h, o->crop_w, x + b * clip)) return -1;
    int s = v->cfg.spatial_factor, tl = 1 + (T - 1) / v->cfg.temporal_factor;
    int64_t n_eps = (int64_t)o->batch * v->cfg.z_dim * tl * (o->crop_h / s) * (o->crop_w / s);
    gv_fill_normal(eps, n_eps, o->seed * 0x9E3779B97F4A7C15ULL + 2, (uint64_t)step * (uint64_t)n_eps, 0.0f, 1.0f);
    gv_graph_reset(g);
    const int shape[5] = {o->batch, 3, T, o->crop_h, o->crop_w};
    gv_tensor *l2 = NULL;
    gv_tensor *loss = gv_vae_loss(g, v, gv_tensor_from(g, 5, shape, x), eps, o->l2_weight, o->kl_weight, &l2);
    if (!loss) return gv_fail_context("vae train: step %ld", step);
    gv_params_zero_grad(&v->params);
    if (gv_backward(g, loss)) return -1;
    if (o->clip_norm > 0) gv_clip_grad_norm(&v->params, o->clip_norm);
    gv_adamw_config ac = gv_adamw_defaults();
    ac.weight_decay = (float)o->weight_decay;
    if (gv_adamw_step(&v->params, &ac, (float)gv_lr_at(lr, step))) return gv_fail_context("vae train: step %ld", step);
    *loss_out = loss->data[0];
    *mse_out = l2->data[0];
    return 0;
}

static void log_line(FILE *log, long step, double seconds, double loss, double psnr, const gv_vae_eval_result *e)
{
    if (!log) return;
    if (e) fprintf(log, "%ld\t%.1f\t%.6f\t%.3f\t%.3f\t%.4f\n", step, seconds, loss, psnr, e->psnr, e->ssim);
    else fprintf(log, "%ld\t%.1f\t%.6f\t%.3f\t\t\n", step, seconds, loss, psnr);
    fflush(log);
}

int gv_vae_train(const gv_model_config *c, const gv_vae_frames *train, const gv_vae_frames *eval,
                 const gv_vae_train_options *o)
{
    if (check_options(&c->vae, train, o)) return -1;
    gv_vae v;
    if (gv_vae_init(&v, c, 1, o->seed)) return -1;
    long start = 0;
    double seconds = 0;
    if (o->resume && gv_vae_checkpoint_load(&v, o, &start, &seconds)) {
        gv_vae_free(&v);
        return -1;
    }
    int64_t clip = 3LL * o->batch * o->frames * o->crop_h * o->crop_w;
    float *x = malloc((size_t)clip * sizeof *x), *eps = malloc((size_t)clip * sizeof *eps);
    /* after a kill: the temporaries it left go, and the log loses the rows past the checkpoint
     * (they are written again) */
    gv_atomic_sweep_beside(o->out);
    int rc = !x || !eps ? gv_fail("vae train: out of memory") : 0;
    if (rc == 0 && start && o->log_path) rc = gv_step_log_rewind(o->log_path, start);
    FILE *log = rc == 0 && o->log_path ? fopen(o->log_path, start ? "a" : "w") : NULL;
    if (rc == 0 && o->log_path && !log) rc = gv_fail("%s: cannot open the log for writing", o->log_path);
    if (rc == 0 && log && !start) fprintf(log, "step\tseconds\tloss\ttrain_psnr\theldout_psnr\theldout_ssim\n");
    gv_lr_schedule lr = {GV_LR_COSINE, o->lr, o->min_lr, o->warmup, o->steps};
    gv_graph g;
    gv_graph_init(&g, (size_t)256 << 20);
    gv_progress bar;
    long end = o->stop_after > 0 && o->stop_after < o->steps ? o->stop_after : o->steps;
    gv_progress_start(&bar, "vae train", end - start);
    double avg_loss = 0, avg_mse = 0, t_start = gv_now() - seconds;
    for (long step = start; step < end && rc == 0; step++) {
        double loss = 0, mse = 0;
        rc = train_step(&g, &v, train, o, &lr, step, x, eps, &loss, &mse);
        if (rc) break;
        double a = step == start ? 1.0 : 0.05; /* running means for the display */
        avg_loss += a * (loss - avg_loss);
        avg_mse += a * (mse - avg_mse);
        gv_progress_update(&bar, step + 1 - start, "step %ld  loss %.4f  psnr %.2f dB", step + 1, avg_loss, psnr_of(avg_mse));
        gv_vae_eval_result e, *ep = NULL;
        /* Held-out scenes are always measured at the last step; --eval-every adds points on the way. */
        int periodic = o->eval_every > 0 && (step + 1) % o->eval_every == 0;
        if (eval && o->evaluate && (periodic || step + 1 == o->steps)) {
            if ((rc = o->evaluate(&v, eval, o->frames, 1, o->eval_clips, &e))) break;
            ep = &e;
            gv_info("vae train: step %ld: held-out PSNR %.2f dB, SSIM %.4f (%d frames)", step + 1, e.psnr, e.ssim, e.n_frames);
        }
        log_line(log, step + 1, gv_now() - t_start, loss, psnr_of(mse), ep);
        if ((step + 1) % o->checkpoint_every == 0 || step + 1 == end)
            rc = gv_vae_checkpoint_save(&v, c, o, step + 1, gv_now() - t_start);
    }
    gv_progress_finish(&bar);
    if (rc == 0 && end == o->steps) rc = gv_vae_compute_stats(&v, train, o);
    if (rc == 0 && end == o->steps) rc = gv_vae_checkpoint_save(&v, c, o, o->steps, gv_now() - t_start);
    if (log) fclose(log);
    gv_graph_free(&g);
    free(x);
    free(eps);
    gv_vae_free(&v);
    return rc;
}
