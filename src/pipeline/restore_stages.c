/* The restorer's stages of `reconstruct`: adapt (gaussvid adapt on the scene, with --adapt)
 * and restore: every evaluated frame restored in 5-frame clips of the dataset's layout (clean
 * anchors at the two training views around it, three renders between; docs/FORMATS-DATASET.md),
 * written as clip files and restored as `gaussvid restore` restores them (restore.h). */
#include <stdlib.h>
#include <string.h>

#include "gaussvid/adapt.h"
#include "gaussvid/core.h"
#include "gaussvid/coverage.h"
#include "gaussvid/ply.h"
#include "gaussvid/restore.h"
#include "gaussvid/scene_adapt.h"
#include "pipeline/pipeline_internal.h"

#define ADAPTED "restorer.safetensors" /* the scene checkpoint of --adapt, in DIR/nN */

/* The checkpoint restore uses: the adapted one with --adapt, else --ckpt. */
static int restorer_path(pipeline_run *r)
{
    if (!r->opt->adapt) {
        snprintf(r->restorer, sizeof r->restorer, "%s", r->opt->ckpt);
        return 0;
    }
    return pipeline_file(r, ADAPTED, r->restorer, sizeof r->restorer);
}

int pipeline_adapt(pipeline_run *r)
{
    gv_adapt_options a = r->opt->adapt_options;
    if (restorer_path(r)) return -1;
    a.scene_dir = r->opt->scene_dir;
    a.interval = r->n;
    a.base = r->opt->ckpt;
    a.out = r->restorer;
    a.work_dir = NULL;
    a.downscale = r->opt->downscale;
    a.iters = r->opt->iters;
    a.densify = r->opt->densify; /* the internal pairs' 3DGS as the sparse model's */
    gv_adapt_report rep;
    if (gv_adapt_scene(&a, &rep)) return -1;
    if (!rep.done) return gv_fail("%s: the adaptation stopped before its end", r->restorer);
    snprintf(r->summary, sizeof r->summary, "%s: gate %s (held-back pairs %+.2f dB when restored)", r->restorer,
             rep.adaptation.gate_open ? "open" : "closed", gv_scene_gate_change(&rep.adaptation));
    return 0;
}

/* The frame number of a clip entry: an evaluated frame's index, or for an anchor (-1 - k,
 * training view k) its scene frame, on a path 4k. */
static int clip_frame_index(const pipeline_run *r, int entry)
{
    if (entry >= 0) return r->frames[entry].index;
    int k = -1 - entry;
    return r->smooth_path ? 4 * k : r->train[k];
}

/* Clip c as a clip file: anchors the ground truth of the training views, intermediates the
 * renders; their targets the ground truth (held-out) or, on a path, the renders again (no
 * ground truth there; nothing reads them); its coverage plane from the sparse model's depth,
 * as `dataset build` computes it (the coverage variant and the unseen composition read it). */
static int write_clip(pipeline_run *r, const gv_gaussians *sparse, int c, const char *path)
{
    const int *entries = r->clips[c];
    const gv_camera *cams[GV_CLIP_FRAMES];
    gv_image owned[2 * GV_CLIP_FRAMES];
    const gv_image *inputs[GV_CLIP_FRAMES], *targets[GV_CLIP_FRAMES];
    int frames[GV_CLIP_FRAMES], rc = 0;
    memset(owned, 0, sizeof owned);
    for (int i = 0; i < GV_CLIP_FRAMES && rc == 0; i++) {
        int e = entries[i];
        frames[i] = clip_frame_index(r, e);
        if (e < 0) { /* an anchor: a training view's ground truth */
            int scene_frame = r->train[-1 - e];
            cams[i] = &r->scene->cameras[scene_frame];
            rc = gv_scene_load_image(r->scene, scene_frame, &owned[i]);
            inputs[i] = targets[i] = &owned[i];
            continue;
        }
        const pipeline_frame *f = &r->frames[e];
        char png[4200];
        cams[i] = &f->camera;
        rc = pipeline_frame_path(r, "render", f->index, png, sizeof png) || gv_image_read_rgb(png, &owned[i]);
        inputs[i] = &owned[i];
        if (rc == 0 && f->truth >= 0) {
            rc = gv_scene_load_image(r->scene, f->truth, &owned[GV_CLIP_FRAMES + i]);
            targets[i] = &owned[GV_CLIP_FRAMES + i];
        } else {
            targets[i] = &owned[i];
        }
    }
    gv_clip_info info;
    memset(&info, 0, sizeof info);
    snprintf(info.id.scene, sizeof info.id.scene, "%s", r->scene_name);
    snprintf(info.id.split, sizeof info.id.split, "eval");
    info.id.n = r->smooth_path ? 4 : r->n; /* a path's frames are numbered 4k + j */
    info.anchor_gap = 1;
    info.iters = r->opt->iters;
    info.sampling = GV_SAMPLING_UNIFORM;
    info.seed = r->opt->seed;
    info.width = owned[0].width, info.height = owned[0].height;
    gv_clip clip = {0};
    if (rc == 0) rc = gv_clip_alloc(&clip, &info);
    if (rc == 0)
        rc = gv_clip_fill(&clip, frames, inputs, targets, cams) ||
             gv_clip_coverage_gaussians(&clip, sparse, cams, GV_COVERAGE_TOLERANCE, GV_COVERAGE_MIN_OPACITY) ||
             gv_clip_write(path, &clip);
    gv_clip_free(&clip);
    for (int i = 0; i < 2 * GV_CLIP_FRAMES; i++) gv_image_free(&owned[i]);
    return rc ? gv_fail_context("%s: clip %d", r->dir, c) : 0;
}

/* gv_restore_options.each: the restored intermediates this clip owns, as PNGs. Clips arrive
 * in the order of the paths. */
typedef struct {
    pipeline_run *run;
    int next;
} restored_writer;

static int write_restored(void *ctx, const gv_clip *clip, const uint8_t *restored, char *note, size_t size)
{
    restored_writer *w = ctx;
    pipeline_run *r = w->run;
    int c = w->next++;
    for (int slot = 1; slot <= 3; slot++) {
        const pipeline_frame *f = &r->frames[r->clips[c][slot]];
        if (f->clip != c) continue; /* an earlier clip of the gap restored it */
        gv_image img = {clip->info.width, clip->info.height, 3,
                        gv_clip_frame((uint8_t *)restored, &clip->info, slot)};
        char path[4200];
        if (pipeline_frame_path(r, "restored", f->index, path, sizeof path) || gv_image_write_png(path, &img))
            return -1;
    }
    snprintf(note, size, "clip %d", c);
    return 0;
}

int pipeline_restore(pipeline_run *r)
{
    char clips_dir[4200], restored_dir[4200];
    if (restorer_path(r) || pipeline_file(r, "clips", clips_dir, sizeof clips_dir) ||
        pipeline_file(r, "frames/restored", restored_dir, sizeof restored_dir) || gv_mkdirs(clips_dir) ||
        gv_mkdirs(restored_dir))
        return -1;
    char (*paths)[4300] = calloc((size_t)r->n_clips, sizeof *paths);
    const char **names = calloc((size_t)r->n_clips, sizeof *names);
    int rc = paths && names ? 0 : gv_fail("out of memory for %d clips", r->n_clips);
    char sparse_path[4200];
    gv_gaussians sparse;
    memset(&sparse, 0, sizeof sparse);
    if (rc == 0)
        rc = pipeline_file(r, "sparse.ply", sparse_path, sizeof sparse_path) || gv_gaussians_read_ply(sparse_path, &sparse);
    for (int c = 0; c < r->n_clips && rc == 0; c++) {
        snprintf(paths[c], sizeof paths[c], "%s/clip_%04d.safetensors", clips_dir, c);
        names[c] = paths[c];
        rc = write_clip(r, &sparse, c, paths[c]);
    }
    gv_gaussians_free(&sparse);
    gv_restore_options ro;
    memset(&ro, 0, sizeof ro);
    ro.sampler = gv_sampler_default();
    ro.sampler.seed = r->opt->seed;
    ro.compose = GV_COMPOSE_RESIDUAL;
    restored_writer writer = {r, 0};
    ro.each = write_restored, ro.each_ctx = &writer;
    gv_restorer net; /* one open: the record always, the weights unless a closed gate keeps the renders */
    memset(&net, 0, sizeof net);
    if (rc == 0) rc = gv_restorer_open(r->restorer, GV_RESTORER_NETWORK_IF_GATE_OPEN, &net);
    /* a scene checkpoint restores as its gate measured: with its composition */
    if (rc == 0 && net.scene && gv_adapt_gate_compose(&net.adaptation, &ro.compose)) rc = -1;
    ro.keep_renders = rc == 0 && net.scene && !net.adaptation.gate_open;
    if (rc == 0) rc = gv_restore_files(ro.keep_renders ? NULL : &net, names, r->n_clips, &ro);
    if (rc == 0) {
        cJSON_DeleteItemFromObject(r->run, "restorer");
        cJSON_AddItemToObject(r->run, "restorer", pipeline_restorer_json(r->restorer, &net, 0));
        char sampler[256];
        gv_sampler_describe(&ro.sampler, sampler, sizeof sampler);
        if (ro.keep_renders)
            snprintf(r->summary, sizeof r->summary, "%d clips: the scene checkpoint's gate is closed, so the renders "
                     "are kept unchanged", r->n_clips);
        else
            snprintf(r->summary, sizeof r->summary, "%d clips restored with %s (%s, %s composition)", r->n_clips,
                     r->restorer, sampler, gv_compose_name(ro.compose));
    }
    gv_restorer_free(&net);
    free(paths), free(names);
    return rc;
}
