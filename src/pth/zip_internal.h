/* A reader of zip archives held in memory (a mapped file), for PyTorch checkpoints: the
 * central directory (with ZIP64 for archives and entries past 4 GiB), entries looked up by
 * name, stored entries read in place and deflated ones inflated with zlib. Every offset and
 * size is checked against the archive before use. Internal to src/io (and its tests). */
#ifndef GAUSSVID_IO_ZIP_INTERNAL_H
#define GAUSSVID_IO_ZIP_INTERNAL_H

#include <stdint.h>

typedef struct {
    const char *name;        /* NUL-terminated copy */
    int method;              /* 0 stored, 8 deflated (others are refused when read) */
    uint32_t crc32;
    uint64_t compressed_size, size;
    uint64_t data_offset;    /* of the entry's bytes in the archive, after its local header */
} gv_zip_entry;

typedef struct {
    const char *path;        /* for messages */
    const uint8_t *data;
    uint64_t size;
    int n;
    gv_zip_entry *entries;   /* sorted by name */
    char *names;
} gv_zip;

/* Reads the directory of the archive at data (size bytes); path names it in messages. */
int gv_zip_open(gv_zip *z, const char *path, const uint8_t *data, uint64_t size);
void gv_zip_close(gv_zip *z);
/* The entry of that name, or NULL. */
const gv_zip_entry *gv_zip_find(const gv_zip *z, const char *name);
/* The bytes of an entry: stored ones in place (*owned = NULL), deflated ones inflated into a
 * new buffer (*owned = it, to be freed) of at most max_size bytes, checked against the CRC.
 * check_crc also checks a stored entry's CRC (reading it all). */
int gv_zip_read(const gv_zip *z, const gv_zip_entry *e, uint64_t max_size, int check_crc, const uint8_t **bytes,
                void **owned);

#endif
