/* Reading safetensors files: the file is memory-mapped read-only (a multi-GB checkpoint is
 * never copied whole), its header checked (safetensors_header.c), and tensors looked up by
 * name, checked against the caller's expected dtype and shape, and converted to float32. */
#include "gaussvid/io/safetensors.h"

#include <errno.h>
#include <fcntl.h>
#include <inttypes.h>
#include <stdlib.h>
#include <string.h>
#include <sys/mman.h>
#include <sys/stat.h>
#include <unistd.h>

#include "gaussvid/core/core.h"
#include "io/safetensors_internal.h"

#if defined(__BYTE_ORDER__) && __BYTE_ORDER__ != __ORDER_LITTLE_ENDIAN__
#error "safetensors data is little-endian; this reader assumes a little-endian host"
#endif

/* Elements per chunk of a parallel copy or conversion. */
enum { CONVERT_CHUNK = 1 << 16 };

void gv_st_close(gv_st_file *f)
{
    if (f->release) f->release(f->owner);
    if (f->map) munmap((void *)f->map, (size_t)f->file_size);
    free(f->path);
    free(f->tensors);
    free(f->metadata_keys);
    free(f->metadata_values);
    free(f->by_name);
    free(f->strings);
    memset(f, 0, sizeof *f);
}

/* After gv_fail: frees what the failed open had set and passes the failure on. */
static int open_failed(gv_st_file *f, int fd)
{
    if (fd >= 0) close(fd);
    gv_st_close(f);
    return -1;
}

static int map_file(gv_st_file *f, int fd)
{
    struct stat st;
    if (fstat(fd, &st) != 0 || !S_ISREG(st.st_mode))
        return gv_fail("%s: not a regular file", f->path);
    f->file_size = (uint64_t)st.st_size;
    if (f->file_size < 8)
        return gv_fail("%s: %" PRIu64 " bytes is too short for a safetensors file (the 8-byte "
                       "header length is missing)", f->path, f->file_size);
    void *map = mmap(NULL, (size_t)f->file_size, PROT_READ, MAP_PRIVATE, fd, 0);
    if (map == MAP_FAILED) return gv_fail("%s: cannot map: %s", f->path, strerror(errno));
    f->map = map;
    return 0;
}

int gv_st_stream(const gv_st_file *f, int (*each)(void *ctx, const void *bytes, size_t n), void *ctx)
{
    if (!f->map || f->owner) return gv_fail("%s: not a single mapped safetensors file", f->path);
    for (uint64_t at = 0; at < f->file_size; at += GV_ST_STREAM_PIECE) {
        size_t n = f->file_size - at < GV_ST_STREAM_PIECE ? (size_t)(f->file_size - at) : GV_ST_STREAM_PIECE;
        int rc = each(ctx, f->map + at, n);
        /* the map's start is page-aligned and so is every piece's: the pages read return to
         * the file, to be read again if a tensor is wanted later */
        madvise((void *)(f->map + at), n, MADV_DONTNEED);
        if (rc) return rc;
    }
    return 0;
}

int gv_st_open(gv_st_file *f, const char *path)
{
    int fd = open(path, O_RDONLY | O_CLOEXEC);
    if (fd < 0) {
        memset(f, 0, sizeof *f);
        return gv_fail("%s: cannot open: %s", path, strerror(errno));
    }
    return gv_st_open_fd(f, path, fd);
}

int gv_st_open_fd(gv_st_file *f, const char *path, int fd)
{
    memset(f, 0, sizeof *f);
    if (!(f->path = strdup(path))) {
        close(fd);
        return gv_fail("%s: out of memory", path);
    }
    if (map_file(f, fd)) return open_failed(f, fd);
    close(fd);

    uint64_t n = 0;
    for (int k = 7; k >= 0; k--) n = (n << 8) | f->map[k];
    if (n > GV_ST_MAX_HEADER) {
        gv_fail("%s: header length %" PRIu64 " is beyond the format's limit of %d bytes (not a "
                "safetensors file?)", path, n, GV_ST_MAX_HEADER);
        return open_failed(f, -1);
    }
    if (n > f->file_size - 8) {
        gv_fail("%s: header length %" PRIu64 " runs past the end of the %" PRIu64 "-byte file "
                "(truncated?)", path, n, f->file_size);
        return open_failed(f, -1);
    }
    f->header_size = n;
    f->data_size = f->file_size - 8 - n;

    /* cJSON wants a NUL-terminated copy; the header is at most 100 MB, the data is not copied */
    char *text = malloc((size_t)n + 1);
    if (!text) {
        gv_fail("%s: out of memory for a %" PRIu64 "-byte header", path, n);
        return open_failed(f, -1);
    }
    memcpy(text, f->map + 8, (size_t)n);
    text[n] = '\0';
    int rc = gv_st_parse_header(f, text, (size_t)n);
    free(text);
    if (rc) return open_failed(f, -1);
    const uint8_t *data = f->map + 8 + n;
    for (int i = 0; i < f->n_tensors; i++) f->tensors[i].data = data + f->tensors[i].begin;
    return 0;
}

const gv_st_tensor *gv_st_find(const gv_st_file *f, const char *name)
{
    return gv_names_find(f->tensors, sizeof *f->tensors, f->by_name, f->n_tensors, gv_st_tensor_name, name);
}

const char *gv_st_metadata(const gv_st_file *f, const char *key)
{
    for (int i = 0; i < f->n_metadata; i++)
        if (!strcmp(f->metadata_keys[i], key)) return f->metadata_values[i];
    return NULL;
}

const char *gv_st_shape_str(char *out, size_t size, const int64_t *shape, int rank)
{
    size_t used = 0;
    out[0] = '\0';
    used += (size_t)snprintf(out, size, "[");
    for (int k = 0; k < rank && used < size; k++)
        used += (size_t)snprintf(out + used, size - used, "%s%" PRId64, k ? ", " : "", shape[k]);
    if (used < size) snprintf(out + used, size - used, "]");
    return out;
}

static int shape_matches(const gv_st_tensor *t, const int64_t *shape, int rank)
{
    if (rank < 0) return 1;
    if (rank != t->rank) return 0;
    for (int k = 0; k < rank; k++)
        if (shape[k] != t->shape[k]) return 0;
    return 1;
}

static int is_float_dtype(gv_st_dtype d)
{
    return d == GV_ST_F32 || d == GV_ST_F16 || d == GV_ST_BF16 || d == GV_ST_F64;
}

/* Besides a dtype, the expectation of find_checked may be any dtype or any float dtype. */
enum { ANY_DTYPE = -1, ANY_FLOAT = -2 };

/* Looks a tensor up and checks its dtype and shape against the expectation. */
static int find_checked(const gv_st_file *f, const char *name, int dtype, const int64_t *shape,
                        int rank, const gv_st_tensor **out)
{
    const gv_st_tensor *t = gv_st_find(f, name);
    if (!t)
        return gv_fail("%s: no tensor named '%s' (the file has %d tensors)", f->path, name,
                       f->n_tensors);
    if (rank > 0 && !shape)
        return gv_fail("%s: tensor '%s': expected rank %d but no expected shape", f->path,
                       name, rank);
    int dtype_ok = dtype == ANY_DTYPE || (dtype == ANY_FLOAT && is_float_dtype(t->dtype)) ||
                   (int)t->dtype == dtype;
    if (!dtype_ok || !shape_matches(t, shape, rank)) {
        char want[256] = "any shape", found[256];
        if (rank >= 0) gv_st_shape_str(want, sizeof want, shape, rank);
        const char *want_dtype = dtype == ANY_DTYPE ? "any dtype" : dtype == ANY_FLOAT ?
                                 "F32/F16/BF16/F64" : gv_st_dtype_name((gv_st_dtype)dtype);
        return gv_fail("%s: tensor '%s': expected %s %s, found %s %s", f->path, name,
                       want_dtype, want, gv_st_dtype_name(t->dtype),
                       gv_st_shape_str(found, sizeof found, t->shape, t->rank));
    }
    *out = t;
    return 0;
}

int gv_st_get(const gv_st_file *f, const char *name, int dtype, const int64_t *shape, int rank,
              const gv_st_tensor **out)
{
    return find_checked(f, name, dtype < 0 ? ANY_DTYPE : dtype, shape, rank, out);
}

/* Converts elements [lo, hi) of src (dtype) into dst; one plain loop per dtype so the
 * compiler vectorises it. memcpy loads: the data of a file from elsewhere may be unaligned. */
static void convert_range(gv_st_dtype dtype, const uint8_t *src, float *dst, int64_t lo,
                          int64_t hi)
{
    if (dtype == GV_ST_F32) {
        memcpy(dst + lo, src + 4 * lo, (size_t)(hi - lo) * 4);
    } else if (dtype == GV_ST_BF16) {  /* gv_bf16_to_f32 inlined: the top half of a float */
        for (int64_t i = lo; i < hi; i++) {
            uint16_t h;
            memcpy(&h, src + 2 * i, 2);
            uint32_t bits = (uint32_t)h << 16;
            memcpy(dst + i, &bits, 4);
        }
    } else if (dtype == GV_ST_F16) {
        for (int64_t i = lo; i < hi; i++) {
            uint16_t h;
            memcpy(&h, src + 2 * i, 2);
            dst[i] = gv_f16_to_f32(h);
        }
    } else {
        for (int64_t i = lo; i < hi; i++) {
            double v;
            memcpy(&v, src + 8 * i, 8);
            dst[i] = (float)v;
        }
    }
}

int gv_st_tensor_to_f32(const gv_st_file *f, const gv_st_tensor *t, float *dst)
{
    if (!is_float_dtype(t->dtype))
        return gv_fail("%s: tensor '%s' has dtype %s, which does not convert to float32 "
                       "(F32, F16, BF16 or F64 expected)", f->path, t->name,
                       gv_st_dtype_name(t->dtype));
    int64_t n = t->n_elements, chunks = (n + CONVERT_CHUNK - 1) / CONVERT_CHUNK;
    /* chunks in parallel: the page faults of a cold mapping are shared between threads too */
#pragma omp parallel for if (chunks > 1) schedule(static)
    for (int64_t c = 0; c < chunks; c++) {
        int64_t lo = c * CONVERT_CHUNK, hi = lo + CONVERT_CHUNK < n ? lo + CONVERT_CHUNK : n;
        convert_range(t->dtype, t->data, dst, lo, hi);
    }
    return 0;
}

int gv_st_read_f32(const gv_st_file *f, const char *name, float *dst, const int64_t *shape,
                   int rank)
{
    const gv_st_tensor *t;
    if (find_checked(f, name, ANY_FLOAT, shape, rank, &t)) return -1;
    return gv_st_tensor_to_f32(f, t, dst);
}

int gv_st_read_raw(const gv_st_file *f, const char *name, gv_st_dtype dtype,
                   const int64_t *shape, int rank, void *dst)
{
    const gv_st_tensor *t;
    if (gv_st_get(f, name, (int)dtype, shape, rank, &t)) return -1;
    if (t->end > t->begin) memcpy(dst, t->data, (size_t)(t->end - t->begin));
    return 0;
}
