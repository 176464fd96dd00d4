/* The per-frame PSNR of the sparse, restored and refined frames along the path, as inline SVG:
 * x is the scene's frame index, y the PSNR; the training views are ticks under the axis, so
 * the dips between them show. The mapping is written on the <svg> (data-frame-min/max,
 * data-psnr-min/max and the plot box), so a reader can turn any point back into its numbers. */
#include "report_internal.h"

#include <math.h>

enum { WIDTH = 880, HEIGHT = 260, LEFT = 52, RIGHT = 110, TOP = 14, BOTTOM = 40 };
static const char *const COLOURS[N_MODELS] = {"#7f7f7f", "#e6550d", "#3182bd"};

typedef struct {
    double frame_min, frame_max, psnr_min, psnr_max;
    double left, top, width, height;
} plot_box;

static double x_of(const plot_box *b, double frame)
{
    double span = b->frame_max > b->frame_min ? b->frame_max - b->frame_min : 1;
    return b->left + (frame - b->frame_min) / span * b->width;
}

static double y_of(const plot_box *b, double psnr)
{
    return b->top + (b->psnr_max - psnr) / (b->psnr_max - b->psnr_min) * b->height;
}

/* The frames' range and the PSNRs' range rounded out to whole dB. */
static int plot_range(const report_run *run, plot_box *b)
{
    int any = 0;
    b->frame_min = b->psnr_min = INFINITY;
    b->frame_max = b->psnr_max = -INFINITY;
    for (int f = 0; f < run->n_frames; f++) {
        b->frame_min = fmin(b->frame_min, run->frames[f].frame);
        b->frame_max = fmax(b->frame_max, run->frames[f].frame);
        for (int k = 0; k < N_MODELS; k++) {
            if (!run->frames[f].score[k].present) continue;
            b->psnr_min = fmin(b->psnr_min, run->frames[f].score[k].psnr);
            b->psnr_max = fmax(b->psnr_max, run->frames[f].score[k].psnr);
            any = 1;
        }
    }
    if (!any) return 0;
    b->psnr_min = floor(b->psnr_min);
    b->psnr_max = ceil(b->psnr_max);
    if (b->psnr_max <= b->psnr_min) b->psnr_max = b->psnr_min + 1;
    b->left = LEFT, b->top = TOP, b->width = WIDTH - LEFT - RIGHT, b->height = HEIGHT - TOP - BOTTOM;
    return 1;
}

static void axes(report_text *t, const plot_box *b, const report_run *run)
{
    double bottom = b->top + b->height;
    double step = b->psnr_max - b->psnr_min > 12 ? 5 : b->psnr_max - b->psnr_min > 5 ? 2 : 1;
    for (double p = ceil(b->psnr_min / step) * step; p <= b->psnr_max + 1e-9; p += step) {
        double y = y_of(b, p);
        text_printf(t, "<line x1=\"%.2f\" y1=\"%.2f\" x2=\"%.2f\" y2=\"%.2f\" stroke=\"#e4e4e4\"/>"
                       "<text x=\"%.2f\" y=\"%.2f\" text-anchor=\"end\" font-size=\"11\">%g</text>\n",
                    b->left, y, b->left + b->width, y, b->left - 6, y + 4, p);
    }
    text_printf(t, "<rect x=\"%.2f\" y=\"%.2f\" width=\"%.2f\" height=\"%.2f\" fill=\"none\" stroke=\"#999\"/>\n",
                b->left, b->top, b->width, b->height);
    for (int i = 0; i < run->n_train; i++) {
        if (run->train_frames[i] < b->frame_min || run->train_frames[i] > b->frame_max) continue;
        double x = x_of(b, run->train_frames[i]);
        text_printf(t, "<line class=\"train\" x1=\"%.2f\" y1=\"%.2f\" x2=\"%.2f\" y2=\"%.2f\" stroke=\"#333\"/>"
                       "<text x=\"%.2f\" y=\"%.2f\" text-anchor=\"middle\" font-size=\"10\">%d</text>\n",
                    x, bottom, x, bottom + 6, x, bottom + 17, run->train_frames[i]);
    }
    text_printf(t, "<text x=\"%.2f\" y=\"%d\" text-anchor=\"middle\" font-size=\"11\">frame "
                   "(ticks: training views)</text>\n", b->left + b->width / 2, HEIGHT - 4);
    text_printf(t, "<text x=\"12\" y=\"%.2f\" font-size=\"11\" transform=\"rotate(-90 12 %.2f)\" "
                   "text-anchor=\"middle\">PSNR (dB)</text>\n", b->top + b->height / 2, b->top + b->height / 2);
}

void report_plot(report_text *t, const report_run *run)
{
    plot_box b;
    if (!plot_range(run, &b)) return;
    text_printf(t, "<svg class=\"psnr-plot\" width=\"%d\" height=\"%d\" viewBox=\"0 0 %d %d\" role=\"img\" "
                   "data-interval=\"%d\" data-frame-min=\"%g\" data-frame-max=\"%g\" data-psnr-min=\"%g\" "
                   "data-psnr-max=\"%g\" data-left=\"%g\" data-top=\"%g\" data-width=\"%g\" data-height=\"%g\">\n"
                   "<title>PSNR per frame at n = %d</title>\n",
                WIDTH, HEIGHT, WIDTH, HEIGHT, run->interval, b.frame_min, b.frame_max, b.psnr_min,
                b.psnr_max, b.left, b.top, b.width, b.height, run->interval);
    axes(t, &b, run);
    for (int k = 0; k < N_MODELS; k++) {
        int shown = 0;
        for (int f = 0; f < run->n_frames; f++) {
            const report_frame *fr = &run->frames[f];
            if (!fr->score[k].present) continue;
            if (!shown++)
                text_printf(t, "<polyline data-series=\"%s\" fill=\"none\" stroke=\"%s\" stroke-width=\"1.5\" points=\"",
                            report_model_names[k], COLOURS[k]);
            text_printf(t, "%s%.2f,%.2f", shown > 1 ? " " : "", x_of(&b, fr->frame), y_of(&b, fr->score[k].psnr));
        }
        if (!shown) continue;
        text_append(t, "\"/>\n");
        double y = TOP + 10 + 18 * k;
        text_printf(t, "<line x1=\"%d\" y1=\"%.1f\" x2=\"%d\" y2=\"%.1f\" stroke=\"%s\" stroke-width=\"3\"/>"
                       "<text x=\"%d\" y=\"%.1f\" font-size=\"12\">%s</text>\n",
                    WIDTH - RIGHT + 10, y, WIDTH - RIGHT + 30, y, COLOURS[k], WIDTH - RIGHT + 36, y + 4,
                    report_model_names[k]);
    }
    text_append(t, "</svg>\n");
}
