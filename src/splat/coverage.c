/* The error decomposition of a sparse 3DGS model by anchor coverage (include/gaussvid/
 * coverage.h): each held-out frame is rendered with its depth, its two neighbouring training
 * views are warped into it by that depth (occlusion-tested against their own rendered depth),
 * and squared errors are summed per set of pixels. */
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "gaussvid/core/core.h"
#include "gaussvid/splat/coverage.h"
#include "gaussvid/scene/reproject.h"
#include "gaussvid/splat/splat_train.h"

void gv_coverage_options_default(gv_coverage_options *o)
{
    o->rel_tolerance = GV_COVERAGE_TOLERANCE;
    o->min_opacity = GV_COVERAGE_MIN_OPACITY;
    o->bg[0] = o->bg[1] = o->bg[2] = 0;
}

int gv_coverage_frames(const gv_scene *scene, int interval, int *frames)
{
    if (interval < 2) return gv_fail("%s: interval %d leaves no held-out frame between two training frames", scene->dir, interval);
    int n = 0;
    for (int i = 0; i < scene->n_frames; i++)
        if (i % interval != 0 && (i / interval + 1) * interval < scene->n_frames) frames[n++] = i;
    if (n == 0)
        return gv_fail("%s: %d frames at interval %d leave no held-out frame between two "
                       "training frames (need at least %d frames)", scene->dir, scene->n_frames,
                       interval, interval + 1);
    return n;
}

/* A rendered view: the 8-bit render as floats (v / 255), and the depth where the
 * accumulated opacity reaches min_opacity (0 elsewhere). */
static int render_view(gv_splat_renderer *r, const gv_gaussians *g, const gv_camera *cam,
                       const gv_coverage_options *opt, float *rgb, float *depth, float *opacity)
{
    gv_image img = {0};
    int ok = gv_splat_render_camera(r, g, cam, opt->bg, &img);
    if (ok == 0) gv_image_to_float(&img, rgb);
    gv_image_free(&img);
    if (ok == 0) ok = gv_splat_render_depth(r, depth, opacity);
    if (ok != 0) return -1;
    size_t pixels = (size_t)cam->width * cam->height;
    for (size_t p = 0; p < pixels; p++)
        if (!(opacity[p] >= opt->min_opacity)) depth[p] = 0;
    return 0;
}

static int load_rgb(const gv_scene *scene, int frame, float *rgb)
{
    gv_image img = {0};
    if (gv_scene_load_image(scene, frame, &img) != 0) return -1;
    gv_image_to_float(&img, rgb);
    gv_image_free(&img);
    return 0;
}

/* A training view as an anchor: its clean image and its rendered depth. */
typedef struct {
    float *rgb, *depth;
} anchor_view;

static int get_anchor(anchor_view *cache, int frame, gv_splat_renderer *r,
                      const gv_gaussians *g, const gv_scene *scene,
                      const gv_coverage_options *opt, float *scratch_rgb, float *scratch_op)
{
    anchor_view *a = &cache[frame];
    if (a->rgb) return 0;
    const gv_camera *cam = &scene->cameras[frame];
    size_t pixels = (size_t)cam->width * cam->height;
    a->rgb = malloc(pixels * 3 * sizeof(float));
    a->depth = malloc(pixels * sizeof(float));
    if (!a->rgb || !a->depth) return gv_fail("coverage: out of memory for anchor %s", cam->name);
    if (render_view(r, g, cam, opt, scratch_rgb, a->depth, scratch_op) != 0) return -1;
    return load_rgb(scene, frame, a->rgb);
}

static float quantise8(float x)
{
    float v = x * 255.0f + 0.5f;
    v = v > 0 ? (v < 255 ? v : 255) : 0;
    return (float)(int)v / 255.0f;
}

static double psnr_of(double sse, long values)
{
    return values > 0 ? -10.0 * log10(sse / (double)values) : NAN;
}

static double squared_error(const float *a, const float *b)
{
    double e = 0;
    for (int c = 0; c < 3; c++) e += ((double)a[c] - b[c]) * ((double)a[c] - b[c]);
    return e;
}

/* Per-pixel sums of one frame, from the render, the truth and the two warps. */
static void score_frame(gv_coverage_frame *out, long pixels, const float *render,
                        const float *truth, float *const warp[2], uint8_t *const covered[2])
{
    double sse_all = 0, sse_cov = 0, sse_unc = 0, sse_oracle = 0, sse_blend = 0;
    double sse_warp[2] = {0, 0}, sse_on[2] = {0, 0};
    long n_cov = 0, n_on[2] = {0, 0};
    for (long p = 0; p < pixels; p++) {
        const float *t = truth + 3 * p;
        double e = squared_error(render + 3 * p, t), best = e;
        float blend[3] = {render[3 * p], render[3 * p + 1], render[3 * p + 2]};
        int any = 0;
        for (int k = 0; k < 2; k++) {
            if (!covered[k][p]) continue;
            float *w = warp[k] + 3 * p;
            for (int c = 0; c < 3; c++) w[c] = quantise8(w[c]), blend[c] += w[c];
            double ek = squared_error(w, t);
            sse_warp[k] += ek, sse_on[k] += e, n_on[k]++;
            if (ek < best) best = ek;
            any++;
        }
        for (int c = 0; c < 3; c++) blend[c] = quantise8(blend[c] / (float)(1 + any));
        sse_all += e, sse_oracle += best, sse_blend += squared_error(blend, t);
        if (any) sse_cov += e, n_cov++;
        else sse_unc += e;
    }
    out->pixels = (int)pixels;
    out->covered = (double)n_cov / pixels;
    out->psnr_render = psnr_of(sse_all, 3 * pixels);
    out->psnr_oracle = psnr_of(sse_oracle, 3 * pixels);
    out->psnr_blend = psnr_of(sse_blend, 3 * pixels);
    out->psnr_render_covered = psnr_of(sse_cov, 3 * n_cov);
    out->psnr_render_uncovered = psnr_of(sse_unc, 3 * (pixels - n_cov));
    for (int k = 0; k < 2; k++) {
        out->anchor_covered[k] = (double)n_on[k] / pixels;
        out->psnr_warp[k] = psnr_of(sse_warp[k], 3 * n_on[k]);
        out->psnr_render_on[k] = psnr_of(sse_on[k], 3 * n_on[k]);
    }
    out->sse_render = sse_all, out->sse_uncovered = sse_unc;
}

/* Scratch of one target frame. */
typedef struct {
    float *render, *truth, *depth, *opacity, *warp[2];
    uint8_t *covered[2];
} frame_buffers;

static int measure_frame(int frame, int interval, const gv_gaussians *g, const gv_scene *scene,
                         const gv_coverage_options *opt, gv_splat_renderer *r,
                         anchor_view *cache, frame_buffers *b, gv_coverage_frame *out)
{
    const gv_camera *cam = &scene->cameras[frame];
    memset(out, 0, sizeof *out);
    out->frame = frame;
    out->anchor[0] = frame / interval * interval, out->anchor[1] = out->anchor[0] + interval;
    for (int k = 0; k < 2; k++) {
        const gv_camera *ac = &scene->cameras[out->anchor[k]];
        if (ac->width != cam->width || ac->height != cam->height)
            return gv_fail("%s: frames %s and %s differ in size", scene->dir, cam->name, ac->name);
        if (get_anchor(cache, out->anchor[k], r, g, scene, opt, b->render, b->opacity) != 0)
            return -1;
    }
    if (render_view(r, g, cam, opt, b->render, b->depth, b->opacity) != 0 ||
        load_rgb(scene, frame, b->truth) != 0)
        return -1;
    for (int k = 0; k < 2; k++) {
        const anchor_view *a = &cache[out->anchor[k]];
        if (gv_reproject_anchor(cam, b->depth, &scene->cameras[out->anchor[k]], a->depth, a->rgb,
                                opt->rel_tolerance, b->warp[k], b->covered[k]) != 0)
            return -1;
    }
    score_frame(out, (long)cam->width * cam->height, b->render, b->truth, b->warp, b->covered);
    return 0;
}

int gv_coverage_measure(const gv_gaussians *g, const gv_scene *scene, int interval,
                        const int *frames, int n, const gv_coverage_options *opt,
                        gv_coverage_frame *results)
{
    gv_coverage_options defaults;
    if (!opt) gv_coverage_options_default(&defaults), opt = &defaults;
    if (!(opt->rel_tolerance > 0) || !(opt->min_opacity >= 0 && opt->min_opacity <= 1))
        return gv_fail("coverage: tolerance %g must be positive and minimum opacity %g in 0..1",
                       opt->rel_tolerance, opt->min_opacity);
    size_t max_pixels = 0;
    for (int i = 0; i < scene->n_frames; i++) {
        size_t px = (size_t)scene->cameras[i].width * scene->cameras[i].height;
        if (px > max_pixels) max_pixels = px;
    }
    frame_buffers b = {0};
    anchor_view *cache = calloc((size_t)scene->n_frames, sizeof *cache);
    b.render = malloc(max_pixels * 3 * sizeof(float)), b.truth = malloc(max_pixels * 3 * sizeof(float));
    b.depth = malloc(max_pixels * sizeof(float)), b.opacity = malloc(max_pixels * sizeof(float));
    for (int k = 0; k < 2; k++)
        b.warp[k] = malloc(max_pixels * 3 * sizeof(float)), b.covered[k] = malloc(max_pixels);
    int ok = cache && b.render && b.truth && b.depth && b.opacity && b.warp[0] && b.warp[1] &&
                     b.covered[0] && b.covered[1]
                 ? 0
                 : gv_fail("coverage: out of memory for %zu-pixel frames", max_pixels);
    gv_splat_renderer r = {0};
    gv_progress bar;
    gv_progress_start(&bar, "coverage", n);
    for (int i = 0; i < n && ok == 0; i++) {
        int f = frames[i];
        if (f < 0 || f >= scene->n_frames || f % interval == 0 || f / interval * interval + interval >= scene->n_frames)
            ok = gv_fail("coverage: frame %d is not a held-out frame between two training frames", f);
        else
            ok = measure_frame(f, interval, g, scene, opt, &r, cache, &b, &results[i]);
        gv_progress_update(&bar, i + 1, NULL);
    }
    gv_progress_finish(&bar);
    gv_splat_renderer_free(&r);
    for (int i = 0; cache && i < scene->n_frames; i++) free(cache[i].rgb), free(cache[i].depth);
    free(cache), free(b.render), free(b.truth), free(b.depth), free(b.opacity);
    for (int k = 0; k < 2; k++) free(b.warp[k]), free(b.covered[k]);
    return ok;
}

/* Running mean that skips undefined values. */
typedef struct {
    double sum;
    int count;
} mean_acc;

static void add(mean_acc *m, double v)
{
    if (isfinite(v)) m->sum += v, m->count++;
}

static double mean(mean_acc m)
{
    return m.count ? m.sum / m.count : NAN;
}

void gv_coverage_summarise(const gv_coverage_frame *r, int n, gv_coverage_summary *s)
{
    mean_acc cov = {0}, acov[2] = {{0}}, pr = {0}, pon[2] = {{0}}, pw[2] = {{0}};
    mean_acc pc = {0}, pu = {0}, po = {0}, pb = {0}, share = {0};
    double sse = 0, sse_unc = 0;
    for (int i = 0; i < n; i++) {
        add(&cov, r[i].covered), add(&pr, r[i].psnr_render), add(&po, r[i].psnr_oracle);
        add(&pb, r[i].psnr_blend);
        add(&pc, r[i].psnr_render_covered), add(&pu, r[i].psnr_render_uncovered);
        for (int k = 0; k < 2; k++) {
            add(&acov[k], r[i].anchor_covered[k]);
            add(&pon[k], r[i].psnr_render_on[k]), add(&pw[k], r[i].psnr_warp[k]);
        }
        if (r[i].sse_render > 0) add(&share, r[i].sse_uncovered / r[i].sse_render);
        sse += r[i].sse_render, sse_unc += r[i].sse_uncovered;
    }
    memset(s, 0, sizeof *s);
    s->frames = n;
    s->covered = mean(cov), s->psnr_render = mean(pr), s->psnr_oracle = mean(po);
    s->psnr_blend = mean(pb);
    s->psnr_render_covered = mean(pc), s->psnr_render_uncovered = mean(pu);
    for (int k = 0; k < 2; k++) {
        s->anchor_covered[k] = mean(acov[k]);
        s->psnr_render_on[k] = mean(pon[k]), s->psnr_warp[k] = mean(pw[k]);
        s->frames_with[k] = pw[k].count;
    }
    s->uncovered_error_share = sse > 0 ? sse_unc / sse : NAN;
    s->uncovered_error_share_mean = mean(share);
}
