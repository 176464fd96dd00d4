/* Fine-tuning on a scene's internal pairs (scene_adapt.h; docs/ADAPT.md): part of the pairs
 * held back, the usual training loop (trainer.c) on the rest, and after every validation the
 * adapters of the best step so far written to a file of their own, so that the run ends with
 * the step its held-back pairs liked best (early stopping) and an interrupted run resumes with
 * the same choice. The validations never change the trajectory (trainer.c), so the kept step is
 * a function of the options and the clips. */
#include <errno.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "gaussvid/core/core.h"
#include "gaussvid/core/dist.h"
#include "gaussvid/train/scene_adapt.h"
#include "train/train_internal.h"

/* Moves entry i of src into dst's next slot. */
static void move_entry(gv_latent_set *src, int i, gv_latent_set *dst)
{
    dst->clips[dst->count] = src->clips[i];
    dst->names[dst->count++] = src->names[i];
    memset(&src->clips[i], 0, sizeof src->clips[i]);
    src->names[i] = NULL;
}

int gv_latent_set_hold_back(gv_latent_set *all, int every, gv_latent_set *train, gv_latent_set *held)
{
    memset(train, 0, sizeof *train), memset(held, 0, sizeof *held);
    int n_held = every >= 2 && all->count >= 2 ? (all->count - 2) / every + 1 : 0;
    if (every < 2 || n_held < 1 || all->count - n_held < 1)
        return gv_fail("%d internal clips cannot be split into training and held-back clips (every %d held back)",
                       all->count, every);
    gv_latent_set *parts[2] = {train, held};
    int sizes[2] = {all->count - n_held, n_held};
    for (int k = 0; k < 2; k++) {
        parts[k]->clips = calloc((size_t)sizes[k], sizeof *parts[k]->clips);
        parts[k]->names = calloc((size_t)sizes[k], sizeof *parts[k]->names);
        if (!parts[k]->clips || !parts[k]->names) {
            gv_latent_set_free(train), gv_latent_set_free(held);
            return gv_fail("out of memory for %d clips", all->count);
        }
        snprintf(parts[k]->cache_path, sizeof parts[k]->cache_path, "%s", all->cache_path);
    }
    for (int i = 0; i < all->count; i++) move_entry(all, i, i % every == 1 ? held : train);
    train->encoded = all->encoded;
    gv_latent_set_free(all);
    return 0;
}

int gv_latent_set_join(const gv_latent_set *a, const gv_latent_set *b, const char *b_prefix, gv_latent_set *out)
{
    memset(out, 0, sizeof *out);
    int count = a->count + b->count;
    out->clips = calloc((size_t)count, sizeof *out->clips);
    out->names = calloc((size_t)count, sizeof *out->names);
    if (!out->clips || !out->names) {
        gv_latent_set_view_free(out);
        return gv_fail("out of memory for %d clips", count);
    }
    for (int i = 0; i < count; i++) {
        const gv_latent_set *from = i < a->count ? a : b;
        int k = i < a->count ? i : i - a->count;
        out->clips[i] = from->clips[k];
        size_t len = strlen(from->names[k]) + (from == b ? strlen(b_prefix) : 0) + 1;
        if (!(out->names[i] = malloc(len))) {
            gv_latent_set_view_free(out);
            return gv_fail("out of memory for %d clips", count);
        }
        snprintf(out->names[i], len, "%s%s", from == b ? b_prefix : "", from->names[k]);
        out->count = i + 1;
    }
    snprintf(out->cache_path, sizeof out->cache_path, "%s", a->cache_path);
    return 0;
}

void gv_latent_set_view_free(gv_latent_set *view)
{
    for (int i = 0; view->names && i < view->count; i++) free(view->names[i]);
    free(view->names), free(view->clips);
    memset(view, 0, sizeof *view);
}

/* ---- the best step ------------------------------------------------------------------------- */
typedef struct {
    const char *path;
    char training[GV_CHECKPOINT_TEXT], data[GV_CHECKPOINT_TEXT];
    gv_adapt_best *best;
    long every, steps;           /* the steps that count: multiples of every, and S */
    const gv_adapt_score *score; /* NULL: the latent gain chooses */
} keeper;

static int save_best(const keeper *k, gv_dit *m)
{
    const gv_adapt_best *b = k->best;
    char num[5][40];
    snprintf(num[0], sizeof num[0], "%ld", b->step);
    snprintf(num[1], sizeof num[1], "%.17g", b->gain_db);
    snprintf(num[2], sizeof num[2], "%.17g", b->loss);
    snprintf(num[3], sizeof num[3], "%.17g", b->identity);
    snprintf(num[4], sizeof num[4], "%.17g %.17g", b->first_gain_db, b->first_loss);
    const char *keys[] = {"format", "step", "gain_db", "loss", "identity", "first", "training", "data"};
    const char *values[] = {"gaussvid-adapters", num[0], num[1], num[2], num[3], num[4], k->training, k->data};
    return gv_adapters_save(k->path, m, keys, values, 8);
}

/* gv_train_options.on_validation: keeps the step whose held-back gain is the highest. */
static int keep_best(void *ctx, gv_dit *m, long step, const gv_validation *v)
{
    keeper *k = ctx;
    gv_adapt_best *b = k->best;
    /* an invocation that stops early validates its last step too: not a step of the run's own
     * schedule, so it does not count (the interrupted run keeps the uninterrupted one's step) */
    if (step % k->every && step != k->steps) return 0;
    double gain = v->all_gain_db;
    if (k->score) {
        if (k->score->fn(k->score->ctx, m, &gain)) return -1;
        gv_info("adapt: step %ld: held-back %s %+.3f dB (latent %+.3f dB)", step, k->score->name, gain, v->all_gain_db);
    }
    if (step == 0) b->first_gain_db = gain, b->first_loss = v->all_loss;
    if (b->step >= 0 && !(gain > b->gain_db)) return 0;
    b->step = step, b->gain_db = gain, b->loss = v->all_loss, b->identity = v->all_identity;
    return save_best(k, m);
}

static int meta_double(const gv_st_file *f, const char *key, double *out)
{
    const char *text = gv_st_metadata(f, key);
    char *end = NULL;
    errno = 0;
    *out = text ? strtod(text, &end) : 0;
    return text && *text && !*end && !errno ? 0 : -1;
}

/* The best step of an earlier invocation of the same run, when its file is there. */
static void resume_best(const keeper *k)
{
    gv_st_file f;
    if (!gv_file_exists(k->path) || gv_st_open(&f, k->path)) {
        gv_clear_error();
        return;
    }
    const char *training = gv_st_metadata(&f, "training"), *data = gv_st_metadata(&f, "data");
    const char *step = gv_st_metadata(&f, "step"), *first = gv_st_metadata(&f, "first");
    gv_adapt_best b = {-1, 0, 0, 0, 0, 0};
    int ok = training && data && step && first && !strcmp(training, k->training) && !strcmp(data, k->data) &&
             !meta_double(&f, "gain_db", &b.gain_db) && !meta_double(&f, "loss", &b.loss) &&
             !meta_double(&f, "identity", &b.identity) &&
             sscanf(first, "%lf %lf", &b.first_gain_db, &b.first_loss) == 2 && sscanf(step, "%ld", &b.step) == 1;
    gv_st_close(&f);
    if (ok) *k->best = b;
    else gv_info("%s: written by another run; the best step is chosen again", k->path);
}

int gv_adapt_train(gv_dit *m, const gv_model_config *cfg, const gv_latent_set *train, const gv_latent_set *held,
                   gv_train_options *o, const gv_train_state *meta, const gv_adapt_score *score, const char *best_path,
                   gv_adapt_best *best, gv_train_report *report)
{
    if (o->val_every < 1) return gv_fail("adapt: the validation interval must be positive");
    keeper k = {best_path, "", "", best, o->val_every, o->steps, score};
    gv_train_options_text(o, k.training, sizeof k.training);
    if (score) { /* the choice is the score's: a best file of the latent choice is not this run's */
        size_t len = strlen(k.training);
        snprintf(k.training + len, sizeof k.training - len, "; best step by %s", score->name);
    }
    snprintf(k.data, sizeof k.data, "%s", meta->data);
    memset(best, 0, sizeof *best);
    best->step = -1;
    char ckpt[4200];
    snprintf(ckpt, sizeof ckpt, "%s.ckpt", o->out);
    gv_atomic_sweep_beside(best_path); /* a kill while it was written leaves its temporary */
    if (o->resume && gv_file_exists(ckpt)) resume_best(&k);
    o->val = held;
    o->on_validation = keep_best, o->on_validation_ctx = &k;
    int rc = gv_train_run(m, cfg, train, o, meta, report);
    o->on_validation = NULL, o->on_validation_ctx = NULL;
    if (rc) return -1;
    if (report->end_step < o->steps) return 1;
    /* under mpirun the other ranks are done here: rank 0 alone validated, and it keeps the best
     * step, measures the gate and writes the scene checkpoint */
    if (!gv_dist_is_root()) return 1;
    if (best->step < 0) return gv_fail("%s: no validation was kept; remove it and the run's checkpoint", best_path);
    if (gv_adapters_load(best_path, m)) return -1;
    return 0;
}
