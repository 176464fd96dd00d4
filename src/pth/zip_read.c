/* Zip archives (PKWARE APPNOTE 6.3): the end-of-central-directory record is found from the
 * end of the archive (ZIP64 records when a count or offset does not fit 16/32 bits, as in
 * multi-GB checkpoints), the central directory gives each entry's name, method, sizes and
 * local header, and the local header gives where its bytes start. Every size and offset is
 * checked against the archive's bounds before it is used, so a truncated or malformed file
 * gives one message, never a read outside the mapping. */
#include "pth/zip_internal.h"

#include <inttypes.h>
#include <stdlib.h>
#include <string.h>
#include <zlib.h>

#include "gaussvid/core/core.h"

enum {
    EOCD_SIG = 0x06054b50, EOCD_SIZE = 22,
    ZIP64_LOCATOR_SIG = 0x07064b50, ZIP64_LOCATOR_SIZE = 20,
    ZIP64_EOCD_SIG = 0x06064b50, ZIP64_EOCD_SIZE = 56,
    CENTRAL_SIG = 0x02014b50, CENTRAL_SIZE = 46,
    LOCAL_SIG = 0x04034b50, LOCAL_SIZE = 30,
};

static uint64_t le(const uint8_t *p, int n)
{
    uint64_t v = 0;
    for (int k = n - 1; k >= 0; k--) v = (v << 8) | p[k];
    return v;
}

/* Whether [offset, offset + length) lies in the archive. */
static int inside(const gv_zip *z, uint64_t offset, uint64_t length)
{
    return offset <= z->size && length <= z->size - offset;
}

/* The end of central directory: the last EOCD signature whose comment reaches the end. */
static int find_eocd(const gv_zip *z, uint64_t *at)
{
    if (z->size < EOCD_SIZE) return gv_fail("%s: %" PRIu64 " bytes is too short for a zip archive", z->path, z->size);
    uint64_t lowest = z->size > EOCD_SIZE + 0xffff ? z->size - EOCD_SIZE - 0xffff : 0;
    for (uint64_t p = z->size - EOCD_SIZE + 1; p-- > lowest;)
        if (le(z->data + p, 4) == EOCD_SIG && p + EOCD_SIZE + le(z->data + p + 20, 2) == z->size) {
            *at = p;
            return 0;
        }
    return gv_fail("%s: no zip end-of-central-directory record (truncated file?)", z->path);
}

/* The central directory's offset, size and entry count, from the EOCD or its ZIP64 form. */
static int read_directory_location(const gv_zip *z, uint64_t eocd, uint64_t *offset, uint64_t *size, uint64_t *count,
                                   uint64_t *limit)
{
    const uint8_t *e = z->data + eocd;
    if (le(e + 4, 2) != 0 || le(e + 6, 2) != 0) return gv_fail("%s: a multi-disk (split) zip archive", z->path);
    *count = le(e + 10, 2), *size = le(e + 12, 4), *offset = le(e + 16, 4), *limit = eocd;
    if (*count != 0xffff && *size != 0xffffffff && *offset != 0xffffffff) return 0;
    /* ZIP64: the locator sits just before the EOCD and points at the ZIP64 EOCD record */
    if (eocd < ZIP64_LOCATOR_SIZE || le(z->data + eocd - ZIP64_LOCATOR_SIZE, 4) != ZIP64_LOCATOR_SIG)
        return gv_fail("%s: the zip directory needs ZIP64 records, which are missing", z->path);
    uint64_t at = le(z->data + eocd - ZIP64_LOCATOR_SIZE + 8, 8);
    if (!inside(z, at, ZIP64_EOCD_SIZE) || at + ZIP64_EOCD_SIZE > eocd - ZIP64_LOCATOR_SIZE ||
        le(z->data + at, 4) != ZIP64_EOCD_SIG)
        return gv_fail("%s: the ZIP64 end-of-central-directory record is not where its locator says", z->path);
    const uint8_t *r = z->data + at;
    *count = le(r + 32, 8), *size = le(r + 40, 8), *offset = le(r + 48, 8), *limit = at;
    return 0;
}

/* Values that did not fit the central record come from its ZIP64 extra field (id 1), in
 * the order size, compressed size, local header offset, each only when its 32-bit field is
 * 0xffffffff. */
static int zip64_extra(const gv_zip *z, const uint8_t *extra, uint64_t n, const char *name, uint64_t *size,
                       uint64_t *csize, uint64_t *local)
{
    int want_size = *size == 0xffffffff, want_csize = *csize == 0xffffffff, want_local = *local == 0xffffffff;
    if (!want_size && !want_csize && !want_local) return 0;
    for (uint64_t p = 0; p + 4 <= n;) {
        uint64_t id = le(extra + p, 2), len = le(extra + p + 2, 2);
        if (p + 4 + len > n) break;
        if (id == 1) {
            const uint8_t *f = extra + p + 4;
            uint64_t need = 8 * (uint64_t)(want_size + want_csize + want_local);
            if (len < need) break;
            if (want_size) *size = le(f, 8), f += 8;
            if (want_csize) *csize = le(f, 8), f += 8;
            if (want_local) *local = le(f, 8);
            return 0;
        }
        p += 4 + len;
    }
    return gv_fail("%s: entry '%s' needs a ZIP64 extra field, which is missing or short", z->path, name);
}

/* One central record at *p (advanced past it); finds its data through the local header. */
static int read_entry(gv_zip *z, uint64_t *p, uint64_t end, gv_zip_entry *e, char **names)
{
    if (*p + CENTRAL_SIZE > end || le(z->data + *p, 4) != CENTRAL_SIG)
        return gv_fail("%s: malformed zip central directory at byte %" PRIu64, z->path, *p);
    const uint8_t *c = z->data + *p;
    uint64_t name_len = le(c + 28, 2), extra_len = le(c + 30, 2), comment_len = le(c + 32, 2);
    if (*p + CENTRAL_SIZE + name_len + extra_len + comment_len > end)
        return gv_fail("%s: a zip central directory record runs past the directory", z->path);
    memcpy(*names, c + CENTRAL_SIZE, name_len);
    (*names)[name_len] = '\0';
    e->name = *names;
    *names += name_len + 1;
    if (memchr(c + CENTRAL_SIZE, 0, name_len)) return gv_fail("%s: a zip entry name holds a NUL byte", z->path);
    if (le(c + 8, 2) & 1) return gv_fail("%s: entry '%s' is encrypted", z->path, e->name);
    e->method = (int)le(c + 10, 2);
    e->crc32 = (uint32_t)le(c + 16, 4);
    e->compressed_size = le(c + 20, 4), e->size = le(c + 24, 4);
    uint64_t local = le(c + 42, 4);
    if (zip64_extra(z, c + CENTRAL_SIZE + name_len, extra_len, e->name, &e->size, &e->compressed_size, &local)) return -1;
    *p += CENTRAL_SIZE + name_len + extra_len + comment_len;

    if (!inside(z, local, LOCAL_SIZE) || le(z->data + local, 4) != LOCAL_SIG)
        return gv_fail("%s: entry '%s': no local header at byte %" PRIu64 " (truncated file?)", z->path, e->name, local);
    const uint8_t *l = z->data + local;
    uint64_t l_name = le(l + 26, 2), l_extra = le(l + 28, 2);
    if (l_name != name_len || !inside(z, local + LOCAL_SIZE, l_name) || memcmp(l + LOCAL_SIZE, e->name, name_len))
        return gv_fail("%s: entry '%s': its local header names another file", z->path, e->name);
    e->data_offset = local + LOCAL_SIZE + l_name + l_extra;
    if (!inside(z, e->data_offset, e->compressed_size))
        return gv_fail("%s: entry '%s': its %" PRIu64 " bytes run past the end of the archive (truncated file?)", z->path,
                       e->name, e->compressed_size);
    return 0;
}

static const char *entry_name(const void *entries, int i)
{
    return ((const gv_zip_entry *)entries)[i].name;
}

const gv_zip_entry *gv_zip_find(const gv_zip *z, const char *name)
{
    return gv_names_find(z->entries, sizeof *z->entries, NULL, z->n, entry_name, name);
}

/* Puts the entries in name order (the order gv_zip_find bisects); fails on a name twice. */
static int sort_entries(gv_zip *z)
{
    const char *repeat;
    int *order = malloc(((size_t)z->n + 1) * sizeof *order);
    gv_zip_entry *sorted = malloc(((size_t)z->n + 1) * sizeof *sorted);
    int rc = !order || !sorted ? gv_fail("%s: out of memory for %d zip entries", z->path, z->n)
                               : gv_names_order(z->entries, z->n, entry_name, order, &repeat);
    if (rc == 0 && repeat) rc = gv_fail("%s: zip entry '%s' appears twice", z->path, repeat);
    for (int i = 0; rc == 0 && i < z->n; i++) sorted[i] = z->entries[order[i]];
    if (rc == 0) memcpy(z->entries, sorted, (size_t)z->n * sizeof *sorted);
    free(order), free(sorted);
    return rc;
}

int gv_zip_open(gv_zip *z, const char *path, const uint8_t *data, uint64_t size)
{
    memset(z, 0, sizeof *z);
    z->path = path, z->data = data, z->size = size;
    uint64_t eocd = 0, offset = 0, dir_size = 0, count = 0, limit = 0;
    if (find_eocd(z, &eocd) || read_directory_location(z, eocd, &offset, &dir_size, &count, &limit)) return -1;
    if (offset > limit || dir_size > limit - offset)
        return gv_fail("%s: the zip central directory (%" PRIu64 " bytes at %" PRIu64 ") runs past its end record "
                       "(truncated file?)", path, dir_size, offset);
    /* every record is at least 46 bytes: bounds the count before anything is allocated */
    if (count > dir_size / CENTRAL_SIZE)
        return gv_fail("%s: the zip directory claims %" PRIu64 " entries in %" PRIu64 " bytes", path, count, dir_size);
    z->entries = calloc((size_t)count + 1, sizeof *z->entries);
    z->names = malloc((size_t)dir_size + 1); /* names are shorter than their records */
    if (!z->entries || !z->names) {
        gv_zip_close(z);
        return gv_fail("%s: out of memory for %" PRIu64 " zip entries", path, count);
    }
    char *names = z->names;
    uint64_t p = offset;
    for (uint64_t i = 0; i < count; i++) {
        if (read_entry(z, &p, offset + dir_size, &z->entries[i], &names)) {
            gv_zip_close(z);
            return -1;
        }
        z->n++;
    }
    if (sort_entries(z)) {
        gv_zip_close(z);
        return -1;
    }
    return 0;
}

void gv_zip_close(gv_zip *z)
{
    free(z->entries);
    free(z->names);
    memset(z, 0, sizeof *z);
}

/* zlib's crc32 takes uInt lengths: fed in pieces. */
static uint32_t crc_of(const uint8_t *p, uint64_t n)
{
    uLong crc = crc32(0L, Z_NULL, 0);
    while (n) {
        uInt piece = n > (1u << 30) ? (1u << 30) : (uInt)n;
        crc = crc32(crc, p, piece);
        p += piece, n -= piece;
    }
    return (uint32_t)crc;
}

static int inflate_entry(const gv_zip *z, const gv_zip_entry *e, uint8_t *out)
{
    z_stream s;
    memset(&s, 0, sizeof s);
    if (inflateInit2(&s, -MAX_WBITS) != Z_OK) return gv_fail("%s: entry '%s': zlib cannot start", z->path, e->name);
    const uint8_t *in = z->data + e->data_offset;
    uint64_t in_left = e->compressed_size, out_left = e->size;
    int rc = Z_OK;
    while (rc == Z_OK) {
        if (s.avail_in == 0 && in_left) {
            s.avail_in = in_left > (1u << 30) ? (1u << 30) : (uInt)in_left;
            s.next_in = (Bytef *)(uintptr_t)in;
            in += s.avail_in, in_left -= s.avail_in;
        }
        if (s.avail_out == 0 && out_left) {
            s.avail_out = out_left > (1u << 30) ? (1u << 30) : (uInt)out_left;
            s.next_out = out;
            out += s.avail_out, out_left -= s.avail_out;
        }
        rc = inflate(&s, Z_NO_FLUSH);
        if (rc == Z_BUF_ERROR && (s.avail_in || in_left) && (s.avail_out || out_left)) rc = Z_OK;
    }
    int whole = rc == Z_STREAM_END && s.avail_out == 0 && out_left == 0;
    inflateEnd(&s);
    if (!whole)
        return gv_fail("%s: entry '%s': the deflated data is corrupt or does not give its %" PRIu64 " bytes", z->path,
                       e->name, e->size);
    return 0;
}

int gv_zip_read(const gv_zip *z, const gv_zip_entry *e, uint64_t max_size, int check_crc, const uint8_t **bytes,
                void **owned)
{
    *bytes = NULL, *owned = NULL;
    if (e->size > max_size)
        return gv_fail("%s: entry '%s' has %" PRIu64 " bytes, more than the %" PRIu64 " expected", z->path, e->name, e->size,
                       max_size);
    if (e->method == 0) {
        if (e->compressed_size != e->size)
            return gv_fail("%s: stored entry '%s' has %" PRIu64 " bytes but says %" PRIu64, z->path, e->name,
                           e->compressed_size, e->size);
        if (check_crc && crc_of(z->data + e->data_offset, e->size) != e->crc32)
            return gv_fail("%s: entry '%s' does not match its CRC-32 (corrupt file?)", z->path, e->name);
        *bytes = z->data + e->data_offset;
        return 0;
    }
    if (e->method != 8) return gv_fail("%s: entry '%s' uses zip method %d (stored and deflated are read)", z->path, e->name, e->method);
    /* deflate expands at most about 1032:1, so a larger claim is a lie, refused before allocating */
    if (e->size / 1032 > e->compressed_size + 1)
        return gv_fail("%s: entry '%s' claims %" PRIu64 " bytes from %" PRIu64 " deflated ones", z->path, e->name, e->size,
                       e->compressed_size);
    uint8_t *out = malloc(e->size ? (size_t)e->size : 1);
    if (!out) return gv_fail("%s: out of memory for entry '%s' (%" PRIu64 " bytes)", z->path, e->name, e->size);
    if (inflate_entry(z, e, out) != 0) {
        free(out);
        return -1;
    }
    if (crc_of(out, e->size) != e->crc32) {
        free(out);
        return gv_fail("%s: entry '%s' does not match its CRC-32 (corrupt file?)", z->path, e->name);
    }
    *bytes = out, *owned = out;
    return 0;
}
