/* A set of 3D Gaussians in structure-of-arrays form, with the raw (pre-activation)
 * parameters of the official 3DGS: positions, SH coefficients, opacity logits, log-scales
 * and unnormalised quaternions (w, x, y, z). */
#ifndef GAUSSVID_GAUSSIANS_H
#define GAUSSVID_GAUSSIANS_H

typedef struct {
    int n;            /* number of Gaussians */
    int capacity;     /* allocated rows */
    int sh_degree;    /* 0..3; K = (sh_degree + 1)^2 coefficients per colour channel */
    float *means;     /* n * 3 */
    float *sh;        /* n * K * 3, [gaussian][coefficient k][channel c] (3DGS in-memory order) */
    float *opacities; /* n, logit */
    float *scales;    /* n * 3, natural log of the standard deviations */
    float *rotations; /* n * 4, quaternion (w, x, y, z), not necessarily normalised */
} gv_gaussians;

/* Number of SH coefficients per channel for a degree: (d + 1)^2. */
int gv_sh_coefficient_count(int degree);
/* Allocates n zeroed Gaussians of the given SH degree. */
int gv_gaussians_alloc(gv_gaussians *g, int n, int sh_degree);
/* Grows the capacity to at least `capacity`, keeping the contents. */
int gv_gaussians_reserve(gv_gaussians *g, int capacity);
/* Copies every attribute of row src to row dst (rows of the same set, dst != src). */
void gv_gaussians_copy_row(gv_gaussians *g, int dst, int src);
/* Zeroes every attribute of rows [from, to). */
void gv_gaussians_zero_rows(gv_gaussians *g, int from, int to);
/* Frees the arrays and zeroes the struct. */
void gv_gaussians_free(gv_gaussians *g);
/* Fails naming `what` and the first Gaussian with a NaN or infinite parameter. */
int gv_gaussians_check_finite(const gv_gaussians *g, const char *what);

#endif
