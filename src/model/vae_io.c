/* VAE weight files: safetensors with the checkpoint key names (Wan2.1_VAE converted to
 * safetensors loads as it is), plus this project's metadata: "config" (the model config
 * JSON), "latent_mean" and "latent_std" (JSON arrays of z_dim numbers). */
#include <cjson/cJSON.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "gaussvid/core/core.h"
#include "gaussvid/io/safetensors.h"
#include "gaussvid/model/vae.h"
#include "gaussvid/model/weight_names.h"
#include "gaussvid/pth/weight_files.h"

enum { LISTED = 4 }; /* names shown per kind of problem */

typedef struct {
    int n;
    char text[600];
} problem_list;

static void note(problem_list *p, const char *fmt, const char *a, const char *b)
{
    size_t len = strlen(p->text);
    if (p->n < LISTED && len < sizeof p->text - 1)
        snprintf(p->text + len, sizeof p->text - len, fmt, p->n ? ", " : "", a, b);
    p->n++;
}

static int same_shape(const gv_st_tensor *t, const gv_tensor *x)
{
    if (t->rank != x->ndim) return 0;
    for (int k = 0; k < t->rank; k++)
        if (t->shape[k] != x->shape[k]) return 0;
    return t->dtype == GV_ST_F32 || t->dtype == GV_ST_F16 || t->dtype == GV_ST_BF16 || t->dtype == GV_ST_F64;
}

/* Reads a JSON array of n finite numbers; 1 found, 0 absent, -1 malformed. */
static int metadata_array(const gv_st_file *f, const char *key, int n, double *out)
{
    const char *text = gv_st_metadata(f, key);
    if (!text) return 0;
    cJSON *a = cJSON_Parse(text);
    int ok = cJSON_IsArray(a) && cJSON_GetArraySize(a) == n;
    for (int k = 0; ok && k < n; k++) {
        cJSON *e = cJSON_GetArrayItem(a, k);
        ok = cJSON_IsNumber(e) && isfinite(e->valuedouble);
        if (ok) out[k] = e->valuedouble;
    }
    cJSON_Delete(a);
    if (!ok) return gv_fail("%s: metadata %s is not an array of %d numbers", f->path, key, n);
    return 1;
}

static int load_stats(gv_vae *v, const gv_st_file *f)
{
    double mean[GV_VAE_MAX_Z_DIM], std[GV_VAE_MAX_Z_DIM];
    int has_mean = metadata_array(f, "latent_mean", v->cfg.z_dim, mean);
    int has_std = metadata_array(f, "latent_std", v->cfg.z_dim, std);
    if (has_mean < 0 || has_std < 0) return -1;
    if (has_mean != has_std) return gv_fail("%s: metadata has only one of latent_mean and latent_std", f->path);
    if (has_mean && gv_vae_set_stats(v, mean, std)) return gv_fail_context("%s", f->path);
    return 0;
}

int gv_vae_load(gv_vae *v, const char *path, int allow_other)
{
    gv_st_file f;
    if (gv_weights_open(&f, path)) return -1;
    int rc = gv_vae_read(v, &f, allow_other);
    gv_st_close(&f);
    return rc;
}

int gv_vae_read(gv_vae *v, const gv_st_file *f, int allow_other)
{
    const char *path = f->path;
    problem_list missing = {0, ""}, unexpected = {0, ""}, shaped = {0, ""};
    char have[64], want[64];
    for (int i = 0; i < v->params.n; i++) {
        const gv_tensor *x = &v->params.items[i]->t;
        const gv_st_tensor *t = gv_st_find(f, x->name);
        if (!t) {
            note(&missing, "%s%s%s", x->name, "");
        } else if (!same_shape(t, x)) {
            snprintf(have, sizeof have, "%s %s", gv_st_dtype_name(t->dtype), gv_st_shape_str(want, sizeof want, t->shape, t->rank));
            note(&shaped, "%s%s is %s", x->name, have);
        }
    }
    for (int i = 0; !allow_other && i < f->n_tensors; i++)
        if (!gv_params_find(&v->params, f->tensors[i].name)) note(&unexpected, "%s%s%s", f->tensors[i].name, "");
    if (missing.n || unexpected.n || shaped.n) {
        gv_fail("%s: not the weights of this VAE: %d missing%s%s%s, %d unexpected%s%s%s, %d mis-shaped%s%s%s", path,
                missing.n, missing.n ? " (" : "", missing.text, missing.n ? (missing.n > LISTED ? ", ...)" : ")") : "",
                unexpected.n, unexpected.n ? " (" : "", unexpected.text,
                unexpected.n ? (unexpected.n > LISTED ? ", ...)" : ")") : "", shaped.n, shaped.n ? " (" : "", shaped.text,
                shaped.n ? (shaped.n > LISTED ? ", ...)" : ")") : "");
        return -1;
    }
    int rc = 0;
    for (int i = 0; i < v->params.n && rc == 0; i++) {
        gv_tensor *x = &v->params.items[i]->t;
        rc = gv_st_tensor_to_f32(f, gv_st_find(f, x->name), x->data);
    }
    if (rc == 0) rc = load_stats(v, f);
    if (rc == 0 && gv_params_check_finite(&v->params, 0)) rc = gv_fail_context("%s", path);
    return rc;
}

static char *json_numbers(const float *x, int n)
{
    size_t cap = (size_t)n * 24 + 8, len = 0;
    char *s = malloc(cap);
    if (!s) return NULL;
    len += (size_t)snprintf(s, cap, "[");
    for (int k = 0; k < n; k++) len += (size_t)snprintf(s + len, cap - len, "%s%.9g", k ? ", " : "", x[k]);
    snprintf(s + len, cap - len, "]");
    return s;
}

int gv_vae_save(const gv_vae *v, const gv_model_config *c, const char *path, const char *const *extra_keys,
                const char *const *extra_values, int n_extra)
{
    gv_model_config cfg = *c;
    cfg.vae = v->cfg; /* with the statistics when known */
    char *config = gv_model_config_to_json(&cfg);
    char *mean = v->has_stats ? json_numbers(v->mean, v->cfg.z_dim) : NULL;
    char *std = v->has_stats ? json_numbers(v->std, v->cfg.z_dim) : NULL;
    gv_st_builder b;
    gv_st_builder_init(&b);
    int rc = !config || (v->has_stats && (!mean || !std)) ? gv_fail("%s: out of memory", path) : 0;
    for (int i = 0; i < v->params.n && rc == 0; i++) {
        const gv_tensor *x = &v->params.items[i]->t;
        int64_t shape[GV_MAX_DIMS];
        for (int k = 0; k < x->ndim; k++) shape[k] = x->shape[k];
        rc = gv_st_add_f32(&b, x->name, GV_ST_F32, shape, x->ndim, x->data);
    }
    if (rc == 0) rc = gv_st_add_metadata(&b, "config", config);
    if (rc == 0 && mean) rc = gv_st_add_metadata(&b, "latent_mean", mean);
    if (rc == 0 && std) rc = gv_st_add_metadata(&b, "latent_std", std);
    for (int k = 0; k < n_extra && rc == 0; k++) rc = gv_st_add_metadata(&b, extra_keys[k], extra_values[k]);
    if (rc == 0) rc = gv_st_write(&b, path);
    gv_st_builder_free(&b);
    free(config);
    free(mean);
    free(std);
    return rc;
}

int gv_vae_file_config(const char *path, gv_model_config *c)
{
    gv_st_file f;
    if (gv_st_open(&f, path)) return -1;
    const char *json = gv_st_metadata(&f, "config");
    int rc = json ? gv_model_config_parse(c, json, path)
                  : gv_fail("%s: no \"config\" metadata (pass the model config with --config)", path);
    /* the file's own config must fit in it before anyone builds that VAE (issue 25) */
    if (rc == 0) rc = gv_weights_fit(c, GV_PART_VAE, f.data_size, path);
    gv_st_close(&f);
    return rc;
}
