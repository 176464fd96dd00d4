/* PLY files: the standard 3DGS Gaussian model (binary little-endian, the reference property
 * names and order, SH degree 0 to 3), the antimatter15 32-byte .splat export, and coloured
 * point clouds (x y z red green blue; ASCII or binary) such as points3D.ply. */
#ifndef GAUSSVID_PLY_H
#define GAUSSVID_PLY_H

#include <stdint.h>

#include "gaussvid/io/gaussians.h"

/* Reads a 3DGS model; properties are found by name, the SH degree from the f_rest count
 * (0/9/24/45); other properties are ignored; NaN or infinite values are refused. */
int gv_gaussians_read_ply(const char *path, gv_gaussians *out);
/* Writes a 3DGS model (atomically); reading it back gives the same bytes. Refuses NaN. */
int gv_gaussians_write_ply(const char *path, const gv_gaussians *g);
/* Writes the 32-byte-per-splat format (atomically), sorted by descending volume x opacity;
 * only the DC colour is kept (docs/PLY.md). */
int gv_gaussians_write_splat(const char *path, const gv_gaussians *g);

/* Reads the vertices' x, y, z and (when present) red, green, blue; *rgb gets 128 grey when
 * the file has no colour. The arrays are malloc'ed. ASCII or binary; float colours are
 * taken as 0..1. Other properties are ignored; NaN or infinite coordinates are refused. */
int gv_points_read_ply(const char *path, int *n, float **xyz, uint8_t **rgb);
/* Writes an ASCII point cloud: x y z (float) red green blue (uchar), atomically; rgb NULL
 * writes x y z only. Floats are written with the fewest digits that read back exactly. */
int gv_points_write_ply(const char *path, int n, const float *xyz, const uint8_t *rgb);

#endif
