/* Weights kept in bfloat16 (tensor.h): a frozen parameter whose values are the bfloat16
 * bytes of a mapped weight file rather than a float32 copy. gv_linear converts such a weight
 * at each use into a temporary buffer and, when it lives in a file mapping, drops its pages
 * afterwards, so the resident memory holds one weight matrix at a time (the published 14B
 * model is 35 GB in bfloat16; docs/WAN_WEIGHTS.md "Memory"). */
#include <stdlib.h>
#include <sys/mman.h>
#include <unistd.h>

#include "nn/nn_internal.h"

gv_tensor *gv_params_add_empty(gv_params *ps, const char *name, int ndim, const int *shape)
{
    gv_tensor *t = gv_params_add(ps, name, ndim, (const int[GV_MAX_DIMS]){1, 1, 1, 1, 1}, 0);
    if (!t) return NULL;
    /* registered with a one-element buffer, then given its shape and no values */
    free(t->data);
    t->data = NULL;
    t->numel = 1;
    for (int i = 0; i < ndim; i++) {
        t->shape[i] = shape[i];
        t->numel *= shape[i];
    }
    return t;
}

int gv_param_alloc(gv_param *p)
{
    if (p->t.data) return 0;
    p->t.data = calloc((size_t)p->t.numel, sizeof(float));
    if (!p->t.data) return gv_fail("%s: out of memory for %lld floats", p->t.name, (long long)p->t.numel);
    p->t.bf16 = NULL;
    p->t.bf16_mapped = 0;
    return 0;
}

int gv_param_set_bf16(gv_param *p, const void *bf16, int mapped)
{
    if (p->trainable) return gv_fail("%s: a trainable parameter cannot be kept in bfloat16", p->t.name);
    free(p->t.data);
    p->t.data = NULL;
    p->t.bf16 = bf16;
    p->t.bf16_mapped = mapped != 0;
    return 0;
}

int gv_param_materialize(gv_param *p)
{
    if (p->t.data) return 0;
    if (!p->t.bf16) return gv_param_alloc(p);
    float *scratch = NULL;
    const float *values = gv_tensor_values(&p->t, &scratch);
    if (!values) return -1;
    p->t.data = scratch;
    p->t.bf16 = NULL;
    p->t.bf16_mapped = 0;
    return 0;
}

void gv_bf16_to_f32_n(const unsigned char *src, float *dst, int64_t n)
{
#pragma omp parallel for schedule(static) if (n >= GV_OMP_MIN)
    for (int64_t i = 0; i < n; i++) {
        uint32_t bits = ((uint32_t)src[2 * i] | (uint32_t)src[2 * i + 1] << 8) << 16;
        memcpy(&dst[i], &bits, sizeof bits);
    }
}

/* Index of the first NaN or infinity (all exponent bits set) of n bfloat16 values, or -1. */
static int64_t first_non_finite(const unsigned char *src, int64_t n)
{
    int64_t bad = n;
#pragma omp parallel for schedule(static) reduction(min : bad) if (n >= GV_OMP_MIN)
    for (int64_t i = 0; i < n; i++)
        if ((src[2 * i + 1] & 0x7f) == 0x7f && (src[2 * i] & 0x80)) bad = i < bad ? i : bad;
    return bad < n ? bad : -1;
}

/* The pages holding [p, p + bytes) leave the resident set; a read-only file mapping reads
 * them back from the file (or the page cache) when touched again. */
static void drop_pages(const void *p, size_t bytes)
{
    long page = sysconf(_SC_PAGESIZE);
    uintptr_t lo = (uintptr_t)p & ~(uintptr_t)(page - 1), hi = (uintptr_t)p + bytes;
    if (page > 0 && hi > lo) madvise((void *)lo, hi - lo, MADV_DONTNEED);
}

const float *gv_tensor_values(const gv_tensor *t, float **scratch)
{
    *scratch = NULL;
    if (t->data) return t->data;
    if (!t->bf16) {
        gv_fail("%s: a parameter without values (not loaded)", t->name ? t->name : "tensor");
        return NULL;
    }
    float *out = malloc((size_t)t->numel * sizeof *out);
    if (!out) {
        gv_fail("%s: out of memory for %lld floats", t->name ? t->name : "weight", (long long)t->numel);
        return NULL;
    }
    int64_t bad = first_non_finite(t->bf16, t->numel);
    if (bad >= 0) { /* docs/ARCHITECTURE.md 4: a NaN in a weight is bad input, named */
        free(out);
        gv_fail("%s: value element %lld is not finite", t->name ? t->name : "weight", (long long)bad);
        return NULL;
    }
    gv_bf16_to_f32_n(t->bf16, out, t->numel);
    if (t->bf16_mapped) drop_pages(t->bf16, (size_t)t->numel * 2);
    *scratch = out;
    return out;
}
