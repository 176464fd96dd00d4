/* The 3D Gaussian Splatting rendering kernels on the CPU (docs/reference/gaussian-splatting.md
 * sections 2-10; docs/SPLAT.md): projection, SH colour, tile binning and rasterisation, each with
 * its forward and backward, and a plain double-precision reference renderer for the tests.
 *
 * Conventions. Camera axes OpenCV (x right, y down, z forward), world-to-camera R, t.
 * Pixel coordinates are continuous: pixel (i, j) has its centre at (i + 0.5, j + 0.5) and a
 * camera-space point projects to (fx x/z + cx, fy y/z + cy) with the camera's real
 * principal point (as gsplat; 3DGS always uses the image centre, which is the special case
 * cx = W/2, cy = H/2). Images are float HWC, 3 channels. Per-Gaussian arrays are
 * structure-of-arrays indexed by Gaussian: means2d n*2, conics n*3 (A, B, C of the inverse
 * 2D covariance [[A, B], [B, C]]), colors n*3, opacities n (activated), depths n, radii n
 * (pixels; 0 = culled). Backward functions write the rows of the Gaussians they are given
 * (the visible ones) and leave every other row untouched. */
#ifndef GAUSSVID_SPLAT_H
#define GAUSSVID_SPLAT_H

#include <stdint.h>

#include "gaussvid/scene/scene.h"

/* Reference constants ([RAST] config.h, forward.cu, auxiliary.h). */
#define GV_SPLAT_TILE 16                    /* BLOCK_X = BLOCK_Y */
#define GV_SPLAT_NEAR 0.2f                  /* view-space z <= 0.2 is culled (in_frustum) */
#define GV_SPLAT_DILATION 0.3f              /* low-pass added to the 2D covariance diagonal */
#define GV_SPLAT_ALPHA_MAX 0.99f            /* alpha clamp */
#define GV_SPLAT_ALPHA_MIN (1.0f / 255.0f)  /* alpha below this is skipped */
#define GV_SPLAT_T_MIN 0.0001f              /* stop a pixel when T (1 - alpha) < this */
#define GV_SPLAT_CLAMP_FOV 1.3f             /* Jacobian clamp at 1.3 x the half field of view */
#define GV_SPLAT_MAX_RADIUS (1 << 20)       /* radii are capped here (far above any image) */

/* A camera as the kernels use it. */
typedef struct {
    int width, height;
    float fx, fy, cx, cy;     /* pixels, continuous coordinates */
    float R[9], t[3];         /* world-to-camera, row-major */
    float campos[3];          /* camera centre in world coordinates, -R^T t */
    /* Jacobian clamp of x/z and y/z (section 5): -lim_x_neg <= x/z <= lim_x_pos; each
     * equals 1.3 tan(fov_x / 2) when the principal point is centred (gsplat's form). */
    float lim_x_neg, lim_x_pos, lim_y_neg, lim_y_pos;
} gv_splat_view;

/* Fills a view from intrinsics and a world-to-camera pose; fails on a non-positive size or
 * focal length or a non-finite value. */
int gv_splat_view_init(gv_splat_view *v, int width, int height, double fx, double fy,
                       double cx, double cy, const double R[9], const double t[3]);
/* The same from a scene camera. */
int gv_splat_view_from_camera(gv_splat_view *v, const gv_camera *cam);

/* ---- view.c, projection_forward.c, projection_backward.c ---------------------------------
 * Per Gaussian: s = exp(log-scale), q = normalised quaternion, Sigma = R(q) S S R(q)^T;
 * view transform; near cull; EWA 2D covariance J W Sigma W^T J^T with the Jacobian clamp and
 * the 0.3 dilation; conic; 3-sigma radius (3DGS formula); means2d; depth; tile rectangle
 * (an empty rectangle culls, radius 0). Parallel over Gaussians. */
void gv_splat_project_forward(int n, const float *means, const float *scales,
                              const float *rotations, const gv_splat_view *view,
                              float *means2d, float *conics, float *depths, int *radii);
/* Gradients of the listed Gaussians from d_means2d (pixels) and d_conics (dL/dA, dL/dB,
 * dL/dC, B being the single off-diagonal value of the conic): WRITES d_means (the
 * projection part only), d_scales (w.r.t. log-scales) and d_rotations (w.r.t. the raw
 * quaternion). The clamped Jacobian is treated as 3DGS does (section 10.3). */
void gv_splat_project_backward(int n_list, const int *list, const float *means,
                               const float *scales, const float *rotations,
                               const gv_splat_view *view, const float *d_means2d,
                               const float *d_conics, float *d_means, float *d_scales,
                               float *d_rotations);

/* ---- sh.c ------------------------------------------------------------------------------
 * colour = sum_k Y_k(d) sh[k] + 0.5, clamped at 0 (section 8), d = normalised mean - campos.
 * sh rows hold (sh_degree + 1)^2 coefficients x 3 channels; only the first
 * (active_degree + 1)^2 are used. clamped[i] has bit c set when channel c was clamped. */
void gv_splat_sh_forward(int n_list, const int *list, int sh_degree, int active_degree,
                         const float *sh, const float *means, const float campos[3],
                         float *colors, uint8_t *clamped);
/* WRITES d_sh (whole rows; zero above the active degree) and ADDS the view-direction part
 * to d_means, from d_colors; clamped channels pass no gradient. */
void gv_splat_sh_backward(int n_list, const int *list, int sh_degree, int active_degree,
                          const float *sh, const float *means, const float campos[3],
                          const uint8_t *clamped, const float *d_colors, float *d_sh,
                          float *d_means);
/* The 16 real SH basis values of degree <= 3 at unit direction (x, y, z) (section 8). */
void gv_splat_sh_basis(float x, float y, float z, float basis[16]);

/* ---- binning.c -------------------------------------------------------------------------
 * 16x16 tiles. Every visible Gaussian (radius > 0) is listed in each tile of its
 * rectangle; each tile's list is sorted front to back by (depth, index), as the reference's
 * stable radix sort of (tile, depth) keys orders it. */
typedef struct {
    int tiles_x, tiles_y;   /* ceil(W / 16), ceil(H / 16) */
    int n_visible;          /* Gaussians with radius > 0 */
    int *visible;           /* their indices, ascending */
    int *depth_order;       /* the same indices sorted by (depth, index): rank -> Gaussian */
    int n_entries;          /* (tile, Gaussian) pairs */
    int *tile_offsets;      /* tiles_x * tiles_y + 1: tile t owns entries [off[t], off[t+1]) */
    int *entries;           /* depth rank of each entry's Gaussian (increasing in a tile) */
    /* Entries of the Gaussian of rank k: entry_of[gauss_offsets[k] .. gauss_offsets[k+1]),
     * used to sum per-entry gradients per Gaussian in a fixed order. */
    int *gauss_offsets;     /* n_visible + 1 */
    int *entry_of;          /* n_entries */
    int *rects;             /* 4 per rank: the tile rectangle */
    float *splats;          /* rasteriser scratch: 12 floats per rank */
    float *entry_grads;     /* rasteriser scratch: 9 floats per entry */
    uint32_t *sort_keys;    /* depth sort scratch, 2 per Gaussian */
    int *sort_tmp;
    int *tile_counts;       /* per thread and tile: scratch of the parallel dealing */
    int *thread_counts;     /* per thread, 256: scratch of the parallel listing and sort */
    int cap_gaussians, cap_entries, cap_tiles, cap_counts, cap_thread_counts; /* capacities */
} gv_splat_tiles;

/* Tile rectangle [rect[0], rect[2]) x [rect[1], rect[3]) of a Gaussian (getRect, with the
 * mean shifted by -0.5 to the reference's pixel-index coordinates). */
void gv_splat_tile_rect(float mean_x, float mean_y, int radius, int tiles_x, int tiles_y,
                        int rect[4]);
/* Builds the lists for an image of width x height from the projection's outputs (the
 * depths of visible Gaussians are positive: view z > 0.2). Fails only when memory runs
 * out. The lists do not depend on the number of threads. */
int gv_splat_tiles_build(gv_splat_tiles *t, int n, int width, int height,
                         const float *means2d, const int *radii, const float *depths);
void gv_splat_tiles_free(gv_splat_tiles *t);

/* ---- rasterize.c -----------------------------------------------------------------------
 * Front-to-back alpha blending per tile (section 9): alpha = min(0.99, o exp(power)),
 * skipped below 1/255, pixel stopped when T (1 - alpha) < 1e-4; image = sum c alpha T +
 * T_final bg. Also final_T and n_contrib (1 + position in the tile list of the last
 * Gaussian blended, 0 for none) per pixel. Parallel over tiles. */
void gv_splat_rasterize_forward(const gv_splat_tiles *t, int width, int height,
                                const float *means2d, const float *conics,
                                const float *colors, const float *opacities,
                                const float bg[3], float *image, float *final_T,
                                int *n_contrib);
/* Back to front per pixel, mirroring the forward (section 10.1; the alpha clamp is ignored
 * in the gradient as in 3DGS), from dL/dimage. Must follow the forward on the same tiles:
 * it reads the forward's per-tile copy of the Gaussians' 2D data, final_T and n_contrib.
 * WRITES, for the visible Gaussians, d_means2d (pixels), d_conics (full derivative w.r.t.
 * A, B, C), d_colors and d_opacities (activated). Uses t->entry_grads; the sums over pixels
 * are in a fixed order whatever the thread count. */
void gv_splat_rasterize_backward(gv_splat_tiles *t, int width, int height, const float bg[3],
                                 const float *final_T, const int *n_contrib,
                                 const float *d_image, float *d_means2d, float *d_conics,
                                 float *d_colors, float *d_opacities);

/* ---- rasterize_depth.c -----------------------------------------------------------------
 * Per pixel, over the tiles of a forward with the same 2D data: the expected view-space
 * depth sum_i w_i z_i / sum_i w_i (w_i = alpha_i T_i, the colour's weights; 0 where nothing
 * blends) into depth, the accumulated opacity 1 - T_final into opacity, and the accumulated
 * depth sum_i w_i z_i into depth_sum (any of the three may be NULL). The same Gaussians blend
 * as in gv_splat_rasterize_forward, and 1 - opacity is its final_T exactly. Parallel over
 * tiles. */
void gv_splat_rasterize_depth(const gv_splat_tiles *t, int width, int height,
                              const float *means2d, const float *conics,
                              const float *opacities, const float *depths, float *depth,
                              float *opacity, float *depth_sum);

/* ---- rasterize_depth_backward.c --------------------------------------------------------
 * The backward of depth_sum (sum_i w_i z_i), back to front per pixel, from dL/d depth_sum:
 * must follow gv_splat_rasterize_forward on the same tiles and 2D data (it reads its final_T
 * and n_contrib; the alpha clamp is ignored in the gradient, as in 3DGS). WRITES, for the
 * visible Gaussians, d_means2d (pixels), d_conics (w.r.t. A, B, C), d_opacities (activated)
 * and d_depths (view z). Uses t->entry_grads; the same result for any thread count. */
void gv_splat_rasterize_depth_backward(gv_splat_tiles *t, int width, int height,
                                       const float *means2d, const float *conics,
                                       const float *opacities, const float *depths,
                                       const float *final_T, const int *n_contrib,
                                       const float *d_depth_sum, float *d_means2d,
                                       float *d_conics, float *d_opacities, float *d_depths);

/* ---- reference.c -----------------------------------------------------------------------
 * Plain double-precision implementation of the same formulas, written independently of the
 * kernels above, for the tests: no tiles, every pixel loops over every Gaussian. The
 * signature hashes every discrete decision (culling, radii, Jacobian and colour clamps,
 * which Gaussians blend into which pixel, alpha clamps), so that a finite difference can
 * tell when it stepped across a discontinuity. */
typedef struct {
    double mean2d[2], conic[3], depth;
    int radius;             /* 0 when culled */
    int clamp_x, clamp_y;   /* Jacobian clamp active */
} gv_splat_ref_projection;

/* Projects one Gaussian (raw parameters); returns 1 when visible, 0 when culled. */
int gv_splat_reference_project(const double mean[3], const double log_scale[3],
                               const double quat[4], const gv_splat_view *view,
                               gv_splat_ref_projection *out);
/* SH colour of one Gaussian; returns the clamp bits (bit c for channel c). */
int gv_splat_reference_sh(int sh_degree, int active_degree, const double *sh,
                          const double mean[3], const double campos[3], double rgb[3]);
/* Rasterises projected Gaussians: for every pixel, every Gaussian whose tile rectangle
 * holds the pixel's tile, in (depth, index) order. image is HWC width*height*3. */
int gv_splat_reference_rasterize(int n, int width, int height, const double *means2d,
                                 const double *conics, const double *colors,
                                 const double *opacities, const double *depths,
                                 const int *radii, const double bg[3], double *image,
                                 uint64_t *signature);
/* Renders raw parameters (layout of gv_gaussians, in double) through the three stages. */
int gv_splat_reference_render(int n, int sh_degree, int active_degree, const double *means,
                              const double *sh, const double *opacities,
                              const double *scales, const double *rotations,
                              const gv_splat_view *view, const double bg[3], double *image,
                              uint64_t *signature);

#endif
