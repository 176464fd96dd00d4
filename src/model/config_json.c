/* The JSON form of a model config (docs/MODEL.md): strict parsing, where every unknown key,
 * duplicate key, wrong type or bad value gives one line naming the file and the key, and
 * the canonical writer (every field, fixed order) used for files and checkpoint metadata. */
#include "gaussvid/model/model_config.h"
#include "gaussvid/core/core.h"
#include "gaussvid/io/json.h"
#include "model/config_internal.h"

#include <cjson/cJSON.h>
#include <limits.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

enum { MAX_CONFIG_BYTES = 1 << 20 };

/* Reading context: the file and the section ("dit", "vae", ...; "" at the top). */
typedef struct {
    const char *src;
    const char *section;
    char key[96];
} reader;

static const char *full_key(reader *r, const char *name)
{
    snprintf(r->key, sizeof r->key, "%s%s%s", r->section, r->section[0] ? "." : "", name);
    return r->key;
}

/* Every key of obj must be in known (NULL-terminated) and appear once. */
static int check_keys(reader *r, const cJSON *obj, const char *const *known)
{
    for (const cJSON *item = obj->child; item; item = item->next) {
        int ok = 0;
        for (int i = 0; known[i] && !ok; i++) ok = !strcmp(item->string, known[i]);
        if (!ok) {
            char list[512] = "";
            for (int i = 0; known[i]; i++)
                snprintf(list + strlen(list), sizeof list - strlen(list), "%s%s", i ? ", " : "", known[i]);
            return gv_config_bad(r->src, full_key(r, item->string), "unknown key (known: %s)", list);
        }
        for (const cJSON *other = obj->child; other != item; other = other->next)
            if (!strcmp(other->string, item->string))
                return gv_config_bad(r->src, full_key(r, item->string), "duplicate key");
    }
    return 0;
}

/* The item of that key; NULL when absent (an error when required). */
static int lookup(reader *r, const cJSON *obj, const char *name, int required, const cJSON **out)
{
    *out = cJSON_GetObjectItemCaseSensitive(obj, name);
    if (!*out && required) return gv_config_bad(r->src, full_key(r, name), "missing (required)");
    return 0;
}

static int to_int(reader *r, const char *name, const cJSON *j, int *out)
{
    if (!cJSON_IsNumber(j)) return gv_config_bad(r->src, full_key(r, name), "expected an integer, got %s", gv_json_type(j));
    double v = j->valuedouble;
    if (v != floor(v) || fabs(v) > INT_MAX) return gv_config_bad(r->src, full_key(r, name), "expected an integer, got %g", v);
    *out = (int)v;
    return 0;
}

static int get_int(reader *r, const cJSON *obj, const char *name, int required, int *out)
{
    const cJSON *j;
    if (lookup(r, obj, name, required, &j)) return -1;
    return j ? to_int(r, name, j, out) : 0;
}

static int get_double(reader *r, const cJSON *obj, const char *name, int required, double *out)
{
    const cJSON *j;
    if (lookup(r, obj, name, required, &j)) return -1;
    if (j && gv_json_number(obj, name, -HUGE_VAL, HUGE_VAL, 0, out))
        return gv_config_bad(r->src, full_key(r, name), "expected a number, got %s", gv_json_type(j));
    /* 1e999 parses as infinity, which the writer could not write back (fuzz_config) */
    if (j && !isfinite(*out)) return gv_config_bad(r->src, full_key(r, name), "%g is not a finite number", *out);
    return 0;
}

static int get_bool(reader *r, const cJSON *obj, const char *name, int required, int *out)
{
    const cJSON *j;
    if (lookup(r, obj, name, required, &j)) return -1;
    if (!j) return 0;
    if (!cJSON_IsBool(j)) return gv_config_bad(r->src, full_key(r, name), "expected true or false, got %s", gv_json_type(j));
    *out = cJSON_IsTrue(j) ? 1 : 0;
    return 0;
}

static int get_string(reader *r, const cJSON *obj, const char *name, const char **out)
{
    const cJSON *j;
    if (lookup(r, obj, name, 0, &j)) return -1;
    if (!j) return 0;
    if (!cJSON_IsString(j)) return gv_config_bad(r->src, full_key(r, name), "expected a string, got %s", gv_json_type(j));
    *out = j->valuestring;
    return 0;
}

/* An array of at most max elements of one kind: 'i' integers, 'b' booleans, 'd' numbers. */
static int get_list(reader *r, const cJSON *obj, const char *name, int required, char kind, void *out, int max, int *n)
{
    const cJSON *j;
    if (lookup(r, obj, name, required, &j)) return -1;
    if (!j) return 0;
    if (!cJSON_IsArray(j)) return gv_config_bad(r->src, full_key(r, name), "expected an array, got %s", gv_json_type(j));
    int count = cJSON_GetArraySize(j);
    if (count > max) return gv_config_bad(r->src, full_key(r, name), "has %d entries, at most %d allowed", count, max);
    int i = 0;
    for (const cJSON *e = j->child; e; e = e->next, i++) {
        if (kind == 'i') {
            if (to_int(r, name, e, (int *)out + i)) return -1;
        } else if (kind == 'b') {
            if (!cJSON_IsBool(e)) return gv_config_bad(r->src, full_key(r, name), "entry %d: expected true or false, got %s", i, gv_json_type(e));
            ((int *)out)[i] = cJSON_IsTrue(e) ? 1 : 0;
        } else {
            if (!cJSON_IsNumber(e)) return gv_config_bad(r->src, full_key(r, name), "entry %d: expected a number, got %s", i, gv_json_type(e));
            if (!isfinite(e->valuedouble))
                return gv_config_bad(r->src, full_key(r, name), "entry %d: %g is not a finite number", i, e->valuedouble);
            ((double *)out)[i] = e->valuedouble;
        }
    }
    *n = count;
    return 0;
}

static int parse_dit(reader *r, const cJSON *o, gv_dit_config *d)
{
    static const char *const known[] = {"dim", "ffn_dim", "freq_dim", "text_dim", "num_heads", "num_layers",
        "vace_layers", "vace_in_dim", "patch_size", "in_dim", "out_dim", "text_len", "eps", "qk_norm",
        "cross_attn_norm", "cross_attn", NULL};
    int n_patch = 0;
    if (check_keys(r, o, known) || get_bool(r, o, "cross_attn", 0, &d->cross_attn) ||
        get_int(r, o, "dim", 1, &d->dim) || get_int(r, o, "ffn_dim", 1, &d->ffn_dim) ||
        get_int(r, o, "freq_dim", 1, &d->freq_dim) || get_int(r, o, "text_dim", d->cross_attn, &d->text_dim) ||
        get_int(r, o, "num_heads", 1, &d->num_heads) || get_int(r, o, "num_layers", 1, &d->num_layers) ||
        get_list(r, o, "vace_layers", 1, 'i', d->vace_layers, GV_MAX_LAYERS, &d->n_vace_layers) ||
        get_int(r, o, "vace_in_dim", 1, &d->vace_in_dim) ||
        get_list(r, o, "patch_size", 1, 'i', d->patch_size, 3, &n_patch) ||
        get_int(r, o, "in_dim", 1, &d->in_dim) || get_int(r, o, "out_dim", 1, &d->out_dim) ||
        get_int(r, o, "text_len", d->cross_attn, &d->text_len) || get_double(r, o, "eps", 1, &d->eps) ||
        get_bool(r, o, "qk_norm", 0, &d->qk_norm) || get_bool(r, o, "cross_attn_norm", 0, &d->cross_attn_norm))
        return -1;
    if (n_patch != 3) return gv_config_bad(r->src, "dit.patch_size", "needs 3 entries (t, h, w), got %d", n_patch);
    return 0;
}

static int parse_vae(reader *r, const cJSON *o, gv_vae_config *v)
{
    static const char *const known[] = {"dim", "z_dim", "dim_mult", "num_res_blocks", "attn_scales",
        "temperal_downsample", "temporal_factor", "spatial_factor", "latent_mean", "latent_std", NULL};
    int n_down = 0, n_mean = -1, n_std = -1;
    v->temporal_factor = v->spatial_factor = -1;
    if (check_keys(r, o, known) || get_int(r, o, "dim", 1, &v->dim) || get_int(r, o, "z_dim", 1, &v->z_dim) ||
        get_list(r, o, "dim_mult", 1, 'i', v->dim_mult, GV_VAE_MAX_LEVELS, &v->n_levels) ||
        get_int(r, o, "num_res_blocks", 1, &v->num_res_blocks) ||
        get_list(r, o, "attn_scales", 1, 'd', v->attn_scales, GV_VAE_MAX_ATTN_SCALES, &v->n_attn_scales) ||
        get_list(r, o, "temperal_downsample", 1, 'b', v->temperal_downsample, GV_VAE_MAX_LEVELS - 1, &n_down) ||
        get_int(r, o, "temporal_factor", 0, &v->temporal_factor) || get_int(r, o, "spatial_factor", 0, &v->spatial_factor) ||
        get_list(r, o, "latent_mean", 0, 'd', v->latent_mean, GV_VAE_MAX_Z_DIM, &n_mean) ||
        get_list(r, o, "latent_std", 0, 'd', v->latent_std, GV_VAE_MAX_Z_DIM, &n_std))
        return -1;
    if (v->n_levels < 2) return gv_config_bad(r->src, "vae.dim_mult", "needs 2 to %d levels, got %d", GV_VAE_MAX_LEVELS, v->n_levels);
    if (n_down != v->n_levels - 1)
        return gv_config_bad(r->src, "vae.temperal_downsample", "has %d flags; vae.dim_mult has %d levels, so %d are needed",
                             n_down, v->n_levels, v->n_levels - 1);
    int n_temporal = 0;
    for (int k = 0; k < n_down; k++) n_temporal += v->temperal_downsample[k];
    if (v->temporal_factor < 0) v->temporal_factor = 1 << n_temporal; /* derived when absent */
    if (v->spatial_factor < 0) v->spatial_factor = 1 << (v->n_levels - 1);
    if ((n_mean < 0) != (n_std < 0))
        return gv_config_bad(r->src, n_mean < 0 ? "vae.latent_mean" : "vae.latent_std", "missing: latent_mean and latent_std come together");
    if (n_mean >= 0) {
        if (n_mean != v->z_dim) return gv_config_bad(r->src, "vae.latent_mean", "has %d entries, vae.z_dim is %d", n_mean, v->z_dim);
        if (n_std != v->z_dim) return gv_config_bad(r->src, "vae.latent_std", "has %d entries, vae.z_dim is %d", n_std, v->z_dim);
        v->has_latent_stats = 1;
    }
    return 0;
}

static int parse_camera(reader *r, const cJSON *o, gv_camera_config *k)
{
    static const char *const known[] = {"channels", "gate_hidden", "proj_hidden", "gamma_init", NULL};
    return check_keys(r, o, known) || get_int(r, o, "channels", 0, &k->channels) ||
                   get_int(r, o, "gate_hidden", 0, &k->gate_hidden) || get_int(r, o, "proj_hidden", 0, &k->proj_hidden) ||
                   get_double(r, o, "gamma_init", 0, &k->gamma_init)
               ? -1 : 0;
}

static int parse_lora(reader *r, const cJSON *o, gv_lora_config *l)
{
    static const char *const known[] = {"rank", "alpha", "targets", "modules", NULL};
    const cJSON *targets, *modules, *alpha;
    if (check_keys(r, o, known) || get_int(r, o, "rank", 0, &l->rank) || lookup(r, o, "alpha", 0, &alpha) ||
        lookup(r, o, "targets", 0, &targets) || lookup(r, o, "modules", 0, &modules))
        return -1;
    l->alpha = l->rank; /* default: alpha = rank, scale 1 as PEFT in GaussVid
                           (docs/reference/wan-vace-gaussvid.md 1.5) */
    if (alpha && get_double(r, o, "alpha", 1, &l->alpha)) return -1;
    if (targets) {
        if (!cJSON_IsArray(targets)) return gv_config_bad(r->src, "lora.targets", "expected an array, got %s", gv_json_type(targets));
        int n = cJSON_GetArraySize(targets);
        if (n > GV_LORA_MAX_TARGETS) return gv_config_bad(r->src, "lora.targets", "has %d entries, at most %d allowed", n, GV_LORA_MAX_TARGETS);
        l->n_targets = 0;
        for (const cJSON *e = targets->child; e; e = e->next) {
            if (!cJSON_IsString(e)) return gv_config_bad(r->src, "lora.targets", "entry %d: expected a string, got %s", l->n_targets, gv_json_type(e));
            if (!gv_lora_target_known(e->valuestring))
                return gv_config_bad(r->src, "lora.targets", "\"%.40s\" is not a linear layer of a block", e->valuestring);
            snprintf(l->targets[l->n_targets++], GV_LORA_TARGET_MAX, "%s", e->valuestring);
        }
    }
    if (modules) {
        if (!cJSON_IsArray(modules)) return gv_config_bad(r->src, "lora.modules", "expected an array, got %s", gv_json_type(modules));
        l->blocks = l->vace_blocks = 0;
        for (const cJSON *e = modules->child; e; e = e->next) {
            int *flag = !cJSON_IsString(e) ? NULL : !strcmp(e->valuestring, "blocks") ? &l->blocks
                      : !strcmp(e->valuestring, "vace_blocks") ? &l->vace_blocks : NULL;
            if (!flag) return gv_config_bad(r->src, "lora.modules", "entries must be \"blocks\" or \"vace_blocks\"");
            if (*flag) return gv_config_bad(r->src, "lora.modules", "\"%s\" is listed twice", e->valuestring);
            *flag = 1;
        }
    }
    return 0;
}

static int parse_variant(reader *r, const cJSON *o, gv_variant_config *v)
{
    static const char *const known[] = {"camera", "anchors", "per_frame", "skip", "residual", "coverage", NULL};
    const char *camera = NULL, *anchors = NULL;
    if (check_keys(r, o, known) || get_string(r, o, "camera", &camera) || get_string(r, o, "anchors", &anchors) ||
        get_bool(r, o, "per_frame", 0, &v->per_frame) || get_bool(r, o, "skip", 0, &v->skip) ||
        get_bool(r, o, "residual", 0, &v->residual) || get_bool(r, o, "coverage", 0, &v->coverage))
        return -1;
    if (camera) {
        int c = gv_camera_variant_from_name(camera);
        if (c < 0) return gv_config_bad(r->src, "variant.camera", "\"%.40s\" is not none, early, monolithic or decomposed", camera);
        v->camera = (gv_camera_variant)c;
    }
    if (anchors) {
        int a = gv_anchors_from_name(anchors);
        if (a < 0) return gv_config_bad(r->src, "variant.anchors", "\"%.40s\" is not none, first or both", anchors);
        v->anchors = (gv_anchors)a;
    }
    return 0;
}

/* The object of an optional section, or an error when it is not an object. */
static int section(reader *top, const cJSON *root, const char *name, int required, const cJSON **out)
{
    if (lookup(top, root, name, required, out)) return -1;
    if (*out && !cJSON_IsObject(*out)) return gv_config_bad(top->src, name, "expected an object, got %s", gv_json_type(*out));
    return 0;
}

/* The default name of a config read from a file: the file's base name without ".json". */
static void name_from_source(char *name, const char *src)
{
    const char *base = strrchr(src, '/');
    base = base ? base + 1 : src;
    size_t len = strlen(base);
    if (len > 5 && !strcmp(base + len - 5, ".json")) len -= 5;
    if (len >= GV_CONFIG_NAME_MAX) len = GV_CONFIG_NAME_MAX - 1;
    memcpy(name, base, len);
    name[len] = '\0';
}

static int parse_root(gv_model_config *c, const cJSON *root, const char *src)
{
    static const char *const known[] = {"name", "dit", "vae", "camera", "lora", "variant", NULL};
    reader r = {src, "", ""};
    const cJSON *dit, *vae, *camera, *lora, *variant;
    const char *name = NULL;
    if (!cJSON_IsObject(root)) return gv_fail("%s: a model config must be a JSON object, got %s", src, gv_json_type(root));
    if (check_keys(&r, root, known) || get_string(&r, root, "name", &name) || section(&r, root, "dit", 1, &dit) ||
        section(&r, root, "vae", 1, &vae) || section(&r, root, "camera", 0, &camera) ||
        section(&r, root, "lora", 0, &lora) || section(&r, root, "variant", 0, &variant))
        return -1;
    if (name && strlen(name) >= GV_CONFIG_NAME_MAX) return gv_config_bad(src, "name", "longer than %d characters", GV_CONFIG_NAME_MAX - 1);
    if (name) snprintf(c->name, sizeof c->name, "%s", name);
    else name_from_source(c->name, src);
    reader rd = {src, "dit", ""}, rv = {src, "vae", ""}, rc = {src, "camera", ""}, rl = {src, "lora", ""},
           rr = {src, "variant", ""};
    if (parse_dit(&rd, dit, &c->dit) || parse_vae(&rv, vae, &c->vae)) return -1;
    if (camera && parse_camera(&rc, camera, &c->camera)) return -1;
    if (c->camera.proj_hidden == 0) c->camera.proj_hidden = c->dit.dim;
    if (lora && parse_lora(&rl, lora, &c->lora)) return -1;
    if (variant && parse_variant(&rr, variant, &c->variant)) return -1;
    return 0;
}

int gv_model_config_parse(gv_model_config *c, const char *json, const char *source)
{
    const char *src = source ? source : "config";
    gv_model_config_defaults(c);
    size_t size = strlen(json);
    if (size > MAX_CONFIG_BYTES) return gv_fail("%s: %zu bytes, too large for a model config", src, size);
    const char *end = NULL;
    cJSON *root = cJSON_ParseWithLengthOpts(json, size, &end, 0);
    if (!root) {
        const char *at = end ? end : json;
        int line = 1;
        for (const char *p = json; p < at && *p; p++) line += *p == '\n';
        return gv_fail("%s: line %d: not valid JSON", src, line);
    }
    int rc = parse_root(c, root, src);
    cJSON_Delete(root);
    if (rc) return -1;
    return gv_model_config_validate(c, src);
}

/* ---- writing -------------------------------------------------------------------------- */

static cJSON *int_array(const int *v, int n)
{
    return cJSON_CreateIntArray(v, n);
}

static cJSON *bool_array(const int *v, int n)
{
    cJSON *a = cJSON_CreateArray();
    for (int i = 0; a && i < n; i++) cJSON_AddItemToArray(a, cJSON_CreateBool(v[i]));
    return a;
}

static cJSON *double_array(const double *v, int n)
{
    return cJSON_CreateDoubleArray(v, n);
}

static cJSON *dit_json(const gv_dit_config *d)
{
    cJSON *o = cJSON_CreateObject();
    cJSON_AddNumberToObject(o, "dim", d->dim);
    cJSON_AddNumberToObject(o, "ffn_dim", d->ffn_dim);
    cJSON_AddNumberToObject(o, "freq_dim", d->freq_dim);
    cJSON_AddNumberToObject(o, "text_dim", d->text_dim);
    cJSON_AddNumberToObject(o, "num_heads", d->num_heads);
    cJSON_AddNumberToObject(o, "num_layers", d->num_layers);
    cJSON_AddItemToObject(o, "vace_layers", int_array(d->vace_layers, d->n_vace_layers));
    cJSON_AddNumberToObject(o, "vace_in_dim", d->vace_in_dim);
    cJSON_AddItemToObject(o, "patch_size", int_array(d->patch_size, 3));
    cJSON_AddNumberToObject(o, "in_dim", d->in_dim);
    cJSON_AddNumberToObject(o, "out_dim", d->out_dim);
    cJSON_AddNumberToObject(o, "text_len", d->text_len);
    cJSON_AddNumberToObject(o, "eps", d->eps);
    cJSON_AddBoolToObject(o, "qk_norm", d->qk_norm);
    cJSON_AddBoolToObject(o, "cross_attn_norm", d->cross_attn_norm);
    cJSON_AddBoolToObject(o, "cross_attn", d->cross_attn);
    return o;
}

static cJSON *vae_json(const gv_vae_config *v)
{
    cJSON *o = cJSON_CreateObject();
    cJSON_AddNumberToObject(o, "dim", v->dim);
    cJSON_AddNumberToObject(o, "z_dim", v->z_dim);
    cJSON_AddItemToObject(o, "dim_mult", int_array(v->dim_mult, v->n_levels));
    cJSON_AddNumberToObject(o, "num_res_blocks", v->num_res_blocks);
    cJSON_AddItemToObject(o, "attn_scales", double_array(v->attn_scales, v->n_attn_scales));
    cJSON_AddItemToObject(o, "temperal_downsample", bool_array(v->temperal_downsample, v->n_levels - 1));
    cJSON_AddNumberToObject(o, "temporal_factor", v->temporal_factor);
    cJSON_AddNumberToObject(o, "spatial_factor", v->spatial_factor);
    if (v->has_latent_stats) {
        cJSON_AddItemToObject(o, "latent_mean", double_array(v->latent_mean, v->z_dim));
        cJSON_AddItemToObject(o, "latent_std", double_array(v->latent_std, v->z_dim));
    }
    return o;
}

static cJSON *rest_json(cJSON *root, const gv_model_config *c)
{
    cJSON *camera = cJSON_AddObjectToObject(root, "camera");
    cJSON_AddNumberToObject(camera, "channels", c->camera.channels);
    cJSON_AddNumberToObject(camera, "gate_hidden", c->camera.gate_hidden);
    cJSON_AddNumberToObject(camera, "proj_hidden", c->camera.proj_hidden);
    cJSON_AddNumberToObject(camera, "gamma_init", c->camera.gamma_init);
    cJSON *lora = cJSON_AddObjectToObject(root, "lora");
    cJSON_AddNumberToObject(lora, "rank", c->lora.rank);
    cJSON_AddNumberToObject(lora, "alpha", c->lora.alpha);
    cJSON *targets = cJSON_AddArrayToObject(lora, "targets");
    for (int i = 0; i < c->lora.n_targets; i++) cJSON_AddItemToArray(targets, cJSON_CreateString(c->lora.targets[i]));
    cJSON *modules = cJSON_AddArrayToObject(lora, "modules");
    if (c->lora.blocks) cJSON_AddItemToArray(modules, cJSON_CreateString("blocks"));
    if (c->lora.vace_blocks) cJSON_AddItemToArray(modules, cJSON_CreateString("vace_blocks"));
    cJSON *variant = cJSON_AddObjectToObject(root, "variant");
    cJSON_AddStringToObject(variant, "camera", gv_camera_variant_name(c->variant.camera));
    cJSON_AddStringToObject(variant, "anchors", gv_anchors_name(c->variant.anchors));
    cJSON_AddBoolToObject(variant, "per_frame", c->variant.per_frame);
    cJSON_AddBoolToObject(variant, "skip", c->variant.skip);
    cJSON_AddBoolToObject(variant, "residual", c->variant.residual);
    /* only when on: the configs (and checkpoints) of every other variant stay as they were */
    if (c->variant.coverage) cJSON_AddBoolToObject(variant, "coverage", 1);
    return root;
}

char *gv_model_config_to_json(const gv_model_config *c)
{
    cJSON *root = cJSON_CreateObject();
    if (!root) return NULL;
    cJSON_AddStringToObject(root, "name", c->name);
    cJSON_AddItemToObject(root, "dit", dit_json(&c->dit));
    cJSON_AddItemToObject(root, "vae", vae_json(&c->vae));
    rest_json(root, c);
    char *text = cJSON_Print(root);
    cJSON_Delete(root);
    return text;
}

int gv_model_config_write(const gv_model_config *c, const char *path)
{
    char *text = gv_model_config_to_json(c);
    if (!text) return gv_fail("%s: out of memory while writing the model config", path);
    int rc = gv_write_text_atomic(path, text);
    free(text);
    return rc;
}
