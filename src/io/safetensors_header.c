/* The safetensors header: a JSON object mapping each tensor name to {"dtype", "shape",
 * "data_offsets": [begin, end]}, plus an optional "__metadata__" object of strings. Checked
 * as the reference reader checks it (huggingface/safetensors, tensor.rs: read_metadata and
 * Metadata::validate): valid UTF-8 JSON, known dtypes, end - begin equal to the tensor's
 * size, and tensors that, sorted by offset, tile the data region exactly from byte 0 to its
 * end. We also refuse duplicate names, which the reference silently collapses. */
#include "io/safetensors_internal.h"

#include <cjson/cJSON.h>
#include <inttypes.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "gaussvid/core/core.h"

/* A real header nests 3 deep ({ name: { shape: [ ); the bound only keeps the parser's
 * recursion small whatever cJSON was built with. */
enum { HEADER_MAX_DEPTH = 64 };

/* Length of the valid UTF-8 sequence at s (at most `left` bytes), or 0 when it is invalid
 * (overlong forms, surrogates and code points above U+10FFFF are invalid). */
static int utf8_sequence_length(const unsigned char *s, size_t left)
{
    uint32_t c = s[0], cp, min;
    int len;
    if (c < 0x80) return 1;
    if ((c & 0xe0) == 0xc0) { len = 2; cp = c & 0x1f; min = 0x80; }
    else if ((c & 0xf0) == 0xe0) { len = 3; cp = c & 0x0f; min = 0x800; }
    else if ((c & 0xf8) == 0xf0) { len = 4; cp = c & 0x07; min = 0x10000; }
    else return 0;
    if ((size_t)len > left) return 0;
    for (int k = 1; k < len; k++) {
        if ((s[k] & 0xc0) != 0x80) return 0;
        cp = (cp << 6) | (s[k] & 0x3f);
    }
    if (cp < min || cp > 0x10ffff || (cp >= 0xd800 && cp <= 0xdfff)) return 0;
    return len;
}

int gv_st_utf8_valid(const char *s, size_t n)
{
    const unsigned char *u = (const unsigned char *)s;
    for (size_t i = 0; i < n;) {
        int len = utf8_sequence_length(u + i, n - i);
        if (!len) return 0;
        i += (size_t)len;
    }
    return 1;
}

/* Before handing the text to cJSON: UTF-8 (the reference decodes the header as UTF-8), no
 * raw control bytes (JSON allows none inside strings, only whitespace outside), and a
 * bounded nesting depth. */
static int prescan(const char *path, const char *text, size_t n)
{
    const unsigned char *s = (const unsigned char *)text;
    int in_string = 0, depth = 0;
    for (size_t i = 0; i < n; i++) {
        unsigned c = s[i];
        if (c >= 0x80) {
            int len = utf8_sequence_length(s + i, n - i);
            if (!len) return gv_fail("%s: header is not valid UTF-8 (byte %zu)", path, 8 + i);
            i += (size_t)len - 1;
            continue;
        }
        if (c < 0x20 && (in_string || (c != '\t' && c != '\n' && c != '\r')))
            return gv_fail("%s: header has a raw control byte 0x%02x at byte %zu", path, c, 8 + i);
        if (in_string) {
            if (c == '\\' && i + 1 < n && s[i + 1] < 0x80 && s[i + 1] >= 0x20) i++;
            else if (c == '"') in_string = 0;
        } else if (c == '"') {
            in_string = 1;
        } else if (c == '{' || c == '[') {
            if (++depth > HEADER_MAX_DEPTH)
                return gv_fail("%s: header JSON nests deeper than %d levels", path,
                               HEADER_MAX_DEPTH);
        } else if (c == '}' || c == ']') {
            depth--;
        }
    }
    return 0;
}

/* A JSON number that is a non-negative integer exactly representable in a double. */
static int json_u64(const cJSON *item, uint64_t *out)
{
    if (!cJSON_IsNumber(item)) return -1;
    double v = item->valuedouble;
    if (!(v >= 0) || v > 9007199254740992.0 || v != floor(v)) return -1;
    *out = (uint64_t)v;
    return 0;
}

/* Copies a string into the pool sized (by parse_entries) to hold every header string. */
static const char *pool_add(char *pool, size_t capacity, size_t *used, const char *s)
{
    size_t len = strlen(s) + 1;
    if (len > capacity - *used) return NULL;
    char *out = memcpy(pool + *used, s, len);
    *used += len;
    return out;
}

static int parse_shape(const char *path, const char *name, const cJSON *shape, gv_st_tensor *t)
{
    if (!cJSON_IsArray(shape))
        return gv_fail("%s: tensor '%s': \"shape\" is not an array", path, name);
    uint64_t count = 1;
    const cJSON *dim;
    cJSON_ArrayForEach(dim, shape) {
        uint64_t d;
        if (t->rank == GV_ST_MAX_RANK)
            return gv_fail("%s: tensor '%s': more than %d dimensions are not supported", path,
                           name, GV_ST_MAX_RANK);
        if (json_u64(dim, &d))
            return gv_fail("%s: tensor '%s': shape entries must be non-negative integers",
                           path, name);
        if (__builtin_mul_overflow(count, d, &count) || count > (uint64_t)INT64_MAX)
            return gv_fail("%s: tensor '%s': element count overflows", path, name);
        t->shape[t->rank++] = (int64_t)d;
    }
    t->n_elements = (int64_t)count;
    return 0;
}

static int parse_offsets(const char *path, const char *name, const cJSON *offsets,
                         gv_st_tensor *t)
{
    const cJSON *b = cJSON_IsArray(offsets) ? offsets->child : NULL;
    const cJSON *e = b ? b->next : NULL;
    if (!e || e->next || json_u64(b, &t->begin) || json_u64(e, &t->end))
        return gv_fail("%s: tensor '%s': \"data_offsets\" must be two non-negative integers",
                       path, name);
    return 0;
}

/* One tensor entry; unknown fields are ignored, as the reference does. */
static int parse_tensor(const gv_st_file *f, const cJSON *entry, gv_st_tensor *t)
{
    const char *path = f->path, *name = entry->string;
    if (!cJSON_IsObject(entry))
        return gv_fail("%s: tensor '%s': entry is not an object", path, name);
    const cJSON *dtype = NULL, *shape = NULL, *offsets = NULL, *field;
    cJSON_ArrayForEach(field, entry) {
        const cJSON **slot = !strcmp(field->string, "dtype")   ? &dtype
                             : !strcmp(field->string, "shape") ? &shape
                             : !strcmp(field->string, "data_offsets") ? &offsets : NULL;
        if (slot && *slot)
            return gv_fail("%s: tensor '%s': field \"%s\" appears twice", path, name,
                           field->string);
        if (slot) *slot = field;
    }
    if (!dtype || !shape || !offsets)
        return gv_fail("%s: tensor '%s': missing \"%s\"", path, name,
                       !dtype ? "dtype" : !shape ? "shape" : "data_offsets");
    int d = cJSON_IsString(dtype) ? gv_st_dtype_from_name(dtype->valuestring) : -1;
    if (d < 0)
        return gv_fail("%s: tensor '%s': unknown dtype %s", path, name,
                       cJSON_IsString(dtype) ? dtype->valuestring : "(not a string)");
    t->dtype = (gv_st_dtype)d;
    if (parse_shape(path, name, shape, t) || parse_offsets(path, name, offsets, t)) return -1;

    /* Metadata::validate: the byte size must be whole and equal end - begin */
    uint64_t bits, bytes = t->end - t->begin;
    char text[256];
    if (__builtin_mul_overflow((uint64_t)t->n_elements, (uint64_t)gv_st_dtype_bits(t->dtype), &bits))
        return gv_fail("%s: tensor '%s': byte size overflows", path, name);
    if (bits % 8)
        return gv_fail("%s: tensor '%s': %s %s is not a whole number of bytes", path, name,
                       gv_st_dtype_name(t->dtype), gv_st_shape_str(text, sizeof text, t->shape, t->rank));
    if (t->end < t->begin)
        return gv_fail("%s: tensor '%s': data_offsets [%" PRIu64 ", %" PRIu64 "] end before "
                       "they begin", path, name, t->begin, t->end);
    if (t->end > f->data_size)
        return gv_fail("%s: tensor '%s': data_offsets [%" PRIu64 ", %" PRIu64 "] run past the "
                       "%" PRIu64 "-byte data region (truncated file?)", path, name, t->begin,
                       t->end, f->data_size);
    if (bytes != bits / 8)
        return gv_fail("%s: tensor '%s': data_offsets [%" PRIu64 ", %" PRIu64 "] hold %" PRIu64
                       " bytes but %s %s needs %" PRIu64, path, name, t->begin, t->end, bytes,
                       gv_st_dtype_name(t->dtype), gv_st_shape_str(text, sizeof text, t->shape, t->rank),
                       bits / 8);
    return 0;
}

static int by_string(const void *a, const void *b)
{
    return strcmp(*(const char *const *)a, *(const char *const *)b);
}

/* Sorts a copy: headers and builders may hold many strings. */
int gv_st_check_unique(const char *path, const char *what, const char **strings, int n)
{
    if (n < 2) return 0;
    const char **sorted = malloc((size_t)n * sizeof *sorted);
    if (!sorted) return gv_fail("%s: out of memory", path);
    memcpy(sorted, strings, (size_t)n * sizeof *sorted);
    qsort(sorted, (size_t)n, sizeof *sorted, by_string);
    int rc = 0;
    for (int i = 1; i < n && !rc; i++)
        if (!strcmp(sorted[i], sorted[i - 1]))
            rc = gv_fail("%s: %s '%s' appears twice", path, what, sorted[i]);
    free(sorted);
    return rc;
}

static int parse_metadata(gv_st_file *f, const cJSON *object, char *pool, size_t capacity,
                          size_t *used)
{
    if (cJSON_IsNull(object)) return 0;  /* the reference reads null as no metadata */
    if (!cJSON_IsObject(object))
        return gv_fail("%s: \"__metadata__\" is not an object of strings", f->path);
    int count = 0;
    const cJSON *item;
    cJSON_ArrayForEach(item, object) count++;
    f->metadata_keys = calloc((size_t)count + 1, sizeof *f->metadata_keys);
    f->metadata_values = calloc((size_t)count + 1, sizeof *f->metadata_values);
    if (!f->metadata_keys || !f->metadata_values) return gv_fail("%s: out of memory", f->path);
    cJSON_ArrayForEach(item, object) {
        if (!cJSON_IsString(item))
            return gv_fail("%s: metadata value of '%s' is not a string", f->path, item->string);
        const char *key = pool_add(pool, capacity, used, item->string);
        const char *value = pool_add(pool, capacity, used, item->valuestring);
        if (!key || !value) return gv_fail("%s: header strings overflow", f->path);
        f->metadata_keys[f->n_metadata] = key;
        f->metadata_values[f->n_metadata++] = value;
    }
    return gv_st_check_unique(f->path, "metadata key", f->metadata_keys, f->n_metadata);
}

static int by_offset(const void *a, const void *b)
{
    const gv_st_tensor *x = a, *y = b;
    if (x->begin != y->begin) return x->begin < y->begin ? -1 : 1;
    if (x->end != y->end) return x->end < y->end ? -1 : 1;
    return strcmp(x->name, y->name);
}

/* Sorted by offset, the tensors must tile [0, data_size): each begins where the previous
 * one ends (Metadata::validate), and the last ends at the end of the file. */
static int check_layout(const gv_st_file *f)
{
    uint64_t covered = 0;
    for (int i = 0; i < f->n_tensors; i++) {
        const gv_st_tensor *t = &f->tensors[i], *prev = i ? t - 1 : NULL;
        if (t->begin < covered)
            return gv_fail("%s: tensors '%s' [%" PRIu64 ", %" PRIu64 "] and '%s' [%" PRIu64
                           ", %" PRIu64 "] overlap", f->path, prev->name, prev->begin,
                           prev->end, t->name, t->begin, t->end);
        if (t->begin > covered && prev)
            return gv_fail("%s: a hole of %" PRIu64 " bytes between tensors '%s' and '%s' is "
                           "not covered by any tensor", f->path, t->begin - covered,
                           prev->name, t->name);
        if (t->begin > covered)
            return gv_fail("%s: a hole of %" PRIu64 " bytes before tensor '%s' is not covered "
                           "by any tensor", f->path, t->begin, t->name);
        covered = t->end;
    }
    if (covered != f->data_size)
        return gv_fail("%s: %" PRIu64 " bytes after the last tensor are not covered by any "
                       "tensor", f->path, f->data_size - covered);
    return 0;
}

const char *gv_st_tensor_name(const void *tensors, int i)
{
    return ((const gv_st_tensor *)tensors)[i].name;
}

int gv_st_build_name_index(gv_st_file *f)
{
    const char *repeat;
    f->by_name = malloc(((size_t)f->n_tensors + 1) * sizeof *f->by_name);
    if (!f->by_name) return gv_fail("%s: out of memory", f->path);
    if (gv_names_order(f->tensors, f->n_tensors, gv_st_tensor_name, f->by_name, &repeat))
        return gv_fail_context("%s", f->path);
    return repeat ? gv_fail("%s: tensor name '%s' appears twice", f->path, repeat) : 0;
}

static int parse_entries(gv_st_file *f, const cJSON *root, size_t n)
{
    size_t count = 0, used = 0;
    int metadata_seen = 0;
    const cJSON *entry;
    cJSON_ArrayForEach(entry, root) count++;
    /* every string of the header is shorter than its quoted JSON text: n bytes hold them */
    f->strings = malloc(n + 1);
    f->tensors = calloc(count + 1, sizeof *f->tensors);
    if (!f->strings || !f->tensors) return gv_fail("%s: out of memory", f->path);
    cJSON_ArrayForEach(entry, root) {
        if (!strcmp(entry->string, "__metadata__")) {
            if (metadata_seen++) return gv_fail("%s: \"__metadata__\" appears twice", f->path);
            if (parse_metadata(f, entry, f->strings, n + 1, &used)) return -1;
            continue;
        }
        gv_st_tensor *t = &f->tensors[f->n_tensors];
        if (parse_tensor(f, entry, t)) return -1;
        if (!(t->name = pool_add(f->strings, n + 1, &used, entry->string)))
            return gv_fail("%s: header strings overflow", f->path);
        f->n_tensors++;
    }
    return 0;
}

int gv_st_parse_header(gv_st_file *f, const char *text, size_t n)
{
    if (prescan(f->path, text, n)) return -1;
    const char *end = NULL;
    /* length n + 1 and require_null_terminated: after the object only whitespace may follow */
    cJSON *root = cJSON_ParseWithLengthOpts(text, n + 1, &end, 1);
    if (!root) {
        size_t at = end && end >= text && end <= text + n ? (size_t)(end - text) : 0;
        return gv_fail("%s: header is not valid JSON (near byte %zu)", f->path, 8 + at);
    }
    int rc = -1;
    if (!cJSON_IsObject(root))
        gv_fail("%s: header is not a JSON object", f->path);
    else if (parse_entries(f, root, n) == 0) {
        qsort(f->tensors, (size_t)f->n_tensors, sizeof *f->tensors, by_offset);
        rc = gv_st_build_name_index(f) || check_layout(f) ? -1 : 0;
    }
    cJSON_Delete(root);
    return rc;
}
