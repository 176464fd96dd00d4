/* Shared by build.c (the loop over runs) and build_run.c (one run). */
#ifndef GAUSSVID_DATA_BUILD_INTERNAL_H
#define GAUSSVID_DATA_BUILD_INTERNAL_H

#include "gaussvid/data/dataset.h"

/* One (scene, n) run of `dataset build`. */
typedef struct {
    const gv_scene *scene;
    gv_run_id id;                     /* the scene's name, its split, n */
    const gv_dataset_params *params;
    const gv_artifact_simulator *simulator;
    const char *out_dir;
    int write_manifest;               /* 0: add the run to m only (ranks other than 0) */
} data_run;

/* Trains, renders and measures every held-out frame, writes the clips and the run record,
 * then adds the run to m and rewrites the manifest (the commit point). *record receives
 * what was measured (free with gv_run_record_free). */
/* The dataset folder, its clips/ and runs/, made if missing and swept of the temporaries an
 * interrupted build left (said when any). */
int data_prepare_out_dir(const char *out);
int data_build_run(const data_run *run, gv_manifest *m, gv_run_record *record);

/* build_ranks.c: under mpirun, rank 0 adds to m the runs the other ranks built (built: this
 * rank's, n_built of them), writes the manifest and adds their counts to result. Every rank
 * calls it once its own runs are done; one process: nothing to do. */
int data_merge_ranks(const char *out_dir, gv_manifest *m, const gv_run_id *built, int n_built,
                     gv_dataset_build_result *result);

#endif
