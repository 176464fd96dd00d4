/* Fusing the published GaussVid LoRA into base weights with the release's rounding, and
 * `gaussvid model merge`: a base file and its VAE rewritten tensor by tensor with the pairs
 * fused and the decoder entries replaced (include/gaussvid/model/release_lora.h). Every output
 * tensor is made when the writer reaches it (gv_st_add_produced), and the base's mapped pages
 * are dropped once read, so merging the 35 GB 14B base holds about one tensor in memory. */
#include "gaussvid/model/release_lora.h"

#include <math.h>
#include <omp.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "gaussvid/core/core.h"

static float bf16_round(float x)
{
    return gv_bf16_to_f32(gv_f32_to_bf16(x));
}

/* A tensor's values as floats in a new buffer (NULL after a recorded failure). */
static float *values_of(const gv_st_file *f, const gv_st_tensor *t, int round_bf16)
{
    float *x = malloc((size_t)(t->n_elements ? t->n_elements : 1) * sizeof *x);
    if (!x) {
        gv_fail("%s: %s: out of memory", f->path, t->name);
        return NULL;
    }
    if (gv_st_tensor_to_f32(f, t, x)) {
        free(x);
        return NULL;
    }
    for (int64_t k = 0; k < t->n_elements; k++) {
        if (!isfinite(x[k])) { /* a NaN is bad input, named */
            gv_fail("%s: %s: value element %lld is %g", f->path, t->name, (long long)k, (double)x[k]);
            free(x);
            return NULL;
        }
        if (round_bf16) x[k] = bf16_round(x[k]);
    }
    return x;
}

/* Row o of the fused weight: acc = sum over the rank, in ascending order, in double (the
 * products of two bf16 values are exact in float, so this is the float32 GEMM's sum up to
 * its order), then the release's roundings. */
static void fuse_row(const float *a, const float *brow, int rank, int64_t n_in, int bf16, double *acc, float *w_row)
{
    for (int64_t i = 0; i < n_in; i++) acc[i] = 0.0;
    for (int k = 0; k < rank; k++) {
        const double b = brow[k];
        const float *arow = a + (int64_t)k * n_in;
        for (int64_t i = 0; i < n_in; i++) acc[i] += b * (double)arow[i];
    }
    for (int64_t i = 0; i < n_in; i++)
        w_row[i] = bf16 ? bf16_round(w_row[i] + bf16_round((float)acc[i])) : (float)((double)w_row[i] + acc[i]);
}

int gv_release_fuse(const gv_st_file *base, const gv_st_tensor *w, const gv_st_file *lora, const gv_release_module *m,
                    gv_fuse_precision precision, float *out)
{
    const int bf16 = precision == GV_FUSE_BF16, rank = m->rank;
    const int64_t n_out = m->b->shape[0], n_in = m->a->shape[1];
    if (n_out * n_in != w->n_elements) return gv_fail("%s: %s does not fit %s", lora->path, m->b->name, w->name);
    if (gv_st_tensor_to_f32(base, w, out)) return -1;
    gv_st_tensor_drop_pages(w);
    if (bf16)
        for (int64_t k = 0; k < w->n_elements; k++) out[k] = bf16_round(out[k]);
    float *a = values_of(lora, m->a, bf16), *b = a ? values_of(lora, m->b, bf16) : NULL;
    int threads = omp_get_max_threads();
    double *acc = b ? malloc((size_t)threads * (size_t)n_in * sizeof *acc) : NULL;
    int rc = acc ? 0 : a && b ? gv_fail("%s: out of memory", w->name) : -1;
    if (rc == 0) {
#pragma omp parallel for schedule(static) num_threads(threads)
        for (int64_t o = 0; o < n_out; o++)
            fuse_row(a, b + o * rank, rank, n_in, bf16, acc + (int64_t)omp_get_thread_num() * n_in, out + o * n_in);
    }
    free(acc);
    free(a);
    free(b);
    return rc;
}

/* ---- merge ------------------------------------------------------------------------------- */

static int produce(void *ctx, void *dst, uint64_t n_bytes)
{
    const gv_release_job *j = ctx;
    const int64_t n = j->tensor->n_elements;
    const int bf16 = j->precision == GV_FUSE_BF16;
    float *x = bf16 ? malloc((size_t)(n ? n : 1) * sizeof *x) : dst;
    if (!x) return gv_fail("%s: out of memory", j->tensor->name);
    if (n_bytes != (uint64_t)n * (bf16 ? 2 : 4)) {
        if (bf16) free(x);
        return gv_fail("%s: internal size mismatch", j->tensor->name);
    }
    int rc;
    if (j->module) rc = gv_release_fuse(j->file, j->tensor, j->lora, j->module, j->precision, x);
    else if (j->replacement) {
        float *v = values_of(j->lora, j->replacement, 0);
        if (v) memcpy(x, v, (size_t)n * sizeof *x);
        rc = v ? 0 : -1;
        free(v);
    }
    else rc = gv_st_tensor_to_f32(j->file, j->tensor, x), gv_st_tensor_drop_pages(j->tensor);
    if (rc == 0 && bf16) {
        uint16_t *out = dst;
        for (int64_t k = 0; k < n; k++) out[k] = gv_f32_to_bf16(x[k]);
    }
    if (bf16) free(x);
    return rc;
}

int gv_release_add_job(gv_st_builder *b, gv_release_job *j)
{
    const gv_st_tensor *t = j->tensor;
    return gv_st_add_produced(b, t->name, j->precision == GV_FUSE_BF16 ? GV_ST_BF16 : GV_ST_F32, t->shape, t->rank,
                              produce, j);
}

static int is_float(gv_st_dtype d)
{
    return d == GV_ST_F32 || d == GV_ST_F16 || d == GV_ST_BF16 || d == GV_ST_F64;
}

/* Every tensor of f into b: raw bytes where nothing changes, else a job of jobs[]. */
static int add_tensors(gv_st_builder *b, const gv_st_file *f, const gv_release_plan *p, const gv_st_file *lora,
                       int decoder, gv_fuse_precision precision, gv_release_job *jobs)
{
    const gv_st_dtype want = precision == GV_FUSE_BF16 ? GV_ST_BF16 : GV_ST_F32;
    for (int i = 0; i < f->n_tensors; i++) {
        const gv_st_tensor *t = &f->tensors[i];
        gv_release_job *j = &jobs[i];
        *j = (gv_release_job){f, t, lora, NULL, NULL, precision};
        if (decoder) j->replacement = gv_release_plan_decoder(p, lora, t->name);
        else j->module = gv_release_plan_module(p, t->name);
        int rc;
        if (!j->module && !j->replacement && (!is_float(t->dtype) || t->dtype == want))
            rc = gv_st_add_raw(b, t->name, t->dtype, t->shape, t->rank, t->data);
        else
            rc = gv_release_add_job(b, j);
        if (rc) return -1;
    }
    return 0;
}

static int write_merged(const gv_st_file *f, const gv_release_plan *p, const gv_st_file *lora, int decoder,
                        gv_fuse_precision precision, const char *path)
{
    gv_release_job *jobs = calloc((size_t)f->n_tensors + 1, sizeof *jobs);
    if (!jobs) return gv_fail("%s: out of memory", path);
    gv_st_builder b;
    gv_st_builder_init(&b);
    b.drop_source_pages = 1;
    int rc = add_tensors(&b, f, p, lora, decoder, precision, jobs);
    for (int k = 0; rc == 0 && k < f->n_metadata; k++)
        if (strcmp(f->metadata_keys[k], "merged_lora") && strcmp(f->metadata_keys[k], "merge_precision"))
            rc = gv_st_add_metadata(&b, f->metadata_keys[k], f->metadata_values[k]);
    if (rc == 0) rc = gv_st_add_metadata(&b, "merged_lora", lora->path);
    if (rc == 0) rc = gv_st_add_metadata(&b, "merge_precision", precision == GV_FUSE_BF16 ? "bf16" : "f32");
    if (rc == 0) rc = gv_st_write(&b, path);
    gv_st_builder_free(&b);
    free(jobs);
    return rc;
}

int gv_release_merge(const gv_release_plan *p, const gv_st_file *lora, const gv_st_file *base, const char *out_path,
                     const gv_st_file *vae, const char *vae_out, gv_fuse_precision precision)
{
    if (write_merged(base, p, lora, 0, precision, out_path)) return -1;
    if (vae && vae_out && write_merged(vae, p, lora, 1, precision, vae_out)) {
        unlink(out_path); /* both files or neither */
        return -1;
    }
    return 0;
}
