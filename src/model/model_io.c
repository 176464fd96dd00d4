/* DiT weights in safetensors files, by name: the published Wan2.1-VACE keys for the base,
 * this project's names for the camera encoder and LoRA (docs/MODEL.md). A base checkpoint and
 * an adapter file load into one model; adapters save alone. */
#include "model/dit_internal.h"
#include "gaussvid/core.h"
#include "gaussvid/safetensors.h"
#include "gaussvid/weight_files.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

static void close_all(gv_st_file *files, int n)
{
    for (int i = 0; i < n; i++) gv_st_close(&files[i]);
    free(files);
}

/* Reads every tensor of the files that is a tensor of the network. */
static int read_tensors(gv_dit *m, const gv_st_file *files, int n)
{
    for (int f = 0; f < n; f++)
        for (int i = 0; i < files[f].n_tensors; i++) {
            const gv_st_tensor *t = &files[f].tensors[i];
            gv_param *p = gv_params_find(&m->params, t->name);
            if (!p) continue; /* a VAE tensor of a combined checkpoint */
            int64_t shape[GV_MAX_DIMS];
            for (int k = 0; k < p->t.ndim; k++) shape[k] = p->t.shape[k];
            if (gv_st_read_f32(&files[f], t->name, p->t.data, shape, p->t.ndim) != 0) return -1;
            for (int64_t k = 0; k < p->t.numel; k++) /* DESIGN 4: a NaN is bad input, named with its file */
                if (!isfinite(p->t.data[k]))
                    return gv_fail("%s: %s: value element %lld is %g", files[f].path, t->name, (long long)k,
                                   (double)p->t.data[k]);
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
    close_all(files, n_paths);
    return rc;
}

static const char *parts_text(unsigned parts, char *out, size_t size)
{
    static const char *const names[] = {"dit", "vace", "vae", "camera", "lora"};
    out[0] = '\0';
    for (int i = 0; i < 5; i++)
        if (parts & (1u << i)) {
            size_t len = strlen(out);
            snprintf(out + len, size - len, "%s%s", len ? "," : "", names[i]);
        }
    return out;
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
        rc = gv_st_add_f32(&b, t->name, GV_ST_F32, shape, t->ndim, t->data);
        n++;
    }
    if (rc == 0 && n == 0) rc = gv_fail("%s: the model has no tensors of the requested parts", path);
    char *json = rc == 0 ? gv_model_config_to_json(&m->cfg) : NULL;
    char list[64];
    if (rc == 0 && !json) rc = gv_fail("%s: out of memory for the config", path);
    if (rc == 0) rc = gv_st_add_metadata(&b, "format", "gaussvid-dit");
    if (rc == 0) rc = gv_st_add_metadata(&b, "config", json);
    if (rc == 0) rc = gv_st_add_metadata(&b, "parts", parts_text(parts, list, sizeof list));
    if (rc == 0) rc = gv_st_write(&b, path);
    free(json);
    gv_st_builder_free(&b);
    return rc;
}
