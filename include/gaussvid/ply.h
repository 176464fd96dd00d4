/* PLY files: the standard 3DGS Gaussian model (binary little-endian, the reference property
 * names and order, SH degree 0 to 3), the antimatter15 32-byte .splat export, and coloured
 * point clouds (x y z red green blue; ASCII or binary) such as points3D.ply. */
#ifndef GAUSSVID_PLY_H
#define GAUSSVID_PLY_H

#include <stdint.h>

#include "gaussvid/gaussians.h"

/* Reads a 3DGS model; properties are found by name, the SH degree from the f_rest count. */
int gv_gaussians_read_ply(const char *path, gv_gaussians *out);
/* Writes a 3DGS model (atomically); reading it back gives the same bytes. */
int gv_gaussians_write_ply(const char *path, const gv_gaussians *g);
/* Writes the 32-byte-per-splat format, sorted by descending volume x opacity. */
int gv_gaussians_write_splat(const char *path, const gv_gaussians *g);

/* Reads the vertices' x, y, z and (when present) red, green, blue; *rgb gets 128 grey when
 * the file has no colour. The arrays are malloc'ed. */
int gv_points_read_ply(const char *path, int *n, float **xyz, uint8_t **rgb);
/* Writes an ASCII point cloud: x y z (float) red green blue (uchar), atomically. */
int gv_points_write_ply(const char *path, int n, const float *xyz, const uint8_t *rgb);

#endif
