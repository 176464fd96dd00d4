/* `gaussvid bench train`: training throughput of the restoration network (issue 7
 * "Performance"). The training loop itself (gv_train_run: data order, curriculum, draws,
 * forward, losses, backward, gradient clipping, AdamW) runs on synthetic clip latents of a
 * 5-frame clip of the preset (random latents and VACE context, the Plücker field of a real
 * camera path), so no VAE or dataset is needed: clip latents are cached before training
 * anyway (docs/ARCHITECTURE.md 6.2). Reported per run: clips per second of the optimiser steps (wall), CPU
 * seconds per clip (all threads; the steadier measure on a shared machine), the step graph's
 * arena peak; the network's restoration time per clip with and without the camera-stream
 * cache; and the process's peak resident memory. */
#include <omp.h>
#include <stdlib.h>
#include <string.h>
#include <sys/resource.h>
#include <time.h>
#include <unistd.h>

#include "bench/bench_train.h"
#include "gaussvid/core/core.h"
#include "gaussvid/model/plucker.h"
#include "gaussvid/restore/restore.h"
#include "gaussvid/train/train.h"

enum { CLIPS = 4 };

static double cpu_seconds(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &ts);
    return ts.tv_sec + 1e-9 * ts.tv_nsec;
}

/* CLIPS clips of random latents with intervals 6, 12, 18, 24 and a sideways camera path. */
static int make_set(const gv_model_config *c, int height, int width, gv_latent_set *set)
{
    memset(set, 0, sizeof *set);
    set->clips = calloc(CLIPS, sizeof *set->clips);
    set->names = calloc(CLIPS, sizeof *set->names);
    if (!set->clips || !set->names) return gv_fail("bench train: out of memory");
    int tf = c->vae.temporal_factor, sf = c->vae.spatial_factor;
    for (int i = 0; i < CLIPS; i++) {
        gv_clip_latents *l = &set->clips[i];
        l->interval = 6 + 6 * i, l->frames = 5, l->height = height, l->width = width, l->batch = 1;
        l->z_dim = c->vae.z_dim, l->latent_frames = 1 + 4 / tf, l->lh = height / sf, l->lw = width / sf;
        l->vace_dim = c->dit.vace_in_dim;
        l->plucker_frames = gv_plucker_packed_frames(5, tf);
        set->names[i] = strdup("synthetic");
        set->count++;
        if (!set->names[i] || gv_clip_latents_alloc(l, 1)) return -1;
        gv_fill_normal(l->z_clean, gv_clip_latents_z_count(l), 10 + i, 0, 0.0f, 1.0f);
        gv_fill_normal(l->z_corrupt, gv_clip_latents_z_count(l), 20 + i, 0, 0.0f, 1.0f);
        gv_fill_normal(l->vace, gv_clip_latents_vace_count(l), 30 + i, 0, 0.0f, 1.0f);
        gv_camera cams[5];
        memset(cams, 0, sizeof cams);
        for (int f = 0; f < 5; f++) {
            cams[f].fx = cams[f].fy = 0.9 * width, cams[f].cx = 0.5 * width, cams[f].cy = 0.5 * height;
            cams[f].R[0] = cams[f].R[4] = cams[f].R[8] = 1;
            cams[f].t[0] = -0.1 * f * (i + 1), cams[f].t[2] = 2;
        }
        if (gv_plucker_field(cams, 5, height, width, tf, l->plucker, NULL)) return -1;
    }
    return 0;
}

typedef struct {
    const char *name, *variant;
    gv_objective objective;
    int steps;
    double clips_per_second, cpu_per_clip;
    double arena_mib;
    double trainable;
    double step_seconds, cpu_seconds; /* of the whole run (first step and checkpoints included) */
    long clips;
} run;

/* One training run in a scratch folder; its files are removed afterwards. */
static int time_run(const char *preset, int height, int width, const char *dir, run *r)
{
    gv_model_config cfg;
    gv_latent_set set;
    if (gv_model_config_load(&cfg, preset) || (r->variant && gv_model_config_set_variant(&cfg, r->variant, "bench")))
        return -1;
    gv_dit m;
    gv_train_state meta;
    memset(&meta, 0, sizeof meta);
    memset(&m, 0, sizeof m);
    int rc = make_set(&cfg, height, width, &set);
    if (rc == 0) rc = gv_train_model(&cfg, r->objective, NULL, 0, 1, &m, &meta);
    char out[4200], ckpt[4300];
    snprintf(out, sizeof out, "%s/run.safetensors", dir);
    snprintf(ckpt, sizeof ckpt, "%s.ckpt", out);
    gv_train_options o;
    gv_train_defaults(&o, r->objective);
    o.steps = r->steps, o.checkpoint_every = r->steps, o.out = out;
    gv_train_report rep;
    int level = gv_log_level();
    gv_log_set_level(GV_LOG_QUIET);
    double cpu0 = cpu_seconds();
    if (rc == 0) rc = gv_train_run(&m, &cfg, &set, &o, &meta, &rep);
    double cpu = cpu_seconds() - cpu0;
    gv_log_set_level(level);
    if (rc == 0) {
        r->step_seconds = rep.step_seconds;
        r->cpu_seconds = cpu;
        r->clips = rep.clips_used;
        r->arena_mib = rep.arena_peak / 1048576.0;
        r->trainable = (double)gv_params_count(&m.params, 1);
    }
    unlink(out), unlink(ckpt);
    gv_dit_free(&m);
    gv_latent_set_free(&set);
    return rc;
}

/* Restoration of one clip by the network (the default sampler on a fine-tuning-shaped
 * network), with the camera stream computed once per clip and recomputed at every
 * evaluation; the VAE's encoding and decoding are not included (bench model has them). */
typedef struct {
    double cached, fresh;  /* wall seconds per clip, best of the trials */
    int evaluations;       /* network evaluations per clip */
} restore_timing;

static double restore_once(gv_dit *m, const gv_clip_latents *l, const gv_sampler *s, int use_cache, float *z,
                           int *evaluations)
{
    gv_restore_net net;
    double t0 = gv_now();
    int rc = gv_restore_net_init(&net, m, l, use_cache);
    if (rc == 0) rc = gv_sample(s, gv_restore_net_velocity, &net, l->z_corrupt, gv_clip_latents_z_count(l), 7, z);
    double seconds = gv_now() - t0;
    *evaluations = net.evaluations;
    gv_restore_net_free(&net);
    return rc ? -1 : seconds;
}

static int time_restore(const char *preset, int height, int width, int trials, restore_timing *r)
{
    gv_model_config cfg;
    gv_latent_set set;
    gv_dit m;
    if (gv_model_config_load(&cfg, preset)) return -1;
    if (make_set(&cfg, height, width, &set) || gv_dit_init(&m, &cfg, 1)) { /* as time_run */
        gv_latent_set_free(&set);
        return -1;
    }
    const gv_clip_latents *l = &set.clips[0];
    gv_sampler s = gv_sampler_default();
    float *z = malloc((size_t)gv_clip_latents_z_count(l) * sizeof *z);
    int rc = z ? gv_dit_set_train_mode(&m, GV_DIT_FROZEN) : gv_fail("bench train: out of memory");
    r->cached = r->fresh = 1e30;
    for (int i = 0; rc == 0 && i < trials; i++) {
        double c = restore_once(&m, l, &s, 1, z, &r->evaluations);
        double f = c < 0 ? -1 : restore_once(&m, l, &s, 0, z, &r->evaluations);
        if (c < 0 || f < 0) rc = -1;
        if (c < r->cached) r->cached = c;
        if (f < r->fresh) r->fresh = f;
    }
    free(z);
    gv_dit_free(&m);
    gv_latent_set_free(&set);
    return rc;
}

static void print_table(FILE *out, const char *preset, int height, int width, const run *runs, int n,
                        const restore_timing *rt, double rss)
{
    fprintf(out, "training throughput: %s preset, 5x%dx%d clips (synthetic latents), %d thread(s)\n\n", preset, height,
            width, omp_get_max_threads());
    fprintf(out, "| run | variant | steps x batch | clips/s | CPU s/clip | trainable | arena peak MiB |\n");
    fprintf(out, "|---|---|---:|---:|---:|---:|---:|\n");
    for (int i = 0; i < n; i++)
        fprintf(out, "| %s | %s | %d x 2 | %.2f | %.3f | %.2f M | %.1f |\n", runs[i].name,
                runs[i].variant ? runs[i].variant : "decomposed", runs[i].steps, runs[i].clips_per_second,
                runs[i].cpu_per_clip, runs[i].trainable / 1e6, runs[i].arena_mib);
    fprintf(out, "\nrestoration by the network, default sampler (%d evaluation(s) per clip, VAE excluded):\n"
                 "%.3f s per clip with the camera-stream cache, %.3f s recomputing the camera stream\n",
            rt->evaluations, rt->cached, rt->fresh);
    fprintf(out, "\npeak resident memory of the process: %.1f MiB\n", rss);
}

int gv_bench_train(const gv_bench_options *o, const char *preset, int height, int width, FILE *out)
{
    int steps = o->quick ? 2 : 10;
    run runs[] = {
        {.name = "pretrain", .objective = GV_OBJECTIVE_PRETRAIN, .steps = steps},
        {.name = "fine-tune", .objective = GV_OBJECTIVE_FINETUNE, .steps = steps},
        {.name = "pretrain", .variant = "camera=none", .objective = GV_OBJECTIVE_PRETRAIN, .steps = steps},
        {.name = "fine-tune", .variant = "camera=none", .objective = GV_OBJECTIVE_FINETUNE, .steps = steps},
    };
    int n = o->quick ? 2 : (int)(sizeof runs / sizeof runs[0]);
    char dir[] = "/tmp/gaussvid-bench-train-XXXXXX";
    if (!mkdtemp(dir)) return gv_fail("bench train: cannot make a scratch folder in /tmp");
    int rc = 0;
    /* a run of 1 step and one of 1 + steps: their difference is the steady cost of `steps`
     * steps, without the first step's allocations, the setup and the checkpoint writes */
    for (int i = 0; rc == 0 && i < n; i++) {
        run first = runs[i];
        first.steps = 1;
        runs[i].steps++;
        rc = time_run(preset, height, width, dir, &first);
        if (rc == 0) rc = time_run(preset, height, width, dir, &runs[i]);
        runs[i].steps--;
        double clips = (double)(runs[i].clips - first.clips);
        runs[i].clips_per_second = clips / (runs[i].step_seconds - first.step_seconds);
        runs[i].cpu_per_clip = (runs[i].cpu_seconds - first.cpu_seconds) / clips;
    }
    rmdir(dir);
    restore_timing rt;
    if (rc == 0) rc = time_restore(preset, height, width, o->quick ? 1 : 3, &rt);
    if (rc) return -1;
    struct rusage ru;
    getrusage(RUSAGE_SELF, &ru);
    double rss = ru.ru_maxrss / 1024.0;
    if (!o->json) {
        print_table(out, preset, height, width, runs, n, &rt, rss);
        return 0;
    }
    fprintf(out, "{\"preset\": \"%s\", \"clip\": [5, %d, %d], \"threads\": %d, \"batch\": 2, \"runs\": [", preset,
            height, width, omp_get_max_threads());
    for (int i = 0; i < n; i++)
        fprintf(out, "%s{\"run\": \"%s\", \"variant\": \"%s\", \"steps\": %d, \"clips_per_second\": %.4f, "
                     "\"cpu_seconds_per_clip\": %.4f, \"trainable\": %.0f, \"arena_peak_mib\": %.2f}",
                i ? ", " : "", runs[i].name, runs[i].variant ? runs[i].variant : "decomposed", runs[i].steps,
                runs[i].clips_per_second, runs[i].cpu_per_clip, runs[i].trainable, runs[i].arena_mib);
    fprintf(out, "], \"restore\": {\"evaluations\": %d, \"seconds_per_clip_cached\": %.4f, "
                 "\"seconds_per_clip_uncached\": %.4f}, \"max_rss_mib\": %.1f}\n",
            rt.evaluations, rt.cached, rt.fresh, rss);
    return 0;
}

int gv_bench_train_command(int argc, char **argv)
{
    gv_bench_options o = {0};
    const char *preset = "small";
    int height = 144, width = 256;
    const gv_flag flags[] = {
        {"json", GV_FLAG_BOOL, &o.json, NULL, "print JSON", 0},
        {"quick", GV_FLAG_BOOL, &o.quick, NULL, "two steps of each objective (a smoke test)", 0},
        {"preset", GV_FLAG_STRING, &preset, "PRESET|FILE", "model config (default small)", 0},
        {"height", GV_FLAG_INT, &height, "H", "clip height (default 144)", 0},
        {"width", GV_FLAG_INT, &width, "W", "clip width (default 256)", 0},
    };
    const gv_command_spec spec = {
        "bench train", NULL, "training throughput: pretraining and fine-tuning clips/s, peak memory",
        "Runs the training loop (gv_train_run) of base pretraining and GaussVid fine-tuning,\n"
        "with the camera stream and without it (camera=none), for 10 steps of 2 clips each\n"
        "beyond a first step, on synthetic latents of a 5-frame clip (no VAE: latents\n"
        "are cached before training). Prints clips per second of the optimiser steps, CPU\n"
        "seconds per clip, trainable parameters, the arena peak, the network's restoration\n"
        "time per clip with and without the camera-stream cache (default sampler, VAE\n"
        "excluded) and the process's peak resident memory. Results: docs/BENCHMARKS.md.",
        flags, sizeof flags / sizeof flags[0], 0, 0};
    int rc = gv_args_parse(&spec, argc, argv, NULL, NULL);
    if (rc != GV_ARGS_OK) return gv_args_exit_code(rc);
    if (height < 1 || width < 1) {
        fprintf(stderr, "gaussvid bench train: --height and --width must be positive\n");
        return 2;
    }
    return gv_bench_train(&o, preset, height, width, stdout) == 0 ? 0 : gv_report_failure();
}
