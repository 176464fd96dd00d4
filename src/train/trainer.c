/* The training loop shared by base pretraining and GaussVid fine-tuning (docs/ARCHITECTURE.md 7): a step
 * takes `batch` clips (chosen by the curriculum, or shuffled), accumulates the gradients of the
 * objective over them, clips the gradient norm and takes one AdamW step. A step depends only on
 * its number, the data position and the weights and moments, all of which the checkpoints
 * store, so a resumed run takes exactly the steps an uninterrupted one would. */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "gaussvid/core/core.h"
#include "gaussvid/core/dist.h"
#include "gaussvid/train/train.h"
#include "train/train_internal.h"

/* Restores out + ".ckpt" into m and st after checking it belongs to this run. */
static int resume(gv_dit *m, const gv_model_config *cfg, const char *ckpt, gv_train_state *st)
{
    gv_model_config c;
    gv_train_state s;
    if (gv_checkpoint_read_info(ckpt, &c, &s)) return -1;
    /* compared as the JSON the files hold: parsing it back may move a statistic by an ulp */
    char *was = gv_model_config_to_json(&c), *now = gv_model_config_to_json(cfg);
    int same = was && now && !strcmp(was, now);
    free(was), free(now);
    if (!same) return gv_fail("%s: written for another model config than this run's (%s)", ckpt, cfg->name);
    if (strcmp(s.kind, st->kind)) return gv_fail("%s: a %s checkpoint, this run is %s", ckpt, s.kind, st->kind);
    if (strcmp(s.training, st->training))
        return gv_fail("%s: written with other training options (%s), now %s", ckpt, s.training, st->training);
    if (strcmp(s.data, st->data)) return gv_fail("%s: trained on other clips (%s), now %s", ckpt, s.data, st->data);
    if (gv_checkpoint_restore(ckpt, m, &s)) return -1;
    st->step = s.step;
    st->data_position = s.data_position;
    st->clips_used = s.clips_used;
    st->clips_skipped = s.clips_skipped;
    st->seconds = s.seconds;
    st->loss = s.loss;
    gv_info("%s: resuming at step %ld of %ld", ckpt, s.step, s.steps);
    return 0;
}

typedef struct {
    const gv_train_options *o;
    gv_data_order order;
    gv_pretrain_schedule grid;
    double *difficulty;            /* per clip; NULL without curriculum */
    double *relative;              /* per clip: the weight of --relative-loss; NULL without */
    int *index;
    double *weight;
    float *eps;
    gv_clip_latents crop;          /* the window of the current sample (--crop) */
    gv_graph g;
    gv_grad_sum grad;              /* the step's gradient over its clips and the ranks */
    FILE *log, *val_log;
} loop_ctx;

/* --relative-loss: clip i's loss weighted by 1 / identity_i, normalised to mean 1 over the
 * clips, so that each clip counts by its loss relative to leaving its renders unchanged. A
 * clip's PSNR change is about -10 log10 of that ratio, and evaluations average PSNR over
 * clips: unweighted, the few clips with the largest errors would decide what is learned,
 * and the clips already rendered well (small n) would count for nothing. Identities are
 * floored at 1e-3 of their mean so that a clip rendered perfectly has a finite weight.
 * Measured on the recipe's clips it is much worse than equal weights
 * (docs/history/RESULTS-2026-11.md, "The relative loss in the network"): the near-perfect
 * clips take most of the weight and their error is noise, so it is off by default. */
int gv_train_relative_weights(const gv_latent_set *data, double **out)
{
    double *w = malloc((size_t)data->count * sizeof *w), mean_id = 0, mean_w = 0;
    if (!w) return gv_fail("training: out of memory");
    for (int i = 0; i < data->count; i++) mean_id += (w[i] = gv_clip_latents_identity_loss(&data->clips[i])) / data->count;
    for (int i = 0; i < data->count; i++) mean_w += (w[i] = 1.0 / fmax(w[i], 1e-3 * mean_id + 1e-30)) / data->count;
    for (int i = 0; i < data->count; i++) w[i] /= mean_w;
    *out = w;
    return 0;
}

static int ctx_init(loop_ctx *x, gv_dit *m, const gv_latent_set *data, const gv_train_options *o, long start)
{
    int appending = start > 0;
    memset(x, 0, sizeof *x);
    x->o = o;
    gv_graph_init(&x->g, 0);
    if (gv_grad_sum_init(&x->grad, &m->params)) return -1;
    gv_pretrain_schedule_init(&x->grid, o->shift);
    if (gv_data_order_init(&x->order, data->count, o->seed)) return -1;
    int64_t most = gv_latent_set_max_z_count(data);
    x->eps = malloc((size_t)most * sizeof *x->eps);
    x->index = malloc((size_t)o->batch * sizeof *x->index);
    x->weight = malloc((size_t)o->batch * sizeof *x->weight);
    int curriculum = o->objective == GV_OBJECTIVE_FINETUNE && o->curriculum;
    if (curriculum) x->difficulty = malloc((size_t)data->count * sizeof *x->difficulty);
    if (!x->eps || !x->index || !x->weight || (curriculum && !x->difficulty)) return gv_fail("training: out of memory");
    for (int i = 0; curriculum && i < data->count; i++)
        x->difficulty[i] = gv_curriculum_difficulty(data->clips[i].interval, o->n_min, o->n_max);
    if (o->objective == GV_OBJECTIVE_FINETUNE && o->relative_loss && gv_train_relative_weights(data, &x->relative)) return -1;
    if (!gv_dist_is_root()) return 0; /* rank 0 writes the logs */
    /* resumed after a kill: the rows past the checkpoint are written again */
    if (appending && o->log_path && gv_step_log_rewind(o->log_path, start)) return -1;
    if (appending && o->val && o->val_log && gv_step_log_rewind(o->val_log, start)) return -1;
    if (o->log_path) {
        x->log = fopen(o->log_path, appending ? "a" : "w");
        if (!x->log) return gv_fail("%s: cannot open the log for writing", o->log_path);
        if (!appending) fprintf(x->log, "step\tseconds\tlr\tloss\tfm\tlatent\tthreshold\tskipped\tclips_per_s\n");
    }
    if (o->val && o->val_log) {
        x->val_log = fopen(o->val_log, appending ? "a" : "w");
        if (!x->val_log) return gv_fail("%s: cannot open the validation log for writing", o->val_log);
        if (!appending) fprintf(x->val_log, "step\tn\tclips\tloss\tidentity\tgain_db\n");
    }
    return 0;
}

static void ctx_free(loop_ctx *x)
{
    gv_data_order_free(&x->order);
    gv_graph_free(&x->g);
    gv_grad_sum_free(&x->grad);
    free(x->difficulty), free(x->relative), free(x->index), free(x->weight), free(x->eps);
    gv_clip_latents_free(&x->crop);
    if (x->log) fclose(x->log);
    if (x->val_log) fclose(x->val_log);
}

/* One optimiser step; *mean gets the batch's mean losses. Every rank draws the same batch;
 * each computes the clips of its share (all of them in one process), the gradients and losses
 * are summed over the ranks, and every rank takes the same AdamW step. */
static int train_step(gv_dit *m, const gv_latent_set *data, loop_ctx *x, gv_train_state *st, double threshold,
                      double lr, int *skipped, gv_sample_losses *mean)
{
    const gv_train_options *o = x->o;
    memset(mean, 0, sizeof *mean);
    if (gv_curriculum_batch(&x->order, x->difficulty, threshold, o->batch, &st->data_position, x->index, x->weight,
                            skipped))
        return -1;
    double losses[3] = {0, 0, 0};
    long first, end;
    gv_dist_share(o->batch, &first, &end);
    gv_params_zero_grad(&m->params);
    for (long b = first; b < end; b++) {
        const gv_clip_latents *l = &data->clips[x->index[b]];
        const int ph = m->cfg.dit.patch_size[1], pw = m->cfg.dit.patch_size[2];
        gv_sample_draw d;
        gv_sample_losses s;
        gv_train_window win;
        gv_train_draw(o, &x->grid, st->step, (int)b, x->weight[b], l->lh / ph, l->lw / pw, &d, &win);
        if (win.h * ph < l->lh || win.w * pw < l->lw) {
            if (gv_clip_latents_crop(l, win.y * ph, win.x * pw, win.h * ph, win.w * pw, &x->crop))
                return gv_fail_context("step %ld (%s)", st->step + 1, data->names[x->index[b]]);
            l = &x->crop;
        }
        gv_train_noise(o, st->step, (int)b, gv_clip_latents_z_count(l), x->eps);
        double scale = (x->relative ? x->relative[x->index[b]] : 1.0) / o->batch;
        if (gv_train_sample(m, &x->g, l, o->objective, &d, x->eps, scale, 1, &s))
            return gv_fail_context("step %ld (%s)", st->step + 1, data->names[x->index[b]]);
        gv_grad_sum_add(&x->grad, &m->params);
        losses[0] += s.loss / o->batch, losses[1] += s.fm / o->batch, losses[2] += s.latent / o->batch;
    }
    if (gv_grad_sum_finish(&x->grad, &m->params) || gv_dist_sum_doubles(losses, 3))
        return gv_fail_context("step %ld", st->step + 1);
    mean->loss = losses[0], mean->fm = losses[1], mean->latent = losses[2];
    if (o->clip_norm > 0) gv_clip_grad_norm(&m->params, o->clip_norm);
    gv_adamw_config ac = gv_adamw_defaults();
    ac.weight_decay = (float)o->weight_decay;
    if (gv_adamw_step(&m->params, &ac, (float)lr)) return gv_fail_context("step %ld", st->step + 1);
    st->step++;
    st->clips_used += o->batch;
    st->clips_skipped += *skipped;
    return 0;
}

/* The step's line in the log and on the progress bar (threshold < 0: no curriculum). */
static void show_step(loop_ctx *x, gv_progress *bar, const gv_train_state *st, long done, double lr, double threshold,
                      int skipped, const gv_sample_losses *mean, double rate)
{
    if (x->log) {
        fprintf(x->log, "%ld\t%.2f\t%.3g\t%.6f\t%.6f\t%.6f\t%.4f\t%d\t%.3f\n", st->step, st->seconds, lr, mean->loss,
                mean->fm, mean->latent, threshold >= 0 ? threshold : 1.0, skipped, rate);
        fflush(x->log); /* a kill loses no row the checkpoint holds */
    }
    char dmax[48] = "";
    if (threshold >= 0) snprintf(dmax, sizeof dmax, "  dmax %.2f, %d skipped", threshold, skipped);
    gv_progress_update(bar, done, "step %ld/%ld  loss %.4f (fm %.4f, latent %.4f)%s  %.2f clips/s", st->step,
                       x->o->steps, st->loss, mean->fm, mean->latent, dmax, rate);
}

/* Validates at step st->step: a line above the progress bar and rows in the validation log. */
static int validate(gv_dit *m, loop_ctx *x, const gv_train_state *st, gv_progress *bar)
{
    gv_validation v;
    if (gv_train_validate(m, &x->g, x->o->val, x->o->t_max, &v)) return gv_fail_context("step %ld", st->step);
    char per_n[512] = "";
    size_t used = 0;
    for (int k = 0; k < v.groups && used < sizeof per_n; k++)
        used += (size_t)snprintf(per_n + used, sizeof per_n - used, "%sn=%d %.5f/%.5f (%+.3f dB)", k ? ", " : "",
                                 v.intervals[k], v.loss[k], v.identity[k], v.gain_db[k]);
    gv_progress_note(bar, "validation at step %ld: loss %.5f, identity %.5f (%+.1f %%), latent gain %+.3f dB; %s",
                     st->step, v.all_loss, v.all_identity,
                     v.all_identity > 0 ? 100 * (v.all_loss / v.all_identity - 1) : 0.0, v.all_gain_db, per_n);
    if (x->val_log) {
        for (int k = 0; k < v.groups; k++)
            fprintf(x->val_log, "%ld\t%d\t%d\t%.6f\t%.6f\t%.4f\n", st->step, v.intervals[k], v.clips[k], v.loss[k],
                    v.identity[k], v.gain_db[k]);
        fprintf(x->val_log, "%ld\tall\t%d\t%.6f\t%.6f\t%.4f\n", st->step, v.all_clips, v.all_loss, v.all_identity,
                v.all_gain_db);
        fflush(x->val_log);
    }
    if (x->o->on_validation && x->o->on_validation(x->o->on_validation_ctx, m, st->step, &v))
        return gv_fail_context("step %ld", st->step);
    return 0;
}

/* Rank 0 writes; under mpirun every rank first checks that the ranks hold the same weights
 * (they take the same steps from the same sums, so a difference is a fault to report). */
static int save_checkpoint(const char *path, gv_dit *m, const gv_model_config *cfg, const gv_train_state *st,
                           int with_moments)
{
    int same = 1;
    if (gv_dist_size() > 1 && gv_dist_same(gv_params_checksum(&m->params), &same))
        return gv_fail_context("training: step %ld", st->step);
    if (!same) return gv_fail("training: step %ld: the ranks hold different weights", st->step);
    if (gv_dist_is_root() && gv_checkpoint_save(path, m, cfg, st, with_moments))
        return gv_fail_context("training: step %ld", st->step);
    return 0;
}

int gv_train_run(gv_dit *m, const gv_model_config *save_cfg, const gv_latent_set *data, const gv_train_options *o,
                 const gv_train_state *meta, gv_train_report *report)
{
    if (gv_train_check_options(o)) return -1;
    if (data->count < 1) return gv_fail("training: no training clips");
    char ckpt[4200];
    snprintf(ckpt, sizeof ckpt, "%s.ckpt", o->out);
    gv_train_state st = *meta;
    st.step = st.data_position = st.clips_used = st.clips_skipped = 0;
    st.seconds = st.loss = 0;
    st.steps = o->steps;
    st.seed = o->seed;
    gv_train_options_text(o, st.training, sizeof st.training);
    if (o->batch < gv_dist_size())
        return gv_fail("training: a batch of %d clips for %d ranks: each rank needs a clip (--batch at least %d)",
                       o->batch, gv_dist_size(), gv_dist_size());
    if (gv_dist_is_root()) gv_atomic_sweep_beside(o->out); /* temporaries of the weights and checkpoint a kill left */
    int resumed = o->resume && gv_file_exists(ckpt);
    if (resumed && resume(m, save_cfg, ckpt, &st)) return -1;
    if (o->resume && !resumed) gv_info("%s: no checkpoint, starting at step 0", ckpt);
    if (st.step > o->steps) return gv_fail("%s: at step %ld, beyond the run's %ld steps", ckpt, st.step, o->steps);
    long start = st.step, end = o->stop_after > 0 && o->stop_after < o->steps ? o->stop_after : o->steps;
    loop_ctx x;
    int rc = ctx_init(&x, m, data, o, start);
    gv_lr_schedule sched = {o->lr_schedule, o->lr, o->min_lr, o->warmup, o->steps};
    int curriculum = x.difficulty != NULL;
    gv_progress bar;
    gv_progress_start(&bar, o->objective == GV_OBJECTIVE_PRETRAIN ? "pretrain" : "train", end > start ? end - start : 0);
    double t0 = gv_now(), seconds0 = st.seconds, avg = st.loss, first = 0, step_seconds = 0;
    long used0 = st.clips_used;
    int validating = o->val && o->val_every > 0 && gv_dist_is_root(); /* the others wait at the next step */
    if (rc == 0 && validating && start == 0 && end > 0) rc = validate(m, &x, &st, &bar);
    for (long step = start; rc == 0 && step < end; step++) {
        double threshold = curriculum ? gv_curriculum_threshold(step, o->steps, o->p_w) : -1, lr = gv_lr_at(&sched, step);
        int skipped = 0;
        gv_sample_losses mean;
        double t_step = gv_now();
        if ((rc = train_step(m, data, &x, &st, threshold, lr, &skipped, &mean))) break;
        step_seconds += gv_now() - t_step;
        /* the recorded loss averages over the whole run: a resumed run continues the checkpoint's */
        avg = step == 0 ? mean.loss : 0.95 * avg + 0.05 * mean.loss;
        if (step == start) first = avg;
        st.loss = avg;
        double elapsed = gv_now() - t0, rate = step_seconds > 0 ? (double)(st.clips_used - used0) / step_seconds : 0;
        st.seconds = seconds0 + elapsed;
        show_step(&x, &bar, &st, step + 1 - start, lr, threshold, skipped, &mean, rate);
        if (validating && (st.step % o->val_every == 0 || st.step == end)) rc = validate(m, &x, &st, &bar);
        if (rc) break;
        if (st.step % o->checkpoint_every == 0 || st.step == end) rc = save_checkpoint(ckpt, m, save_cfg, &st, 1);
    }
    gv_progress_finish(&bar);
    if (rc == 0 && st.step == o->steps) rc = save_checkpoint(o->out, m, save_cfg, &st, 0);
    if (report) {
        memset(report, 0, sizeof *report);
        report->start_step = start, report->end_step = st.step;
        report->clips_used = st.clips_used - used0;
        report->clips_skipped = st.clips_skipped;
        report->seconds = gv_now() - t0;
        report->step_seconds = step_seconds;
        report->clips_per_second = step_seconds > 0 ? report->clips_used / step_seconds : 0;
        report->first_loss = first, report->last_loss = avg;
        report->arena_peak = x.g.arena.peak;
    }
    ctx_free(&x);
    return rc;
}
