/* `gaussvid model import`: a published Wan2.1-VACE release folder becomes a gaussvid base
 * checkpoint and its VAE (include/gaussvid/train/model_import.h, docs/WAN_WEIGHTS.md). The release
 * files are read through gv_weights_open (sharded index, safetensors, PyTorch zip), checked
 * against the config's weight list, and re-packaged: the DiT tensors straight from the
 * mapping in their own dtype (no float32 copy of a 14B model in memory), the VAE through
 * gv_vae_load/gv_vae_save. The checkpoint's metadata is the one gv_checkpoint_save writes for
 * a base that took no training step, so every loader of checkpoints reads it unchanged
 * (tests/cli/model_import.sh restores and fine-tunes from it). */
#include <cjson/cJSON.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "gaussvid/train/checkpoint.h"
#include "gaussvid/train/condition.h"
#include "gaussvid/core/core.h"
#include "gaussvid/train/model_import.h"
#include "gaussvid/model/release_lora.h"
#include "gaussvid/model/umt5.h"
#include "gaussvid/model/vae.h"
#include "gaussvid/pth/weight_files.h"
#include "gaussvid/model/weight_names.h"

/* Elements converted at a time when checking values. */
enum { CHECK_CHUNK = 1 << 20 };

/* The first of the names that exists in dir, into out; 0 when none does. */
static int first_existing(const char *dir, const char *const *names, int n, char *out)
{
    for (int i = 0; i < n; i++)
        if (gv_path_join(out, GV_RELEASE_PATH_MAX, dir, names[i]) == 0 && gv_file_exists(out)) return 1;
    out[0] = '\0';
    return 0;
}

int gv_release_find(const char *dir, gv_release_files *files)
{
    static const char *const dit[] = {"diffusion_pytorch_model.safetensors.index.json",
                                      "diffusion_pytorch_model.safetensors"};
    static const char *const vae[] = {"Wan2.1_VAE.pth", "Wan2.1_VAE.safetensors"};
    static const char *const config[] = {"config.json"};
    static const char *const t5[] = {"models_t5_umt5-xxl-enc-bf16.pth"};
    static const char *const tokenizer[] = {"google/umt5-xxl/spiece.model"};
    memset(files, 0, sizeof *files);
    if (!gv_dir_exists(dir)) return gv_fail("%s: not a folder (give the release folder)", dir);
    if (!first_existing(dir, dit, 2, files->dit))
        return gv_fail("%s: no DiT weights (%s or %s)", dir, dit[0], dit[1]);
    if (!first_existing(dir, vae, 2, files->vae)) return gv_fail("%s: no VAE weights (%s or %s)", dir, vae[0], vae[1]);
    first_existing(dir, config, 1, files->config);
    first_existing(dir, t5, 1, files->t5);
    first_existing(dir, tokenizer, 1, files->tokenizer);
    return 0;
}

/* ---- the release's config.json -------------------------------------------------------------- */

/* The numbers the release states about its network must be the config's (the other keys,
 * e.g. "_class_name", are not about shapes). */
static int check_release_config(const char *path, const gv_model_config *c)
{
    char *text = NULL;
    if (gv_read_file(path, &text, NULL)) return -1;
    cJSON *root = cJSON_Parse(text);
    free(text);
    if (!cJSON_IsObject(root)) {
        cJSON_Delete(root);
        return gv_fail("%s: not a JSON object", path);
    }
    const struct { const char *key; int value; } ints[] = {
        {"dim", c->dit.dim}, {"ffn_dim", c->dit.ffn_dim}, {"freq_dim", c->dit.freq_dim},
        {"num_heads", c->dit.num_heads}, {"num_layers", c->dit.num_layers}, {"in_dim", c->dit.in_dim},
        {"out_dim", c->dit.out_dim}, {"text_len", c->dit.text_len}, {"text_dim", c->dit.text_dim},
        {"vace_in_dim", c->dit.vace_in_dim},
    };
    int rc = 0;
    for (size_t i = 0; rc == 0 && i < sizeof ints / sizeof *ints; i++) {
        const cJSON *v = cJSON_GetObjectItemCaseSensitive(root, ints[i].key);
        if (v && (!cJSON_IsNumber(v) || v->valuedouble != (double)ints[i].value))
            rc = gv_fail("%s: %s is %g, but the config %s has %d", path, ints[i].key, cJSON_IsNumber(v) ? v->valuedouble : NAN,
                         c->name, ints[i].value);
    }
    const cJSON *layers = cJSON_GetObjectItemCaseSensitive(root, "vace_layers");
    if (rc == 0 && layers) {
        int same = cJSON_IsArray(layers) && cJSON_GetArraySize(layers) == c->dit.n_vace_layers;
        for (int k = 0; same && k < c->dit.n_vace_layers; k++) {
            const cJSON *e = cJSON_GetArrayItem(layers, k);
            same = cJSON_IsNumber(e) && e->valuedouble == c->dit.vace_layers[k];
        }
        if (!same) rc = gv_fail("%s: vace_layers differ from the config %s's", path, c->name);
    }
    cJSON_Delete(root);
    return rc;
}

/* ---- the DiT tensors ------------------------------------------------------------------------ */

/* A NaN or an infinity in a weight is bad input (docs/ARCHITECTURE.md 4): checked chunk by chunk. */
static int check_finite(const gv_st_file *f, const gv_st_tensor *t, float *buffer)
{
    for (int64_t lo = 0; lo < t->n_elements; lo += CHECK_CHUNK) {
        gv_st_tensor part = *t;
        part.n_elements = t->n_elements - lo < CHECK_CHUNK ? t->n_elements - lo : CHECK_CHUNK;
        part.data = (const uint8_t *)t->data + lo * (gv_st_dtype_bits(t->dtype) / 8);
        if (gv_st_tensor_to_f32(f, &part, buffer)) return -1;
        for (int64_t k = 0; k < part.n_elements; k++)
            if (!isfinite(buffer[k]))
                return gv_fail("%s: %s: value element %lld is %g", f->path, t->name, (long long)(lo + k), (double)buffer[k]);
    }
    gv_st_tensor_drop_pages(t); /* read again when written: one tensor resident at a time */
    return 0;
}

static int dtype_slot(gv_st_dtype d)
{
    return d == GV_ST_F32 ? 0 : d == GV_ST_BF16 ? 1 : d == GV_ST_F16 ? 2 : 3;
}

/* Checks the DiT file against the list and adds its tensors (in the list's order, raw bytes
 * from the mapping) to the builder. */
/* The GaussVid checkpoint, when one is given: its file, the VAE's and the routing. */
typedef struct {
    gv_st_file lora, vae;
    gv_release_plan plan;
    gv_release_job *jobs;     /* one per weight of the list */
    int active;
} lora_import;

static int add_dit(const gv_st_file *f, const gv_weight_list *l, gv_st_builder *b, gv_import_summary *s,
                   lora_import *li)
{
    gv_weight_report r;
    if (gv_weights_check(l, GV_PART_DIT | GV_PART_VACE, f, 1, &r)) return -1;
    int rc = gv_weight_report_fail(&r, f->path);
    gv_weight_report_free(&r);
    float *buffer = rc == 0 ? malloc((size_t)CHECK_CHUNK * sizeof *buffer) : NULL;
    if (rc == 0 && !buffer) rc = gv_fail("out of memory");
    for (int i = 0; rc == 0 && i < l->n; i++) {
        const gv_weight_spec *w = &l->items[i];
        if (!(gv_module_part(w->module) & (GV_PART_DIT | GV_PART_VACE))) continue;
        const gv_st_tensor *t = gv_st_find(f, w->name);
        rc = check_finite(f, t, buffer);
        const gv_release_module *fused = li->active ? gv_release_plan_module(&li->plan, t->name) : NULL;
        if (rc == 0 && fused) {
            li->jobs[i] = (gv_release_job){f, t, &li->lora, fused, NULL, GV_FUSE_BF16};
            rc = gv_release_add_job(b, &li->jobs[i]);
        } else if (rc == 0) {
            rc = gv_st_add_raw(b, t->name, t->dtype, t->shape, t->rank, t->data);
        }
        s->dit_tensors++, s->dit_values += t->n_elements, s->dit_bytes += fused ? 2 * t->n_elements : (int64_t)(t->end - t->begin);
        s->dit_dtypes[dtype_slot(fused ? GV_ST_BF16 : t->dtype)]++;
    }
    free(buffer);
    return rc;
}

/* The metadata of gv_checkpoint_save (src/train/checkpoint_state.c) for a base at step 0. */
/* The VAE is named as written (out_dir/vae.safetensors), as pretraining names its --vae;
 * gv_checkpoint_vae_path also finds it beside the checkpoint when the folder moves. */
static int add_metadata(gv_st_builder *b, const gv_model_config *cfg, const char *vae, const char *vae_checksum,
                        const char *from, const char *text_context, const char *prompt, const char *encoder,
                        const char *tokenizer)
{
    char *json = gv_model_config_to_json(cfg), version[8], training[GV_CHECKPOINT_TEXT];
    if (!json) return gv_fail("out of memory for the config");
    snprintf(version, sizeof version, "%d", GV_CHECKPOINT_VERSION);
    snprintf(training, sizeof training, "none: the published weights of %s, imported by gaussvid model import", from);
    const char *keys[] = {"format", "format_version", "kind", "config", "parts", "step", "steps", "adamw_step",
                          "data_position", "clips_used", "clips_skipped", "seed", "seconds", "loss", "vae",
                          "vae_checksum", "base", "clips", "data", "training", "imported_from", "text_context",
                          "text_prompt", "text_encoder", "text_tokenizer"};
    const char *values[] = {GV_CHECKPOINT_FORMAT, version, "base", json, "dit,vace", "0", "0", "0", "0", "0", "0", "0",
                            "0", "0", vae, vae_checksum, "", "", "", training, from, text_context, prompt,
                            encoder, tokenizer};
    int rc = 0;
    for (size_t i = 0; rc == 0 && i < sizeof keys / sizeof *keys; i++) rc = gv_st_add_metadata(b, keys[i], values[i]);
    free(json);
    return rc;
}

/* ---- the import --------------------------------------------------------------------------- */

/* The checkpoint's decoder entries into the loaded VAE, rounded to bf16 as the release's
 * bf16 VAE holds them. */
static int replace_decoder(gv_vae *vae, const lora_import *li)
{
    for (int k = 0; k < li->plan.n_keys; k++) {
        const gv_release_key *e = &li->plan.keys[k];
        if (e->fate != GV_RKEY_DECODER_REPLACED) continue;
        gv_param *p = gv_params_find(&vae->params, e->target);
        const gv_st_tensor *t = &li->lora.tensors[k];
        if (!p || p->t.numel != t->n_elements || !p->t.data)
            return gv_fail("%s: %s: the VAE has no tensor %s of its size", li->lora.path, e->key, e->target);
        if (gv_st_tensor_to_f32(&li->lora, t, p->t.data)) return -1;
        for (int64_t i = 0; i < t->n_elements; i++) {
            if (!isfinite(p->t.data[i]))
                return gv_fail("%s: %s: value element %lld is %g", li->lora.path, e->key, (long long)i, (double)p->t.data[i]);
            p->t.data[i] = gv_bf16_to_f32(gv_f32_to_bf16(p->t.data[i]));
        }
    }
    return 0;
}

/* The VAE: loaded (names, shapes, values checked), the checkpoint's decoder entries applied,
 * its checksum, written to `path`. */
static int import_vae(const char *from, const gv_model_config *cfg, const char *path, gv_import_summary *s,
                      const lora_import *li)
{
    gv_vae vae;
    if (gv_vae_init(&vae, cfg, 0, 0)) return -1;
    int rc = gv_vae_load(&vae, from, 0);
    if (rc == 0 && li->active) rc = replace_decoder(&vae, li);
    if (rc == 0) {
        gv_checkpoint_vae_checksum(&vae, s->vae_checksum, sizeof s->vae_checksum);
        s->vae_tensors = vae.params.n;
        for (int i = 0; i < vae.params.n; i++) s->vae_values += vae.params.items[i]->t.numel;
        const char *keys[] = {"imported_from"}, *values[] = {from};
        rc = gv_vae_save(&vae, cfg, path, keys, values, 1);
    }
    gv_vae_free(&vae);
    return rc;
}

/* Opens the checkpoint and the VAE and routes the keys against the DiT file. */
static int lora_open(lora_import *li, const gv_release_files *files, const gv_st_file *dit, const gv_weight_list *l,
                     gv_import_summary *s)
{
    memset(li, 0, sizeof *li);
    if (!files->lora[0]) return 0;
    if (gv_st_open(&li->lora, files->lora) || gv_weights_open(&li->vae, files->vae) ||
        gv_release_plan_build(&li->plan, &li->lora, dit, &li->vae))
        return -1;
    li->jobs = calloc((size_t)l->n + 1, sizeof *li->jobs);
    if (!li->jobs) return gv_fail("%s: out of memory", files->lora);
    gv_release_plan_summary(&li->plan, s->lora_summary, sizeof s->lora_summary);
    li->active = 1;
    return 0;
}

static void lora_close(lora_import *li)
{
    free(li->jobs);
    gv_release_plan_free(&li->plan);
    gv_st_close(&li->vae);
    gv_st_close(&li->lora);
}

int gv_model_import(const gv_release_files *files, const gv_model_config *cfg, const char *prompt, const char *out_dir,
                    gv_import_summary *summary)
{
    memset(summary, 0, sizeof *summary);
    gv_model_config base = *cfg;
    base.variant.camera = GV_CAMERA_NONE; /* the release has no camera encoder */
    if (files->config[0] && check_release_config(files->config, &base)) return -1;
    int text = prompt && base.dit.cross_attn && (files->t5[0] || files->tokenizer[0]);
    if (text && (!files->t5[0] || !files->tokenizer[0]))
        return gv_fail("%s: a text encoder needs its tokenizer (google/umt5-xxl/spiece.model) and the tokenizer its "
                       "encoder (models_t5_umt5-xxl-enc-bf16.pth); give both, or import without text",
                       files->t5[0] ? files->t5 : files->tokenizer);
    gv_weight_list list;
    if (gv_weight_list_build(&list, &base)) return -1;
    gv_st_file dit;
    if (gv_weights_open(&dit, files->dit)) {
        gv_weight_list_free(&list);
        return -1;
    }
    char vae_tmp[GV_RELEASE_PATH_MAX], base_tmp[GV_RELEASE_PATH_MAX], vae_path[GV_RELEASE_PATH_MAX],
        base_path[GV_RELEASE_PATH_MAX], text_tmp[GV_RELEASE_PATH_MAX], text_path[GV_RELEASE_PATH_MAX], name[64];
    gv_st_builder b;
    gv_st_builder_init(&b);
    b.drop_source_pages = 1; /* a 14B release is written with one tensor resident at a time */
    lora_import li;
    int rc = lora_open(&li, files, &dit, &list, summary);
    if (rc == 0) rc = add_dit(&dit, &list, &b, summary, &li);
    if (rc == 0) rc = gv_mkdirs(out_dir);
    /* both files under temporary names first, renamed together at the end */
    snprintf(name, sizeof name, ".vae.safetensors.import.%ld", (long)getpid());
    if (rc == 0) rc = gv_path_join(vae_tmp, sizeof vae_tmp, out_dir, name);
    snprintf(name, sizeof name, ".base.safetensors.import.%ld", (long)getpid());
    if (rc == 0) rc = gv_path_join(base_tmp, sizeof base_tmp, out_dir, name);
    if (rc == 0) rc = gv_path_join(vae_path, sizeof vae_path, out_dir, "vae.safetensors");
    if (rc == 0) rc = gv_path_join(base_path, sizeof base_path, out_dir, "base.safetensors");
    snprintf(name, sizeof name, ".text_context.safetensors.import.%ld", (long)getpid());
    if (rc == 0) rc = gv_path_join(text_tmp, sizeof text_tmp, out_dir, name);
    if (rc == 0) rc = gv_path_join(text_path, sizeof text_path, out_dir, "text_context.safetensors");
    int wrote_vae = 0, wrote_base = 0, wrote_text = 0;
    if (rc == 0) rc = import_vae(files->vae, &base, vae_tmp, summary, &li), wrote_vae = rc == 0;
    if (rc == 0 && text)
        rc = gv_text_context_write(files->t5, files->tokenizer, &base, prompt, text_tmp, &summary->text_tokens),
        wrote_text = rc == 0;
    if (rc == 0)
        rc = add_metadata(&b, &base, vae_path, summary->vae_checksum, files->dit, text ? text_path : "", text ? prompt : "",
                          text ? files->t5 : "", text ? files->tokenizer : "");
    if (rc == 0 && li.active) rc = gv_st_add_metadata(&b, "merged_lora", files->lora);
    if (rc == 0) rc = gv_st_write(&b, base_tmp), wrote_base = rc == 0;
    if (rc == 0 && (rename(vae_tmp, vae_path) != 0 || (text && rename(text_tmp, text_path) != 0) ||
                    rename(base_tmp, base_path) != 0))
        rc = gv_fail("%s: cannot rename the imported files into place", out_dir);
    if (rc) {
        if (wrote_vae) unlink(vae_tmp);
        if (wrote_text) unlink(text_tmp);
        if (wrote_base) unlink(base_tmp);
    }
    gv_st_builder_free(&b);
    lora_close(&li);
    gv_st_close(&dit); /* after the write: the builder points into its mapping */
    gv_weight_list_free(&list);
    return rc;
}
