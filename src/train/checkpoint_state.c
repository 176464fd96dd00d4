/* Writing checkpoints and resuming training from them (docs/TRAINING.md): every tensor of the
 * network, the AdamW moments of the trainable ones ("adamw.m.<name>", "adamw.v.<name>"), and
 * the state that makes a resumed run take exactly the steps an uninterrupted one would: step,
 * AdamW step, data position, seed (every draw of step s comes from the stream (seed, s)). */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "gaussvid/core/core.h"
#include "train/train_internal.h"

/* The parts the file's tensors cover: every tensor of m, or only those fine-tuning trains. */
static const char *parts_text(const gv_dit *m, int adapters_only, char *out, size_t size)
{
    unsigned parts = 0;
    for (int i = 0; i < m->params.n; i++)
        if (!adapters_only || gv_dit_param_is_adapter(m, m->params.items[i]->t.name))
            parts |= gv_dit_param_part(m, m->params.items[i]->t.name);
    return gv_parts_text(parts, out, size);
}

static int add_tensor(gv_st_builder *b, const char *prefix, const gv_tensor *t, const float *data)
{
    char name[GV_WEIGHT_NAME_MAX + 16];
    int64_t shape[GV_MAX_DIMS];
    for (int k = 0; k < t->ndim; k++) shape[k] = t->shape[k];
    snprintf(name, sizeof name, "%s%s", prefix, t->name);
    if (!data) return gv_st_add_raw(b, name, GV_ST_BF16, shape, t->ndim, t->bf16); /* a BF16 base weight, as loaded */
    return gv_st_add_f32(b, name, GV_ST_F32, shape, t->ndim, data);
}

int gv_ckpt_add_state(gv_st_builder *b, const gv_dit *m, const gv_model_config *cfg, const gv_train_state *s,
                      int adapters_only)
{
    char num[12][40], parts[64], version[8];
    char *json = gv_model_config_to_json(cfg);
    if (!json) return gv_fail("out of memory for the config");
    snprintf(version, sizeof version, "%d", GV_CHECKPOINT_VERSION);
    snprintf(num[0], 40, "%ld", s->step);
    snprintf(num[1], 40, "%ld", s->steps);
    snprintf(num[2], 40, "%ld", m->params.step);
    snprintf(num[3], 40, "%ld", s->data_position);
    snprintf(num[4], 40, "%ld", s->clips_used);
    snprintf(num[5], 40, "%ld", s->clips_skipped);
    snprintf(num[6], 40, "%llu", (unsigned long long)s->seed);
    snprintf(num[7], 40, "%.3f", s->seconds);
    snprintf(num[8], 40, "%.17g", s->loss); /* exact: a resumed run continues the average from it */
    const char *keys[] = {"format", "format_version", "kind", "config", "parts", "step", "steps", "adamw_step",
                          "data_position", "clips_used", "clips_skipped", "seed", "seconds", "loss", "vae",
                          "vae_checksum", "base", "clips", "data", "training", "rng", "text_context", "text_prompt",
                          "text_encoder", "text_tokenizer"};
    const char *values[] = {GV_CHECKPOINT_FORMAT, version, s->kind, json, parts_text(m, adapters_only, parts, sizeof parts),
                            num[0], num[1], num[2], num[3], num[4], num[5], num[6], num[7], num[8], s->vae,
                            s->vae_checksum, s->base, s->clips, s->data, s->training,
                            "philox4x32-10: step s draws its clips' timesteps and noise from the stream (seed, s)",
                            s->text.path, s->text.prompt, s->text.encoder, s->text.tokenizer};
    int rc = 0;
    for (int i = 0; rc == 0 && i < (int)(sizeof keys / sizeof keys[0]); i++) rc = gv_st_add_metadata(b, keys[i], values[i]);
    /* only when known: a file without the key says nothing about its training scenes */
    if (rc == 0 && s->scenes[0]) rc = gv_st_add_metadata(b, "scenes", s->scenes);
    free(json);
    return rc;
}

int gv_checkpoint_save(const char *path, const gv_dit *m, const gv_model_config *cfg, const gv_train_state *s,
                       int with_moments)
{
    gv_st_builder b;
    gv_st_builder_init(&b);
    int rc = 0;
    for (int i = 0; rc == 0 && i < m->params.n; i++) {
        const gv_param *p = m->params.items[i];
        rc = add_tensor(&b, "", &p->t, p->t.data);
        if (rc == 0 && with_moments && p->trainable && p->m) rc = add_tensor(&b, "adamw.m.", &p->t, p->m);
        if (rc == 0 && with_moments && p->trainable && p->v) rc = add_tensor(&b, "adamw.v.", &p->t, p->v);
    }
    if (rc == 0) rc = gv_ckpt_add_state(&b, m, cfg, s, 0);
    if (rc == 0) rc = gv_st_write(&b, path);
    gv_st_builder_free(&b);
    return rc;
}

static int read_tensor(const gv_st_file *f, const char *prefix, const gv_tensor *t, float *dst)
{
    char name[GV_WEIGHT_NAME_MAX + 16];
    int64_t shape[GV_MAX_DIMS];
    for (int k = 0; k < t->ndim; k++) shape[k] = t->shape[k];
    snprintf(name, sizeof name, "%s%s", prefix, t->name);
    return gv_st_read_f32(f, name, dst, shape, t->ndim);
}

int gv_checkpoint_restore(const char *path, gv_dit *m, gv_train_state *s)
{
    gv_st_file f;
    gv_model_config cfg;
    if (gv_ckpt_open(&f, path)) return -1;
    int rc = gv_ckpt_read_meta(&f, &cfg, s);
    for (int i = 0; rc == 0 && i < m->params.n; i++) {
        gv_param *p = m->params.items[i];
        if (p->t.bf16) continue; /* a frozen BF16 base weight, mapped from the base this run loaded */
        rc = read_tensor(&f, "", &p->t, p->t.data);
        if (rc == 0 && p->trainable && p->m) rc = read_tensor(&f, "adamw.m.", &p->t, p->m);
        if (rc == 0 && p->trainable && p->v) rc = read_tensor(&f, "adamw.v.", &p->t, p->v);
    }
    if (rc == 0 && gv_params_check_finite(&m->params, 0)) rc = gv_fail_context("%s", path);
    if (rc == 0) m->params.step = s->adamw_step;
    gv_st_close(&f);
    return rc;
}

/* A base's tensor that fine-tuning takes: DiT and VACE always, the camera encoder when the
 * base had the same camera variant (then all of it), LoRA adapters when the file has them.
 * A DiT tensor that fine-tuning trains (the residual output's layer, weight_names.c) keeps its
 * zero initialisation instead: the base's head predicts a velocity, the residual head a
 * correction, so fine-tuning starts at the identity. */
static int wanted(const gv_dit *m, const gv_st_file *f, const char *name, int same_camera)
{
    const gv_weight_spec *s = gv_weight_list_find(&m->weights, name);
    unsigned part = s ? gv_module_part(s->module) : 0;
    if (part == GV_PART_CAMERA) return same_camera;
    if (part == GV_PART_LORA) return gv_st_find(f, name) != NULL;
    return (part == GV_PART_DIT || part == GV_PART_VACE) && !s->trainable;
}

int gv_checkpoint_load_base_open(const gv_st_file *f, gv_dit *m, int take_camera, int *camera_loaded, int *kept)
{
    gv_model_config cfg;
    gv_train_state s;
    char have[160], want[160];
    *camera_loaded = *kept = 0;
    int rc = gv_ckpt_read_meta(f, &cfg, &s);
    if (rc == 0 && !gv_config_same_network(&cfg, &m->cfg)) {
        gv_config_describe(&cfg, have, sizeof have);
        gv_config_describe(&m->cfg, want, sizeof want);
        rc = gv_fail("%s: the base is another network (%s) than the config (%s)", f->path, have, want);
    }
    int same_camera = rc == 0 && take_camera && cfg.variant.camera == m->cfg.variant.camera && cfg.variant.camera != GV_CAMERA_NONE;
    for (int i = 0; rc == 0 && i < m->params.n; i++) {
        gv_param *p = m->params.items[i];
        if (!wanted(m, f, p->t.name, same_camera)) continue;
        int kept_one = 0;
        rc = gv_dit_read_param(m, f, p, &kept_one);
        *kept |= kept_one;
        if (rc == 0 && gv_dit_param_part(m, p->t.name) == GV_PART_CAMERA) *camera_loaded = 1;
    }
    if (rc == 0 && gv_dit_check_loaded(m)) rc = gv_fail_context("%s", f->path);
    if (rc == 0) rc = gv_checkpoint_text(f->path, &s, m);
    return rc;
}

int gv_checkpoint_load_base(const char *path, gv_dit *m, int take_camera, int *camera_loaded)
{
    gv_st_file f;
    int kept;
    *camera_loaded = 0;
    if (gv_ckpt_open(&f, path)) return -1;
    int rc = gv_checkpoint_load_base_open(&f, m, take_camera, camera_loaded, &kept);
    if (rc == 0 && kept) rc = gv_dit_keep_file(m, &f); /* BF16 base weights point into it */
    gv_st_close(&f);
    return rc;
}
