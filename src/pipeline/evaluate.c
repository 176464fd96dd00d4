/* The evaluate stage of `reconstruct`: every evaluated frame with ground truth scored as the
 * 3DGS evaluation scores it (gv_image_psnr_ssim on the 8-bit PNGs the earlier stages wrote;
 * PSNR of identical images capped at 100 dB), LPIPS with --lpips; their means; and the sparse
 * and refined models on every held-out view, the frames after the last training view
 * included (they have no right anchor, so no clip restores them). With --no-restore only the
 * sparse model is scored; the restored and refined entries are null. */
#include <stdlib.h>
#include <string.h>

#include "gaussvid/core/core.h"
#include "gaussvid/eval/lpips.h"
#include "gaussvid/io/metrics.h"
#include "gaussvid/io/ply.h"
#include "gaussvid/splat/splat_train.h"
#include "pipeline/pipeline_internal.h"

#define PSNR_CAP 100.0
static const char *const KINDS[3] = {"render", "restored", "refined"};
static const char *const NAMES[3] = {"sparse", "restored", "refined"};

typedef struct {
    int frames;
    double psnr, ssim, lpips;
} metric_sum;

static int score(const gv_image *a, const gv_image *truth, const gv_lpips *lp, double m[3])
{
    if (gv_image_psnr_ssim(a, truth, &m[0], &m[1])) return -1;
    if (m[0] > PSNR_CAP) m[0] = PSNR_CAP;
    m[2] = 0;
    return lp ? gv_lpips_distance(lp, a, truth, &m[2]) : 0;
}

static void add(metric_sum *s, const double m[3])
{
    s->frames++, s->psnr += m[0], s->ssim += m[1], s->lpips += m[2];
}

static cJSON *mean_json(const metric_sum *s, int has_lpips)
{
    cJSON *j = pipeline_metric_json(s->psnr / s->frames, s->ssim / s->frames, s->lpips / s->frames, has_lpips);
    cJSON_AddNumberToObject(j, "frames", s->frames);
    return j;
}

/* The models scored: sparse, restored, refined; sparse alone with --no-restore. */
static int n_kinds(const pipeline_run *r) { return r->opt->restore_with == GV_RESTORE_NONE ? 1 : 3; }

/* The frame's images scored against its ground truth; into its JSON object and sums. */
static int score_frame(pipeline_run *r, const pipeline_frame *f, const gv_lpips *lp, cJSON *fj, metric_sum sums[3],
                       double sparse_refined[2][3])
{
    gv_image truth = {0};
    int rc = gv_scene_load_image(r->scene, f->truth, &truth);
    for (int k = n_kinds(r); k < 3; k++) cJSON_ReplaceItemInObject(fj, NAMES[k], cJSON_CreateNull());
    for (int k = 0; k < n_kinds(r) && rc == 0; k++) {
        char path[4200];
        gv_image img = {0};
        double m[3];
        rc = pipeline_frame_path(r, KINDS[k], f->index, path, sizeof path) || gv_image_read_rgb(path, &img) ||
             score(&img, &truth, lp, m);
        if (rc) gv_fail_context("%s", path);
        gv_image_free(&img);
        if (rc) break;
        cJSON_ReplaceItemInObject(fj, NAMES[k], pipeline_metric_json(m[0], m[1], m[2], lp != NULL));
        add(&sums[k], m);
        if (k != 1) memcpy(sparse_refined[k / 2], m, sizeof m);
    }
    gv_image_free(&truth);
    return rc;
}

/* A held-out frame no clip restores: the sparse and refined models rendered there. */
static int score_tail(pipeline_run *r, int frame, const gv_gaussians models[2], const gv_lpips *lp,
                      metric_sum all[2])
{
    int n_models = n_kinds(r) == 1 ? 1 : 2;
    static const float black[3] = {0, 0, 0};
    gv_splat_renderer renderer;
    memset(&renderer, 0, sizeof renderer);
    gv_image truth = {0};
    int rc = gv_scene_load_image(r->scene, frame, &truth);
    for (int k = 0; k < n_models && rc == 0; k++) {
        gv_image img = {0};
        double m[3];
        rc = gv_splat_render_camera(&renderer, &models[k], &r->scene->cameras[frame], black, &img) ||
             score(&img, &truth, lp, m);
        if (rc == 0) add(&all[k], m);
        gv_image_free(&img);
    }
    gv_splat_renderer_free(&renderer);
    gv_image_free(&truth);
    return rc;
}

static int in_plan(const pipeline_run *r, int frame)
{
    for (int i = 0; i < r->n_frames; i++)
        if (r->frames[i].index == frame) return 1;
    return 0;
}

static int load_models(pipeline_run *r, gv_gaussians models[2])
{
    char path[4200];
    return pipeline_file(r, "sparse.ply", path, sizeof path) || gv_gaussians_read_ply(path, &models[0]) ||
           (n_kinds(r) > 1 &&
            (pipeline_file(r, "refined.ply", path, sizeof path) || gv_gaussians_read_ply(path, &models[1])));
}

/* The run's "consistency" (consistency.c), its means appended to the stage's summary. */
static int record_consistency(pipeline_run *r)
{
    cJSON *j;
    double psnr[3];
    if (pipeline_consistency(r, 0, &j, psnr)) return -1;
    cJSON_DeleteItemFromObject(r->run, "consistency");
    cJSON_AddItemToObject(r->run, "consistency", j);
    char means[160];
    pipeline_consistency_means(psnr, pipeline_consistency_sets(r), means, sizeof means);
    size_t used = strlen(r->summary);
    snprintf(r->summary + used, sizeof r->summary - used, "; consistency (frames warped into their neighbours) %s",
             means);
    return 0;
}

int pipeline_evaluate(pipeline_run *r)
{
    gv_lpips lpips;
    memset(&lpips, 0, sizeof lpips);
    const gv_lpips *lp = NULL;
    if (r->opt->lpips) {
        if (gv_lpips_load(&lpips, r->opt->lpips)) return -1;
        lp = &lpips;
    }
    metric_sum sums[3] = {{0}}, all[2] = {{0}};
    cJSON *frames = cJSON_GetObjectItem(r->run, "frames");
    gv_progress bar;
    char label[48];
    snprintf(label, sizeof label, "evaluate n=%d", r->interval);
    gv_progress_start(&bar, label, r->n_frames + r->n_held_out);
    int rc = 0, done = 0;
    for (int i = 0; i < r->n_frames && rc == 0; i++) {
        const pipeline_frame *f = &r->frames[i];
        double sr[2][3] = {{0}};
        if (f->truth >= 0) {
            rc = score_frame(r, f, lp, cJSON_GetArrayItem(frames, i), sums, sr);
            if (rc == 0) add(&all[0], sr[0]), add(&all[1], sr[1]);
        }
        gv_progress_update(&bar, ++done, NULL);
    }
    gv_gaussians models[2] = {{0}};
    int tail = 0;
    for (int i = 0; i < r->n_held_out && rc == 0; i++) {
        if (!in_plan(r, r->held_out[i])) {
            if (!tail++) rc = load_models(r, models);
            if (rc == 0) rc = score_tail(r, r->held_out[i], models, lp, all);
        }
        gv_progress_update(&bar, ++done, NULL);
    }
    gv_progress_finish(&bar);
    gv_gaussians_free(&models[0]), gv_gaussians_free(&models[1]);
    gv_lpips_free(&lpips);
    if (rc) return -1;
    cJSON *means = sums[0].frames ? cJSON_CreateObject() : cJSON_CreateNull();
    for (int k = 0; k < 3 && sums[0].frames; k++)
        cJSON_AddItemToObject(means, NAMES[k], k < n_kinds(r) ? mean_json(&sums[k], lp != NULL) : cJSON_CreateNull());
    cJSON_ReplaceItemInObject(r->run, "means", means);
    cJSON *every = all[0].frames ? cJSON_CreateObject() : cJSON_CreateNull();
    if (all[0].frames) {
        cJSON_AddItemToObject(every, "sparse", mean_json(&all[0], lp != NULL));
        cJSON_AddItemToObject(every, "refined", n_kinds(r) > 1 ? mean_json(&all[1], lp != NULL) : cJSON_CreateNull());
    }
    cJSON_ReplaceItemInObject(r->run, "all_held_out", every);
    if (!sums[0].frames)
        snprintf(r->summary, sizeof r->summary, "no ground truth on the path: nothing to score");
    else if (n_kinds(r) == 1)
        snprintf(r->summary, sizeof r->summary, "PSNR sparse %.2f dB, SSIM %.4f (%d frames); all %d held-out views: "
                 "sparse %.2f dB", sums[0].psnr / sums[0].frames, sums[0].ssim / sums[0].frames, sums[0].frames,
                 all[0].frames, all[0].psnr / all[0].frames);
    else
        snprintf(r->summary, sizeof r->summary,
                 "PSNR sparse %.2f, restored %.2f, refined %.2f dB; SSIM %.4f, %.4f, %.4f (%d frames); all %d held-out "
                 "views: sparse %.2f, refined %.2f dB",
                 sums[0].psnr / sums[0].frames, sums[1].psnr / sums[1].frames, sums[2].psnr / sums[2].frames,
                 sums[0].ssim / sums[0].frames, sums[1].ssim / sums[1].frames, sums[2].ssim / sums[2].frames,
                 sums[0].frames, all[0].frames, all[0].psnr / all[0].frames, all[1].psnr / all[1].frames);
    return record_consistency(r);
}
