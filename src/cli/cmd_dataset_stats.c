/* gaussvid dataset stats DIR [--runs] [--json]: clips per n and split, and the baseline quality
 * of the corrupted frames per n (mean over every held-out frame of every scene at that n);
 * with --runs also one row per (scene, n) run, the sparse-3DGS baseline table. */
#include <cjson/cJSON.h>
#include <stdio.h>
#include <stdlib.h>

#include "cli/commands.h"
#include "gaussvid/core/core.h"
#include "gaussvid/data/dataset.h"

/* Calls fn on the record of every run of the manifest, in manifest order (scene, n). */
static int for_each_run(const char *dir, void (*fn)(const gv_run_record *, void *), void *arg)
{
    gv_manifest m;
    int rc;
    if ((rc = gv_manifest_read_dataset(dir, &m)) != 0) return rc;
    for (int i = 0; i < m.n_runs && rc == 0; i++) {
        char file[GV_SCENE_NAME_MAX + 32], path[4096];
        gv_run_record rec;
        rc = gv_run_file_name(file, sizeof file, m.runs[i].id.scene, m.runs[i].id.interval) ||
             gv_path_join(path, sizeof path, dir, file) || gv_run_record_read(path, &rec);
        if (rc == 0) {
            fn(&rec, arg);
            gv_run_record_free(&rec);
        }
    }
    gv_manifest_free(&m);
    return rc ? -1 : 0;
}

static void print_run(const gv_run_record *r, void *unused)
{
    (void)unused;
    char train[32] = "-";
    if (r->train_frames > 0) snprintf(train, sizeof train, "%.2f / %.4f", r->train_psnr, r->train_ssim);
    printf("| %s | %s | %d | %d | %.2f / %.4f | %s | %d | %.0f |\n", r->id.scene, r->id.split, r->id.interval,
           r->n_train, r->psnr_mean, r->ssim_mean, train, r->n_clips, r->seconds);
}

static void add_run_json(const gv_run_record *r, void *list)
{
    cJSON *o = cJSON_CreateObject();
    cJSON_AddStringToObject(o, "scene", r->id.scene);
    cJSON_AddStringToObject(o, "split", r->id.split);
    cJSON_AddNumberToObject(o, "n", r->id.interval);
    cJSON_AddNumberToObject(o, "train_views", r->n_train);
    cJSON *b = cJSON_AddObjectToObject(o, "held_out");
    cJSON_AddNumberToObject(b, "psnr", r->psnr_mean);
    cJSON_AddNumberToObject(b, "ssim", r->ssim_mean);
    cJSON_AddNumberToObject(b, "frames", r->n_held_out);
    if (r->train_frames > 0) {
        cJSON *t = cJSON_AddObjectToObject(o, "train");
        cJSON_AddNumberToObject(t, "psnr", r->train_psnr);
        cJSON_AddNumberToObject(t, "ssim", r->train_ssim);
        cJSON_AddNumberToObject(t, "frames", r->train_frames);
    }
    cJSON_AddNumberToObject(o, "clips", r->n_clips);
    cJSON_AddNumberToObject(o, "seconds", r->seconds);
    cJSON_AddItemToArray((cJSON *)list, o);
}

/* --runs in text: the runs as a Markdown table. */
static int print_runs(const char *dir)
{
    printf("\n| scene | split | n | training views | held-out PSNR / SSIM | training views PSNR / SSIM | clips | seconds |\n"
           "|---|---|---:|---:|---|---|---:|---:|\n");
    return for_each_run(dir, print_run, NULL);
}

/* The totals over every n (frame-weighted means, like each row's). */
static gv_dataset_stats_row total_row(const gv_dataset_stats *s)
{
    gv_dataset_stats_row t = {0};
    double seconds = 0;
    for (int i = 0; i < s->n_rows; i++) {
        const gv_dataset_stats_row *r = &s->rows[i];
        t.clips_train += r->clips_train, t.clips_eval += r->clips_eval, t.runs += r->runs;
        t.frames += r->frames;
        t.psnr += r->psnr * r->frames, t.ssim += r->ssim * r->frames;
        seconds += r->seconds * r->runs;
    }
    if (t.frames) t.psnr /= t.frames, t.ssim /= t.frames;
    if (t.runs) t.seconds = seconds / t.runs;
    return t;
}

static cJSON *row_json(const gv_dataset_stats_row *r, int with_n)
{
    cJSON *o = cJSON_CreateObject();
    if (with_n) cJSON_AddNumberToObject(o, "n", r->interval);
    cJSON_AddNumberToObject(o, "clips_train", r->clips_train);
    cJSON_AddNumberToObject(o, "clips_eval", r->clips_eval);
    cJSON_AddNumberToObject(o, "runs", r->runs);
    cJSON_AddNumberToObject(o, "frames", r->frames);
    cJSON_AddNumberToObject(o, "psnr", r->psnr);
    cJSON_AddNumberToObject(o, "ssim", r->ssim);
    cJSON_AddNumberToObject(o, "seconds_per_run", r->seconds);
    return o;
}

static int print_json(const char *dir, const gv_dataset_stats *s, int runs)
{
    cJSON *root = cJSON_CreateObject();
    cJSON_AddStringToObject(root, "dataset", dir);
    cJSON_AddItemToObject(root, "params", gv_dataset_params_json(&s->params)); /* as the manifest has them */
    cJSON_AddNumberToObject(root, "scenes", s->n_scenes);
    cJSON_AddNumberToObject(root, "runs", s->n_runs);
    cJSON_AddNumberToObject(root, "clips", s->n_clips);
    cJSON *rows = cJSON_AddArrayToObject(root, "per_n");
    for (int i = 0; i < s->n_rows; i++) cJSON_AddItemToArray(rows, row_json(&s->rows[i], 1));
    gv_dataset_stats_row t = total_row(s);
    cJSON_AddItemToObject(root, "all", row_json(&t, 0));
    if (runs && for_each_run(dir, add_run_json, cJSON_AddArrayToObject(root, "runs")) != 0) {
        cJSON_Delete(root);
        return -1;
    }
    char *text = cJSON_Print(root);
    cJSON_Delete(root);
    if (!text) return gv_fail("out of memory");
    printf("%s\n", text);
    free(text);
    return 0;
}

static void print_row(const char *n, const gv_dataset_stats_row *r)
{
    printf("%5s %12d %11d %5d %8d %14.2f %14.4f %8.1f\n", n, r->clips_train, r->clips_eval,
           r->runs, r->frames, r->psnr, r->ssim, r->seconds);
}

static void print_text(const char *dir, const gv_dataset_stats *s)
{
    printf("dataset %s: %d clips from %d runs of %d scenes\n", dir, s->n_clips, s->n_runs, s->n_scenes);
    char flags[GV_DATASET_FLAGS_MAX];
    gv_dataset_params_flags(&s->params, flags, sizeof flags);
    printf("built with %s\n\n", flags);
    printf("%5s %12s %11s %5s %8s %14s %14s %8s\n", "n", "clips train", "clips eval", "runs",
           "frames", "baseline PSNR", "baseline SSIM", "s/run");
    for (int i = 0; i < s->n_rows; i++) {
        char n[16];
        snprintf(n, sizeof n, "%d", s->rows[i].interval);
        print_row(n, &s->rows[i]);
    }
    gv_dataset_stats_row t = total_row(s);
    print_row("all", &t);
    printf("\nframes: held-out frames scored; baseline: mean PSNR (dB) and SSIM of their corrupted\n"
           "renders against the ground truth, over every frame of every scene at that n.\n");
}

int cmd_dataset_stats(int argc, char **argv)
{
    int json = 0, runs = 0;
    const gv_flag flags[] = {
        {"runs", GV_FLAG_BOOL, &runs, NULL,
         "also one row per (scene, n) run: held-out and training-view PSNR/SSIM, seconds", 0},
        {"json", GV_FLAG_BOOL, &json, NULL, "print JSON instead of a table", 0},
    };
    const gv_command_spec spec = {
        "dataset stats", "DIR", "clips per n and split, baseline PSNR/SSIM of the corrupted frames",
        "Reads DIR/manifest.json and the run records under DIR/runs/.", flags,
        sizeof flags / sizeof flags[0], 1, 1};
    char *positional[1];
    int n_positional;
    int parsed = gv_args_parse(&spec, argc, argv, positional, &n_positional);
    if (parsed != GV_ARGS_OK) return gv_args_exit_code(parsed);
    gv_dataset_stats *s = malloc(sizeof *s);
    if (!s) {
        gv_fail("out of memory");
        return gv_report_failure();
    }
    int rc = gv_dataset_stats_read(positional[0], s);
    if (rc == 0) {
        if (json) rc = print_json(positional[0], s, runs);
        else {
            print_text(positional[0], s);
            if (runs) rc = print_runs(positional[0]);
        }
    }
    free(s);
    return rc == 0 ? 0 : gv_report_failure();
}
