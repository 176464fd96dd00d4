/* `dataset build` (paper section 3.2; docs/ARCHITECTURE.md section 8): every scene at every interval n,
 * resumable. Every scene and interval is checked before anything is trained; finished runs
 * (listed in the manifest, with their clips and record present) are skipped; temporaries left
 * by a killed build are removed; the options must match those of the runs already built. */
#include <errno.h>
#include <limits.h>
#include <omp.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "data/build_internal.h"
#include "gaussvid/core/dist.h"
#include "gaussvid/splat/splat_train.h"

void gv_dataset_default_params(gv_dataset_params *p)
{
    memset(p, 0, sizeof *p);
    p->iters = 8000;        /* paper 3.2: "terminating the optimization early at 8,000" */
    p->anchor_gap = 1;
    p->clips_per_run = 4;
    p->downscale = 1;
    p->sampling = GV_SAMPLING_UNIFORM;
    p->seed = 0;
    p->densify = GV_DENSIFY_REFERENCE; /* the paper's artifacts: the restorer's training data */
}

uint64_t gv_run_seed(uint64_t seed, const char *scene, int n)
{
    uint64_t h = 1469598103934665603ull; /* FNV-1a 64 of the scene name */
    for (const unsigned char *p = (const unsigned char *)scene; *p; p++) h = (h ^ *p) * 1099511628211ull;
    uint32_t out[4];
    gv_philox4x32(seed, h ^ ((uint64_t)(uint32_t)n << 32 | (uint32_t)n), out);
    return (uint64_t)out[1] << 32 | out[0];
}

int gv_scene_name_of(const char *dir, char *out, size_t size)
{
    char path[PATH_MAX];
    if (!gv_dir_exists(dir)) return gv_fail("%s: no such scene folder", dir);
    if (snprintf(path, sizeof path, "%s", dir) >= (int)sizeof path) return gv_fail("%s: path too long", dir);
    size_t len = strlen(path);
    while (len > 1 && path[len - 1] == '/') path[--len] = '\0';
    const char *slash = strrchr(path, '/');
    const char *name = slash ? slash + 1 : path;
    /* "." and ".." name no scene: use the folder they stand for (symbolic links keep the
     * name they were given otherwise). */
    if (!strcmp(name, ".") || !strcmp(name, "..") || !name[0]) {
        if (!realpath(dir, path)) return gv_fail("%s: cannot resolve: %s", dir, strerror(errno));
        slash = strrchr(path, '/');
        name = slash ? slash + 1 : path;
    }
    if (!name[0] || strlen(name) >= size || strlen(name) >= GV_SCENE_NAME_MAX)
        return gv_fail("%s: the folder name '%s' cannot name a scene (empty or over %d bytes)",
                       dir, name, GV_SCENE_NAME_MAX - 1);
    snprintf(out, size, "%s", name);
    return 0;
}

static int check_params(const gv_dataset_params *p)
{
    if (p->iters < 1) return gv_fail("iterations %d: must be at least 1", p->iters);
    if (p->clips_per_run < 1 || p->clips_per_run > 100000)
        return gv_fail("clips per run %d: must be in 1..100000", p->clips_per_run);
    if (p->anchor_gap < 1) return gv_fail("anchor gap %d: must be at least 1", p->anchor_gap);
    if (p->downscale != 1 && p->downscale != 2 && p->downscale != 4 && p->downscale != 8)
        return gv_fail("downscale %d: expected 1, 2, 4 or 8", p->downscale);
    if ((unsigned)p->sampling > GV_SAMPLING_RELEASED) return gv_fail("unknown sampling %d", (int)p->sampling);
    if ((unsigned)p->densify > GV_DENSIFY_LEAN) /* the last of gv_splat_densify_mode */
        return gv_fail("unknown density control %d", p->densify);
    return 0;
}

/* The options of a folder's existing runs must be this build's: one dataset, one recipe. */
static int same_params(const char *dir, const gv_dataset_params *old, const gv_dataset_params *now)
{
    char a[GV_DATASET_FLAGS_MAX], b[GV_DATASET_FLAGS_MAX];
    gv_dataset_params_flags(old, a, sizeof a);
    gv_dataset_params_flags(now, b, sizeof b);
    if (strcmp(a, b))
        return gv_fail("%s/manifest.json: the dataset was built with %s; this build asks for %s "
                       "(use another --out folder)", dir, a, b);
    return 0;
}

int data_prepare_out_dir(const char *out)
{
    static const char *subdirs[] = {"", "clips", "runs"};
    for (int i = 0; i < 3; i++) {
        char path[4096];
        if (gv_path_join(path, sizeof path, out, subdirs[i]) != 0 || gv_mkdirs(path) != 0) return -1;
        int removed = gv_atomic_sweep(path, NULL);
        if (removed) gv_info("%s: removed %d temporary file(s) left by an interrupted build", path, removed);
    }
    return 0;
}

typedef struct {
    gv_scene *scenes;
    char (*names)[GV_SCENE_NAME_MAX];
    const char **splits;
    int n;
} scene_set;

static void scenes_free(scene_set *s)
{
    for (int i = 0; s->scenes && i < s->n; i++) gv_scene_free(&s->scenes[i]);
    free(s->scenes), free(s->names), free(s->splits);
}

/* Loads every scene (cameras only), names it, splits it, checks every interval on it. */
static int load_scenes(const gv_dataset_build_options *opt, scene_set *s)
{
    memset(s, 0, sizeof *s);
    s->scenes = calloc((size_t)opt->n_scenes, sizeof *s->scenes);
    s->names = calloc((size_t)opt->n_scenes, sizeof *s->names);
    s->splits = calloc((size_t)opt->n_scenes, sizeof *s->splits);
    if (!s->scenes || !s->names || !s->splits) return gv_fail("out of memory for %d scenes", opt->n_scenes);
    gv_scene_options so = {.downscale = opt->params.downscale};
    for (int i = 0; i < opt->n_scenes; i++) {
        const char *dir = opt->scene_dirs[i];
        if (gv_scene_name_of(dir, s->names[i], sizeof s->names[i]) != 0) return -1;
        for (int j = 0; j < i; j++)
            if (!strcmp(s->names[i], s->names[j]))
                return gv_fail("%s: scene name '%s' is also that of %s (scenes are named by their "
                               "folder)", dir, s->names[i], opt->scene_dirs[j]);
        if (gv_scene_load(dir, &so, &s->scenes[i]) != 0) return -1;
        s->n = i + 1;
        s->splits[i] = "train";
        for (int e = 0; e < opt->n_eval_scenes; e++)
            if (!strcmp(opt->eval_scenes[e], s->names[i])) s->splits[i] = "eval";
        for (int k = 0; k < opt->n_intervals; k++)
            if (gv_clip_check_interval(s->scenes[i].n_frames, opt->intervals[k], opt->params.anchor_gap))
                return gv_fail_context("%s", dir);
    }
    for (int e = 0; e < opt->n_eval_scenes; e++) {
        int found = 0;
        for (int i = 0; i < s->n; i++) found |= !strcmp(opt->eval_scenes[e], s->names[i]);
        if (!found) return gv_fail("eval scene '%s' is not one of the scenes given", opt->eval_scenes[e]);
    }
    return 0;
}

/* 1 when the manifest lists the run and its clips and record exist; fails when it lists the
 * run under the other split. */
static int run_is_complete(const char *out, const gv_manifest *m, const char *name, int n,
                           const char *split, int *complete)
{
    *complete = 0;
    int r = gv_manifest_find_run(m, name, n);
    if (r < 0) return 0;
    if (strcmp(m->runs[r].id.split, split))
        return gv_fail("%s/manifest.json: %s n=%d was built in the %s split, this build puts it in "
                       "%s (use another --out folder)", out, name, n, m->runs[r].id.split, split);
    char file[GV_SCENE_NAME_MAX + 32], path[4096];
    if (gv_run_file_name(file, sizeof file, name, n) || gv_path_join(path, sizeof path, out, file))
        return -1;
    if (!gv_file_exists(path)) return 0;
    int clips = 0;
    for (int i = 0; i < m->n_clips; i++) {
        const gv_manifest_clip *c = &m->clips[i];
        if (c->id.interval != n || strcmp(c->id.scene, name)) continue;
        if (gv_path_join(path, sizeof path, out, c->file) != 0 || !gv_file_exists(path)) return 0;
        clips++;
    }
    *complete = clips == m->runs[r].n_clips;
    return 0;
}

static void format_time(char *out, size_t size, double seconds)
{
    long s = (long)(seconds + 0.5);
    snprintf(out, size, "%ld:%02ld:%02ld", s / 3600, s / 60 % 60, s % 60);
}

typedef struct {
    const gv_dataset_build_options *opt;
    const scene_set *scenes;
    gv_manifest *manifest;
    gv_dataset_build_result *result;
    int todo;
    double start;
} build_state;

/* Builds run r (scene r / n_intervals at its interval), then prints the overall progress. */
static int build_one(build_state *b, int r)
{
    const gv_dataset_build_options *opt = b->opt;
    int i = r / opt->n_intervals, n = opt->intervals[r % opt->n_intervals];
    const scene_set *s = b->scenes;
    gv_info("dataset: starting %s n=%d (%s split)", s->names[i], n, s->splits[i]);
    data_run run = {&s->scenes[i], {"", "", n}, &opt->params, opt->simulator ? opt->simulator : &gv_artifact_3dgs,
                    opt->out_dir, gv_dist_is_root()};
    snprintf(run.id.scene, sizeof run.id.scene, "%s", s->names[i]);
    snprintf(run.id.split, sizeof run.id.split, "%s", s->splits[i]);
    gv_run_record rec;
    if (data_build_run(&run, b->manifest, &rec) != 0) return -1;
#pragma omp critical(gv_dataset_progress)
    {
        gv_dataset_build_result *result = b->result;
        result->runs_built++;
        result->clips_written += rec.n_clips;
        double elapsed = gv_now() - b->start;
        char elapsed_text[32], eta_text[32];
        format_time(elapsed_text, sizeof elapsed_text, elapsed);
        format_time(eta_text, sizeof eta_text,
                    elapsed / result->runs_built * (b->todo - result->runs_built));
        gv_info("dataset: %d/%d runs built; %s n=%d: %d clips, baseline PSNR %.2f dB SSIM %.4f over "
                "%d held-out frames, %.1f s; elapsed %s, eta %s", result->runs_built, b->todo,
                s->names[i], n, rec.n_clips, rec.psnr_mean, rec.ssim_mean, rec.n_held_out,
                rec.seconds, elapsed_text, eta_text);
    }
    gv_run_record_free(&rec);
    return 0;
}

/* Runs `jobs` runs at a time, one thread each (nested parallel regions get one thread), their
 * progress bars muted; the first failure stops the runs not yet started and is reported once
 * the running ones end (their clips are committed: a rebuild resumes after them). */
static int build_side_by_side(build_state *b, const int *todo, int jobs)
{
    int failed = 0;
    char first_error[1024] = "";
    omp_set_max_active_levels(1);
#pragma omp parallel for num_threads(jobs) schedule(dynamic, 1)
    for (int k = 0; k < b->todo; k++) {
        int stop;
#pragma omp atomic read
        stop = failed;
        if (stop) continue;
        gv_progress_mute_thread(1);
        if (build_one(b, todo[k]) != 0) {
#pragma omp critical(gv_dataset_progress)
            if (!failed) snprintf(first_error, sizeof first_error, "%s", gv_last_error());
#pragma omp atomic write
            failed = 1;
        }
        gv_progress_mute_thread(0);
    }
    return failed ? gv_fail("%s", first_error) : 0;
}

/* Runs every (scene, n) not yet complete; one line of overall progress per run. Under mpirun
 * rank r builds the runs to do k = r, r + K, r + 2K, ... and rank 0 merges the manifest. */
static int build_runs(const gv_dataset_build_options *opt, const scene_set *s, gv_manifest *m,
                      gv_dataset_build_result *result)
{
    int total = s->n * opt->n_intervals;
    int *todo = malloc((size_t)total * sizeof *todo);
    gv_run_id *mine = calloc((size_t)total + 1, sizeof *mine);
    if (!todo || !mine) {
        free(todo), free(mine);
        return gv_fail("out of memory for %d runs", total);
    }
    result->runs_total = total;
    int n_todo = 0, n_mine = 0, ranks = gv_dist_size();
    for (int r = 0; r < total; r++) {
        int c, i = r / opt->n_intervals, n = opt->intervals[r % opt->n_intervals];
        if (run_is_complete(opt->out_dir, m, s->names[i], n, s->splits[i], &c) != 0) {
            free(todo), free(mine);
            return -1;
        }
        if (c) result->runs_skipped++;
        else if (n_todo++ % ranks == gv_dist_rank()) {
            todo[n_mine] = r;
            snprintf(mine[n_mine].scene, sizeof mine[n_mine].scene, "%s", s->names[i]);
            mine[n_mine++].interval = n;
        }
    }
    int jobs = opt->jobs < 1 ? 1 : opt->jobs < n_mine ? opt->jobs : n_mine;
    if (jobs < 1) jobs = 1;
    char share[64] = "";
    if (ranks > 1) snprintf(share, sizeof share, " on each of %d ranks", ranks);
    gv_info("dataset: %d runs (%d scenes x %d intervals): %d already built, %d to build, %d at a "
            "time%s", total, s->n, opt->n_intervals, result->runs_skipped, n_todo, jobs, share);
    build_state b = {opt, s, m, result, n_mine, gv_now()};
    int rc = 0;
    if (jobs > 1) rc = build_side_by_side(&b, todo, jobs);
    else
        for (int k = 0; k < n_mine && rc == 0; k++) rc = build_one(&b, todo[k]);
    if (rc == 0) rc = data_merge_ranks(opt->out_dir, m, mine, n_mine, result);
    free(todo), free(mine);
    return rc;
}

/* Sweeps the folder, reads its manifest, checks the options and marks the folder as a
 * dataset's: rank 0 writes; the other ranks read what it left (after it, see below). */
static int open_out_dir(const gv_dataset_build_options *opt, gv_manifest *m)
{
    int found, root = gv_dist_is_root();
    if ((root && data_prepare_out_dir(opt->out_dir) != 0) || gv_manifest_read(opt->out_dir, m, &found) != 0) return -1;
    /* A folder without a finished run takes this build's options. */
    if (found && m->n_runs > 0 && same_params(opt->out_dir, &m->params, &opt->params) != 0) return -1;
    m->params = opt->params;
    if (root && m->n_runs == 0 && gv_manifest_write(opt->out_dir, m) != 0) return -1; /* marks the folder */
    return 0;
}

int gv_dataset_build(const gv_dataset_build_options *opt, gv_dataset_build_result *result)
{
    memset(result, 0, sizeof *result);
    double start = gv_now();
    if (opt->n_scenes < 1) return gv_fail("dataset build: no scene given");
    if (opt->n_intervals < 1) return gv_fail("dataset build: no interval given");
    if (!opt->out_dir || !opt->out_dir[0]) return gv_fail("dataset build: no output folder given");
    if (check_params(&opt->params) != 0) return -1;
    scene_set scenes;
    gv_manifest m;
    int rc = -1;
    gv_manifest_init(&m, NULL);
    if (load_scenes(opt, &scenes) != 0) goto done;
    /* under mpirun the other ranks open the folder once rank 0 has swept and marked it */
    if (!gv_dist_is_root() && gv_dist_after_root(0, opt->out_dir) != 0) goto done;
    int opened = open_out_dir(opt, &m);
    if (gv_dist_is_root() && gv_dist_after_root(opened, opt->out_dir) != 0) goto done;
    if (opened == 0) rc = build_runs(opt, &scenes, &m, result);
done:
    result->seconds = gv_now() - start;
    gv_manifest_free(&m);
    scenes_free(&scenes);
    return rc;
}
