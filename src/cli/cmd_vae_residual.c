/* gaussvid vae residual --weights vae.safetensors DATA...: what the VAE costs the restorer on
 * dataset clips, per sparsity interval n: the render (the sparse-3DGS baseline), the render
 * through the VAE, the ground truth through the VAE, and residual decoding with the latent
 * unchanged (exactly the render) and with a perfect restorer (docs/VAE.md). */
#include <cjson/cJSON.h>
#include <dirent.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "cli/cmd_vae.h"
#include "cli/commands.h"
#include "gaussvid/core/core.h"
#include "gaussvid/data/dataset.h"
#include "gaussvid/eval/eval.h"

enum { MAX_CLIPS = 4096, MAX_INTERVALS = 64 };

typedef struct {
    char *paths[MAX_CLIPS];
    int n;
} clip_list;

static int by_name(const void *a, const void *b)
{
    return strcmp(*(char *const *)a, *(char *const *)b);
}

static int ends_with(const char *s, const char *tail)
{
    size_t n = strlen(s), k = strlen(tail);
    return n >= k && !strcmp(s + n - k, tail);
}

/* A clip file, or every *.safetensors of DIR/clips (a dataset) or else of DIR, sorted. */
static int add_path(clip_list *l, const char *path)
{
    if (!gv_dir_exists(path)) {
        if (l->n == MAX_CLIPS) return gv_fail("%s: more than %d clips", path, MAX_CLIPS);
        return (l->paths[l->n++] = strdup(path)) ? 0 : gv_fail("out of memory");
    }
    char dir[4096];
    if (gv_path_join(dir, sizeof dir, path, "clips") || !gv_dir_exists(dir)) snprintf(dir, sizeof dir, "%s", path);
    DIR *d = opendir(dir);
    if (!d) return gv_fail("%s: cannot open the folder", dir);
    int first = l->n, rc = 0;
    for (struct dirent *e; rc == 0 && (e = readdir(d));) {
        char file[4096 + 256];
        if (!ends_with(e->d_name, ".safetensors")) continue;
        if (l->n == MAX_CLIPS) rc = gv_fail("%s: more than %d clips", dir, MAX_CLIPS);
        else if (gv_path_join(file, sizeof file, dir, e->d_name) || !(l->paths[l->n++] = strdup(file)))
            rc = gv_fail("%s: path too long or out of memory", dir);
    }
    closedir(d);
    if (rc == 0 && l->n == first) rc = gv_fail("%s: no clip files (*.safetensors)", dir);
    qsort(l->paths + first, (size_t)(l->n - first), sizeof l->paths[0], by_name);
    return rc;
}

static const char *const kind_names[GV_VAE_RESIDUAL_KINDS] = {"render", "vae_render", "vae_target", "residual_same",
                                                               "residual_target"};

static void print_row(const char *label, const gv_vae_residual_scores *s)
{
    printf("  %-5s %5d %6d", label, s->n_clips, s->n_frames);
    for (int q = 0; q < GV_VAE_RESIDUAL_KINDS; q++) printf("   %6.2f %.4f", s->psnr[q], s->ssim[q]);
    printf("   %.3g\n", s->max_abs_same);
}

static cJSON *row_json(int n, const gv_vae_residual_scores *s)
{
    cJSON *o = cJSON_CreateObject();
    if (n > 0) cJSON_AddNumberToObject(o, "n", n);
    else cJSON_AddStringToObject(o, "n", "all");
    cJSON_AddNumberToObject(o, "clips", s->n_clips);
    cJSON_AddNumberToObject(o, "frames", s->n_frames);
    for (int q = 0; q < GV_VAE_RESIDUAL_KINDS; q++) {
        char key[64];
        snprintf(key, sizeof key, "psnr_%s", kind_names[q]);
        cJSON_AddNumberToObject(o, key, s->psnr[q]);
        snprintf(key, sizeof key, "ssim_%s", kind_names[q]);
        cJSON_AddNumberToObject(o, key, s->ssim[q]);
    }
    cJSON_AddNumberToObject(o, "max_abs_same", s->max_abs_same);
    return o;
}

/* Scores every clip into per-n sums (by_n[i] for intervals[i]) and `all`. */
static int score_clips(gv_vae *v, const clip_list *l, int *intervals, gv_vae_residual_scores *by_n, int *n_intervals,
                       gv_vae_residual_scores *all)
{
    static const int score[GV_CLIP_FRAMES] = {0, 1, 1, 1, 0}; /* the three corrupted frames */
    gv_progress bar;
    gv_progress_start(&bar, "vae residual", l->n);
    int rc = 0;
    for (int i = 0; rc == 0 && i < l->n; i++) {
        gv_clip clip;
        if ((rc = gv_clip_read(l->paths[i], &clip))) break;
        int k = 0;
        while (k < *n_intervals && intervals[k] != clip.info.id.interval) k++;
        if (k == *n_intervals && k == MAX_INTERVALS) rc = gv_fail("%s: more than %d intervals", l->paths[i], MAX_INTERVALS);
        if (rc == 0 && k == *n_intervals) intervals[(*n_intervals)++] = clip.info.id.interval;
        gv_vae_residual_scores one;
        memset(&one, 0, sizeof one);
        if (rc == 0 && gv_vae_residual_score_clip(v, clip.inputs, clip.targets, GV_CLIP_FRAMES, clip.info.height,
                                                  clip.info.width, score, &one))
            rc = gv_fail_context("%s", l->paths[i]);
        gv_clip_free(&clip);
        for (int t = 0; rc == 0 && t < 2; t++) {
            gv_vae_residual_scores *s = t ? all : &by_n[k];
            s->n_clips += one.n_clips, s->n_frames += one.n_frames;
            for (int q = 0; q < GV_VAE_RESIDUAL_KINDS; q++) s->psnr[q] += one.psnr[q], s->ssim[q] += one.ssim[q];
            if (one.max_abs_same > s->max_abs_same) s->max_abs_same = one.max_abs_same;
        }
        gv_progress_update(&bar, i + 1, NULL);
    }
    gv_progress_finish(&bar);
    return rc;
}

/* Prints the means per interval (increasing n) and over all clips. */
static void report(const char *weights, const gv_model_config *c, int *intervals, gv_vae_residual_scores *by_n,
                   int n_intervals, gv_vae_residual_scores *all, int json)
{
    for (int k = 0; k < n_intervals; k++) /* selection sort: a handful of intervals */
        for (int j = k + 1; j < n_intervals; j++)
            if (intervals[j] < intervals[k]) {
                int ti = intervals[k];
                intervals[k] = intervals[j], intervals[j] = ti;
                gv_vae_residual_scores ts = by_n[k];
                by_n[k] = by_n[j], by_n[j] = ts;
            }
    for (int k = 0; k < n_intervals; k++) gv_vae_residual_finish(&by_n[k]);
    gv_vae_residual_finish(all);
    if (json) {
        cJSON *root = cJSON_CreateObject(), *rows;
        cJSON_AddStringToObject(root, "weights", weights);
        cJSON_AddStringToObject(root, "config", c->name);
        rows = cJSON_AddArrayToObject(root, "rows");
        for (int k = 0; k < n_intervals; k++) cJSON_AddItemToArray(rows, row_json(intervals[k], &by_n[k]));
        cJSON_AddItemToArray(rows, row_json(0, all));
        char *text = cJSON_Print(root);
        if (text) printf("%s\n", text);
        cJSON_free(text);
        cJSON_Delete(root);
        return;
    }
    printf("%s (%s VAE, %dx spatial, %dx temporal): PSNR (dB) and SSIM of the 3 corrupted frames of each clip\n"
           "  %-5s %5s %6s   %-13s   %-13s   %-13s   %-13s   %-13s   %s\n",
           weights, c->name, c->vae.spatial_factor, c->vae.temporal_factor, "n", "clips", "frames", "render",
           "D(E(render))", "D(E(target))", "resid. same", "resid. target", "max|same-render|");
    for (int k = 0; k < n_intervals; k++) {
        char label[16];
        snprintf(label, sizeof label, "%d", intervals[k]);
        print_row(label, &by_n[k]);
    }
    print_row("all", all);
}

static int run(const char *weights, const char *config, const clip_list *l, int json)
{
    gv_model_config c;
    if (config ? gv_model_config_load(&c, config) : gv_vae_file_config(weights, &c)) return -1;
    gv_vae v;
    if (gv_vae_init(&v, &c, 0, 0)) return -1;
    int intervals[MAX_INTERVALS], n_intervals = 0;
    gv_vae_residual_scores *by_n = calloc(MAX_INTERVALS, sizeof *by_n), all;
    memset(&all, 0, sizeof all);
    int rc = by_n ? gv_vae_load(&v, weights, 0) : gv_fail("out of memory");
    if (rc == 0) rc = score_clips(&v, l, intervals, by_n, &n_intervals, &all);
    gv_vae_free(&v);
    if (rc == 0) report(weights, &c, intervals, by_n, n_intervals, &all, json);
    free(by_n);
    return rc;
}

int cmd_vae_residual(int argc, char **argv)
{
    const char *weights = NULL, *config = NULL;
    int json = 0;
    const gv_flag flags[] = {
        {"weights", GV_FLAG_STRING, &weights, "FILE", "VAE weights (.safetensors)", 1},
        {"config", GV_FLAG_STRING, &config, "PRESET|FILE", "model config (default: the one in the weights' metadata)", 0},
        {"json", GV_FLAG_BOOL, &json, NULL, "print the results as JSON", 0},
    };
    const gv_command_spec spec = {
        "vae residual", "CLIP|DATASET...", "what the VAE costs the restorer on dataset clips, per interval n",
        "Each argument is a clip file or a dataset folder (its clips/*.safetensors; see\n"
        "'gaussvid dataset build'). For the three corrupted frames of every clip: PSNR and SSIM\n"
        "against the ground truth of the render (the sparse-3DGS baseline), of the render\n"
        "through the VAE D(E(render)), of the ground truth through the VAE D(E(target)), and\n"
        "of residual decoding render + D(z) - D(E(render)) with z = E(render) (exactly the\n"
        "render: the last column must be 0) and with z = E(target) (a perfect restorer: the\n"
        "upper bound). Means per interval n and over all clips. See docs/VAE.md.",
        flags, (int)(sizeof flags / sizeof flags[0]), 1, MAX_CLIPS};
    char *positional[MAX_CLIPS];
    int n_positional = 0;
    int parsed = gv_args_parse(&spec, argc, argv, positional, &n_positional);
    if (parsed != GV_ARGS_OK) return gv_args_exit_code(parsed);
    clip_list *l = calloc(1, sizeof *l);
    int rc = l ? 0 : gv_fail("out of memory");
    for (int i = 0; rc == 0 && i < n_positional; i++) rc = add_path(l, positional[i]);
    if (rc == 0) rc = run(weights, config, l, json);
    for (int i = 0; l && i < l->n; i++) free(l->paths[i]);
    free(l);
    return rc == 0 ? 0 : gv_report_failure();
}
