/* NPY float32 arrays: the writer produces numpy.save's exact layout (version 1.0, header
 * padded to 64 bytes); the reader takes versions 1.0 to 3.0 and the header dict's keys in
 * any order, as numpy.lib.format does, but only '<f4' in C order. */
#include <ctype.h>
#include <errno.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "gaussvid/core/core.h"
#include "gaussvid/io/npy.h"

#if defined(__BYTE_ORDER__) && __BYTE_ORDER__ != __ORDER_LITTLE_ENDIAN__
#error "npy.c writes the host's float bytes as little-endian '<f4'"
#endif

static const char NPY_MAGIC[6] = {'\x93', 'N', 'U', 'M', 'P', 'Y'};
enum { NPY_ALIGN = 64, NPY_MAX_HEADER = 65535 };

int gv_npy_write_f32(const char *path, int rank, const int64_t *shape, const float *data)
{
    if (rank < 1 || rank > GV_NPY_MAX_RANK) return gv_fail("%s: rank %d is not 1..%d", path, rank, GV_NPY_MAX_RANK);
    char dict[256];
    int len = snprintf(dict, sizeof dict, "{'descr': '<f4', 'fortran_order': False, 'shape': (");
    size_t count = 1;
    for (int i = 0; i < rank; i++) {
        if (shape[i] <= 0) return gv_fail("%s: extent %lld of axis %d is not positive", path, (long long)shape[i], i);
        count *= (size_t)shape[i];
        len += snprintf(dict + len, sizeof dict - (size_t)len, "%lld%s", (long long)shape[i],
                        rank == 1 ? "," : i + 1 < rank ? ", " : "");
    }
    len += snprintf(dict + len, sizeof dict - (size_t)len, "), }");
    /* magic (6) + version (2) + length (2) + dict + spaces + '\n' = a multiple of 64 */
    int total = 10 + len + 1;
    int padded = (total + NPY_ALIGN - 1) / NPY_ALIGN * NPY_ALIGN;
    int header_len = padded - 10;
    unsigned char prefix[10];
    memcpy(prefix, NPY_MAGIC, 6);
    prefix[6] = 1, prefix[7] = 0;
    prefix[8] = (unsigned char)(header_len & 0xff), prefix[9] = (unsigned char)(header_len >> 8);

    gv_atomic_file af;
    if (gv_atomic_open(&af, path) != 0) return -1;
    fwrite(prefix, 1, sizeof prefix, af.f);
    fwrite(dict, 1, (size_t)len, af.f);
    for (int i = 0; i < padded - total; i++) fputc(' ', af.f);
    fputc('\n', af.f);
    fwrite(data, sizeof(float), count, af.f);
    return gv_atomic_commit(&af);
}

/* The text after "'key':" in the header dict (spaces skipped), or NULL. */
static const char *dict_value(const char *dict, const char *key)
{
    char quoted[32];
    snprintf(quoted, sizeof quoted, "'%s'", key);
    const char *p = strstr(dict, quoted);
    if (!p) return NULL;
    p += strlen(quoted);
    while (*p == ' ') p++;
    if (*p != ':') return NULL;
    p++;
    while (*p == ' ') p++;
    return p;
}

/* Parses "(d0, d1, ...)" with at most GV_NPY_MAX_RANK positive-or-zero extents. */
static int parse_shape(const char *p, int *rank, int64_t shape[GV_NPY_MAX_RANK])
{
    if (*p++ != '(') return -1;
    *rank = 0;
    for (;;) {
        while (*p == ' ') p++;
        if (*p == ')') return 0;
        if (!isdigit((unsigned char)*p) || *rank == GV_NPY_MAX_RANK) return -1;
        char *end;
        errno = 0;
        long long v = strtoll(p, &end, 10);
        if (errno || v > ((long long)1 << 40)) return -1;
        shape[(*rank)++] = v;
        p = end;
        while (*p == ' ') p++;
        if (*p == ',') p++;
        else if (*p != ')') return -1;
    }
}

static int parse_header(const char *path, const char *dict, int *rank, int64_t shape[GV_NPY_MAX_RANK])
{
    const char *descr = dict_value(dict, "descr");
    const char *order = dict_value(dict, "fortran_order");
    const char *dims = dict_value(dict, "shape");
    if (!descr || !order || !dims)
        return gv_fail("%s: NPY header lacks 'descr', 'fortran_order' or 'shape'", path);
    if (strncmp(descr, "'<f4'", 5) != 0) {
        char got[16] = {0};
        for (int i = 0; i < 12 && descr[i] && descr[i] != ','; i++) got[i] = descr[i];
        return gv_fail("%s: dtype %s is not float32 little-endian ('<f4')", path, got);
    }
    if (strncmp(order, "False", 5) != 0) return gv_fail("%s: Fortran-order arrays are not supported", path);
    if (parse_shape(dims, rank, shape) != 0) return gv_fail("%s: malformed NPY shape", path);
    if (*rank < 1) return gv_fail("%s: a 0-dimensional array is not a map", path);
    return 0;
}

int gv_npy_read_f32(const char *path, int *rank, int64_t shape[GV_NPY_MAX_RANK], float **data)
{
    *data = NULL;
    char *bytes;
    size_t size;
    if (gv_read_file(path, &bytes, &size) != 0) return -1;
    int ok = -1;
    const unsigned char *u = (const unsigned char *)bytes;
    if (size < 10 || memcmp(bytes, NPY_MAGIC, 6) != 0) {
        gv_fail("%s: not an NPY file (no \\x93NUMPY magic)", path);
        goto done;
    }
    size_t header_len, start;
    if (u[6] == 1) header_len = u[8] | (size_t)u[9] << 8, start = 10;
    else if ((u[6] == 2 || u[6] == 3) && size >= 12)
        header_len = u[8] | (size_t)u[9] << 8 | (size_t)u[10] << 16 | (size_t)u[11] << 24, start = 12;
    else {
        gv_fail("%s: NPY version %d.%d is not supported", path, u[6], u[7]);
        goto done;
    }
    if (header_len > size - start || header_len == 0 || bytes[start + header_len - 1] != '\n') {
        gv_fail("%s: truncated or malformed NPY header", path);
        goto done;
    }
    if (header_len > NPY_MAX_HEADER) {
        gv_fail("%s: NPY header of %zu bytes is too long", path, header_len);
        goto done;
    }
    bytes[start + header_len - 1] = '\0'; /* the dict ends at its newline */
    if (parse_header(path, bytes + start, rank, shape) != 0) goto done;
    size_t count = 1;
    for (int i = 0; i < *rank; i++) count *= (size_t)shape[i];
    size_t have = size - start - header_len;
    if (have != count * sizeof(float)) {
        gv_fail("%s: %zu data bytes, the shape needs %zu", path, have, count * sizeof(float));
        goto done;
    }
    *data = malloc(count ? count * sizeof(float) : 1);
    if (!*data) {
        gv_fail("%s: out of memory for %zu floats", path, count);
        goto done;
    }
    memcpy(*data, bytes + start + header_len, count * sizeof(float));
    ok = 0;
done:
    free(bytes);
    return ok;
}
