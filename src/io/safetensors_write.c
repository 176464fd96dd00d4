/* Writing safetensors files in the reference writer's canonical layout (huggingface/
 * safetensors, tensor.rs: prepare and serialize): tensors ordered by descending dtype
 * alignment, then by name; their data packed back to back in that order; the header the
 * compact JSON that serde_json prints ("__metadata__" first, then the tensors in data order),
 * padded with spaces to a multiple of 8 bytes. With the header a multiple of 8 and the
 * largest elements first, every tensor starts aligned to its element size. */
#include "gaussvid/io/safetensors.h"

#include <errno.h>
#include <inttypes.h>
#include <stdlib.h>
#include <string.h>
#include <sys/mman.h>
#include <unistd.h>

#include "gaussvid/core/core.h"
#include "io/safetensors_internal.h"

/* Elements converted per write when F32 values are stored as BF16 or F16. */
enum { WRITE_CHUNK = 1 << 20 };

struct gv_st_entry {
    char *name;
    gv_st_dtype dtype;
    int rank;
    int64_t shape[GV_ST_MAX_RANK];
    uint64_t n_elements, n_bytes;
    const void *data;
    int from_f32;   /* data are floats, converted to dtype when written */
    gv_st_produce_fn produce;  /* when set, the bytes are made at write time (data is its ctx) */
};

void gv_st_builder_init(gv_st_builder *b)
{
    memset(b, 0, sizeof *b);
}

void gv_st_builder_free(gv_st_builder *b)
{
    for (int i = 0; i < b->n_tensors; i++) free(b->tensors[i].name);
    for (int i = 0; i < b->n_metadata; i++) {
        free(b->metadata_keys[i]);
        free(b->metadata_values[i]);
    }
    free(b->tensors);
    free(b->metadata_keys);
    free(b->metadata_values);
    memset(b, 0, sizeof *b);
}

static int check_name(const char *what, const char *name)
{
    if (!name || !name[0]) return gv_fail("safetensors: empty %s", what);
    if (!gv_st_utf8_valid(name, strlen(name)))
        return gv_fail("safetensors: %s '%s' is not valid UTF-8", what, name);
    return 0;
}

static int add_entry(gv_st_builder *b, const char *name, gv_st_dtype dtype,
                     const int64_t *shape, int rank, const void *data, int from_f32,
                     gv_st_produce_fn produce)
{
    if (check_name("tensor name", name)) return -1;
    if (!strcmp(name, "__metadata__"))
        return gv_fail("safetensors: '__metadata__' is reserved and cannot name a tensor");
    if ((unsigned)dtype >= GV_ST_N_DTYPES || gv_st_dtype_bits(dtype) % 8)
        return gv_fail("safetensors: tensor '%s': cannot write dtype %s", name,
                       gv_st_dtype_name(dtype));
    if (rank < 0 || rank > GV_ST_MAX_RANK)
        return gv_fail("safetensors: tensor '%s': rank %d is outside 0..%d", name, rank,
                       GV_ST_MAX_RANK);
    if (rank > 0 && !shape) return gv_fail("safetensors: tensor '%s': no shape", name);
    struct gv_st_entry e = {.dtype = dtype, .rank = rank, .n_elements = 1, .data = data,
                            .from_f32 = from_f32, .produce = produce};
    for (int k = 0; k < rank; k++) {
        if (shape[k] < 0)
            return gv_fail("safetensors: tensor '%s': negative dimension %" PRId64, name,
                           shape[k]);
        if (__builtin_mul_overflow(e.n_elements, (uint64_t)shape[k], &e.n_elements))
            return gv_fail("safetensors: tensor '%s': element count overflows", name);
        e.shape[k] = shape[k];
    }
    if (__builtin_mul_overflow(e.n_elements, (uint64_t)gv_st_dtype_bits(dtype) / 8, &e.n_bytes))
        return gv_fail("safetensors: tensor '%s': byte size overflows", name);
    if (!data && e.n_bytes && !produce) return gv_fail("safetensors: tensor '%s': no data", name);
    if (b->n_tensors == b->cap_tensors) {
        int cap = b->cap_tensors ? 2 * b->cap_tensors : 16;
        struct gv_st_entry *grown = realloc(b->tensors, (size_t)cap * sizeof *grown);
        if (!grown) return gv_fail("safetensors: out of memory");
        b->tensors = grown;
        b->cap_tensors = cap;
    }
    if (!(e.name = strdup(name))) return gv_fail("safetensors: out of memory");
    b->tensors[b->n_tensors++] = e;
    return 0;
}

int gv_st_add_f32(gv_st_builder *b, const char *name, gv_st_dtype dtype, const int64_t *shape,
                  int rank, const float *data)
{
    if (dtype != GV_ST_F32 && dtype != GV_ST_BF16 && dtype != GV_ST_F16)
        return gv_fail("safetensors: tensor '%s': float32 values are stored as F32, BF16 or "
                       "F16, not %s", name ? name : "", gv_st_dtype_name(dtype));
    return add_entry(b, name, dtype, shape, rank, data, 1, NULL);
}

int gv_st_add_raw(gv_st_builder *b, const char *name, gv_st_dtype dtype, const int64_t *shape,
                  int rank, const void *data)
{
    return add_entry(b, name, dtype, shape, rank, data, 0, NULL);
}

int gv_st_add_produced(gv_st_builder *b, const char *name, gv_st_dtype dtype, const int64_t *shape,
                       int rank, gv_st_produce_fn produce, void *ctx)
{
    if (!produce) return gv_fail("safetensors: tensor '%s': no producer", name ? name : "");
    return add_entry(b, name, dtype, shape, rank, ctx, 0, produce);
}

int gv_st_add_metadata(gv_st_builder *b, const char *key, const char *value)
{
    if (check_name("metadata key", key)) return -1;
    if (!value || !gv_st_utf8_valid(value, strlen(value)))
        return gv_fail("safetensors: metadata value of '%s' is not valid UTF-8", key);
    if (b->n_metadata == b->cap_metadata) {
        int cap = b->cap_metadata ? 2 * b->cap_metadata : 8;
        char **keys = realloc(b->metadata_keys, (size_t)cap * sizeof *keys);
        if (keys) b->metadata_keys = keys;
        char **values = realloc(b->metadata_values, (size_t)cap * sizeof *values);
        if (values) b->metadata_values = values;
        if (!keys || !values) return gv_fail("safetensors: out of memory");
        b->cap_metadata = cap;
    }
    char *k = strdup(key), *v = strdup(value);
    if (!k || !v) {
        free(k);
        free(v);
        return gv_fail("safetensors: out of memory");
    }
    b->metadata_keys[b->n_metadata] = k;
    b->metadata_values[b->n_metadata++] = v;
    return 0;
}

/* ---- the header text ---------------------------------------------------------------- */

typedef struct {
    char *text;
    size_t length, capacity;
    int failed;
} text_buffer;

static void put(text_buffer *t, const char *s, size_t n)
{
    if (t->failed) return;
    if (t->length + n + 1 > t->capacity) {
        size_t cap = t->capacity ? t->capacity : 4096;
        while (cap < t->length + n + 1) cap *= 2;
        char *grown = realloc(t->text, cap);
        if (!grown) { t->failed = 1; return; }
        t->text = grown;
        t->capacity = cap;
    }
    memcpy(t->text + t->length, s, n);
    t->length += n;
    t->text[t->length] = '\0';
}

static void put_str(text_buffer *t, const char *s)
{
    put(t, s, strlen(s));
}

static void put_u64(text_buffer *t, uint64_t v)
{
    char number[32];
    put(t, number, (size_t)snprintf(number, sizeof number, "%" PRIu64, v));
}

/* A JSON string escaped as serde_json escapes it: quote, backslash, the short forms
 * \b \t \n \f \r, other control bytes as \u00xx (lowercase hex), all else verbatim. */
static void put_json_string(text_buffer *t, const char *s)
{
    put(t, "\"", 1);
    for (const unsigned char *p = (const unsigned char *)s; *p; p++) {
        char escaped[8];
        const char *shortcut = *p == '"' ? "\\\"" : *p == '\\' ? "\\\\" : *p == '\b' ? "\\b"
                               : *p == '\t' ? "\\t" : *p == '\n' ? "\\n" : *p == '\f' ? "\\f"
                               : *p == '\r' ? "\\r" : NULL;
        if (shortcut) put_str(t, shortcut);
        else if (*p < 0x20) put(t, escaped, (size_t)snprintf(escaped, sizeof escaped, "\\u%04x", *p));
        else put(t, (const char *)p, 1);
    }
    put(t, "\"", 1);
}

static void put_tensor_info(text_buffer *t, const struct gv_st_entry *e, uint64_t begin)
{
    put_json_string(t, e->name);
    put_str(t, ":{\"dtype\":");
    put_json_string(t, gv_st_dtype_name(e->dtype));
    put_str(t, ",\"shape\":[");
    for (int k = 0; k < e->rank; k++) {
        if (k) put(t, ",", 1);
        put_u64(t, (uint64_t)e->shape[k]);
    }
    put_str(t, "],\"data_offsets\":[");
    put_u64(t, begin);
    put(t, ",", 1);
    put_u64(t, begin + e->n_bytes);
    put_str(t, "]}");
}

/* ---- ordering ------------------------------------------------------------------------ */

static int by_alignment_then_name(const void *a, const void *b)
{
    const struct gv_st_entry *x = *(const struct gv_st_entry *const *)a;
    const struct gv_st_entry *y = *(const struct gv_st_entry *const *)b;
    if (x->dtype != y->dtype) return x->dtype > y->dtype ? -1 : 1;
    return strcmp(x->name, y->name);
}

static int by_key(const void *a, const void *b)
{
    return strcmp(**(char *const *const *)a, **(char *const *const *)b);
}

/* Builds the padded header: "__metadata__" (keys sorted: the reference's map has no order)
 * then the tensors in `order`. */
static int build_header(const gv_st_builder *b, struct gv_st_entry **order, const char *path,
                        text_buffer *t)
{
    put(t, "{", 1);
    if (b->n_metadata) {
        char ***keys = malloc((size_t)b->n_metadata * sizeof *keys);
        if (!keys) return gv_fail("%s: out of memory", path);
        for (int i = 0; i < b->n_metadata; i++) keys[i] = &b->metadata_keys[i];
        qsort(keys, (size_t)b->n_metadata, sizeof *keys, by_key);
        put_str(t, "\"__metadata__\":{");
        for (int i = 0; i < b->n_metadata; i++) {
            size_t at = (size_t)(keys[i] - b->metadata_keys);
            if (i) put(t, ",", 1);
            put_json_string(t, b->metadata_keys[at]);
            put(t, ":", 1);
            put_json_string(t, b->metadata_values[at]);
        }
        put(t, "}", 1);
        free(keys);
    }
    uint64_t offset = 0;
    for (int i = 0; i < b->n_tensors; i++) {
        if (i || b->n_metadata) put(t, ",", 1);
        put_tensor_info(t, order[i], offset);
        offset += order[i]->n_bytes;
    }
    put(t, "}", 1);
    while (!t->failed && t->length % 8) put(t, " ", 1);  /* as tensor.rs prepare() pads */
    if (t->failed) return gv_fail("%s: out of memory for the header", path);
    if (t->length > GV_ST_MAX_HEADER)
        return gv_fail("%s: header of %zu bytes exceeds the format's limit of %d", path,
                       t->length, GV_ST_MAX_HEADER);
    return 0;
}

/* ---- the file ------------------------------------------------------------------------ */

/* A produced tensor: made into a buffer of its size, written, freed. A producer's failure
 * is already recorded (gv_fail); *produce_failed tells the caller not to overwrite it. */
static int write_produced(FILE *out, const struct gv_st_entry *e, int *produce_failed)
{
    void *bytes = malloc((size_t)e->n_bytes);
    if (!bytes) {
        *produce_failed = 1;
        return gv_fail("safetensors: tensor '%s': out of memory for %" PRIu64 " bytes", e->name, e->n_bytes);
    }
    int rc = e->produce((void *)e->data, bytes, e->n_bytes);
    if (rc) *produce_failed = 1;
    else rc = fwrite(bytes, 1, (size_t)e->n_bytes, out) == (size_t)e->n_bytes ? 0 : -1;
    free(bytes);
    return rc;
}

static void drop_pages(const void *p, uint64_t bytes)
{
    long page = sysconf(_SC_PAGESIZE);
    uintptr_t lo = (uintptr_t)p & ~(uintptr_t)(page - 1), hi = (uintptr_t)p + bytes;
    if (page > 0 && hi > lo) madvise((void *)lo, hi - lo, MADV_DONTNEED);
}

void gv_st_tensor_drop_pages(const gv_st_tensor *t)
{
    if (t && t->data && t->end > t->begin) drop_pages(t->data, t->end - t->begin);
}

static int write_tensor_data(FILE *out, const struct gv_st_entry *e, uint16_t *buffer, int drop,
                             int *produce_failed)
{
    if (e->n_bytes == 0) return 0;
    if (e->produce) return write_produced(out, e, produce_failed);
    if (!e->from_f32 || e->dtype == GV_ST_F32) {
        int rc = fwrite(e->data, 1, (size_t)e->n_bytes, out) == (size_t)e->n_bytes ? 0 : -1;
        if (drop && !e->from_f32) drop_pages(e->data, e->n_bytes);
        return rc;
    }
    const float *src = e->data;
    int half = e->dtype == GV_ST_F16;
    for (uint64_t lo = 0; lo < e->n_elements; lo += WRITE_CHUNK) {
        int64_t len = (int64_t)(e->n_elements - lo < WRITE_CHUNK ? e->n_elements - lo : WRITE_CHUNK);
#pragma omp parallel for if (len > 8192) schedule(static)
        for (int64_t i = 0; i < len; i++)
            buffer[i] = half ? gv_f32_to_f16(src[lo + (uint64_t)i]) : gv_f32_to_bf16(src[lo + (uint64_t)i]);
        if (fwrite(buffer, 2, (size_t)len, out) != (size_t)len) return -1;
    }
    return 0;
}

static int check_names(const gv_st_builder *b, const char *path)
{
    const char **names = malloc(((size_t)b->n_tensors + 1) * sizeof *names);
    if (!names) return gv_fail("%s: out of memory", path);
    for (int i = 0; i < b->n_tensors; i++) names[i] = b->tensors[i].name;
    int rc = gv_st_check_unique(path, "tensor name", names, b->n_tensors);
    free(names);
    return rc || gv_st_check_unique(path, "metadata key", (const char **)b->metadata_keys,
                                    b->n_metadata);
}

static int write_file(const gv_st_builder *b, const char *path, struct gv_st_entry **order,
                      const text_buffer *header, uint16_t *buffer)
{
    gv_atomic_file af;
    if (gv_atomic_open(&af, path)) return -1;
    errno = 0;
    int produce_failed = 0;
    unsigned char length[8];
    for (int k = 0; k < 8; k++) length[k] = (unsigned char)((uint64_t)header->length >> (8 * k));
    int failed = fwrite(length, 1, 8, af.f) != 8 ||
                 fwrite(header->text, 1, header->length, af.f) != header->length;
    for (int i = 0; i < b->n_tensors && !failed; i++)
        failed = write_tensor_data(af.f, order[i], buffer, b->drop_source_pages, &produce_failed) != 0;
    if (failed) {
        int e = errno;
        gv_atomic_abort(&af);
        if (produce_failed) return -1; /* the producer said what is wrong */
        return gv_fail("%s: write error: %s", path, e ? strerror(e) : "short write");
    }
    return gv_atomic_commit(&af);
}

int gv_st_write(const gv_st_builder *b, const char *path)
{
    if (check_names(b, path)) return -1;
    struct gv_st_entry **order = malloc(((size_t)b->n_tensors + 1) * sizeof *order);
    uint16_t *buffer = malloc(WRITE_CHUNK * sizeof *buffer);
    text_buffer header = {0};
    int rc = -1;
    if (!order || !buffer) {
        gv_fail("%s: out of memory", path);
    } else {
        for (int i = 0; i < b->n_tensors; i++) order[i] = &b->tensors[i];
        qsort(order, (size_t)b->n_tensors, sizeof *order, by_alignment_then_name);
        if (build_header(b, order, path, &header) == 0)
            rc = write_file(b, path, order, &header, buffer);
    }
    free(header.text);
    free(buffer);
    free(order);
    return rc;
}
