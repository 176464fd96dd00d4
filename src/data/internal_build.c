/* Building the scene-internal clips (internal_pairs.h; docs/FORMATS-DATASET.md): the artifact
 * simulator trained on each subset of the training views, its renders of the views it did not
 * see, written as clips of a dataset folder; or, for the do-no-harm clips, the same clips'
 * frames rendered by the simulator trained on every training view. Images are read only for
 * training views at n: the held-out frames are rendered, never read. */
#include <stdlib.h>
#include <string.h>

#include "gaussvid/core/core.h"
#include "gaussvid/data/internal_pairs.h"
#include "gaussvid/io/metrics.h"
#include "gaussvid/splat/splat_train.h"
#include "data/build_internal.h"

#define SUBSET_SEED 0x9E3779B97F4A7C15ull /* subset j trains with the run seed ^ (j * this) */

typedef struct {
    const gv_scene *scene;
    const gv_internal_options *o;
    const gv_artifact_simulator *sim;
    char name[GV_SCENE_NAME_MAX];
    gv_internal_clip *clips;
    int count;
    int subsets;                     /* K */
    int runs;                        /* subsets that leave out an interior view: min(K, T - 2) */
    gv_dataset_params params;
} build_ctx;

/* K as the files record it: only for pairs of other than the default 2 subsets (older folders
 * read as 2), never for the do-no-harm clips, which one model renders. */
static int recorded_subsets(const gv_internal_options *o, int subsets)
{
    return o->full_model || subsets == GV_INTERNAL_SUBSETS ? 0 : subsets;
}

/* The metadata of a planned clip. */
static void clip_info(const build_ctx *b, const gv_internal_clip *c, gv_clip_info *info)
{
    const gv_camera *cams = b->scene->cameras;
    memset(info, 0, sizeof *info);
    snprintf(info->id.scene, sizeof info->id.scene, "%s", b->name);
    snprintf(info->id.split, sizeof info->id.split, "train");
    info->id.interval = 2 * b->o->interval; /* the window's: the do-no-harm clips keep the pairs' metadata */
    info->anchor_gap = 1;
    info->iters = b->o->iters;
    info->sampling = GV_SAMPLING_UNIFORM;
    info->seed = b->o->seed;
    info->width = cams[c->frames[0]].width;
    info->height = cams[c->frames[0]].height;
    info->offset = (c->view - 1) % 2 * b->o->interval; /* the window's first anchor mod 2n */
    info->subsets = b->params.subsets;
    for (int f = 0; f < GV_CLIP_FRAMES; f++) {
        info->frames[f] = c->frames[f];
        snprintf(info->frame_names[f], sizeof info->frame_names[f], "%s", cams[c->frames[f]].name);
    }
    info->no_target[1] = info->no_target[3] = 1; /* held-out frames of the scene */
}

static int clip_path(const build_ctx *b, int i, char *file, size_t file_size, char *path, size_t size)
{
    if (gv_clip_file_name(file, file_size, b->name, 2 * b->o->interval, i)) return -1;
    return gv_path_join(path, size, b->o->out_dir, file);
}

/* 1 when clip i exists and was written by these options (it is then kept). */
static int clip_present(const build_ctx *b, int i)
{
    char file[GV_SCENE_NAME_MAX + 64], path[4096];
    gv_clip_info want, have;
    if (clip_path(b, i, file, sizeof file, path, sizeof path) || !gv_file_exists(path)) return 0;
    clip_info(b, &b->clips[i], &want);
    if (gv_clip_read_info(path, &have)) {
        gv_clear_error();
        return 0;
    }
    return !strcmp(have.id.scene, want.id.scene) && have.id.interval == want.id.interval && have.offset == want.offset &&
           have.subsets == want.subsets &&
           have.iters == want.iters && have.seed == want.seed && have.width == want.width &&
           have.height == want.height && !memcmp(have.frames, want.frames, sizeof want.frames) &&
           !memcmp(have.no_target, want.no_target, sizeof want.no_target) &&
           (have.has_coverage || !b->o->coverage); /* from before the coverage plane: rebuilt when needed */
}

static int fits(const gv_image *img, const gv_clip_info *info)
{
    return img->width == info->width && img->height == info->height && img->channels == 3;
}

/* Clip i from the model of a subset or of every view: clean anchors, the renders of frames 1-3
 * as inputs, the middle frame's ground truth as its target; the masked frames' targets repeat
 * their inputs; the coverage plane by that model's depth when the simulator renders depth. */
static int write_clip(const build_ctx *b, void *model, int i)
{
    const gv_internal_clip *c = &b->clips[i];
    gv_clip_info info;
    gv_clip clip;
    clip_info(b, c, &info);
    if (gv_clip_alloc(&clip, &info)) return -1;
    size_t bytes = (size_t)info.width * info.height * 3;
    int rc = 0;
    for (int f = 0; rc == 0 && f < GV_CLIP_FRAMES; f++) {
        int frame = c->frames[f], anchor = f == 0 || f == GV_CLIP_FRAMES - 1, has_truth = anchor || f == 2;
        gv_image truth = {0}, render = {0};
        if (has_truth) rc = gv_scene_load_image(b->scene, frame, &truth);
        if (rc == 0 && !anchor) rc = b->sim->render(b->sim->ctx, model, b->scene, frame, &render);
        const gv_image *input = anchor ? &truth : &render, *target = has_truth ? &truth : &render;
        if (rc == 0 && (!fits(input, &info) || !fits(target, &info)))
            rc = gv_fail("%s: frame %d is not %dx%d RGB like the clip's first frame: a clip needs one size", b->name,
                         frame, info.width, info.height);
        if (rc == 0) {
            memcpy(gv_clip_frame(clip.inputs, &info, f), input->pixels, bytes);
            memcpy(gv_clip_frame(clip.targets, &info, f), target->pixels, bytes);
            gv_clip_set_camera(&clip, f, &b->scene->cameras[frame]);
        }
        gv_image_free(&truth), gv_image_free(&render);
    }
    if (rc == 0 && b->sim->depth) rc = gv_clip_coverage_simulated(&clip, b->sim, model, b->scene, c->frames);
    char file[GV_SCENE_NAME_MAX + 64], path[4096];
    if (rc == 0) rc = clip_path(b, i, file, sizeof file, path, sizeof path);
    if (rc == 0) rc = gv_clip_write(path, &clip);
    gv_clip_free(&clip);
    return rc ? gv_fail_context("%s: internal clip of view %d", b->name, c->view) : 0;
}

/* 1 when clip i is rendered by the model of pass p (subset p; the full model renders every
 * clip in its one pass). */
static int in_pass(const build_ctx *b, int i, int p) { return b->o->full_model || b->clips[i].subset == p; }

/* "0, 6, 12 and 18" or "0, 6, ..., 30" of a list of frames. */
static void describe_views(const int *v, int count, char *out, size_t size)
{
    if (count <= 4) {
        int used = 0;
        for (int i = 0; i < count && used < (int)size; i++)
            used += snprintf(out + used, size - used, "%s%d", i == 0 ? "" : i == count - 1 ? " and " : ", ", v[i]);
    } else
        snprintf(out, size, "%d, %d, ..., %d", v[0], v[1], v[count - 1]);
}

/* Trains the model of pass p (subset p, or the full model) and writes its clips. */
static int build_subset(const build_ctx *b, int p)
{
    int n = b->o->interval, *views = malloc(2 * (size_t)b->scene->n_frames * sizeof *views), n_views = 0, clips = 0;
    if (!views) return gv_fail("out of memory for %d frames", b->scene->n_frames);
    if (b->o->full_model) {
        for (int f = 0; f < b->scene->n_frames; f += n) views[n_views++] = f;
    } else if (gv_internal_subset_views(b->scene->n_frames, n, b->subsets, p, views, &n_views)) {
        free(views);
        return -1;
    }
    int *left_out = views + b->scene->n_frames; /* the frames this model renders with ground truth */
    for (int i = 0; i < b->count; i++)
        if (in_pass(b, i, p)) left_out[clips++] = b->clips[i].frames[2];
    char list[96], rendered[96], what[96];
    describe_views(views, n_views, list, sizeof list);
    describe_views(left_out, clips, rendered, sizeof rendered);
    if (b->o->full_model) snprintf(what, sizeof what, "do-no-harm clips: %s, the full model", b->name);
    else snprintf(what, sizeof what, "internal pairs: %s subset %d of %d", b->name, p + 1, b->runs);
    gv_info("%s (views %s: %d views), %d clip%s (view%s %s)", what, list, n_views, clips, clips == 1 ? "" : "s",
            clips == 1 ? "" : "s", rendered);
    /* the full model: the seed `dataset build` would give the user's model at n */
    uint64_t seed = b->o->full_model ? gv_run_seed(b->o->seed, b->name, n)
                                     : gv_run_seed(b->o->seed, b->name, 2 * n) ^ ((uint64_t)p * SUBSET_SEED);
    void *model = NULL;
    int rc = b->sim->train(b->sim->ctx, b->scene, views, n_views, b->o->iters, b->o->densify, seed, &model);
    free(views);
    if (rc) return gv_fail_context("%s: %s", what, b->sim->name);
    for (int i = 0; rc == 0 && i < b->count; i++)
        if (in_pass(b, i, p)) rc = write_clip(b, model, i);
    b->sim->free_model(b->sim->ctx, model);
    return rc;
}

/* The run record, from the clips: the left-out views' renders against their ground truth. */
static int make_record(const build_ctx *b, gv_run_record *rec)
{
    memset(rec, 0, sizeof *rec);
    if (gv_run_record_alloc(rec, b->count)) return -1;
    snprintf(rec->id.scene, sizeof rec->id.scene, "%s", b->name);
    snprintf(rec->id.split, sizeof rec->id.split, "train");
    rec->id.interval = 2 * b->o->interval;
    rec->iters = b->o->iters;
    rec->n_train = gv_internal_views(b->scene->n_frames, b->o->interval);
    rec->n_clips = b->count;
    for (int i = 0; i < b->count; i++) {
        char file[GV_SCENE_NAME_MAX + 64], path[4096];
        gv_clip clip;
        if (clip_path(b, i, file, sizeof file, path, sizeof path) || gv_clip_read(path, &clip)) return -1;
        const gv_clip_info *info = &clip.info;
        gv_image render = {info->width, info->height, 3, gv_clip_frame(clip.inputs, info, 2)};
        gv_image truth = {info->width, info->height, 3, gv_clip_frame(clip.targets, info, 2)};
        rec->held_out[i] = b->clips[i].frames[2];
        int rc = gv_image_psnr_ssim(&render, &truth, &rec->psnr[i], &rec->ssim[i]);
        gv_clip_free(&clip);
        if (rc) return gv_fail_context("%s", path);
    }
    gv_run_record_summarise(rec);
    return 0;
}

/* Writes the record and the manifest (the commit point). */
static int commit(const build_ctx *b, gv_run_record *rec, double seconds)
{
    char name[GV_SCENE_NAME_MAX + 32], path[4096];
    rec->seconds = seconds;
    if (gv_run_file_name(name, sizeof name, b->name, 2 * b->o->interval) ||
        gv_path_join(path, sizeof path, b->o->out_dir, name) || gv_run_record_write(path, rec))
        return -1;
    gv_manifest m;
    gv_manifest_init(&m, &b->params);
    gv_manifest_run run = {.id.interval = 2 * b->o->interval, .n_clips = b->count, .seconds = seconds};
    snprintf(run.id.scene, sizeof run.id.scene, "%s", b->name);
    snprintf(run.id.split, sizeof run.id.split, "train");
    gv_manifest_clip *entries = calloc((size_t)b->count, sizeof *entries);
    int rc = entries ? 0 : gv_fail("out of memory for %d clips", b->count);
    for (int i = 0; rc == 0 && i < b->count; i++) {
        gv_manifest_clip *e = &entries[i];
        rc = gv_clip_file_name(e->file, sizeof e->file, b->name, run.id.interval, i);
        snprintf(e->id.scene, sizeof e->id.scene, "%s", b->name);
        snprintf(e->id.split, sizeof e->id.split, "train");
        e->id.interval = run.id.interval;
        memcpy(e->frames, b->clips[i].frames, sizeof e->frames);
    }
    if (rc == 0) rc = gv_manifest_add_run(&m, &run, entries, b->count);
    if (rc == 0) rc = gv_manifest_write(b->o->out_dir, &m);
    free(entries);
    gv_manifest_free(&m);
    return rc;
}

/* 1 when the folder's manifest already lists this build complete; fails when the folder holds
 * another build. */
static int already_built(const build_ctx *b)
{
    gv_manifest m;
    int found = 0;
    if (gv_manifest_read(b->o->out_dir, &m, &found)) return -1;
    if (!found) return 0;
    const gv_dataset_params *p = &m.params, *q = &b->params;
    int same = m.n_runs == 1 && !strcmp(m.runs[0].id.scene, b->name) && m.runs[0].id.interval == 2 * b->o->interval &&
               p->iters == q->iters && p->densify == q->densify && p->seed == q->seed && p->clips_per_run == q->clips_per_run &&
               p->downscale == q->downscale && p->anchor_gap == q->anchor_gap && p->sampling == q->sampling &&
               p->subsets == q->subsets;
    int complete = same && m.n_clips == b->count;
    for (int i = 0; complete && i < m.n_clips; i++) {
        char path[4096];
        gv_clip_info info;
        complete = gv_path_join(path, sizeof path, b->o->out_dir, m.clips[i].file) == 0 && gv_file_exists(path);
        if (complete && b->o->coverage) { /* the coverage mask needs every clip's plane */
            complete = gv_clip_read_info(path, &info) == 0 && info.has_coverage;
            gv_clear_error();
        }
    }
    gv_manifest_free(&m);
    if (!same) {
        char subsets[32] = "";
        if (!b->o->full_model) snprintf(subsets, sizeof subsets, ", %d subsets", b->subsets);
        return gv_fail("%s: holds other clips than the %s of %s at n = %d with %d iterations%s, density control %s "
                       "and seed %llu: use another folder", b->o->out_dir,
                       b->o->full_model ? "do-no-harm clips" : "internal pairs", b->name, b->o->interval, q->iters,
                       subsets, gv_splat_densify_mode_name(q->densify), (unsigned long long)q->seed);
    }
    return complete;
}

int gv_internal_build(const gv_scene *scene, const gv_internal_options *o, gv_internal_result *result)
{
    double start = gv_now();
    memset(result, 0, sizeof *result);
    build_ctx b;
    memset(&b, 0, sizeof b);
    b.scene = scene, b.o = o, b.sim = o->simulator ? o->simulator : &gv_artifact_3dgs;
    if (o->iters < 1) return gv_fail("internal pairs: iterations %d: must be at least 1", o->iters);
    if (o->coverage && !b.sim->depth)
        return gv_fail("internal pairs: the coverage mask needs the clips' coverage plane, and the artifact "
                       "simulator %s renders no depth", b.sim->name);
    if (gv_scene_name_of(scene->dir, b.name, sizeof b.name)) return -1;
    if (gv_internal_check(scene->n_frames, o->interval)) return gv_fail_context("%s", scene->dir);
    b.clips = malloc((size_t)scene->n_frames * sizeof *b.clips);
    if (!b.clips) return gv_fail("out of memory for %d frames", scene->n_frames);
    b.subsets = o->subsets ? o->subsets : GV_INTERNAL_SUBSETS;
    int rc = gv_internal_plan(scene->n_frames, o->interval, b.subsets, b.clips, &b.count);
    gv_dataset_default_params(&b.params);
    b.params.iters = o->iters, b.params.densify = o->densify, b.params.seed = o->seed, b.params.clips_per_run = b.count;
    b.params.subsets = recorded_subsets(o, b.subsets);
    b.params.downscale = scene->downscale > 0 ? scene->downscale : 1;
    if (rc == 0) rc = data_prepare_out_dir(o->out_dir); /* as dataset build: a killed subset's temporaries go */
    int done = rc == 0 ? already_built(&b) : -1;
    if (done < 0) rc = -1;
    b.runs = b.subsets < b.count ? b.subsets : b.count; /* subsets 0 .. runs - 1 render the T - 2 clips */
    for (int p = 0; rc == 0 && !done && p < (o->full_model ? 1 : b.runs); p++) {
        int present = 1;
        for (int i = 0; present && i < b.count; i++)
            if (in_pass(&b, i, p)) present = clip_present(&b, i);
        if (present) {
            if (o->full_model) gv_info("do-no-harm clips: %s: already built", b.name);
            else gv_info("internal pairs: %s subset %d of %d: its clips are already built", b.name, p + 1, b.runs);
            continue;
        }
        rc = build_subset(&b, p);
        result->subsets_trained += rc == 0;
    }
    gv_run_record rec = {0};
    if (rc == 0) rc = make_record(&b, &rec);
    if (rc == 0 && !done) rc = commit(&b, &rec, gv_now() - start);
    if (rc == 0) {
        result->clips = b.count;
        result->psnr = rec.psnr_mean, result->ssim = rec.ssim_mean;
    }
    result->seconds = gv_now() - start;
    gv_run_record_free(&rec);
    free(b.clips);
    return rc ? -1 : 0;
}
