/* Test helper: builds files byte by byte (text, and integers and floats in either byte
 * order) so that the PLY tests write their inputs independently of the library's writers. */
#ifndef GAUSSVID_TESTS_PLY_BYTES_H
#define GAUSSVID_TESTS_PLY_BYTES_H

#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

typedef struct {
    unsigned char *data;
    size_t n, capacity;
    int big_endian;  /* byte order of the numbers appended next */
} bytes;

static void bytes_append(bytes *b, const void *p, size_t n)
{
    if (b->n + n > b->capacity) {
        b->capacity = (b->n + n) * 2 + 256;
        b->data = realloc(b->data, b->capacity);
        if (!b->data) { fprintf(stderr, "out of memory\n"); exit(1); }
    }
    memcpy(b->data + b->n, p, n);
    b->n += n;
}

static void put_text(bytes *b, const char *text)
{
    bytes_append(b, text, strlen(text));
}

/* An unsigned integer of `size` bytes in the current byte order. */
static void put_uint(bytes *b, uint64_t v, int size)
{
    unsigned char raw[8];
    for (int i = 0; i < size; i++) {
        unsigned char byte = (unsigned char)(v >> (8 * i));
        raw[b->big_endian ? size - 1 - i : i] = byte;
    }
    bytes_append(b, raw, (size_t)size);
}

static void put_f32(bytes *b, float v)
{
    uint32_t u;
    memcpy(&u, &v, 4);
    put_uint(b, u, 4);
}

static void put_f64(bytes *b, double v)
{
    uint64_t u;
    memcpy(&u, &v, 8);
    put_uint(b, u, 8);
}

static void bytes_save(const bytes *b, const char *path)
{
    FILE *f = fopen(path, "wb");
    if (!f || fwrite(b->data, 1, b->n, f) != b->n || fclose(f) != 0) {
        fprintf(stderr, "cannot write %s\n", path);
        exit(1);
    }
}

static void bytes_free(bytes *b)
{
    free(b->data);
    memset(b, 0, sizeof *b);
}

/* Reads a whole file for byte comparisons; *n gets its size. */
static unsigned char *slurp(const char *path, size_t *n)
{
    FILE *f = fopen(path, "rb");
    *n = 0;
    if (!f) return NULL;
    fseek(f, 0, SEEK_END);
    long size = ftell(f);
    rewind(f);
    unsigned char *data = malloc((size_t)size + 1);
    if (data && fread(data, 1, (size_t)size, f) == (size_t)size) *n = (size_t)size;
    fclose(f);
    return data;
}

#endif
