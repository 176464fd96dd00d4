/* 3D consistency of a sequence of frames (include/gaussvid/eval/consistency.h): each frame warped
 * into its neighbours by the model's depth (gv_reproject_anchor, the warp the anchor coverage
 * uses) and scored against them on the pixels the warp covers. */
#include <math.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

#include "gaussvid/eval/consistency.h"
#include "gaussvid/core/core.h"
#include "gaussvid/scene/reproject.h"

static double capped_psnr(double mse)
{
    if (!(mse > 0)) return GV_CONSISTENCY_PSNR_CAP; /* identical on every covered value */
    double psnr = -10.0 * log10(mse);
    return psnr < GV_CONSISTENCY_PSNR_CAP ? psnr : GV_CONSISTENCY_PSNR_CAP;
}

int gv_consistency_pair_measure(const gv_camera *from, const float *from_rgb, const float *from_depth,
                                const gv_camera *to, const float *to_rgb, const float *to_depth,
                                double rel_tolerance, gv_consistency_pair *out)
{
    memset(out, 0, sizeof *out);
    out->to = 1;
    size_t pixels = (size_t)(to->width > 0 ? to->width : 0) * (size_t)(to->height > 0 ? to->height : 0);
    float *warped = malloc((pixels ? pixels : 1) * 3 * sizeof *warped);
    uint8_t *covered = malloc(pixels ? pixels : 1);
    int rc = warped && covered ? 0 : gv_fail("consistency: out of memory for a %dx%d view", to->width, to->height);
    if (rc == 0)
        rc = gv_reproject_anchor(to, to_depth, from, from_depth, from_rgb, rel_tolerance, warped, covered);
    double sse = 0;
    long n = 0;
    for (size_t p = 0; rc == 0 && p < pixels; p++) {
        if (!covered[p]) continue;
        n++;
        for (int c = 0; c < 3; c++) {
            double d = (double)warped[3 * p + c] - (double)to_rgb[3 * p + c];
            sse += d * d;
        }
    }
    free(warped), free(covered);
    if (rc) return -1;
    out->pixels = n;
    out->coverage = pixels ? (double)n / (double)pixels : 0;
    out->mse = n ? sse / (3.0 * (double)n) : NAN;
    out->psnr = n ? capped_psnr(out->mse) : NAN;
    return 0;
}

/* One frame of the sliding window: its colours (v / 255) and the model's depth there. */
typedef struct {
    float *rgb, *depth;
} loaded_frame;

static void unload(loaded_frame *f)
{
    free(f->rgb), free(f->depth);
    f->rgb = f->depth = NULL;
}

static int load_frame(gv_splat_renderer *r, const gv_gaussians *g, const gv_camera *cam, const char *path,
                      const gv_coverage_options *opt, loaded_frame *f)
{
    gv_image img = {0};
    if (gv_image_read_rgb(path, &img)) return -1;
    int rc = 0;
    if (img.width != cam->width || img.height != cam->height)
        rc = gv_fail("%s is %dx%d but its camera %s is %dx%d", path, img.width, img.height, cam->name, cam->width,
                     cam->height);
    size_t pixels = (size_t)img.width * img.height;
    if (rc == 0) {
        f->rgb = malloc(pixels * 3 * sizeof *f->rgb), f->depth = malloc(pixels * sizeof *f->depth);
        if (!f->rgb || !f->depth) rc = gv_fail("%s: out of memory for a %dx%d frame", path, img.width, img.height);
    }
    if (rc == 0) {
        gv_image_to_float(&img, f->rgb);
        if (gv_coverage_depth(r, g, cam, opt, f->depth)) rc = gv_fail_context("%s", path);
    }
    gv_image_free(&img);
    if (rc) unload(f);
    return rc;
}

static void summarise(gv_consistency *c)
{
    double psnr = 0, coverage = 0;
    c->scored = 0;
    for (int k = 0; k < c->n_pairs; k++) {
        coverage += c->pairs[k].coverage;
        if (c->pairs[k].pixels > 0) psnr += c->pairs[k].psnr, c->scored++;
    }
    c->mean_psnr = c->scored ? psnr / c->scored : NAN;
    c->mean_coverage = c->n_pairs ? coverage / c->n_pairs : NAN;
}

int gv_consistency_measure(const gv_gaussians *g, const gv_camera *cameras, const char *const *paths, int n,
                           const gv_coverage_options *opt, gv_consistency *out)
{
    memset(out, 0, sizeof *out);
    if (n < 2) return gv_fail("consistency: %d frame%s: a frame needs a neighbour to be compared with", n, n == 1 ? "" : "s");
    gv_coverage_options defaults;
    if (!opt) gv_coverage_options_default(&defaults), opt = &defaults;
    out->n_frames = n, out->n_pairs = 2 * (n - 1);
    out->pairs = calloc((size_t)out->n_pairs, sizeof *out->pairs);
    if (!out->pairs) return gv_fail("consistency: out of memory for %d frames", n);
    gv_splat_renderer r;
    memset(&r, 0, sizeof r);
    loaded_frame window[2] = {{0}};
    int rc = load_frame(&r, g, &cameras[0], paths[0], opt, &window[0]);
    for (int k = 0; k + 1 < n && rc == 0; k++) {
        loaded_frame *a = &window[k % 2], *b = &window[(k + 1) % 2];
        const gv_camera *ca = &cameras[k], *cb = &cameras[k + 1];
        gv_consistency_pair *p = &out->pairs[2 * k];
        rc = load_frame(&r, g, cb, paths[k + 1], opt, b) ||
             gv_consistency_pair_measure(ca, a->rgb, a->depth, cb, b->rgb, b->depth, opt->rel_tolerance, &p[0]) ||
             gv_consistency_pair_measure(cb, b->rgb, b->depth, ca, a->rgb, a->depth, opt->rel_tolerance, &p[1]);
        p[0].from = k, p[0].to = k + 1;
        p[1].from = k + 1, p[1].to = k;
        unload(a); /* frame k is done with */
    }
    unload(&window[0]), unload(&window[1]);
    gv_splat_renderer_free(&r);
    if (rc) {
        gv_consistency_free(out);
        return -1;
    }
    summarise(out);
    return 0;
}

void gv_consistency_free(gv_consistency *c)
{
    free(c->pairs);
    memset(c, 0, sizeof *c);
}
