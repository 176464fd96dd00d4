/* One (scene, n) run of `dataset build` (paper section 3.2): train the degraded model on the
 * sparse views, render and score every held-out frame, write the sampled clips and the run
 * record, then commit the run to the manifest. */
#include <stdlib.h>
#include <string.h>

#include "data/build_internal.h"
#include "gaussvid/io/metrics.h"

/* Frames of the scene the clips use: their ground truth and, for held-out ones, the render. */
typedef struct {
    int n_frames;
    uint8_t *needed;
    gv_image *truth, *renders;
} frame_cache;

static void cache_free(frame_cache *c)
{
    for (int i = 0; c->truth && c->renders && i < c->n_frames; i++) {
        gv_image_free(&c->truth[i]);
        gv_image_free(&c->renders[i]);
    }
    free(c->needed), free(c->truth), free(c->renders);
}

static int cache_init(frame_cache *c, int n_frames, int (*clips)[GV_CLIP_FRAMES], int n_clips)
{
    memset(c, 0, sizeof *c);
    c->n_frames = n_frames;
    c->needed = calloc((size_t)n_frames, 1);
    c->truth = calloc((size_t)n_frames, sizeof *c->truth);
    c->renders = calloc((size_t)n_frames, sizeof *c->renders);
    if (!c->needed || !c->truth || !c->renders) return gv_fail("out of memory for %d frames", n_frames);
    for (int k = 0; k < n_clips; k++)
        for (int f = 0; f < GV_CLIP_FRAMES; f++) c->needed[clips[k][f]] = 1;
    return 0;
}

/* Renders every held-out frame, scores it against its ground truth, keeps the clip frames. */
static int render_held_out(const data_run *run, void *model, frame_cache *cache,
                           gv_run_record *rec)
{
    const gv_artifact_simulator *sim = run->simulator;
    gv_progress bar;
    char label[48];
    snprintf(label, sizeof label, "render n=%d", run->id.interval);
    gv_progress_start(&bar, label, rec->n_held_out);
    for (int i = 0; i < rec->n_held_out; i++) {
        int f = rec->held_out[i];
        gv_image render = {0}, truth = {0};
        if (sim->render(sim->ctx, model, run->scene, f, &render) != 0 ||
            gv_scene_load_image(run->scene, f, &truth) != 0 ||
            gv_image_psnr_ssim(&render, &truth, &rec->psnr[i], &rec->ssim[i]) != 0) {
            gv_image_free(&render), gv_image_free(&truth);
            return gv_fail_context("%s: held-out frame %d", run->id.scene, f);
        }
        if (cache->needed[f]) {
            cache->renders[f] = render;
            cache->truth[f] = truth;
        } else {
            gv_image_free(&render), gv_image_free(&truth);
        }
        gv_progress_update(&bar, i + 1, "%s", "");
    }
    gv_progress_finish(&bar);
    for (int f = 0; f < cache->n_frames; f++) /* the anchors: clean training views */
        if (cache->needed[f] && !cache->truth[f].pixels &&
            gv_scene_load_image(run->scene, f, &cache->truth[f]) != 0)
            return -1;
    gv_run_record_summarise(rec);
    return 0;
}

/* Scores the render of every training view: how closely the sparse model fits what it saw
 * (the "train" row of the baseline tables). */
static int score_train_views(const data_run *run, void *model, gv_run_record *rec)
{
    const gv_artifact_simulator *sim = run->simulator;
    int n_train = 0, rc = 0;
    double psnr_sum = 0, ssim_sum = 0;
    for (int f = 0; f < run->scene->n_frames && rc == 0; f++) {
        if (!gv_scene_is_train(f, run->id.interval)) continue;
        gv_image render = {0}, truth = {0};
        double psnr, ssim;
        n_train++;
        if (sim->render(sim->ctx, model, run->scene, f, &render) != 0 ||
            gv_scene_load_image(run->scene, f, &truth) != 0 || gv_image_psnr_ssim(&render, &truth, &psnr, &ssim) != 0)
            rc = gv_fail_context("%s: training view %d", run->id.scene, f);
        else {
            psnr_sum += psnr <= 100.0 ? psnr : 100.0; /* identical images: capped as held-out */
            ssim_sum += ssim;
        }
        gv_image_free(&render), gv_image_free(&truth);
    }
    if (rc == 0 && n_train > 0) {
        rec->train_frames = n_train;
        rec->train_psnr = psnr_sum / n_train;
        rec->train_ssim = ssim_sum / n_train;
    }
    return rc;
}

static int write_clip(const data_run *run, void *model, const int *frames, const frame_cache *cache,
                      const char *path)
{
    const gv_camera *cams = run->scene->cameras;
    gv_clip_info info;
    memset(&info, 0, sizeof info);
    info.id = run->id;
    info.anchor_gap = run->params->anchor_gap;
    info.iters = run->params->iters;
    info.sampling = run->params->sampling;
    info.seed = run->params->seed;
    info.width = cams[frames[0]].width;
    info.height = cams[frames[0]].height;
    gv_clip clip;
    if (gv_clip_alloc(&clip, &info) != 0) return -1;
    const gv_image *inputs[GV_CLIP_FRAMES], *targets[GV_CLIP_FRAMES];
    const gv_camera *clip_cams[GV_CLIP_FRAMES];
    for (int i = 0; i < GV_CLIP_FRAMES; i++) {
        int f = frames[i], anchor = i == 0 || i == GV_CLIP_FRAMES - 1;
        inputs[i] = anchor ? &cache->truth[f] : &cache->renders[f];
        targets[i] = &cache->truth[f];
        clip_cams[i] = &cams[f];
    }
    int rc = gv_clip_fill(&clip, frames, inputs, targets, clip_cams);
    if (rc == 0 && run->simulator->depth) /* what the anchors see of each render */
        rc = gv_clip_coverage_simulated(&clip, run->simulator, model, run->scene, frames);
    if (rc) gv_fail_context("%s", run->id.scene);
    if (rc == 0) rc = gv_clip_write(path, &clip);
    gv_clip_free(&clip);
    return rc;
}

/* Writes the clips and fills their manifest entries. */
static int write_clips(const data_run *run, void *model, int (*frames)[GV_CLIP_FRAMES], int n_clips,
                       const frame_cache *cache, gv_manifest_clip *entries)
{
    for (int k = 0; k < n_clips; k++) {
        gv_manifest_clip *e = &entries[k];
        char path[4096];
        memset(e, 0, sizeof *e);
        if (gv_clip_file_name(e->file, sizeof e->file, run->id.scene, run->id.interval, k) != 0 ||
            gv_path_join(path, sizeof path, run->out_dir, e->file) != 0 ||
            write_clip(run, model, frames[k], cache, path) != 0)
            return -1;
        e->id = run->id;
        memcpy(e->frames, frames[k], sizeof e->frames);
    }
    return 0;
}

/* Samples the clips, lists the training views into train (n_frames long) and fills the
 * record's identity and held-out frames. */
static int plan_run(const data_run *run, int (*frames)[GV_CLIP_FRAMES], int *n_clips, int *train,
                    int *n_train, gv_run_record *rec)
{
    int n_frames = run->scene->n_frames;
    int *held_out = malloc((size_t)n_frames * sizeof *held_out);
    int n_held = 0, rc = -1;
    uint64_t seed = gv_run_seed(run->params->seed, run->id.scene, run->id.interval);
    if (!held_out) gv_fail("out of memory for %d frames", n_frames);
    else if (gv_scene_split(n_frames, run->id.interval, train, n_train, held_out, &n_held) == 0 &&
             gv_sample_clips(n_frames, run->id.interval, run->params->anchor_gap, run->params->sampling,
                             run->params->clips_per_run, seed ^ 0x9E3779B97F4A7C15ull, frames,
                             n_clips) == 0 &&
             gv_run_record_alloc(rec, n_held) == 0)
        rc = 0;
    if (rc == 0) {
        memcpy(rec->held_out, held_out, (size_t)n_held * sizeof *held_out);
        rec->id = run->id;
        rec->iters = run->params->iters;
        rec->n_train = *n_train;
        rec->n_clips = *n_clips;
    }
    free(held_out);
    return rc ? gv_fail_context("%s: n=%d", run->id.scene, run->id.interval) : 0;
}

static int commit_run(const data_run *run, gv_run_record *rec, gv_manifest_clip *entries,
                      gv_manifest *m)
{
    char name[GV_SCENE_NAME_MAX + 32], path[4096];
    if (gv_run_file_name(name, sizeof name, run->id.scene, run->id.interval) != 0 ||
        gv_path_join(path, sizeof path, run->out_dir, name) != 0 ||
        gv_run_record_write(path, rec) != 0)
        return -1;
    gv_manifest_run entry;
    memset(&entry, 0, sizeof entry);
    entry.id = run->id;
    entry.n_clips = rec->n_clips;
    entry.seconds = rec->seconds;
    if (gv_manifest_add_run(m, &entry, entries, rec->n_clips) != 0) return -1;
    return run->write_manifest ? gv_manifest_write(run->out_dir, m) : 0;
}

int data_build_run(const data_run *run, gv_manifest *m, gv_run_record *rec)
{
    double start = gv_now();
    int k = run->params->clips_per_run, n_clips = 0, n_train = 0, rc = -1;
    int (*frames)[GV_CLIP_FRAMES] = calloc((size_t)k, sizeof *frames);
    gv_manifest_clip *entries = calloc((size_t)k, sizeof *entries);
    int *train = malloc((size_t)run->scene->n_frames * sizeof *train);
    frame_cache cache = {0};
    void *model = NULL;
    memset(rec, 0, sizeof *rec);
    if (!frames || !entries || !train) { gv_fail("out of memory for %d clips", k); goto done; }
    if (plan_run(run, frames, &n_clips, train, &n_train, rec) != 0 ||
        cache_init(&cache, run->scene->n_frames, frames, n_clips) != 0)
        goto done;
    const gv_artifact_simulator *sim = run->simulator;
    if (sim->train(sim->ctx, run->scene, train, n_train, run->params->iters, run->params->densify,
                   gv_run_seed(run->params->seed, run->id.scene, run->id.interval), &model) != 0) {
        gv_fail_context("%s: n=%d: %s", run->id.scene, run->id.interval, sim->name);
        goto done;
    }
    rec->train_seconds = gv_now() - start;
    if (render_held_out(run, model, &cache, rec) != 0 ||
        score_train_views(run, model, rec) != 0)
        goto done;
    rec->render_seconds = gv_now() - start - rec->train_seconds;
    if (write_clips(run, model, frames, n_clips, &cache, entries) != 0) goto done;
    rec->seconds = gv_now() - start;
    /* Runs built side by side share the manifest. */
#pragma omp critical(gv_dataset_manifest)
    rc = commit_run(run, rec, entries, m);
done:
    if (model) run->simulator->free_model(run->simulator->ctx, model);
    cache_free(&cache);
    free(frames), free(entries), free(train);
    if (rc != 0) gv_run_record_free(rec);
    return rc;
}
