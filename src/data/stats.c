/* `dataset stats`: clips per n and split, and the baseline quality of the corrupted renders
 * per n (the mean over every held-out frame of every scene at that n, from the run records),
 * which should fall as n grows (paper section 3.2: larger n, stronger artifacts). */
#include <string.h>

#include "gaussvid/data/dataset.h"

static gv_dataset_stats_row *row_of(gv_dataset_stats *s, int n)
{
    for (int i = 0; i < s->n_rows; i++)
        if (s->rows[i].interval == n) return &s->rows[i];
    if (s->n_rows == GV_MAX_INTERVALS) return NULL;
    int at = s->n_rows++;
    while (at > 0 && s->rows[at - 1].interval > n) { s->rows[at] = s->rows[at - 1]; at--; }
    memset(&s->rows[at], 0, sizeof s->rows[at]);
    s->rows[at].interval = n;
    return &s->rows[at];
}

/* Adds a run's record (frame-weighted sums, finished below). */
static int add_record(const char *dir, const gv_manifest_run *run, gv_dataset_stats_row *row)
{
    char file[GV_SCENE_NAME_MAX + 32], path[4096];
    gv_run_record rec;
    if (gv_run_file_name(file, sizeof file, run->id.scene, run->id.interval) != 0 ||
        gv_path_join(path, sizeof path, dir, file) != 0 || gv_run_record_read(path, &rec) != 0)
        return -1;
    int rc = 0;
    if (strcmp(rec.id.scene, run->id.scene) || rec.id.interval != run->id.interval)
        rc = gv_fail("%s: holds %s n=%d, the manifest expects %s n=%d", path, rec.id.scene, rec.id.interval,
                     run->id.scene, run->id.interval);
    row->runs++;
    row->frames += rec.n_held_out;
    row->psnr += rec.psnr_mean * rec.n_held_out;
    row->ssim += rec.ssim_mean * rec.n_held_out;
    row->seconds += rec.seconds;
    gv_run_record_free(&rec);
    return rc;
}

int gv_dataset_stats_read(const char *dir, gv_dataset_stats *out)
{
    memset(out, 0, sizeof *out);
    gv_manifest m;
    if (gv_manifest_read_dataset(dir, &m) != 0) return -1;
    out->params = m.params;
    out->n_runs = m.n_runs;
    out->n_clips = m.n_clips;
    int rc = 0;
    for (int i = 0; i < m.n_runs && rc == 0; i++) {
        gv_dataset_stats_row *row = row_of(out, m.runs[i].id.interval);
        if (!row) rc = gv_fail("%s: more than %d intervals", dir, GV_MAX_INTERVALS);
        else rc = add_record(dir, &m.runs[i], row);
        int seen = 0; /* count each scene once */
        for (int j = 0; j < i; j++) seen |= !strcmp(m.runs[j].id.scene, m.runs[i].id.scene);
        out->n_scenes += !seen;
    }
    for (int i = 0; i < m.n_clips && rc == 0; i++) {
        gv_dataset_stats_row *row = row_of(out, m.clips[i].id.interval);
        if (!row) rc = gv_fail("%s: more than %d intervals", dir, GV_MAX_INTERVALS);
        else if (!strcmp(m.clips[i].id.split, "eval")) row->clips_eval++;
        else row->clips_train++;
    }
    for (int i = 0; i < out->n_rows; i++) {
        gv_dataset_stats_row *row = &out->rows[i];
        if (row->frames) row->psnr /= row->frames, row->ssim /= row->frames;
        if (row->runs) row->seconds /= row->runs;
    }
    gv_manifest_free(&m);
    return rc;
}
