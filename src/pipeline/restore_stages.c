/* The restorer's stages of `reconstruct`: adapt (gaussvid adapt on the scene, by default) and
 * restore: every evaluated frame restored in 5-frame clips of the dataset's layout (clean
 * anchors at the two training views around it, three renders between; docs/FORMATS-DATASET.md),
 * written as clip files and restored as `gaussvid restore` restores them (restore.h). Where
 * the evidence says restoring would not help (a closed gate, or no adaptation possible on the
 * scene), restore does not run the network: the restored frames are copies of the renders. */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "gaussvid/restore/adapt.h"
#include "gaussvid/core/core.h"
#include "gaussvid/splat/coverage.h"
#include "gaussvid/data/internal_pairs.h"
#include "gaussvid/io/ply.h"
#include "gaussvid/restore/restore.h"
#include "gaussvid/train/scene_adapt.h"
#include "gaussvid/splat/splat_train.h"
#include "pipeline/pipeline_internal.h"

#define ADAPTED "restorer.safetensors" /* the scene checkpoint of --adapt, in DIR/nN */

void pipeline_plan_adaptation(pipeline_run *r, int scene_ckpt)
{
    r->adapt = 0, r->no_adapt[0] = 0;
    if (r->opt->restore_with != GV_RESTORE_ADAPTED) return;
    if (scene_ckpt) return; /* adapted already: its own gate decides */
    if (r->smooth_path)
        snprintf(r->no_adapt, sizeof r->no_adapt, "every view trains (n = 1), so no view is left to pair with");
    else if (gv_internal_check(r->scene->n_frames, r->interval))
        snprintf(r->no_adapt, sizeof r->no_adapt, "%s", gv_last_error());
    else
        r->adapt = 1;
}

/* The checkpoint restore uses: the adapted one when the adapt stage runs, else --ckpt. */
static int restorer_path(pipeline_run *r)
{
    if (!r->adapt) {
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
    a.interval = r->interval;
    a.base = r->opt->ckpt;
    a.out = r->restorer;
    a.work_dir = NULL;
    a.downscale = r->opt->downscale;
    a.iters = r->opt->iters;
    /* the internal pairs keep the paper's artifact simulation (plain 3DGS, the reference's
     * density control), whatever model the user's sparse 3DGS is: the restorer learned on those */
    a.densify = GV_DENSIFY_REFERENCE;
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
    info.id.interval = r->smooth_path ? 4 : r->interval; /* a path's frames are numbered 4k + j */
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

/* Whether restore runs the network, from one open of the restorer (its weights read only when
 * they will restore: no gate, or an open one): 1 with net loaded, or 0 with why in words (the
 * renders are kept: the adaptation could not run, or the scene checkpoint's gate is closed);
 * -1 on error. Records the run's gate and "restorer"; the caller frees net. */
static int open_restorer(pipeline_run *r, gv_restorer *net, char *why, size_t size)
{
    why[0] = 0;
    if (r->no_adapt[0]) {
        pipeline_decision_gate(r, NULL);
        return snprintf(why, size, "adaptation cannot run here"), 0;
    }
    if (restorer_path(r) || gv_restorer_open(r->restorer, GV_RESTORER_NETWORK_IF_GATE_OPEN, net)) return -1;
    int closed = net->scene && !net->adaptation.gate_open;
    if (closed)
        snprintf(why, size, "the gate is closed (held-back pairs %+.2f dB when restored)",
                 gv_scene_gate_change(&net->adaptation));
    pipeline_decision_gate(r, net->scene ? (closed ? "closed" : "open") : NULL);
    cJSON_DeleteItemFromObject(r->run, "restorer");
    cJSON_AddItemToObject(r->run, "restorer", pipeline_restorer_json(r->restorer, net, 0));
    return !closed;
}

/* Copies the file src to dst, atomically. */
static int copy_path(const char *src, const char *dst)
{
    char *data = NULL;
    size_t size = 0;
    if (gv_read_file(src, &data, &size)) return -1;
    gv_atomic_file af;
    int rc = gv_atomic_open(&af, dst);
    if (rc == 0 && fwrite(data, 1, size, af.f) != size) {
        gv_atomic_abort(&af);
        rc = gv_fail("%s: cannot write", dst);
    } else if (rc == 0) {
        rc = gv_atomic_commit(&af);
    }
    free(data);
    return rc;
}

int pipeline_copy_file(pipeline_run *r, const char *from, const char *to)
{
    char src[4200], dst[4200];
    if (pipeline_file(r, from, src, sizeof src) || pipeline_file(r, to, dst, sizeof dst)) return -1;
    return copy_path(src, dst);
}

int pipeline_copy_frames(pipeline_run *r, const char *from, const char *to)
{
    char name[64], dir[4200];
    snprintf(name, sizeof name, "frames/%s", to);
    if (pipeline_file(r, name, dir, sizeof dir) || gv_mkdirs(dir)) return -1;
    for (int i = 0; i < r->n_frames; i++) {
        char a[4200], b[4200];
        if (pipeline_frame_path(r, from, r->frames[i].index, a, sizeof a) ||
            pipeline_frame_path(r, to, r->frames[i].index, b, sizeof b) || copy_path(a, b))
            return -1;
    }
    return 0;
}

int pipeline_restore(pipeline_run *r)
{
    char why[700];
    gv_restorer net;
    memset(&net, 0, sizeof net);
    int decision = open_restorer(r, &net, why, sizeof why);
    if (decision < 0) return -1;
    pipeline_decision(r, "restoration", decision, decision ? NULL : why);
    if (decision == 0) { /* not run for nothing: the renders pass through */
        gv_restorer_free(&net);
        snprintf(r->summary, sizeof r->summary, "skipped: %s%s%s; the restored frames are the renders", why,
                 r->no_adapt[0] ? " because " : "", r->no_adapt);
        return pipeline_copy_frames(r, "render", "restored");
    }
    char clips_dir[4200], restored_dir[4200];
    if (pipeline_file(r, "clips", clips_dir, sizeof clips_dir) ||
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
    /* a scene checkpoint restores as its gate measured: with its composition */
    if (rc == 0 && net.scene && gv_adapt_gate_compose(&net.adaptation, &ro.compose)) rc = -1;
    if (rc == 0) rc = gv_restore_files(&net, names, r->n_clips, &ro);
    if (rc == 0) {
        char sampler[256];
        gv_sampler_describe(&ro.sampler, sampler, sizeof sampler);
        snprintf(r->summary, sizeof r->summary, "%d clips restored with %s (%s, %s composition)%s", r->n_clips,
                 r->restorer, sampler, gv_compose_name(ro.compose),
                 net.scene ? ": the gate is open" : ", ungated (--restore-with checkpoint)");
    }
    gv_restorer_free(&net);
    free(paths), free(names);
    return rc;
}
