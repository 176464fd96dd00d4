/* Reading checkpoints (docs/TRAINING.md "Checkpoint files"): the metadata (format, config,
 * training state), loading a checkpoint for inference with its VAE, and the checksum that
 * ties a checkpoint to the VAE file it was trained with. Writing and resuming are in
 * checkpoint_state.c. */
#include <errno.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>

#include "gaussvid/train/condition.h"
#include "gaussvid/core/core.h"
#include "gaussvid/train/scene_adapt.h"
#include "train/train_internal.h"

void gv_checkpoint_vae_checksum(const gv_vae *vae, char *out, size_t size)
{
    snprintf(out, size, "fnv1a64:%016llx", (unsigned long long)gv_vae_checksum(vae));
}

int gv_ckpt_open(gv_st_file *f, const char *path)
{
    if (gv_st_open(f, path)) return -1;
    const char *format = gv_st_metadata(f, "format");
    if (!format || strcmp(format, GV_CHECKPOINT_FORMAT)) {
        gv_fail("%s: not a gaussvid checkpoint (metadata format is %s%s%s, expected %s)", path, format ? "\"" : "",
                format ? format : "missing", format ? "\"" : "", GV_CHECKPOINT_FORMAT);
        gv_st_close(f);
        return -1;
    }
    return 0;
}

static int meta_long(const gv_st_file *f, const char *key, long *out)
{
    const char *text = gv_st_metadata(f, key);
    char *end = NULL;
    errno = 0;
    long v = text ? strtol(text, &end, 10) : -1;
    if (!text || !*text || *end || errno || v < 0)
        return gv_fail("%s: metadata %s is %s", f->path, key, text ? "not a count" : "missing");
    *out = v;
    return 0;
}

static int meta_double(const gv_st_file *f, const char *key, double *out)
{
    const char *text = gv_st_metadata(f, key);
    char *end = NULL;
    double v = text ? strtod(text, &end) : 0;
    if (!text || !*text || *end) return gv_fail("%s: metadata %s is %s", f->path, key, text ? "not a number" : "missing");
    *out = v;
    return 0;
}

static void meta_text(const gv_st_file *f, const char *key, char *out, size_t size)
{
    const char *text = gv_st_metadata(f, key);
    snprintf(out, size, "%s", text ? text : "");
}

int gv_ckpt_read_meta(const gv_st_file *f, gv_model_config *cfg, gv_train_state *s)
{
    const char *json = gv_st_metadata(f, "config");
    if (!json) return gv_fail("%s: metadata config is missing", f->path);
    if (gv_model_config_parse(cfg, json, f->path)) return -1;
    memset(s, 0, sizeof *s);
    meta_text(f, "kind", s->kind, sizeof s->kind);
    /* every checkpoint but a scene checkpoint holds the DiT and VACE: refuse a config the file
     * cannot hold before anyone builds its network (issue 25). A scene checkpoint holds only
     * adapters; its base is checked when it loads. */
    if (strcmp(s->kind, GV_SCENE_CHECKPOINT_KIND) &&
        gv_weights_fit(cfg, GV_PART_DIT | GV_PART_VACE, f->data_size, f->path))
        return -1;
    if (strcmp(s->kind, "base") && strcmp(s->kind, "finetune") && strcmp(s->kind, GV_SCENE_CHECKPOINT_KIND))
        return gv_fail("%s: metadata kind is \"%s\", expected base, finetune or scene", f->path, s->kind);
    const char *seed_text = gv_st_metadata(f, "seed");
    char *end = NULL;
    if (meta_long(f, "step", &s->step) || meta_long(f, "steps", &s->steps) || meta_long(f, "adamw_step", &s->adamw_step) ||
        meta_long(f, "data_position", &s->data_position) || meta_long(f, "clips_used", &s->clips_used) ||
        meta_long(f, "clips_skipped", &s->clips_skipped) || meta_double(f, "seconds", &s->seconds) ||
        meta_double(f, "loss", &s->loss))
        return -1;
    if (seed_text) s->seed = strtoull(seed_text, &end, 10);
    if (!seed_text || !*seed_text || *end) return gv_fail("%s: metadata seed is %s", f->path, seed_text ? "not a number" : "missing");
    meta_text(f, "vae", s->vae, sizeof s->vae);
    meta_text(f, "vae_checksum", s->vae_checksum, sizeof s->vae_checksum);
    meta_text(f, "base", s->base, sizeof s->base);
    meta_text(f, "clips", s->clips, sizeof s->clips);
    meta_text(f, "data", s->data, sizeof s->data);
    meta_text(f, "training", s->training, sizeof s->training);
    meta_text(f, "text_context", s->text.path, sizeof s->text.path);
    meta_text(f, "text_prompt", s->text.prompt, sizeof s->text.prompt);
    meta_text(f, "text_encoder", s->text.encoder, sizeof s->text.encoder);
    meta_text(f, "text_tokenizer", s->text.tokenizer, sizeof s->text.tokenizer);
    meta_text(f, "scenes", s->scenes, sizeof s->scenes);
    return 0;
}

int gv_checkpoint_read_info(const char *path, gv_model_config *cfg, gv_train_state *state)
{
    gv_st_file f;
    if (gv_ckpt_open(&f, path)) return -1;
    int rc = gv_ckpt_read_meta(&f, cfg, state);
    gv_st_close(&f);
    return rc;
}

int gv_config_same_network(const gv_model_config *a, const gv_model_config *b)
{
    gv_model_config x = *b;
    memcpy(x.name, a->name, sizeof x.name);
    x.variant = a->variant;
    x.lora = a->lora;
    x.vae.has_latent_stats = a->vae.has_latent_stats;
    memcpy(x.vae.latent_mean, a->vae.latent_mean, sizeof x.vae.latent_mean);
    memcpy(x.vae.latent_std, a->vae.latent_std, sizeof x.vae.latent_std);
    return gv_model_config_equal(a, &x);
}

void gv_config_describe(const gv_model_config *c, char *out, size_t size)
{
    snprintf(out, size, "%s: dim %d, %d layers, %d VACE layers, VAE dim %d z_dim %d", c->name, c->dit.dim,
             c->dit.num_layers, c->dit.n_vace_layers, c->vae.dim, c->vae.z_dim);
}

unsigned gv_dit_param_part(const gv_dit *m, const char *name)
{
    const gv_weight_spec *s = gv_weight_list_find(&m->weights, name);
    return s ? gv_module_part(s->module) : 0;
}

int gv_dit_param_is_adapter(const gv_dit *m, const char *name)
{
    const gv_weight_spec *s = gv_weight_list_find(&m->weights, name);
    return s && s->trainable;
}

/* Reads every tensor of m from the file; a base may lack its (zero-start) LoRA adapters.
 * BF16 base weights stay in the file's mapping, which the model must then keep open: *kept
 * says so (the caller hands the file over once it has read everything else from it). */
static int load_network(const gv_st_file *f, gv_dit *m, const gv_train_state *s, int *kept)
{
    *kept = 0;
    for (int i = 0; i < m->params.n; i++) {
        gv_param *p = m->params.items[i];
        if (!gv_st_find(f, p->t.name) && !strcmp(s->kind, "base") && gv_dit_param_part(m, p->t.name) == GV_PART_LORA)
            continue;
        int kept_one = 0;
        if (gv_dit_read_param(m, f, p, &kept_one)) return -1;
        *kept |= kept_one;
    }
    if (gv_dit_check_loaded(m)) return gv_fail_context("%s", f->path);
    return 0;
}

/* The file named (metadata "vae" of ckpt, or another file it names): as written, else the same
 * relative path or file name in the checkpoint's folder (1), else the file name in the model
 * folders (2), into out; 0 when not found. */
int gv_checkpoint_find_beside(const char *ckpt, const char *named, char *out, size_t size)
{
    if (!*named) return 0;
    snprintf(out, size, "%s", named);
    if (gv_file_exists(out)) return 1;
    char dir[4096];
    snprintf(dir, sizeof dir, "%s", ckpt);
    char *slash = strrchr(dir, '/');
    if (slash) *slash = '\0';
    else snprintf(dir, sizeof dir, ".");
    const char *base = strrchr(named, '/');
    const char *file = base ? base + 1 : named;
    if (named[0] != '/' && gv_path_join(out, size, dir, named) == 0 && gv_file_exists(out)) return 1;
    if (base && gv_path_join(out, size, dir, file) == 0 && gv_file_exists(out)) return 1;
    return *file && gv_find_model(file, out, size) ? 2 : 0;
}

int gv_checkpoint_vae_path(const char *ckpt, const gv_train_state *s, char *out, size_t size)
{
    if (!*s->vae) return gv_fail("%s: metadata vae is missing and the file holds no VAE tensors", ckpt);
    if (gv_checkpoint_find_beside(ckpt, s->vae, out, size)) return 0;
    return gv_fail("%s: the VAE it names, %s, is not found (looked " GV_CHECKPOINT_LOOKED ")", ckpt, s->vae);
}

/* The VAE: its tensors in the file (r->vae_path is then the file the metadata names if there is
 * one, else the checkpoint), or else the file the metadata names, checked by its checksum. */
static int load_vae(const gv_st_file *f, gv_restorer *r)
{
    /* the VAE's tensors are in the checkpoint or in the file it names: one must hold them */
    char sum[64], named[4200];
    struct stat st;
    uint64_t bytes = f->data_size;
    if (gv_checkpoint_find_beside(f->path, r->state.vae, named, sizeof named) && stat(named, &st) == 0 &&
        (uint64_t)st.st_size > bytes)
        bytes = (uint64_t)st.st_size;
    if (gv_weights_fit(&r->cfg, GV_PART_VAE, bytes, f->path)) return -1;
    if (gv_vae_init(&r->vae, &r->cfg, 0, 0)) return -1;
    if (r->vae.params.n > 0 && gv_st_find(f, r->vae.params.items[0]->t.name)) {
        if (!gv_checkpoint_find_beside(f->path, r->state.vae, r->vae_path, sizeof r->vae_path))
            snprintf(r->vae_path, sizeof r->vae_path, "%s", f->path);
        return gv_vae_read(&r->vae, f, 1);
    }
    int where = *r->state.vae ? gv_checkpoint_find_beside(f->path, r->state.vae, r->vae_path, sizeof r->vae_path) : 0;
    if (!where) return gv_checkpoint_vae_path(f->path, &r->state, r->vae_path, sizeof r->vae_path);
    int rc = gv_vae_load(&r->vae, r->vae_path, 0), other = 0;
    if (rc == 0) {
        gv_checkpoint_vae_checksum(&r->vae, sum, sizeof sum);
        other = *r->state.vae_checksum && strcmp(sum, r->state.vae_checksum);
    }
    /* a file of that name in the model folders (e.g. the released vae.safetensors) that is not
     * this VAE: the one named is not found */
    if (where == 2 && (rc || other))
        return gv_fail("%s: the VAE it names, %s, is not found (looked " GV_CHECKPOINT_LOOKED "; %s there is another VAE)",
                       f->path, r->state.vae, r->vae_path);
    if (rc) return -1;
    if (other)
        return gv_fail("%s: the VAE %s is not the one it was trained with (checksum %s, expected %s)", f->path, r->vae_path,
                       sum, r->state.vae_checksum);
    return 0;
}

int gv_restorer_read_network(gv_st_file *f, gv_restorer *r, const gv_model_config *variant)
{
    int kept = 0, camera_loaded;
    /* the DiT and VACE come from the file: no values of their own first (no float32 copy of a
     * BF16 base) */
    int rc = gv_dit_init_parts(&r->net, variant ? variant : &r->cfg, 0, GV_PART_DIT | GV_PART_VACE);
    if (rc == 0)
        rc = variant ? gv_checkpoint_load_base_open(f, &r->net, 1, &camera_loaded, &kept)
                     : load_network(f, &r->net, &r->state, &kept);
    if (rc == 0) rc = load_vae(f, r);
    if (rc == 0 && !variant) rc = gv_checkpoint_text(f->path, &r->state, &r->net); /* the variant's: loaded with the base */
    if (rc == 0 && kept) rc = gv_dit_keep_file(&r->net, f); /* BF16 base weights point into it */
    if (rc == 0) r->loaded = 1;
    return rc;
}

int gv_restorer_open(const char *path, gv_restorer_part what, gv_restorer *r)
{
    gv_st_file f;
    memset(r, 0, sizeof *r);
    if (gv_ckpt_open(&f, path)) return -1;
    int rc = gv_ckpt_read_meta(&f, &r->cfg, &r->state);
    if (rc == 0 && !strcmp(r->state.kind, GV_SCENE_CHECKPOINT_KIND)) { /* adapters over the base it names */
        rc = gv_scene_restorer_open(&f, what, r);
    } else if (rc == 0) {
        gv_restorer_read_scenes(r, path, &r->state);
        if (what != GV_RESTORER_RECORD) rc = gv_restorer_read_network(&f, r, NULL);
    }
    gv_st_close(&f);
    if (rc) gv_restorer_free(r);
    return rc;
}

int gv_restorer_load(const char *path, gv_restorer *r)
{
    return gv_restorer_open(path, GV_RESTORER_NETWORK, r);
}

void gv_restorer_free(gv_restorer *r)
{
    gv_dit_free(&r->net);
    gv_vae_free(&r->vae);
}
