/* The restoration network's speed on one clip (DESIGN 11; issue 5 "Performance"):
 * - one GaussVid fine-tuning step: forward, flow-matching L2 loss, backward, with LoRA and the
 *   camera encoder trainable and the base frozen (DESIGN 6.7), its arena peak, and AdamW;
 * - the same with the camera stream and / or the VACE branch left out (what dominates);
 * - every camera variant and the per-frame restorer;
 * - inference: the forward pass with the camera stream recomputed or taken from its cache.
 * Times are the best of several trials (the machine is shared). */
#include <math.h>
#include <omp.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include "bench/bench_model.h"
#include "gaussvid/core.h"
#include "gaussvid/dit.h"
#include "gaussvid/plucker.h"

typedef struct {
    gv_dit m;
    gv_graph inputs, g;
    gv_tensor *latent, *target, *text, *vace, *plucker;
    float t[8];
    int use_camera, use_vace, backward;
    gv_dit_camera_cache cache;
    int use_cache;
    size_t peak;
} bench;

static gv_tensor *random_leaf(gv_graph *g, int ndim, const int *shape, uint64_t seed)
{
    gv_tensor *t = gv_tensor_new(g, ndim, shape);
    if (t) gv_fill_normal(t->data, t->numel, seed, 0, 0.0f, 1.0f);
    return t;
}

/* A sideways camera path looking along +z. */
static int ray_field(gv_tensor *out, int batch, int frames, int height, int width, int tf)
{
    gv_camera *cams = calloc((size_t)frames, sizeof *cams);
    if (!cams) return gv_fail("bench: out of memory");
    int64_t per = out->numel / batch;
    int rc = 0;
    for (int b = 0; rc == 0 && b < batch; b++) {
        for (int f = 0; f < frames; f++) {
            gv_camera *c = &cams[f];
            c->fx = c->fy = 0.9 * width, c->cx = 0.5 * width, c->cy = 0.5 * height;
            c->R[0] = c->R[4] = c->R[8] = 1;
            c->t[0] = -0.2 * (f + b), c->t[2] = 2;
        }
        rc = gv_plucker_field(cams, frames, height, width, tf, out->data + b * per, NULL);
    }
    free(cams);
    return rc;
}

/* The model of `preset` with `variant`, fine-tuning mode, and inputs of one clip (per-frame:
 * the frames as a batch of single-frame latents). */
static int bench_init(bench *b, const char *preset, const char *variant, int frames, int height, int width)
{
    memset(b, 0, sizeof *b);
    gv_model_config c;
    if (gv_model_config_load(&c, preset) != 0 || (variant && gv_model_config_set_variant(&c, variant, "bench") != 0) ||
        gv_dit_init(&b->m, &c, 1) != 0 || gv_dit_set_train_mode(&b->m, GV_DIT_FINETUNE) != 0)
        return -1;
    gv_graph_init(&b->inputs, 0);
    gv_graph_init(&b->g, 0);
    int tf = c.vae.temporal_factor, sf = c.vae.spatial_factor, B = 1;
    if (c.variant.per_frame) B = frames, frames = 1;
    if ((frames - 1) % tf || height % sf || width % sf)
        return gv_fail("bench: %dx%dx%d does not fit %s", frames, height, width, preset);
    int T = 1 + (frames - 1) / tf, H = height / sf, W = width / sf;
    b->latent = random_leaf(&b->inputs, 5, (int[]){B, c.dit.in_dim, T, H, W}, 1);
    b->target = random_leaf(&b->inputs, 5, (int[]){B, c.dit.out_dim, T, H, W}, 2);
    if (c.dit.cross_attn) b->text = random_leaf(&b->inputs, 3, (int[]){B, c.dit.text_len, c.dit.text_dim}, 3);
    if (c.dit.n_vace_layers) b->vace = random_leaf(&b->inputs, 5, (int[]){B, c.dit.vace_in_dim, T, H, W}, 4);
    if (c.variant.camera != GV_CAMERA_NONE) {
        b->plucker = gv_tensor_new(&b->inputs, 5, (int[]){B, 6, gv_plucker_packed_frames(frames, tf), height, width});
        if (!b->plucker || ray_field(b->plucker, B, frames, height, width, tf) != 0) return -1;
    }
    for (int i = 0; i < B && i < 8; i++) b->t[i] = 300.0f;
    b->use_camera = b->use_vace = 1;
    return b->latent && b->target ? 0 : -1;
}

static void bench_free(bench *b)
{
    if (b->use_cache) gv_dit_camera_cache_free(&b->cache);
    gv_graph_free(&b->g);
    gv_graph_free(&b->inputs);
    gv_dit_free(&b->m);
}

/* One step: forward (and loss + backward when b->backward). */
static int step(bench *b)
{
    gv_graph_reset(&b->g);
    gv_graph_set_grad(&b->g, b->backward);
    gv_arena_reset_peak(&b->g.arena);
    gv_dit_inputs in = gv_dit_inputs_default();
    in.latent = b->latent, in.timestep = b->t, in.text = b->text;
    in.vace = b->use_vace ? b->vace : NULL;
    in.plucker = b->use_camera && !b->use_cache ? b->plucker : NULL;
    in.camera_cache = b->use_cache ? &b->cache : NULL;
    gv_tensor *y = gv_dit_forward(&b->m, &b->g, &in);
    if (!y) return -1;
    if (b->backward) {
        gv_params_zero_grad(&b->m.params);
        if (gv_backward(&b->g, gv_l2_loss(&b->g, y, b->target, NULL)) != 0) return -1;
    }
    if (b->g.arena.peak > b->peak) b->peak = b->g.arena.peak;
    return 0;
}

static double cpu_seconds(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &ts);
    return ts.tv_sec + 1e-9 * ts.tv_nsec;
}

/* Best wall time of `trials` runs after one warm-up; *cpu (may be NULL) the least process CPU
 * time of one run (all threads together): on a loaded machine the wall time includes waiting
 * for a core, the CPU time does not. */
static double best_of(bench *b, int trials, double *cpu)
{
    if (step(b) != 0) return -1;
    double best = 1e30, best_cpu = 1e30;
    for (int i = 0; i < trials; i++) {
        double t0 = gv_now(), c0 = cpu_seconds();
        if (step(b) != 0) return -1;
        double t = gv_now() - t0, c = cpu_seconds() - c0;
        if (t < best) best = t;
        if (c < best_cpu) best_cpu = c;
    }
    if (cpu) *cpu = best_cpu;
    return best;
}

typedef struct {
    const char *label;
    double fwd, step, cpu_step, adamw;
    size_t peak;
} row;

/* Forward and forward + backward of the bench's current settings. */
static int measure(bench *b, const char *label, int trials, row *r)
{
    r->label = label;
    b->backward = 0;
    r->fwd = best_of(b, trials, NULL);
    b->backward = 1;
    b->peak = 0;
    r->step = best_of(b, trials, &r->cpu_step);
    r->peak = b->peak;
    gv_adamw_config cfg = gv_adamw_defaults();
    double t0 = gv_now();
    if (gv_adamw_step(&b->m.params, &cfg, 1e-4f) != 0) return -1;
    r->adamw = gv_now() - t0;
    return r->fwd < 0 || r->step < 0 ? -1 : 0;
}

static void print_row(FILE *out, const row *r, int json, int last)
{
    if (json)
        fprintf(out, "    {\"what\": \"%s\", \"forward_s\": %.4f, \"step_s\": %.4f, \"step_cpu_s\": %.4f, \"adamw_s\": %.4f, "
                     "\"peak_mib\": %.1f}%s\n",
                r->label, r->fwd, r->step, r->cpu_step, r->adamw, r->peak / 1048576.0, last ? "" : ",");
    else
        fprintf(out, "  %-40s %9.1f %11.1f %10.1f %8.1f %9.1f\n", r->label, 1e3 * r->fwd, 1e3 * r->step, 1e3 * r->cpu_step,
                1e3 * r->adamw, r->peak / 1048576.0);
}

int gv_bench_model(const gv_bench_options *o, const char *preset, int frames, int height, int width, FILE *out)
{
    preset = preset ? preset : "small";
    int trials = o->quick ? 1 : 5;
    static const struct { const char *label, *variant; int camera, vace; } cases[] = {
        {"fine-tuning step (decomposed, shipped)", NULL, 1, 1},
        {"  without the camera stream", NULL, 0, 1},
        {"  without VACE", NULL, 1, 0},
        {"  without camera stream and VACE", NULL, 0, 0},
        {"variant monolithic", "monolithic", 1, 1},
        {"variant early fusion", "early", 1, 1},
        {"variant camera none", "none", 0, 1},
        {"per-frame restorer (camera none)", "per-frame,camera=none", 0, 1},
    };
    enum { N_CASES = sizeof cases / sizeof cases[0] };
    row rows[N_CASES];
    double infer_fresh = 0, infer_cached = 0, cache_build = 0;
    bench b;
    for (int i = 0; i < N_CASES; i++) {
        if (i == 0 || cases[i].variant) {
            if (i > 0) bench_free(&b);
            if (bench_init(&b, preset, cases[i].variant, frames, height, width) != 0) return -1;
        }
        b.use_camera = cases[i].camera, b.use_vace = cases[i].vace;
        if (measure(&b, cases[i].label, trials, &rows[i]) != 0) return -1;
        if (i == 0) { /* inference: recomputed camera stream vs its cache */
            b.backward = 0;
            infer_fresh = best_of(&b, trials, NULL);
            double t0 = gv_now();
            if (gv_dit_camera_cache_build(&b.m, b.plucker, &b.cache) != 0) return -1;
            cache_build = gv_now() - t0;
            b.use_cache = 1;
            infer_cached = best_of(&b, trials, NULL);
            gv_dit_camera_cache_free(&b.cache);
            b.use_cache = 0;
        }
    }
    bench_free(&b);
    gv_model_config c;
    gv_model_cost cost;
    if (gv_model_config_load(&c, preset) != 0 || gv_model_cost_estimate(&c, frames, height, width, &cost) != 0) return -1;
    if (o->json) {
        fprintf(out, "{\n  \"preset\": \"%s\", \"clip\": [%d, %d, %d], \"threads\": %d, \"forward_gflop\": %.3f,\n",
                preset, frames, height, width, omp_get_max_threads(), cost.flops_total / 1e9);
        fprintf(out, "  \"inference\": {\"recomputed_s\": %.4f, \"cached_s\": %.4f, \"cache_build_s\": %.4f},\n  \"rows\": [\n",
                infer_fresh, infer_cached, cache_build);
        for (int i = 0; i < N_CASES; i++) print_row(out, &rows[i], 1, i == N_CASES - 1);
        fprintf(out, "  ]\n}\n");
        return 0;
    }
    fprintf(out, "model %s, clip %dx%dx%d (%d video tokens), %d threads, forward %.2f GFLOP (model_cost)\n", preset,
            frames, height, width, cost.video_tokens, omp_get_max_threads(), cost.flops_total / 1e9);
    fprintf(out, "  %-40s %9s %11s %10s %8s %9s\n", "(LoRA + camera trainable, base frozen)", "fwd ms", "fwd+bwd ms",
            "cpu ms", "adamw ms", "peak MiB");
    for (int i = 0; i < N_CASES; i++) print_row(out, &rows[i], 0, 0);
    fprintf(out, "inference (no gradients): camera stream recomputed %.1f ms, from its cache %.1f ms (%.2fx); "
                 "building the cache %.1f ms once per clip\n",
            1e3 * infer_fresh, 1e3 * infer_cached, infer_fresh / infer_cached, 1e3 * cache_build);
    return 0;
}
