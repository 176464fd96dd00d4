/* Image strips: for a chosen frame, the sparse render, the restored frame, the refined
 * model's render and the ground truth side by side, with the error maps under them
 * (|image - ground truth|, gv_error_map). Without ground truth (a smooth path) the second row
 * shows what the restorer and the refinement changed: |restored - render|, |refined - render|.
 *
 * Which frames: with ground truth, the worst and the best by restored-minus-sparse PSNR (where
 * restoration hurt most and helped most); before restoration is evaluated, or when it changed
 * no frame's PSNR (a closed gate keeps the renders), the worst and best sparse PSNR; without
 * ground truth, the frames the restorer changed most and least (mean absolute difference);
 * before anything is restored, the first and last frames. */
#include "report_internal.h"

#include "gaussvid/core/core.h"
#include "gaussvid/report/report.h"
#include "gaussvid/scene/scene.h"

#include <float.h>
#include <stdlib.h>

/* Mean |a - b| over every sample, or -1 when the two cannot be compared. */
static double mean_abs_difference(const gv_image *a, const gv_image *b)
{
    if (a->width != b->width || a->height != b->height || a->channels != b->channels) return -1;
    size_t n = (size_t)a->width * a->height * a->channels;
    double sum = 0;
    for (size_t i = 0; i < n; i++) sum += abs((int)a->pixels[i] - (int)b->pixels[i]);
    return n ? sum / (double)n : 0;
}

int report_restorer_change(const char *dir, const report_frame *f, double *change)
{
    *change = -1;
    if (!f->images[IMAGE_RESTORED]) return 0;
    gv_image render = {0}, restored = {0};
    int rc = report_read_image(dir, f->images[IMAGE_RENDER], &render);
    if (rc == 0) rc = report_read_image(dir, f->images[IMAGE_RESTORED], &restored);
    if (rc == 0) *change = mean_abs_difference(&render, &restored);
    gv_image_free(&render);
    gv_image_free(&restored);
    return rc;
}

int report_pick_frames(const char *dir, const report_run *run, int picked[2], const char **rule,
                       const char *labels[2])
{
    int *worst = &picked[0], *best = &picked[1];
    *worst = *best = -1;
    int unchanged = 0;
    /* 0: restored - sparse PSNR, 1: sparse PSNR, 2: restorer's change, 3: first and last */
    for (int pass = 0; pass < 3 && *worst < 0; pass++) {
        double low = DBL_MAX, high = -DBL_MAX;
        for (int i = 0; i < run->n_frames; i++) {
            const report_frame *f = &run->frames[i];
            double v;
            if (pass == 0 && f->score[MODEL_SPARSE].present && f->score[MODEL_RESTORED].present)
                v = f->score[MODEL_RESTORED].psnr - f->score[MODEL_SPARSE].psnr;
            else if (pass == 1 && f->score[MODEL_SPARSE].present) v = f->score[MODEL_SPARSE].psnr;
            else if (pass == 2 && !report_skipped(run, DECISION_RESTORATION)) {
                if (report_restorer_change(dir, f, &v) != 0) return -1;
                if (v < 0) continue;
                v = -v; /* "worst" here is the largest change: listed first, as the others */
            } else continue;
            if (v < low) low = v, *worst = i;
            if (v > high) high = v, *best = i;
        }
        if (pass == 0 && *worst >= 0 && low == 0 && high == 0) {
            /* Restoration changed no frame's PSNR: show where the renders are worst and best. */
            unchanged = 1;
            *worst = *best = -1;
            continue;
        }
        static const char *const rules[3] = {
            "the frames where restoration lost most and gained most: lowest and highest restored minus sparse PSNR",
            "the frames with the lowest and highest sparse PSNR (restored frames not evaluated yet)",
            "no ground truth: the frames the restorer changed most and least (mean absolute difference to the render)"};
        *rule = pass == 1 && unchanged ? "restoration changed no frame's PSNR (a closed gate keeps the renders): "
                                         "the frames with the lowest and highest sparse PSNR"
                                       : rules[pass];
        labels[0] = pass == 2 ? "changed most" : "worst";
        labels[1] = pass == 2 ? "changed least" : "best";
    }
    if (*worst < 0 && run->n_frames > 0) {
        *worst = 0;
        *best = run->n_frames - 1;
        *rule = report_skipped(run, DECISION_RESTORATION) ? "the first and last frames of the path (restoration was skipped)"
                                                : "the first and last frames of the path (nothing restored yet)";
        labels[0] = "first";
        labels[1] = "last";
    }
    return 0;
}

/* Brings the ground truth to the render's size when the scene's images are k times larger
 * (a downscaled run), as the scene loader does; fails on any other mismatch. */
static int match_size(gv_image *img, const gv_image *like, const char *name)
{
    if (img->width == like->width && img->height == like->height) return 0;
    int k = like->width > 0 ? img->width / like->width : 0;
    if (k >= 2 && gv_downscaled_size(img->width, k) == like->width &&
        gv_downscaled_size(img->height, k) == like->height) {
        gv_image small;
        if (gv_image_downscale(img, k, &small) != 0) return -1;
        gv_image_free(img);
        *img = small;
        return 0;
    }
    return gv_fail("%s: %dx%d, but the render is %dx%d", name, img->width, img->height, like->width, like->height);
}

static int cell(report_text *t, const char *kind, const gv_image *img, const char *caption, const char *alt)
{
    text_printf(t, "<div class=\"cell\" data-image=\"%s\">", kind);
    if (report_embed_image(t, img, alt) != 0) return -1;
    text_append(t, "<div class=\"caption\">");
    text_escaped(t, caption);
    text_append(t, "</div></div>\n");
    return 0;
}

static void score_caption(char *out, size_t size, const char *what, const report_score *s)
{
    if (s->present) snprintf(out, size, "%s: %.2f dB, SSIM %.4f", what, s->psnr, s->ssim);
    else snprintf(out, size, "%s", what);
}

int report_strip(report_text *t, const char *dir, const report_run *run, int index, const char *label)
{
    const report_frame *f = &run->frames[index];
    gv_image img[N_IMAGES] = {{0}};
    int rc = 0, copies = report_skipped(run, DECISION_RESTORATION); /* restored and refined are the render */
    for (int k = 0; k < N_IMAGES && rc == 0; k++) {
        if (!f->images[k] || (copies && (k == IMAGE_RESTORED || k == IMAGE_REFINED))) continue;
        rc = report_read_image(dir, f->images[k], &img[k]);
        if (rc == 0 && k != IMAGE_RENDER) rc = match_size(&img[k], &img[IMAGE_RENDER], f->images[k]);
    }
    static const char *const titles[N_IMAGES] = {"sparse render", "restored", "refined render", "ground truth"};
    static const char *const kinds[N_IMAGES] = {"render", "restored", "refined", "ground-truth"};
    text_printf(t, "<figure class=\"strip\" data-frame=\"%d\"><figcaption>%s: ", f->frame, label);
    text_escaped(t, f->name);
    text_printf(t, " (frame %d)</figcaption>\n<div class=\"row\">\n", f->frame);
    for (int k = 0; k < N_IMAGES && rc == 0; k++) {
        if (!img[k].pixels) continue;
        char caption[160], alt[128];
        if (k < N_MODELS) score_caption(caption, sizeof caption, titles[k], &f->score[k]);
        else snprintf(caption, sizeof caption, "%s", titles[k]);
        snprintf(alt, sizeof alt, "%s, %.60s", titles[k], f->name);
        rc = cell(t, kinds[k], &img[k], caption, alt);
    }
    text_append(t, "</div>\n");
    /* error maps against the ground truth, or the changes against the render without it */
    const gv_image *reference = img[IMAGE_GROUND_TRUTH].pixels ? &img[IMAGE_GROUND_TRUTH] : &img[IMAGE_RENDER];
    int against_truth = reference == &img[IMAGE_GROUND_TRUTH];
    if (!against_truth && copies) { /* nothing changed the render: no row of black maps */
        text_append(t, "</figure>\n");
        for (int k = 0; k < N_IMAGES; k++) gv_image_free(&img[k]);
        return rc;
    }
    text_append(t, "<div class=\"row\">\n");
    for (int k = against_truth ? 0 : 1; k < N_MODELS && rc == 0; k++) {
        if (!img[k].pixels) continue;
        gv_image map;
        rc = gv_error_map(&img[k], reference, &map);
        if (rc != 0) break;
        char caption[160], kind[32];
        snprintf(caption, sizeof caption, "|%s - %s|", kinds[k], against_truth ? "ground truth" : "render");
        snprintf(kind, sizeof kind, "%s-%s", against_truth ? "error" : "change", kinds[k]);
        rc = cell(t, kind, &map, caption, caption);
        gv_image_free(&map);
    }
    text_append(t, "</div>\n</figure>\n");
    for (int k = 0; k < N_IMAGES; k++) gv_image_free(&img[k]);
    return rc;
}
