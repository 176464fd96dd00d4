/* NumPy .npy files of float32 arrays (the NPY format, version 1.0 written, 1.0-3.0 read):
 * the 6-byte magic "\x93NUMPY", the version, a little-endian header length, an ASCII
 * Python dict {'descr': '<f4', 'fortran_order': False, 'shape': (...), } padded with spaces
 * to a multiple of 64 bytes and ended by a newline, then the values in C order. numpy.load
 * reads what gv_npy_write_f32 writes, and gv_npy_read_f32 reads what numpy.save writes for a
 * float32 array. Per-pixel maps (depth, opacity) use it (docs/SPLAT_TRAINING.md). */
#ifndef GAUSSVID_NPY_H
#define GAUSSVID_NPY_H

#include <stdint.h>

#define GV_NPY_MAX_RANK 4

/* Writes data (shape[0] x ... x shape[rank-1] floats, C order) under a temporary name
 * renamed into place. rank is 1..GV_NPY_MAX_RANK; every extent must be positive. */
int gv_npy_write_f32(const char *path, int rank, const int64_t *shape, const float *data);
/* Reads a little-endian float32 array in C order; *data (malloc'ed, free it) holds the
 * values. Anything else (another dtype, Fortran order, a malformed header, a size that does
 * not match the shape) fails with one line naming the file. */
int gv_npy_read_f32(const char *path, int *rank, int64_t shape[GV_NPY_MAX_RANK], float **data);

#endif
