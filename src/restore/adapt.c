/* `gaussvid adapt` as a library call (adapt.h; docs/ADAPT.md): check the inputs, build the
 * scene's internal pairs and do-no-harm clips, fine-tune the base's adapters on the pairs
 * keeping the best step, measure the gate on the held-back pairs and their do-no-harm clips
 * and write the scene checkpoint. Each stage resumes from the
 * work folder; the checkpoint is written last, so its presence means the adaptation is done. */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "gaussvid/restore/adapt.h"
#include "gaussvid/core/core.h"
#include "gaussvid/splat/splat_train.h"
#include "gaussvid/core/dist.h"

void gv_adapt_defaults(gv_adapt_options *o)
{
    memset(o, 0, sizeof *o);
    o->downscale = 1;
    o->iters = 8000;                  /* paper 3.2, as `dataset build` */
    o->densify = GV_DENSIFY_REFERENCE; /* the internal pairs simulate the paper's artifacts, as `dataset build` */
    o->subsets = GV_INTERNAL_SUBSETS; /* every other view: two 3DGS runs */
    o->hold_every = 3;
    gv_train_defaults(&o->train, GV_OBJECTIVE_FINETUNE);
    o->train.steps = 300;
    o->train.batch = 2;
    o->train.lr = 1e-3;
    o->variant = "residual,coverage"; /* step 0 is the identity: the early stop can keep "no change";
                                         the network told which pixels the anchors see (RESULTS) */
    o->train.min_lr = 0.0;
    o->train.lr_schedule = GV_LR_LINEAR; /* the last updates at a vanishing rate (docs/TRAINING.md) */
    o->train.t_max = 0.1;             /* the restorer's t0 = 0.05 inside; where the base learns (RESULTS) */
    o->train.curriculum = 0;          /* one interval: nothing to order */
    o->train.progressive = 0;
    o->train.val_every = 50;
    o->sampler = gv_sampler_default();
    o->compose = GV_COMPOSE_UNSEEN;   /* keeps what the anchors see: the step-300 adapters' damage
                                         cut on every cell, a gain on livingroom (RESULTS, "The unseen composition") */
    o->gate_margin_db = 0.0;
    o->gate_min_frames = 2;           /* 4 while the residual composition's two-frame opening lost
                                         0.68 dB; with unseen both two-frame openings gained (RESULTS) */
    o->harm_max_loss_db = 0.05;       /* issue 20: no n below -0.05 dB */
}

/* The base: a checkpoint (not a scene's) of the network o->config names, whose VAE gives each
 * frame its own latent frame, so that the masked frames of the internal clips leave the
 * left-out view's latent frame supervised. */
int gv_adapt_check_base(const gv_adapt_options *o)
{
    gv_model_config base, want;
    gv_train_state s;
    if (gv_checkpoint_read_info(o->base, &base, &s)) return -1;
    if (!strcmp(s.kind, GV_SCENE_CHECKPOINT_KIND))
        return gv_fail("%s: a scene checkpoint; adapt starts from a cross-scene one (e.g. "
                       "models/gaussvid-small.safetensors)", o->base);
    const char *preset = o->config ? o->config : "small";
    if (gv_model_config_load(&want, preset)) return -1;
    if (!gv_config_same_network(&base, &want)) {
        char have[160], need[160];
        gv_config_describe(&base, have, sizeof have);
        gv_config_describe(&want, need, sizeof need);
        return gv_fail("%s: a checkpoint of another network (%s) than %s (%s)", o->base, have, preset, need);
    }
    if (base.vae.temporal_factor != 1)
        return gv_fail("%s: its VAE packs %d frames into a latent frame; the internal pairs mask frames 1 and 3 "
                       "and need one latent frame per frame (temporal factor 1, as the small preset)",
                       o->base, base.vae.temporal_factor);
    return 0;
}

/* The scene, checked at its interval. */
static int load_scene(const gv_adapt_options *o, gv_scene *scene)
{
    gv_scene_options so = {.downscale = o->downscale};
    if (gv_scene_load(o->scene_dir, &so, scene)) return -1;
    /* any frame size: the clips are padded to the network's block (condition.h) */
    int rc = gv_internal_check(scene->n_frames, o->interval) ? gv_fail_context("%s", o->scene_dir) : 0;
    if (rc) gv_scene_free(scene);
    return rc;
}

typedef struct {
    gv_restorer base;                /* the base: its network (adapters trained here), VAE, state */
    gv_latent_set train, held;
    gv_latent_set harm_unused, harm; /* the do-no-harm clips of the trained and held-back views */
    gv_latent_set fit, check;        /* with harm_train: views of train + harm_unused, held + harm */
} adapt_run;

static void run_free(adapt_run *x)
{
    gv_restorer_free(&x->base);
    gv_latent_set_free(&x->train);
    gv_latent_set_free(&x->held);
    gv_latent_set_view_free(&x->fit);
    gv_latent_set_view_free(&x->check);
    gv_latent_set_free(&x->harm_unused);
    gv_latent_set_free(&x->harm);
}

/* The variant the adapted network is built for; NULL for "base": the base's own. */
static const char *adapted_variant(const gv_adapt_options *o)
{
    return o->variant && strcmp(o->variant, "base") ? o->variant : NULL;
}

/* The base's network (every tensor, its adapters to be trained) and VAE; the internal pairs'
 * latents split into training and held-back clips, and the do-no-harm clips of the held-back
 * views (both folders list clip i for view i + 1, so one hold-back picks the same views). */
static int load_model_and_data(const gv_adapt_options *o, const char *pairs, const char *harm, adapt_run *x)
{
    gv_latent_set all, all_harm;
    if (gv_restorer_load(o->base, &x->base) || gv_dit_set_train_mode(&x->base.net, GV_DIT_FINETUNE)) return -1;
    const char *variant = adapted_variant(o);
    if (variant || o->fresh_camera) {
        /* another output form or a fresh camera encoder: the network is built for the variant
         * and takes the base's weights as `train` takes a base (a residual head from zero) */
        gv_model_config cfg = x->base.cfg;
        gv_train_state unused;
        memset(&unused, 0, sizeof unused);
        if (variant && gv_model_config_set_variant(&cfg, variant, "--variant")) return -1;
        gv_dit_free(&x->base.net);
        if (gv_train_model(&cfg, GV_OBJECTIVE_FINETUNE, o->base, o->fresh_camera, o->train.seed, &x->base.net, &unused))
            return -1;
        x->base.cfg = cfg;
    }
    if (gv_latent_set_load(pairs, "train", x->base.vae_path, &x->base.vae, &x->base.cfg, &all) ||
        gv_latent_set_hold_back(&all, o->hold_every, &x->train, &x->held))
        return -1;
    if (gv_latent_set_load(harm, "train", x->base.vae_path, &x->base.vae, &x->base.cfg, &all_harm) ||
        gv_latent_set_hold_back(&all_harm, o->hold_every, &x->harm_unused, &x->harm))
        return -1;
    if (x->harm.count != x->held.count)
        return gv_fail("%s: %d do-no-harm clips held back for %d internal pairs: the work folder is inconsistent",
                       harm, x->harm.count, x->held.count);
    if (!o->harm_train) return 0;
    return gv_latent_set_join(&x->train, &x->harm_unused, "harm/", &x->fit) ||
                   gv_latent_set_join(&x->held, &x->harm, "harm/", &x->check)
               ? -1
               : 0;
}

/* The gate's measurements: the held-back pairs and their do-no-harm clips, restored with the
 * kept adapters, and its decision. */
static int measure_gate(const gv_adapt_options *o, const char *pairs, const char *harm, adapt_run *x,
                        gv_scene_adaptation *a)
{
    gv_gate_measure g, h;
    if (gv_adapt_measure(&x->base.net, &x->base.vae, pairs, &x->held, &o->sampler, o->compose, &g)) return -1;
    gv_info("adapt: gate: the do-no-harm clips of the %d held-back views", x->harm.count);
    if (gv_adapt_measure(&x->base.net, &x->base.vae, harm, &x->harm, &o->sampler, o->compose, &h)) return -1;
    a->gate_frames = g.frames;
    a->gate_psnr_base = g.psnr_base, a->gate_psnr_restored = g.psnr_restored;
    a->gate_ssim_base = g.ssim_base, a->gate_ssim_restored = g.ssim_restored;
    a->harm_frames = h.frames;
    a->harm_psnr_base = h.psnr_base, a->harm_psnr_restored = h.psnr_restored;
    a->harm_ssim_base = h.ssim_base, a->harm_ssim_restored = h.ssim_restored;
    char text[200];
    gv_sampler_describe(&o->sampler, text, sizeof text);
    snprintf(a->gate_sampler, sizeof a->gate_sampler, "%s, %s composition", text, gv_compose_name(o->compose));
    snprintf(a->gate_compose, sizeof a->gate_compose, "%s", gv_compose_name(o->compose));
    a->gate_margin_db = o->gate_margin_db, a->gate_min_frames = o->gate_min_frames;
    a->harm_max_loss_db = o->harm_max_loss_db;
    a->gate_open = gv_scene_gate_decide(a);
    return 0;
}

/* gv_adapt_score of --early-stop psnr: the held-back pairs' PSNR change, restored with the
 * network as it is now exactly as the gate will restore them. */
typedef struct {
    const gv_adapt_options *o;
    adapt_run *x;
    const char *pairs;
} psnr_score;

static int held_psnr_change(void *ctx, gv_dit *m, double *gain_db)
{
    psnr_score *s = ctx;
    gv_gate_measure g;
    if (gv_adapt_measure(m, &s->x->base.vae, s->pairs, &s->x->held, &s->o->sampler, s->o->compose, &g)) return -1;
    *gain_db = g.psnr_restored - g.psnr_base;
    return 0;
}

/* The training state the scene checkpoint records: the fine-tuning's, naming the base. */
static int scene_state(const gv_adapt_options *o, const char *final, gv_train_state *s)
{
    gv_model_config cfg;
    if (gv_checkpoint_read_info(final, &cfg, s)) return -1;
    snprintf(s->base, sizeof s->base, "%s", o->base);
    return 0;
}

static int write_checkpoint(const gv_adapt_options *o, const char *work, adapt_run *x, gv_adapt_report *r)
{
    char final[4200];
    gv_train_state s;
    gv_scene_adaptation *a = &r->adaptation;
    snprintf(final, sizeof final, "%s/train.safetensors", work);
    if (scene_state(o, final, &s) || gv_file_checksum(o->base, a->base_checksum, sizeof a->base_checksum)) return -1;
    return gv_scene_checkpoint_save(o->out, &x->base.net, &x->base.cfg, &s, a);
}

static int run_stages(const gv_adapt_options *o, const char *work, adapt_run *x, gv_adapt_report *r)
{
    gv_scene_adaptation *a = &r->adaptation;
    char pairs[4200], harm[4200], path[4300];
    snprintf(pairs, sizeof pairs, "%s/pairs", work);
    snprintf(harm, sizeof harm, "%s/harm", work);
    gv_scene scene;
    if (gv_checkpoint_read_info(o->base, &x->base.cfg, &x->base.state) || gv_mkdirs(work) ||
        load_scene(o, &scene))
        return -1;
    double t = gv_now();
    gv_model_config want = x->base.cfg; /* the adapted network's variant: with coverage, every clip needs its plane */
    const char *variant = adapted_variant(o);
    if (variant && gv_model_config_set_variant(&want, variant, "--variant")) {
        gv_scene_free(&scene);
        return -1;
    }
    int planes = want.variant.coverage || o->compose == GV_COMPOSE_UNSEEN; /* both read the coverage plane */
    gv_internal_options po = {.interval = o->interval, .iters = o->iters, .subsets = o->subsets, .densify = o->densify, .seed = o->train.seed,
                              .simulator = o->simulator, .out_dir = pairs, .full_model = 0, .coverage = planes};
    gv_internal_options ho = po;
    ho.out_dir = harm, ho.full_model = 1;
    /* under mpirun rank 0 builds the clips and the others wait for them: only the fine-tuning
     * is shared among the ranks */
    int rc = gv_dist_is_root() ? gv_internal_build(&scene, &po, &r->pairs) : 0;
    if (rc == 0 && gv_dist_is_root()) rc = gv_internal_build(&scene, &ho, &r->harm);
    rc = gv_dist_after_root(gv_dist_is_root() ? rc : 0, pairs);
    if (rc == 0) gv_scene_name_of(scene.dir, a->scene, sizeof a->scene);
    gv_scene_free(&scene);
    if (rc) return -1;
    a->seconds_pairs = gv_now() - t, t = gv_now();
    gv_info("adapt: latents: the base loaded, the internal clips through its VAE (cached in %s)", pairs);
    if (load_model_and_data(o, pairs, harm, x)) return -1;
    a->seconds_latents = gv_now() - t, t = gv_now();

    gv_train_options to = o->train;
    snprintf(path, sizeof path, "%s/train.safetensors", work);
    char log[4300], val_log[4300], best_path[4300];
    snprintf(log, sizeof log, "%s/train.tsv", work);
    snprintf(val_log, sizeof val_log, "%s/val.tsv", work);
    snprintf(best_path, sizeof best_path, "%s/best.safetensors", work);
    to.objective = GV_OBJECTIVE_FINETUNE, to.resume = 1, to.checkpoint_every = to.val_every;
    to.out = path, to.log_path = log, to.val_log = val_log;
    gv_train_state meta;
    memset(&meta, 0, sizeof meta);
    snprintf(meta.kind, sizeof meta.kind, "finetune");
    snprintf(meta.vae, sizeof meta.vae, "%s", x->base.vae_path);
    gv_checkpoint_vae_checksum(&x->base.vae, meta.vae_checksum, sizeof meta.vae_checksum);
    snprintf(meta.base, sizeof meta.base, "%s", o->base);
    snprintf(meta.clips, sizeof meta.clips, "%s", pairs);
    const gv_latent_set *fit = o->harm_train ? &x->fit : &x->train, *check = o->harm_train ? &x->check : &x->held;
    gv_train_data_text(fit, "train", meta.data, sizeof meta.data);
    gv_info("adapt: %s n=%d: %d internal clips for training, %d held back%s; %ld steps of %d clips at lr %g (%s)",
            a->scene, o->interval, x->train.count, x->held.count,
            o->harm_train ? ", each with its do-no-harm clip" : "", to.steps, to.batch, to.lr,
            gv_lr_kind_name(to.lr_schedule));
    psnr_score ps = {o, x, pairs};
    gv_adapt_score score = {held_psnr_change, &ps, "PSNR change"};
    rc = gv_adapt_train(&x->base.net, &x->base.cfg, fit, check, &to, &meta, o->early_stop_psnr ? &score : NULL,
                        best_path, &r->best, &r->train);
    if (rc) return rc < 0 ? -1 : 0; /* 1: stopped before the last step */
    a->seconds_train = gv_now() - t, t = gv_now();

    if (gv_dit_set_train_mode(&x->base.net, GV_DIT_FROZEN)) return -1;
    gv_info("adapt: gate: restoring the %d held-back clips with the adapters of step %ld", x->held.count, r->best.step);
    if (measure_gate(o, pairs, harm, x, a)) return -1;
    a->seconds_gate = gv_now() - t;
    a->interval = o->interval, a->iters = o->iters, a->subsets = o->subsets;
    a->train_clips = x->train.count, a->held_back = x->held.count;
    a->best_step = r->best.step;
    snprintf(a->best_by, sizeof a->best_by, "%s", o->early_stop_psnr ? "PSNR change" : "latent gain");
    a->val_gain_db = r->best.gain_db, a->val_loss = r->best.loss, a->val_identity = r->best.identity;
    if (write_checkpoint(o, work, x, r)) return -1;
    r->done = 1;
    return 0;
}

int gv_adapt_scene(const gv_adapt_options *o, gv_adapt_report *r)
{
    memset(r, 0, sizeof *r);
    if (!o->scene_dir || !o->base || !o->out) return gv_fail("adapt: a scene, a base checkpoint and an output are needed");
    if (gv_interval_check(o->interval, 0, GV_INTERVAL_CLIPS)) return gv_fail_context("adapt");
    if (o->iters < 1 || o->subsets < 2 || o->hold_every < 2 || !(o->harm_max_loss_db >= 0))
        return gv_fail("adapt: iterations %d, subsets %d, hold-back interval %d, do-no-harm loss %g dB: need "
                       "iterations >= 1, subsets >= 2, every >= 2 and a loss >= 0", o->iters,
                       o->subsets, o->hold_every, o->harm_max_loss_db);
    if (o->work_dir) snprintf(r->work_dir, sizeof r->work_dir, "%s", o->work_dir);
    else snprintf(r->work_dir, sizeof r->work_dir, "%s.work", o->out);
    gv_atomic_sweep_beside(o->out); /* the temporary of a scene checkpoint a kill cut short */
    if (gv_file_exists(o->out)) { /* done before: its record is the report */
        if (gv_scene_checkpoint_read(o->out, &r->adaptation)) return -1;
        r->done = r->already = 1;
        return 0;
    }
    if (gv_adapt_check_base(o)) return -1;
    adapt_run x;
    memset(&x, 0, sizeof x);
    int rc = run_stages(o, r->work_dir, &x, r);
    run_free(&x);
    return rc;
}
