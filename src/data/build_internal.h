/* Shared by build.c (the loop over runs) and build_run.c (one run). */
#ifndef GAUSSVID_DATA_BUILD_INTERNAL_H
#define GAUSSVID_DATA_BUILD_INTERNAL_H

#include "gaussvid/dataset.h"

/* One (scene, n) run of `dataset build`. */
typedef struct {
    const gv_scene *scene;
    gv_run_id id;                     /* the scene's name, its split, n */
    const gv_dataset_params *params;
    const gv_artifact_simulator *simulator;
    const char *out_dir;
} data_run;

/* Trains, renders and measures every held-out frame, writes the clips and the run record,
 * then adds the run to m and rewrites the manifest (the commit point). *record receives
 * what was measured (free with gv_run_record_free). */
int data_build_run(const data_run *run, gv_manifest *m, gv_run_record *record);

#endif
