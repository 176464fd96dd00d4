/* `mpirun -np K gaussvid dataset build` (docs/DISTRIBUTED.md): each rank builds its share of
 * the runs into the same folder; the runs of ranks other than 0 are committed to the manifest
 * here, by rank 0, once all ranks are done. The manifest is kept sorted (manifest.c), so it
 * does not depend on which rank built which run. */
#include <stdlib.h>
#include <string.h>

#include "data/build_internal.h"
#include "gaussvid/core/dist.h"

/* A rank's runs as bytes: per run its manifest entry, then its clips' entries (the ranks run
 * the same program on the same kind of machine: the structures travel as they are). */
static int pack_runs(const gv_manifest *m, const gv_run_id *ids, int n_ids, char **out, size_t *bytes)
{
    size_t size = 0;
    for (int k = 0; k < n_ids; k++) {
        int r = gv_manifest_find_run(m, ids[k].scene, ids[k].interval);
        if (r < 0) return gv_fail("%s n=%d: built but not in this rank's manifest", ids[k].scene, ids[k].interval);
        size += sizeof(gv_manifest_run) + (size_t)m->runs[r].n_clips * sizeof(gv_manifest_clip);
    }
    char *p = *out = malloc(size + 1);
    if (!p) return gv_fail("out of memory for the entries of %d runs", n_ids);
    for (int k = 0; k < n_ids; k++) {
        const gv_manifest_run *run = &m->runs[gv_manifest_find_run(m, ids[k].scene, ids[k].interval)];
        memcpy(p, run, sizeof *run), p += sizeof *run;
        for (int i = 0; i < m->n_clips; i++)
            if (m->clips[i].id.interval == run->id.interval && !strcmp(m->clips[i].id.scene, run->id.scene))
                memcpy(p, &m->clips[i], sizeof m->clips[i]), p += sizeof m->clips[i];
    }
    *bytes = size;
    return 0;
}

/* Rank 0: adds the runs packed in [p, end) to m. */
static int unpack_runs(const char *p, const char *end, gv_manifest *m, int *added)
{
    gv_manifest_clip *clips = NULL;
    int rc = 0;
    while (rc == 0 && p < end) {
        gv_manifest_run run;
        if ((size_t)(end - p) < sizeof run) return gv_fail("a rank sent a truncated run entry");
        memcpy(&run, p, sizeof run), p += sizeof run;
        size_t bytes = (size_t)run.n_clips * sizeof *clips;
        if (run.n_clips < 0 || (size_t)(end - p) < bytes) return gv_fail("a rank sent truncated clip entries");
        gv_manifest_clip *grown = realloc(clips, bytes + 1);
        if (!grown) rc = gv_fail("out of memory for %d clip entries", run.n_clips);
        else {
            clips = grown;
            memcpy(clips, p, bytes), p += bytes;
            rc = gv_manifest_add_run(m, &run, clips, run.n_clips);
            (*added)++;
        }
    }
    free(clips);
    return rc;
}

int data_merge_ranks(const char *out_dir, gv_manifest *m, const gv_run_id *built, int n_built,
                     gv_dataset_build_result *result)
{
    if (gv_dist_size() < 2) return 0;
    char *mine = NULL, *all = NULL;
    size_t bytes = 0, *sizes = NULL;
    int rc = gv_dist_is_root() ? 0 : pack_runs(m, built, n_built, &mine, &bytes);
    if (rc == 0) rc = gv_dist_gather(mine ? mine : "", bytes, &all, &sizes);
    free(mine);
    double counts[2] = {gv_dist_is_root() ? 0 : result->runs_built, gv_dist_is_root() ? 0 : result->clips_written};
    if (rc == 0) rc = gv_dist_sum_doubles(counts, 2);
    if (rc == 0 && gv_dist_is_root()) {
        int added = 0;
        size_t at = sizes[0];
        for (int r = 1; rc == 0 && r < gv_dist_size(); at += sizes[r], r++)
            rc = unpack_runs(all + at, all + at + sizes[r], m, &added);
        if (rc == 0 && added) rc = gv_manifest_write(out_dir, m);
        result->runs_built += (int)counts[0];
        result->clips_written += (int)counts[1];
    }
    free(all), free(sizes);
    return rc;
}
