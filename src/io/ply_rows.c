/* PLY data: skipping the elements before the one wanted (binary rows by their declared
 * sizes, list rows by walking their lengths, ASCII rows line by line), checking the declared
 * row count against the bytes left, and decoding rows into doubles. */
#include "io/ply_header.h"

#include <errno.h>
#include <stdlib.h>
#include <string.h>
#include <sys/types.h>

#include "gaussvid/core/core.h"

/* One value of type t stored at p in the file's byte order. */
static double decode(const unsigned char *p, ply_type t, int big_endian)
{
    int size = ply_type_size(t);
    uint64_t u = 0;
    for (int i = 0; i < size; i++) u |= (uint64_t)p[big_endian ? size - 1 - i : i] << (8 * i);
    switch (t) {
    case PLY_CHAR: return (double)(int)u - (u >= 0x80u ? 0x100 : 0);
    case PLY_UCHAR: return (double)u;
    case PLY_SHORT: return (double)(int)u - (u >= 0x8000u ? 0x10000 : 0);
    case PLY_USHORT: return (double)u;
    case PLY_INT: return (double)((int64_t)u - (u >= 0x80000000u ? INT64_C(0x100000000) : 0));
    case PLY_UINT: return (double)u;
    case PLY_FLOAT: { uint32_t w = (uint32_t)u; float v; memcpy(&v, &w, 4); return v; }
    default: { double v; memcpy(&v, &u, 8); return v; }
    }
}

static int is_binary(const ply_file *pf)
{
    return pf->header.format != PLY_ASCII;
}

/* The next line that is not blank, in pf->text; 0 at the end of the file. */
static int next_line(ply_file *pf)
{
    for (;;) {
        ssize_t n = getline(&pf->text, &pf->text_capacity, pf->f);
        if (n < 0) return 0;
        pf->line++;
        if (strspn(pf->text, " \t\r\n") < (size_t)n) return 1;
    }
}

/* Skips one binary row of an element that has list properties. */
static int skip_list_row(ply_file *pf, const ply_element *e, int64_t row, int64_t *position)
{
    const ply_property *props = &pf->header.properties[e->first_property];
    for (int i = 0; i < e->n_properties; i++) {
        int64_t bytes = ply_type_size(props[i].type);
        if (props[i].is_list) {
            unsigned char raw[8];
            int size = ply_type_size(props[i].count_type);
            if (fread(raw, 1, (size_t)size, pf->f) != (size_t)size)
                return gv_fail("%s: truncated in element '%s' row %lld", pf->path, e->name,
                               (long long)row);
            *position += size;
            double length = decode(raw, props[i].count_type, pf->header.format == PLY_BINARY_BE);
            if (length < 0)
                return gv_fail("%s: element '%s' row %lld: negative list length", pf->path,
                               e->name, (long long)row);
            bytes *= (int64_t)length;
        }
        if (bytes > pf->file_size - *position)
            return gv_fail("%s: truncated in element '%s' row %lld", pf->path, e->name,
                           (long long)row);
        if (fseek(pf->f, (long)bytes, SEEK_CUR) != 0)
            return gv_fail("%s: cannot seek", pf->path);
        *position += bytes;
    }
    return 0;
}

/* Fewest bytes a row of e can take: binary rows by their types (a list at least its length),
 * ASCII rows one character and one separator per value. */
static int64_t min_row_bytes(const ply_file *pf, const ply_element *e)
{
    if (!is_binary(pf)) return 2 * (int64_t)e->n_properties;
    if (e->row_size > 0) return e->row_size;
    int64_t bytes = 0;
    for (int i = 0; i < e->n_properties; i++) {
        const ply_property *p = &pf->header.properties[e->first_property + i];
        bytes += ply_type_size(p->is_list ? p->count_type : p->type);
    }
    return bytes;
}

/* Refuses a declared row count that cannot fit in the bytes left after `position`. */
static int check_count(const ply_file *pf, const ply_element *e, int64_t position)
{
    int64_t least = min_row_bytes(pf, e);
    int64_t left = pf->file_size - position + (is_binary(pf) ? 0 : 1);  /* last '\n' optional */
    /* Rows of no properties take no bytes, so nothing bounds their count (found by fuzz/: an
     * ASCII vertex element of 652999802 empty rows had 7.8 GB allocated for its points). */
    if (e->n_properties == 0 && e->count > 0)
        return gv_fail("%s: element '%s' declares %lld rows but no properties", pf->path, e->name,
                       (long long)e->count);
    if (least > 0 && e->count > left / least)
        return gv_fail("%s: element '%s' declares %lld rows, more than the %lld bytes after "
                       "the header can hold (truncated file or corrupt count)", pf->path,
                       e->name, (long long)e->count, (long long)(pf->file_size - position));
    return 0;
}

static int skip_element(ply_file *pf, const ply_element *e, int64_t *position)
{
    if (check_count(pf, e, *position)) return -1;
    if (!is_binary(pf)) {
        for (int64_t r = 0; r < e->count; r++)
            if (!next_line(pf))
                return gv_fail("%s: truncated: element '%s' has %lld of %lld rows", pf->path,
                               e->name, (long long)r, (long long)e->count);
        return 0;
    }
    if (e->row_size > 0 || e->n_properties == 0) {
        int64_t bytes = e->count * e->row_size;
        if (fseek(pf->f, (long)bytes, SEEK_CUR) != 0) return gv_fail("%s: cannot seek", pf->path);
        *position += bytes;
        return 0;
    }
    for (int64_t r = 0; r < e->count; r++)
        if (skip_list_row(pf, e, r, position)) return -1;
    return 0;
}

int ply_seek_element(ply_file *pf, const char *name)
{
    const ply_header *h = &pf->header;
    int index = -1;
    for (int i = 0; i < h->n_elements && index < 0; i++)
        if (!strcmp(h->elements[i].name, name)) index = i;
    if (index < 0) return gv_fail("%s: no element '%s' in the header", pf->path, name);
    const ply_element *e = &h->elements[index];
    for (int i = 0; i < e->n_properties; i++)
        if (h->properties[e->first_property + i].is_list)
            return gv_fail("%s: element '%s' has a list property '%s' (not supported there)",
                           pf->path, name, h->properties[e->first_property + i].name);
    int64_t position = h->data_offset;
    for (int i = 0; i < index; i++)
        if (skip_element(pf, &h->elements[i], &position)) return -1;
    position = (int64_t)ftell(pf->f);  /* ASCII skips do not count their bytes */
    if (position < 0) return gv_fail("%s: cannot tell the file position", pf->path);
    if (check_count(pf, e, position)) return -1;
    pf->element = e;
    pf->rows_read = 0;
    if (is_binary(pf) && e->row_size > 0 && !(pf->record = malloc((size_t)e->row_size)))
        return gv_fail("%s: out of memory", pf->path);
    return 0;
}

/* Parses one ASCII value of type t; integer types must be integers in their range. */
static int parse_value(const char *token, ply_type t, double *value)
{
    static const double lo[] = {-128, 0, -32768, 0, -2147483648.0, 0};
    static const double hi[] = {127, 255, 32767, 65535, 2147483647.0, 4294967295.0};
    char *end;
    errno = 0;
    if (t == PLY_FLOAT || t == PLY_DOUBLE) {
        /* strtof for float: the nearest float, not a double rounded twice */
        *value = t == PLY_FLOAT ? (double)strtof(token, &end) : strtod(token, &end);
        return *end || end == token ? -1 : 0;  /* overflow gives inf, refused by the caller */
    }
    long long v = strtoll(token, &end, 10);
    if (errno || *end || end == token || v < lo[t] || v > hi[t]) return -1;
    *value = (double)v;
    return 0;
}

static int read_ascii_row(ply_file *pf, double *values)
{
    const ply_element *e = pf->element;
    if (!next_line(pf))
        return gv_fail("%s: truncated: element '%s' has %lld of %lld rows", pf->path, e->name,
                       (long long)pf->rows_read, (long long)e->count);
    char *save = NULL, *token = strtok_r(pf->text, " \t\r\n", &save);
    for (int i = 0; i < e->n_properties; i++, token = strtok_r(NULL, " \t\r\n", &save)) {
        const ply_property *p = &pf->header.properties[e->first_property + i];
        if (!token)
            return gv_fail("%s: line %lld: %d values, element '%s' has %d properties", pf->path,
                           (long long)pf->line, i, e->name, e->n_properties);
        if (parse_value(token, p->type, &values[i]))
            return gv_fail("%s: line %lld: '%.32s' is not a valid %s for property '%s'",
                           pf->path, (long long)pf->line, token, ply_type_name(p->type), p->name);
    }
    if (token)
        return gv_fail("%s: line %lld: more than the %d values of element '%s'", pf->path,
                       (long long)pf->line, e->n_properties, e->name);
    return 0;
}

int ply_read_row(ply_file *pf, double *values)
{
    const ply_element *e = pf->element;
    if (!e || pf->rows_read >= e->count)
        return gv_fail("%s: read past the last row", pf->path);
    if (!is_binary(pf)) {
        if (read_ascii_row(pf, values)) return -1;
    } else if (e->row_size > 0) {
        if (fread(pf->record, 1, (size_t)e->row_size, pf->f) != (size_t)e->row_size)
            return gv_fail("%s: truncated: element '%s' row %lld of %lld is incomplete",
                           pf->path, e->name, (long long)pf->rows_read, (long long)e->count);
        int big = pf->header.format == PLY_BINARY_BE;
        for (int i = 0; i < e->n_properties; i++) {
            const ply_property *p = &pf->header.properties[e->first_property + i];
            values[i] = decode(pf->record + p->offset, p->type, big);
        }
    }
    pf->rows_read++;
    return 0;
}

const char *ply_row_name(const ply_file *pf, char *buffer, size_t size)
{
    const char *name = pf->element ? pf->element->name : "row";
    long long row = (long long)pf->rows_read - 1;
    if (is_binary(pf)) snprintf(buffer, size, "%s %lld", name, row);
    else snprintf(buffer, size, "%s %lld (line %lld)", name, row, (long long)pf->line);
    return buffer;
}
