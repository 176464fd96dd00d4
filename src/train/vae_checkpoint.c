/* The files of a VAE training run: the weights (loadable by gv_vae_load, with the config and,
 * at the end, the latent statistics in the metadata) and the checkpoint beside them
 * (out + ".ckpt": weights, AdamW moments "adamw.m.<name>" / "adamw.v.<name>", step and the
 * options that decide the steps taken), both written atomically; and the latent statistics. */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "gaussvid/core/core.h"
#include "gaussvid/io/safetensors.h"
#include "gaussvid/model/weight_names.h"
#include "train/vae_train_internal.h"

/* The options a resumed run must share with the first (steps may grow). */
static void options_text(const gv_vae_train_options *o, char *out, size_t size)
{
    snprintf(out, size,
             "seed=%llu batch=%d frames=%d crop=%dx%d max_stride=%d image_every=%d lr=%g min_lr=%g warmup=%ld "
             "weight_decay=%g clip_norm=%g l2_weight=%g kl_weight=%g",
             (unsigned long long)o->seed, o->batch, o->frames, o->crop_w, o->crop_h, o->max_stride, o->image_every, o->lr,
             o->min_lr, o->warmup, o->weight_decay, o->clip_norm, o->l2_weight, o->kl_weight);
}

static void checkpoint_path(const gv_vae_train_options *o, char *out, size_t size)
{
    snprintf(out, size, "%s.ckpt", o->out);
}

int gv_vae_checkpoint_save(const gv_vae *v, const gv_model_config *c, const gv_vae_train_options *o, long step,
                           double seconds)
{
    char path[4200], options[512], step_text[32], adam_text[32], seconds_text[32], name[GV_WEIGHT_NAME_MAX + 16];
    checkpoint_path(o, path, sizeof path);
    options_text(o, options, sizeof options);
    snprintf(step_text, sizeof step_text, "%ld", step);
    snprintf(adam_text, sizeof adam_text, "%ld", v->params.step);
    snprintf(seconds_text, sizeof seconds_text, "%.1f", seconds);
    /* the weights carry nothing that varies between identical runs (no times) */
    const char *keys[3] = {"step", "training", "config_spec"};
    const char *values[3] = {step_text, options, o->config_spec ? o->config_spec : c->name};
    if (gv_vae_save(v, c, o->out, keys, values, 3)) return -1;
    gv_st_builder b;
    gv_st_builder_init(&b);
    int rc = 0;
    for (int i = 0; i < v->params.n && rc == 0; i++) {
        const gv_param *p = v->params.items[i];
        int64_t shape[GV_MAX_DIMS];
        for (int k = 0; k < p->t.ndim; k++) shape[k] = p->t.shape[k];
        rc = gv_st_add_f32(&b, p->t.name, GV_ST_F32, shape, p->t.ndim, p->t.data);
        snprintf(name, sizeof name, "adamw.m.%s", p->t.name);
        if (rc == 0 && p->m) rc = gv_st_add_f32(&b, name, GV_ST_F32, shape, p->t.ndim, p->m);
        snprintf(name, sizeof name, "adamw.v.%s", p->t.name);
        if (rc == 0 && p->v) rc = gv_st_add_f32(&b, name, GV_ST_F32, shape, p->t.ndim, p->v);
    }
    if (rc == 0) rc = gv_st_add_metadata(&b, "step", step_text);
    if (rc == 0) rc = gv_st_add_metadata(&b, "adamw_step", adam_text);
    if (rc == 0) rc = gv_st_add_metadata(&b, "seconds", seconds_text);
    if (rc == 0) rc = gv_st_add_metadata(&b, "training", options);
    if (rc == 0) rc = gv_st_write(&b, path);
    gv_st_builder_free(&b);
    return rc;
}

static int read_long(const gv_st_file *f, const char *key, long *out)
{
    const char *text = gv_st_metadata(f, key);
    char *end;
    long value = text ? strtol(text, &end, 10) : -1;
    if (!text || *end || value < 0) return gv_fail("%s: metadata %s is missing or not a count", f->path, key);
    *out = value;
    return 0;
}

int gv_vae_checkpoint_load(gv_vae *v, const gv_vae_train_options *o, long *step, double *seconds)
{
    char path[4200], options[512], name[GV_WEIGHT_NAME_MAX + 16];
    checkpoint_path(o, path, sizeof path);
    *step = 0;
    *seconds = 0;
    if (!gv_file_exists(path)) {
        gv_info("vae train: no checkpoint %s, starting from step 0", path);
        return 0;
    }
    gv_st_file f;
    if (gv_st_open(&f, path)) return -1;
    options_text(o, options, sizeof options);
    const char *was = gv_st_metadata(&f, "training");
    long adam_step = 0;
    int rc = !was || strcmp(was, options)
                 ? gv_fail("%s: written with other training options (%s), now %s", path, was ? was : "none", options)
                 : 0;
    if (rc == 0) rc = read_long(&f, "step", step);
    if (rc == 0) rc = read_long(&f, "adamw_step", &adam_step);
    const char *sec = gv_st_metadata(&f, "seconds");
    if (sec) *seconds = atof(sec);
    for (int i = 0; i < v->params.n && rc == 0; i++) {
        gv_param *p = v->params.items[i];
        int64_t shape[GV_MAX_DIMS];
        for (int k = 0; k < p->t.ndim; k++) shape[k] = p->t.shape[k];
        rc = gv_st_read_f32(&f, p->t.name, p->t.data, shape, p->t.ndim);
        snprintf(name, sizeof name, "adamw.m.%s", p->t.name);
        if (rc == 0 && p->m) rc = gv_st_read_f32(&f, name, p->m, shape, p->t.ndim);
        snprintf(name, sizeof name, "adamw.v.%s", p->t.name);
        if (rc == 0 && p->v) rc = gv_st_read_f32(&f, name, p->v, shape, p->t.ndim);
    }
    if (rc == 0) {
        v->params.step = adam_step;
        gv_info("vae train: resuming from %s at step %ld", path, *step);
    }
    gv_st_close(&f);
    return rc;
}

int gv_vae_compute_stats(gv_vae *v, const gv_vae_frames *f, const gv_vae_train_options *o)
{
    int z = v->cfg.z_dim, T = o->frames, h = o->crop_h, w = o->crop_w, tl = 0;
    if (gv_vae_latent_frames(&v->cfg, T, &tl)) return -1;
    int64_t n_lat = (int64_t)tl * (h / v->cfg.spatial_factor) * (w / v->cfg.spatial_factor);
    float *x = malloc(sizeof(float) * 3 * (size_t)T * h * w), *mu = malloc(sizeof(float) * (size_t)(z * n_lat));
    double sum[GV_VAE_MAX_Z_DIM] = {0}, sq[GV_VAE_MAX_Z_DIM] = {0}, mean[GV_VAE_MAX_Z_DIM], std[GV_VAE_MAX_Z_DIM];
    int rc = !x || !mu ? gv_fail("vae: out of memory for the latent statistics") : 0;
    gv_rng r;
    gv_rng_init(&r, o->seed * 0x9E3779B97F4A7C15ULL + 3);
    gv_progress bar;
    gv_progress_start(&bar, "latent statistics", o->stats_clips);
    for (int k = 0; k < o->stats_clips && rc == 0; k++) {
        rc = gv_vae_sample_clip(f, &r, T, o->max_stride, h, w, x);
        if (rc == 0) rc = gv_vae_encode(v, x, T, h, w, 0, 0, mu);
        for (int c = 0; c < z && rc == 0; c++)
            for (int64_t i = 0; i < n_lat; i++) {
                double a = mu[c * n_lat + i];
                sum[c] += a;
                sq[c] += a * a;
            }
        gv_progress_update(&bar, k + 1, NULL);
    }
    gv_progress_finish(&bar);
    double n = (double)o->stats_clips * (double)n_lat;
    for (int c = 0; c < z && rc == 0; c++) {
        mean[c] = sum[c] / n;
        double var = sq[c] / n - mean[c] * mean[c];
        std[c] = sqrt(var > 1e-12 ? var : 1e-12);
    }
    if (rc == 0) rc = gv_vae_set_stats(v, mean, std);
    free(x);
    free(mu);
    return rc;
}
