/* Rendering a set of Gaussians from a camera, and the gradients of a loss on the image with
 * respect to every raw parameter: the calls the trainer makes (docs/SPLAT.md). The
 * renderer keeps the buffers of the last forward for the backward and reuses them. */
#ifndef GAUSSVID_RENDER_H
#define GAUSSVID_RENDER_H

#include <stdint.h>

#include "gaussvid/io/gaussians.h"
#include "gaussvid/splat/splat.h"

/* The stages of a render and its backward, in the order they run. */
enum {
    GV_STAGE_PROJECT,      /* 3D -> 2D Gaussians, culling */
    GV_STAGE_BIN,          /* visible list, depth sort, tile lists */
    GV_STAGE_SH,           /* colours of the visible Gaussians */
    GV_STAGE_OPACITY,      /* sigmoid of the visible opacities */
    GV_STAGE_RASTER,       /* rasteriser forward */
    GV_STAGE_RASTER_BWD,   /* rasteriser backward, per-Gaussian sums */
    GV_STAGE_GRADS,        /* opacity gradient through the sigmoid, densify statistic */
    GV_STAGE_PROJECT_BWD,  /* projection backward */
    GV_STAGE_SH_BWD,       /* SH backward */
    GV_STAGES
};
extern const char *const gv_stage_names[GV_STAGES];

typedef struct {
    /* of the last forward */
    int n, sh_degree, active_degree;
    gv_splat_view view;
    float bg[3];
    const float *opacity_scale; /* the last forward's (borrowed; NULL: none) */
    /* per Gaussian (capacity rows): projected and activated */
    float *means2d, *conics, *depths, *colors, *opacities;
    int *radii;             /* pixels, 0 = not visible in this view */
    uint8_t *clamped;       /* colour channels clamped at 0 */
    float *d_means2d, *d_conics, *d_colors, *d_opacities;
    int capacity;
    /* the depth backward's per-Gaussian gradients (gv_splat_render_backward_depth): d means2d
     * (2), d conic (3), d opacity, d z per row, depth_capacity rows; allocated when first used */
    float *depth_grads;
    int depth_capacity;
    /* visible Gaussians (radius > 0): tiles.visible[0 .. tiles.n_visible), ascending */
    gv_splat_tiles tiles;
    /* per pixel */
    float *final_T;         /* transmittance left after the last Gaussian (1 - alpha) */
    int *n_contrib;
    int pixel_capacity;
    /* wall and process CPU seconds of each stage, summed over every call since r was
     * zeroed (`gaussvid bench raster` reads them; the clocks cost about a microsecond) */
    double stage_seconds[GV_STAGES], stage_cpu_seconds[GV_STAGES];
} gv_splat_renderer;

/* Renders g (SH up to active_degree) from view over background bg into image (float HWC,
 * width * height * 3). r starts zeroed ({0}) and is reused across calls. Fails on an SH
 * degree out of range or when memory runs out. */
int gv_splat_render_forward(gv_splat_renderer *r, const gv_gaussians *g,
                            const gv_splat_view *view, int active_degree, const float bg[3],
                            float *image);
/* The same with the opacity of Gaussian i multiplied by opacity_scale[i] (g->n values, kept
 * by the caller until the backward; NULL is gv_splat_render_forward): 0 leaves the Gaussian
 * out of the render (not visible: no gradient, no densification statistic), a scale above 1
 * may take the opacity above 1 (alpha is still clamped at 0.99). DropGaussian's training
 * renders (src/splat/dropgaussian.c). */
int gv_splat_render_forward_scaled(gv_splat_renderer *r, const gv_gaussians *g,
                                   const gv_splat_view *view, int active_degree,
                                   const float bg[3], const float *opacity_scale, float *image);
/* From d_image = dL/dimage (HWC) of the last forward of the same g, writes grad (same SH
 * degree, capacity >= g->n) for the visible Gaussians only: dL/d means, sh (zero above the
 * active degree), opacity logits (through the last forward's opacity scale), log-scales and
 * raw quaternions; rows of Gaussians not visible are left untouched. densify_grad (may be NULL) receives, for the visible
 * Gaussians, the 3DGS densification statistic of this view: the norm of dL/d means2d in
 * NDC units, |(dL/dx * W/2, dL/dy * H/2)| (docs/reference/gaussian-splatting.md section 14.1). */
int gv_splat_render_backward(gv_splat_renderer *r, const gv_gaussians *g,
                             const float *d_image, gv_gaussians *grad, float *densify_grad);
/* gv_splat_render_backward for a loss on the image and on the accumulated depth
 * sum_i w_i z_i of the last forward (gv_splat_render_depth_sum): d_depth_sum (width * height,
 * NULL: none) is dL/d that per pixel. Its gradient reaches the opacities, the 2D means and
 * conics (so also the densification statistic) and each Gaussian's view z, which moves its
 * mean along the camera's third axis (src/splat/rasterize_depth_backward.c). */
int gv_splat_render_backward_depth(gv_splat_renderer *r, const gv_gaussians *g,
                                   const float *d_image, const float *d_depth_sum,
                                   gv_gaussians *grad, float *densify_grad);
/* Expected depth (view z, 0 where nothing blends) and accumulated opacity 1 - T_final of
 * the last forward, per pixel (width * height floats each; either may be NULL): the pass
 * of gv_splat_rasterize_depth (src/splat/rasterize_depth.c). Fails before any forward. */
int gv_splat_render_depth(const gv_splat_renderer *r, float *depth, float *opacity);
/* The accumulated depth sum_i w_i z_i of the last forward per pixel (width * height floats:
 * the expected depth times the opacity, 0 where nothing blends), the depth Binocular3DGS's
 * release renders and differentiates. Fails before any forward. */
int gv_splat_render_depth_sum(const gv_splat_renderer *r, float *depth_sum);
void gv_splat_renderer_free(gv_splat_renderer *r);

#endif
