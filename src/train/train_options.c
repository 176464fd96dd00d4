/* The options of a training run: defaults, the text that identifies a run's trajectory in its
 * checkpoints, checks, and the random draws of a step (each clip's timestep, weights and noise
 * come from the Philox stream of (seed, step, clip), so they depend on nothing else). */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "gaussvid/core/core.h"
#include "gaussvid/train/train.h"
#include "train/train_internal.h"

/* Step counts: docs/TRAINING.md "Budget" explains them (small preset, 2-core machine). */
void gv_train_defaults(gv_train_options *o, gv_objective objective)
{
    memset(o, 0, sizeof *o);
    o->objective = objective;
    int pre = objective == GV_OBJECTIVE_PRETRAIN;
    o->steps = 5000; /* 10000 clips a stage: ~2700 CPU-s, 20-25 min on 2 free cores */
    o->batch = 2;
    o->lr = pre ? 3e-4 : 1e-4;           /* fine-tuning: the paper's AdamW 1e-4 (4.1) */
    o->min_lr = pre ? 3e-5 : 1e-4;
    o->warmup = pre ? 100 : 0;
    o->lr_schedule = pre ? GV_LR_COSINE : GV_LR_CONSTANT;
    o->weight_decay = 0.01;              /* PyTorch's AdamW default, as DiffSynth trains */
    o->clip_norm = 1.0;                  /* the authors' DeepSpeed config
                                            (docs/reference/wan-vace-gaussvid.md 1.5) */
    o->checkpoint_every = 250;
    o->shift = 5.0;                      /* docs/reference/wan-vace-gaussvid.md 5.5 */
    o->t_max = 0.48;                     /* paper 3.4 */
    o->curriculum = !pre;
    o->n_min = 6, o->n_max = 26;         /* paper 4.1 */
    o->p_w = 0.05;
    o->progressive = !pre;
    o->lambda = 0.1, o->tau_p = 0.3;     /* paper 4.1 */
}

long gv_train_latent_warmup(const gv_train_options *o)
{
    if (o->latent_warmup > 0) return o->latent_warmup;
    long s_w = o->steps / 20; /* the paper's S_w = 1000 of S = 20000 */
    return s_w > 0 ? s_w : 1;
}

/* The options that decide which steps are taken: a resumed run must have the same. The
 * schedule reads "cosine=0" (constant) or "cosine=1" as it did before the linear decay existed,
 * so older checkpoints resume; the linear decay reads "schedule=linear". */
void gv_train_options_text(const gv_train_options *o, char *out, size_t size)
{
    const char *schedule = o->lr_schedule == GV_LR_LINEAR   ? "schedule=linear"
                           : o->lr_schedule == GV_LR_COSINE ? "cosine=1"
                                                            : "cosine=0";
    snprintf(out, size,
             "objective=%s steps=%ld batch=%d lr=%g min_lr=%g warmup=%ld %s weight_decay=%g clip_norm=%g "
             "seed=%llu shift=%g t_max=%g curriculum=%d n=%d:%d p_w=%g progressive=%d lambda=%g tau_p=%g S_w=%ld fresh_camera=%d render_context=%g crop=%dx%d relative_loss=%d",
             o->objective == GV_OBJECTIVE_PRETRAIN ? "pretrain" : "finetune", o->steps, o->batch, o->lr, o->min_lr,
             o->warmup, schedule, o->weight_decay, o->clip_norm, (unsigned long long)o->seed, o->shift, o->t_max,
             o->curriculum, o->n_min, o->n_max, o->p_w, o->progressive, o->lambda, o->tau_p, gv_train_latent_warmup(o),
             o->fresh_camera, o->render_context, o->crop_h, o->crop_w, o->relative_loss);
}

void gv_train_data_text(const gv_latent_set *data, const char *split, char *out, size_t size)
{
    uint64_t h = GV_FNV_OFFSET;
    for (int i = 0; i < data->count; i++) h = gv_fnv1a64(h, data->names[i], strlen(data->names[i]) + 1);
    snprintf(out, size, "%d clips (split %s), names fnv1a64 %016llx", data->count, split ? split : "all",
             (unsigned long long)h);
}

int gv_train_check_options(const gv_train_options *o)
{
    if (o->steps < 1 || o->batch < 1 || o->checkpoint_every < 1 || o->stop_after < 0 || o->warmup < 0)
        return gv_fail("training: steps, batch and the checkpoint interval must be positive");
    if ((unsigned)o->lr_schedule > GV_LR_LINEAR) return gv_fail("training: unknown learning-rate schedule %d", (int)o->lr_schedule);
    if (!(o->lr > 0) || o->min_lr < 0 || o->weight_decay < 0 || o->clip_norm < 0)
        return gv_fail("training: the learning rate must be positive, the other rates not negative");
    if (!(o->t_max > 0 && o->t_max <= 1) || !(o->shift > 0) || !(o->p_w > 0 && o->p_w < 1) || o->n_max <= o->n_min ||
        o->lambda < 0 || !(o->tau_p > 0))
        return gv_fail("training: t_max in (0, 1], shift > 0, p_w in (0, 1), n_max > n_min, lambda >= 0, tau_p > 0");
    if (!(o->render_context >= 0 && o->render_context <= 1))
        return gv_fail("training: the share of samples with renders in the context must be in [0, 1]");
    if (o->crop_h < 0 || o->crop_w < 0) return gv_fail("training: the crop's rows and columns must not be negative");
    if (!o->out || !*o->out) return gv_fail("training: no output file");
    return 0;
}

/* splitmix64: independent streams for (seed, step, clip, purpose). */
static uint64_t mix(uint64_t x)
{
    x += 0x9E3779B97F4A7C15ULL;
    x = (x ^ (x >> 30)) * 0xBF58476D1CE4E5B9ULL;
    x = (x ^ (x >> 27)) * 0x94D049BB133111EBULL;
    return x ^ (x >> 31);
}

static uint64_t stream(uint64_t seed, long step, int clip, int purpose)
{
    return mix(mix(mix(seed) + (uint64_t)step) + (uint64_t)(clip * 2 + purpose));
}

/* The timestep of clip b of a step, its weights, whether its context keeps the renders and
 * the window it sees. Each draw comes after the ones that existed before it, so options
 * left at their defaults give the draws of runs made before they were added. */
void gv_train_draw(const gv_train_options *o, const gv_pretrain_schedule *grid, long step, int b, double w_cur,
                   int tokens_h, int tokens_w, gv_sample_draw *d, gv_train_window *win)
{
    gv_rng r;
    gv_rng_init(&r, stream(o->seed, step, b, 0));
    double u = gv_rng_uniform(&r);
    d->w_cur = w_cur;
    if (o->objective == GV_OBJECTIVE_PRETRAIN) {
        int k = gv_pretrain_index(u);
        d->t = (float)grid->sigma[k];
        d->w_t = grid->weight[k];
        d->w_lat = 0;
        d->renders = gv_rng_uniform(&r) < o->render_context;
    } else {
        d->t = (float)(u * o->t_max); /* paper 3.4: t ~ U[0, 0.48] */
        d->w_t = 1.0;
        d->renders = 1;
        d->w_lat = o->progressive
                       ? gv_progressive_weight(step, gv_train_latent_warmup(o), d->t, o->tau_p, o->lambda)
                       : 0.0;
    }
    win->y = win->x = 0, win->h = tokens_h, win->w = tokens_w;
    if (o->crop_h > 0 && o->crop_h < tokens_h) {
        win->h = o->crop_h;
        win->y = (int)(gv_rng_uniform(&r) * (tokens_h - o->crop_h + 1));
    }
    if (o->crop_w > 0 && o->crop_w < tokens_w) {
        win->w = o->crop_w;
        win->x = (int)(gv_rng_uniform(&r) * (tokens_w - o->crop_w + 1));
    }
}

void gv_train_noise(const gv_train_options *o, long step, int b, int64_t n, float *eps)
{
    gv_fill_normal(eps, n, stream(o->seed, step, b, 1), 0, 0.0f, 1.0f);
}
