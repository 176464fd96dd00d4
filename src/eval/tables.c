/* Evaluation tables of restoration (paper section 4, docs/ARCHITECTURE.md 9): PSNR and SSIM of the three
 * intermediate frames of every clip against their ground truth, for the corrupted input
 * (baseline) and the restored frames (and LPIPS when weights are given), per interval n and over
 * all frames, as Markdown and JSON. */
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include <cjson/cJSON.h>

#include "gaussvid/core/core.h"
#include "gaussvid/eval/eval.h"
#include "gaussvid/io/metrics.h"

void gv_eval_init(gv_eval_table *t, const gv_lpips *lpips)
{
    memset(t, 0, sizeof *t);
    t->lpips = lpips;
}

/* The row of interval n, inserted in increasing order when new; NULL when the table is full. */
static gv_eval_row *row_of(gv_eval_table *t, int n)
{
    int i = 0;
    while (i < t->n_rows && t->rows[i].interval < n) i++;
    if (i < t->n_rows && t->rows[i].interval == n) return &t->rows[i];
    if (t->n_rows == GV_MAX_INTERVALS) return NULL;
    memmove(&t->rows[i + 1], &t->rows[i], (size_t)(t->n_rows - i) * sizeof t->rows[0]);
    memset(&t->rows[i], 0, sizeof t->rows[i]);
    t->rows[i].interval = n;
    t->n_rows++;
    return &t->rows[i];
}

/* scikit-image's peak_signal_noise_ratio(truth, image, data_range=255) on 8-bit values: the
 * squared differences are integers, so the mean is exact before the logarithm. */
static double psnr_u8(const gv_image *a, const gv_image *b)
{
    size_t n = (size_t)a->width * a->height * a->channels;
    double sum = 0;
    for (size_t i = 0; i < n; i++) {
        double d = (double)a->pixels[i] - (double)b->pixels[i];
        sum += d * d;
    }
    return sum == 0 ? INFINITY : 10.0 * log10(255.0 * 255.0 / (sum / (double)n));
}

/* PSNR and SSIM of one frame by the table's metric. */
static int measure(const gv_eval_table *t, const gv_image *image, const gv_image *truth, double *psnr, double *ssim)
{
    if (!t->release_metric) return gv_image_psnr_ssim(image, truth, psnr, ssim);
    *psnr = psnr_u8(image, truth);
    return gv_image_ssim_skimage(truth, image, ssim);
}

int gv_eval_add(gv_eval_table *t, const gv_clip *clip, const uint8_t *restored)
{
    if (t->finished) return gv_fail("eval: the table is already finished");
    const gv_clip_info *info = &clip->info;
    /* psnr, ssim, lpips of the baseline, then of the restored frames */
    double sums[6] = {0, 0, 0, 0, 0, 0};
    int frames = 0;
    for (int f = 1; f < GV_CLIP_FRAMES - 1; f++) {
        if (info->no_target[f]) continue; /* no ground truth: nothing to measure */
        frames++;
        size_t off = (size_t)f * info->width * info->height * 3;
        gv_image truth = {info->width, info->height, 3, clip->targets + off};
        gv_image frames[2] = {{info->width, info->height, 3, clip->inputs + off},
                              {info->width, info->height, 3, (uint8_t *)restored + off}};
        for (int k = 0; k < 2; k++) {
            double psnr, ssim, lpips = 0;
            if (measure(t, &frames[k], &truth, &psnr, &ssim) ||
                (t->lpips && gv_lpips_distance(t->lpips, &frames[k], &truth, &lpips)))
                return gv_fail_context("eval: clip %s n%d frame %d", info->id.scene, info->id.interval, info->frames[f]);
            sums[3 * k] += psnr, sums[3 * k + 1] += ssim, sums[3 * k + 2] += lpips;
        }
    }
    gv_eval_row *r = row_of(t, info->id.interval);
    if (!r) return gv_fail("eval: more than %d intervals", GV_MAX_INTERVALS);
    gv_eval_row *rows[2] = {r, &t->mean};
    for (int k = 0; k < 2; k++) {
        rows[k]->clips++;
        rows[k]->frames += frames;
        rows[k]->psnr_base += sums[0], rows[k]->ssim_base += sums[1], rows[k]->lpips_base += sums[2];
        rows[k]->psnr_rest += sums[3], rows[k]->ssim_rest += sums[4], rows[k]->lpips_rest += sums[5];
    }
    return 0;
}

int gv_eval_add_restored(void *table, const gv_clip *clip, const uint8_t *restored, char *note, size_t size)
{
    gv_eval_table *t = table;
    if (gv_eval_add(t, clip, restored)) return -1;
    snprintf(note, size, "PSNR %+.2f dB", (t->mean.psnr_rest - t->mean.psnr_base) / t->mean.frames);
    return 0;
}

static void row_finish(gv_eval_row *r)
{
    if (r->frames == 0) return;
    r->psnr_base /= r->frames, r->ssim_base /= r->frames;
    r->psnr_rest /= r->frames, r->ssim_rest /= r->frames;
    r->lpips_base /= r->frames, r->lpips_rest /= r->frames;
}

void gv_eval_finish(gv_eval_table *t)
{
    if (t->finished) return;
    for (int i = 0; i < t->n_rows; i++) row_finish(&t->rows[i]);
    row_finish(&t->mean);
    t->finished = 1;
}

static void print_row(FILE *out, const char *label, const gv_eval_row *r, int lpips)
{
    fprintf(out, "| %s | %d | %.2f | %.4f |", label, r->clips, r->psnr_base, r->ssim_base);
    if (lpips) fprintf(out, " %.4f |", r->lpips_base);
    fprintf(out, " %.2f | %.4f |", r->psnr_rest, r->ssim_rest);
    if (lpips) fprintf(out, " %.4f |", r->lpips_rest);
    fprintf(out, " %+.2f |\n", r->psnr_rest - r->psnr_base);
}

void gv_eval_print_markdown(const gv_eval_table *t, FILE *out)
{
    int l = t->lpips != NULL;
    fprintf(out, "| n | clips | baseline PSNR | baseline SSIM |%s restored PSNR | restored SSIM |%s PSNR change |\n",
            l ? " baseline LPIPS |" : "", l ? " restored LPIPS |" : "");
    fprintf(out, "|---|---|---|---|---|---|---|%s\n", l ? "---|---|" : "");
    for (int i = 0; i < t->n_rows; i++) {
        char label[16];
        snprintf(label, sizeof label, "%d", t->rows[i].interval);
        print_row(out, label, &t->rows[i], l);
    }
    print_row(out, "**mean**", &t->mean, l);
}

/* {"psnr", "ssim", ["lpips",] "clips"} of one side of a row (lpips < 0: none); NULL when memory
 * runs out. */
static cJSON *side(double psnr, double ssim, double lpips, int clips)
{
    cJSON *o = cJSON_CreateObject();
    if (o && (!cJSON_AddNumberToObject(o, "psnr", psnr) || !cJSON_AddNumberToObject(o, "ssim", ssim) ||
              (lpips >= 0 && !cJSON_AddNumberToObject(o, "lpips", lpips)) || !cJSON_AddNumberToObject(o, "clips", clips))) {
        cJSON_Delete(o);
        return NULL;
    }
    return o;
}

static int add_sides(cJSON *o, const gv_eval_row *r, int lpips)
{
    cJSON *b = side(r->psnr_base, r->ssim_base, lpips ? r->lpips_base : -1, r->clips);
    cJSON *s = side(r->psnr_rest, r->ssim_rest, lpips ? r->lpips_rest : -1, r->clips);
    if (!b || !s || !cJSON_AddItemToObject(o, "baseline", b)) {
        cJSON_Delete(b), cJSON_Delete(s);
        return -1;
    }
    return cJSON_AddItemToObject(o, "restored", s) ? 0 : (cJSON_Delete(s), -1);
}

int gv_eval_write_json(const gv_eval_table *t, const char *path, const char *const *info_keys,
                       const char *const *info_values, int n_info)
{
    if (!t->finished) return gv_fail("%s: the evaluation table is not finished", path);
    cJSON *root = cJSON_CreateObject(), *per_n = cJSON_CreateArray();
    int ok = root && per_n && add_sides(root, &t->mean, t->lpips != NULL) == 0;
    for (int i = 0; ok && i < n_info; i++) ok = cJSON_AddStringToObject(root, info_keys[i], info_values[i]) != NULL;
    for (int i = 0; ok && i < t->n_rows; i++) {
        cJSON *o = cJSON_CreateObject();
        ok = o && cJSON_AddNumberToObject(o, "n", t->rows[i].interval) && cJSON_AddNumberToObject(o, "clips", t->rows[i].clips) &&
             add_sides(o, &t->rows[i], t->lpips != NULL) == 0;
        if (ok) ok = cJSON_AddItemToArray(per_n, o);
        else cJSON_Delete(o);
    }
    if (ok) ok = cJSON_AddItemToObject(root, "per_n", per_n);
    else cJSON_Delete(per_n);
    char *text = ok ? cJSON_Print(root) : NULL;
    cJSON_Delete(root);
    if (!text) return gv_fail("%s: out of memory", path);
    int rc = gv_write_text_atomic(path, text);
    free(text);
    return rc;
}
