/* Object builders of the procedural scenes (synth_objects.c, synth_decor.c). Each adds the
 * parts of one object, in the frame f (x across its width, y towards its front, z up,
 * origin at the middle of its footprint on the floor), to the open group. */
#ifndef GAUSSVID_SCENE_SYNTH_OBJECTS_H
#define GAUSSVID_SCENE_SYNTH_OBJECTS_H

#include "synth/synth_internal.h"

typedef int (*sy_object_builder)(gv_synth_world *w, gv_rng *r, const sy_frame *f, double width, double depth);

int sy_build_table(gv_synth_world *w, gv_rng *r, const sy_frame *f, double width, double depth);
int sy_build_bookshelf(gv_synth_world *w, gv_rng *r, const sy_frame *f, double width, double depth);
int sy_build_cabinet(gv_synth_world *w, gv_rng *r, const sy_frame *f, double width, double depth);
int sy_build_sofa(gv_synth_world *w, gv_rng *r, const sy_frame *f, double width, double depth);
int sy_build_chair(gv_synth_world *w, gv_rng *r, const sy_frame *f, double width, double depth);
int sy_build_column(gv_synth_world *w, gv_rng *r, const sy_frame *f, double width, double depth);
int sy_build_pedestal(gv_synth_world *w, gv_rng *r, const sy_frame *f, double width, double depth);
int sy_build_barrel(gv_synth_world *w, gv_rng *r, const sy_frame *f, double width, double depth);
int sy_build_crates(gv_synth_world *w, gv_rng *r, const sy_frame *f, double width, double depth);
int sy_build_plant(gv_synth_world *w, gv_rng *r, const sy_frame *f, double width, double depth);
int sy_build_floor_lamp(gv_synth_world *w, gv_rng *r, const sy_frame *f, double width, double depth);
int sy_build_balls(gv_synth_world *w, gv_rng *r, const sy_frame *f, double width, double depth);
/* Vases, balls, bowls and book stacks on a surface at height z, within width x depth. */
int sy_things_on_top(gv_synth_world *w, gv_rng *r, const sy_frame *f, double width, double depth, double z);

#endif
