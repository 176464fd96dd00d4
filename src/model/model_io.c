/* DiT weights in safetensors files, by name: the published Wan2.1-VACE keys for the base,
 * this project's names for the camera encoder and LoRA (docs/MODEL.md). A base checkpoint and
 * an adapter file load into one model; adapters save alone. */
#include "model/dit_internal.h"
#include "gaussvid/core/core.h"
#include "gaussvid/io/safetensors.h"
#include "gaussvid/pth/weight_files.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

static void close_all(gv_st_file *files, int n)
{
    for (int i = 0; i < n; i++) gv_st_close(&files[i]);
    free(files);
}

/* A frozen linear weight of the base (DiT, VACE) stored in BF16 stays in the mapping. */
static int keeps_bf16(const gv_dit *m, const gv_st_tensor *t, const gv_param *p)
{
    const gv_weight_spec *s = gv_weight_list_find(&m->weights, p->t.name);
    return t->dtype == GV_ST_BF16 && !p->trainable && p->t.ndim == 2 && s &&
           (gv_module_part(s->module) & (GV_PART_DIT | GV_PART_VACE));
}

int gv_dit_read_param(gv_dit *m, const gv_st_file *f, gv_param *p, int *kept)
{
    const gv_st_tensor *t;
    int64_t shape[GV_MAX_DIMS];
    *kept = 0;
    for (int k = 0; k < p->t.ndim; k++) shape[k] = p->t.shape[k];
    if (gv_st_get(f, p->t.name, -1, shape, p->t.ndim, &t) != 0) return -1;
    if (keeps_bf16(m, t, p)) { /* its values are checked finite at each use (gv_tensor_values) */
        *kept = 1;
        return gv_param_set_bf16(p, t->data, 1);
    }
    if (gv_param_alloc(p) != 0 || gv_st_read_f32(f, p->t.name, p->t.data, shape, p->t.ndim) != 0) return -1;
    /* docs/ARCHITECTURE.md 4: a NaN is bad input, named with its file */
    for (int64_t k = 0; k < p->t.numel; k++)
        if (!isfinite(p->t.data[k]))
            return gv_fail("%s: %s: value element %lld is %g", f->path, p->t.name, (long long)k, (double)p->t.data[k]);
    return 0;
}

int gv_dit_keep_file(gv_dit *m, gv_st_file *f)
{
    gv_st_file *more = realloc(m->mapped, (size_t)(m->n_mapped + 1) * sizeof *more);
    if (!more) return gv_fail("%s: out of memory", f->path);
    m->mapped = more;
    m->mapped[m->n_mapped++] = *f;
    memset(f, 0, sizeof *f);
    return 0;
}

int gv_dit_check_loaded(const gv_dit *m)
{
    for (int i = 0; i < m->params.n; i++)
        if (!m->params.items[i]->t.data && !m->params.items[i]->t.bf16)
            return gv_fail("%s: tensor %s was not loaded", m->cfg.name, m->params.items[i]->t.name);
    return 0;
}

int64_t gv_dit_bf16_bytes(const gv_dit *m, int *n_tensors)
{
    int64_t bytes = 0;
    int n = 0;
    for (int i = 0; i < m->params.n; i++)
        if (m->params.items[i]->t.bf16) bytes += 2 * m->params.items[i]->t.numel, n++;
    if (n_tensors) *n_tensors = n;
    return bytes;
}

gv_tensor *gv_dit_text_input(const gv_dit *m, gv_graph *g, int batch)
{
    const gv_dit_config *d = &m->cfg.dit;
    gv_tensor *t = gv_tensor_new(g, 3, (int[]){batch, d->text_len, d->text_dim});
    size_t row = (size_t)d->text_len * d->text_dim;
    for (int b = 0; t && m->text && b < batch; b++) memcpy(t->data + b * row, m->text, row * sizeof(float));
    return t;
}

int gv_dit_set_text(gv_dit *m, const float *context)
{
    free(m->text);
    m->text = NULL;
    if (!context) return 0;
    if (!m->cfg.dit.cross_attn) return gv_fail("%s: a text context for a network without cross-attention", m->cfg.name);
    size_t n = (size_t)m->cfg.dit.text_len * m->cfg.dit.text_dim;
    if (!(m->text = malloc(n * sizeof(float)))) return gv_fail("out of memory for the text context");
    memcpy(m->text, context, n * sizeof(float));
    return 0;
}

/* Reads every tensor of the files that is a tensor of the network; files holding BF16
 * weights it keeps are handed to the model. */
static int read_tensors(gv_dit *m, gv_st_file *files, int n)
{
    for (int f = 0; f < n; f++) {
        int kept_any = 0;
        for (int i = 0; i < files[f].n_tensors; i++) {
            gv_param *p = gv_params_find(&m->params, files[f].tensors[i].name);
            if (!p) continue; /* a VAE tensor of a combined checkpoint */
            int kept = 0;
            if (gv_dit_read_param(m, &files[f], p, &kept) != 0) return -1;
            kept_any |= kept;
        }
        if (kept_any && gv_dit_keep_file(m, &files[f]) != 0) return -1;
    }
    return 0;
}

int gv_dit_load(gv_dit *m, const char *const *paths, int n_paths, unsigned parts)
{
    if (n_paths < 1) return gv_fail("%s: no weight file to load", m->cfg.name);
    gv_st_file *files = calloc((size_t)n_paths, sizeof *files);
    if (!files) return gv_fail("out of memory for %d weight files", n_paths);
    for (int i = 0; i < n_paths; i++)
        if (gv_weights_open(&files[i], paths[i]) != 0) {
            close_all(files, i);
            return -1;
        }
    gv_weight_report r;
    int rc = gv_weights_check(&m->weights, parts & ~(unsigned)GV_PART_VAE, files, n_paths, &r);
    if (rc == 0) {
        char what[512];
        snprintf(what, sizeof what, "%s%s", paths[0], n_paths > 1 ? " (and the other weight files)" : "");
        rc = gv_weight_report_fail(&r, what);
        gv_weight_report_free(&r);
    }
    if (rc == 0) rc = read_tensors(m, files, n_paths);
    if (rc == 0) rc = gv_dit_check_loaded(m); /* a tensor registered without values must have come from a file */
    close_all(files, n_paths);
    return rc;
}

int gv_dit_save(const gv_dit *m, const char *path, unsigned parts)
{
    if (m->lora_merged && (parts & GV_PART_LORA) && m->cfg.lora.rank > 0)
        return gv_fail("%s: the LoRA adapters are merged into the base weights; save without the lora part", path);
    gv_st_builder b;
    gv_st_builder_init(&b);
    int rc = 0, n = 0;
    for (int i = 0; rc == 0 && i < m->params.n; i++) {
        const gv_tensor *t = &m->params.items[i]->t;
        const gv_weight_spec *s = gv_weight_list_find(&m->weights, t->name);
        if (!s || !(gv_module_part(s->module) & parts)) continue;
        int64_t shape[GV_MAX_DIMS];
        for (int k = 0; k < t->ndim; k++) shape[k] = t->shape[k];
        rc = t->data ? gv_st_add_f32(&b, t->name, GV_ST_F32, shape, t->ndim, t->data)
                     : gv_st_add_raw(&b, t->name, GV_ST_BF16, shape, t->ndim, t->bf16); /* as loaded */
        n++;
    }
    if (rc == 0 && n == 0) rc = gv_fail("%s: the model has no tensors of the requested parts", path);
    char *json = rc == 0 ? gv_model_config_to_json(&m->cfg) : NULL;
    char list[64];
    if (rc == 0 && !json) rc = gv_fail("%s: out of memory for the config", path);
    if (rc == 0) rc = gv_st_add_metadata(&b, "format", "gaussvid-dit");
    if (rc == 0) rc = gv_st_add_metadata(&b, "config", json);
    if (rc == 0) rc = gv_st_add_metadata(&b, "parts", gv_parts_text(parts, list, sizeof list));
    if (rc == 0) rc = gv_st_write(&b, path);
    free(json);
    gv_st_builder_free(&b);
    return rc;
}
