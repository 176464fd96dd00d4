/* Shared by the harnesses of weight files (fuzz_safetensors.c, fuzz_pth.c, fuzz_st_index.c):
 * an input split into the several files a format is made of, and the reads every loader
 * makes of an open file. */
#ifndef GAUSSVID_FUZZ_WEIGHTS_H
#define GAUSSVID_FUZZ_WEIGHTS_H

#include "fuzz.h"
#include "gaussvid/io/safetensors.h"

/* Inputs holding several files separate them with this (it is in the dictionaries). */
#define FUZZ_PIECE "#PIECE#"

typedef struct {
    const uint8_t *data;
    size_t size;
} fuzz_piece;

/* Splits data at each FUZZ_PIECE into at most max pieces (the last one keeps the rest,
 * separators included); returns the count (at least 1). */
static inline int fuzz_split(const uint8_t *data, size_t size, fuzz_piece *pieces, int max)
{
    const size_t sep = sizeof FUZZ_PIECE - 1;
    int n = 0;
    size_t start = 0;
    for (size_t k = 0; n < max - 1 && k + sep <= size; k++)
        if (!memcmp(data + k, FUZZ_PIECE, sep)) {
            pieces[n++] = (fuzz_piece){data + start, k - start};
            start = k + sep;
            k += sep - 1;
        }
    pieces[n++] = (fuzz_piece){data + start, size - start};
    return n;
}

/* What the loaders do with an open weight file: every tensor found by its name and read
 * with its own shape, into float32 when its dtype is a float one (F32, F16, BF16, F64: the
 * conversion of BF16 and F16 releases), else as raw bytes of its own dtype; every metadata
 * key found. A tensor the file presented must read (else abort: libFuzzer keeps the input);
 * a float read may only fail for a non-float dtype, with one line naming the file. */
static inline void fuzz_read_tensors(const gv_st_file *f, const char *needle)
{
    for (int i = 0; i < f->n_tensors; i++) {
        const gv_st_tensor *t = &f->tensors[i];
        if (gv_st_find(f, t->name) != t) abort(); /* every tensor found by its name */
        int64_t n = 1; /* its shape holds its elements */
        if (t->rank < 0 || t->rank > GV_ST_MAX_RANK) abort();
        for (int k = 0; k < t->rank; k++)
            if (t->shape[k] < 0 || __builtin_mul_overflow(n, t->shape[k], &n)) abort();
        if (n != t->n_elements) abort();
        if (t->end < t->begin || (uint64_t)t->n_elements * (uint64_t)gv_st_dtype_bits(t->dtype) / 8 >
                                     t->end - t->begin + 1)
            abort(); /* its bytes hold its elements */
        void *buffer = malloc((size_t)t->n_elements * 4 + (t->end - t->begin) + 1);
        if (!buffer) abort();
        gv_clear_error();
        int rc = gv_st_read_f32(f, t->name, buffer, t->shape, t->rank);
        if (rc) {
            fuzz_check_failure(rc, needle);
            if (gv_st_read_raw(f, t->name, t->dtype, t->shape, t->rank, buffer)) abort();
        }
        free(buffer);
    }
    for (int i = 0; i < f->n_metadata; i++)
        if (gv_st_metadata(f, f->metadata_keys[i]) == NULL) abort();
}

#endif
