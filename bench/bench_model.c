/* The restoration network's speed on one clip (docs/ARCHITECTURE.md 11; issue 5 "Performance"), per preset:
 * - one GaussVid fine-tuning step: forward, flow-matching L2 loss, backward, with LoRA and the
 *   camera encoder trainable and the base frozen (docs/ARCHITECTURE.md 6.7), its arena peak, and AdamW;
 * - the same with the camera stream and / or the VACE branch left out (what dominates);
 * - every camera variant and the per-frame restorer;
 * - inference: the forward pass with the camera stream recomputed or taken from its cache;
 * - the VAE's chunked encode and decode (bench_model_vae.c).
 * Presets above o->step_limit parameters get the inference rows only; presets whose weights
 * do not fit in the available memory are skipped, with the reason. Times are the best of
 * several trials (the machine is shared); the load average is printed with them. */
#include <cjson/cJSON.h>
#include <omp.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include "bench/bench_model.h"
#include "gaussvid/core/core.h"
#include "gaussvid/model/dit.h"
#include "gaussvid/model/plucker.h"

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

typedef struct {
    const char *label;
    double fwd, fwd_cpu, step, step_cpu, adamw; /* step < 0: not measured (forward only) */
    size_t peak, weights;              /* arena peak of the step (or forward); weight memory */
} row;

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
    if (!cams) return gv_fail("bench model: out of memory");
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

/* Bytes of the model's parameters: data, and gradient + two AdamW moments when trainable. */
static size_t weight_bytes(const gv_params *ps)
{
    return (size_t)(gv_params_count(ps, 0) + 3 * gv_params_count(ps, 1)) * sizeof(float);
}

/* The model of config c with `variant` in `mode`, and the inputs of one clip (per-frame: the
 * frames as a batch of single-frame latents). */
static int bench_init(bench *b, const gv_model_config *base, const char *variant, gv_dit_train_mode mode, int frames,
                      int height, int width)
{
    memset(b, 0, sizeof *b);
    gv_graph_init(&b->inputs, 0);
    gv_graph_init(&b->g, 0);
    gv_model_config c = *base;
    if ((variant && gv_model_config_set_variant(&c, variant, "bench model") != 0) || gv_dit_init(&b->m, &c, 1) != 0)
        return -1;
    if (gv_dit_set_train_mode(&b->m, mode) != 0) return -1;
    int tf = c.vae.temporal_factor, sf = c.vae.spatial_factor, B = 1;
    if (c.variant.per_frame) B = frames, frames = 1;
    if (B > 8) return gv_fail("bench model: the per-frame restorer takes at most 8 frames here");
    int T = 1 + (frames - 1) / tf, H = height / sf, W = width / sf;
    b->latent = random_leaf(&b->inputs, 5, (int[]){B, c.dit.in_dim, T, H, W}, 1);
    b->target = random_leaf(&b->inputs, 5, (int[]){B, c.dit.out_dim, T, H, W}, 2);
    if (c.dit.cross_attn) b->text = random_leaf(&b->inputs, 3, (int[]){B, c.dit.text_len, c.dit.text_dim}, 3);
    if (c.dit.n_vace_layers) b->vace = random_leaf(&b->inputs, 5, (int[]){B, c.dit.vace_in_dim, T, H, W}, 4);
    if (c.variant.camera != GV_CAMERA_NONE) {
        b->plucker = gv_tensor_new(&b->inputs, 5, (int[]){B, 6, gv_plucker_packed_frames(frames, tf), height, width});
        if (!b->plucker || ray_field(b->plucker, B, frames, height, width, tf) != 0) return -1;
    }
    for (int i = 0; i < B; i++) b->t[i] = 300.0f;
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

/* Best wall time of `trials` runs after one warm-up (none when trials is 0: one run counts);
 * *cpu (may be NULL) the least process CPU time of one run (all threads together): on a
 * loaded machine the wall time includes waiting for a core, the CPU time does not. */
static double best_of(bench *b, int trials, double *cpu)
{
    if (trials > 0 && step(b) != 0) return -1;
    double best = 1e30, best_cpu = 1e30;
    for (int i = 0; i < (trials > 0 ? trials : 1); i++) {
        double t0 = gv_now(), c0 = cpu_seconds();
        if (step(b) != 0) return -1;
        double t = gv_now() - t0, c = cpu_seconds() - c0;
        if (t < best) best = t;
        if (c < best_cpu) best_cpu = c;
    }
    if (cpu) *cpu = best_cpu;
    return best;
}

/* Forward, and forward + backward + AdamW unless forward_only, of the current settings. */
static int measure(bench *b, const char *label, int trials, int forward_only, row *r)
{
    memset(r, 0, sizeof *r);
    r->label = label;
    r->weights = weight_bytes(&b->m.params);
    b->backward = 0;
    b->peak = 0;
    r->fwd = best_of(b, trials, &r->fwd_cpu);
    r->peak = b->peak;
    r->step = r->adamw = -1;
    if (r->fwd < 0) return -1;
    if (forward_only) return 0;
    b->backward = 1;
    b->peak = 0;
    r->step = best_of(b, trials, &r->step_cpu);
    r->peak = b->peak;
    gv_adamw_config cfg = gv_adamw_defaults();
    double t0 = gv_now();
    if (r->step < 0 || gv_adamw_step(&b->m.params, &cfg, 1e-4f) != 0) return -1;
    r->adamw = gv_now() - t0;
    return 0;
}

/* ---- one preset ---------------------------------------------------------------------------- */
enum { MAX_ROWS = 8 };

typedef struct {
    char name[GV_CONFIG_NAME_MAX];
    char skipped[256];               /* why the preset was not run, or "" */
    int64_t params;                  /* DiT + VACE + camera + LoRA (the VAE separately) */
    double forward_gflop;
    int video_tokens, camera_tokens, forward_only;
    int n_rows;
    row rows[MAX_ROWS];
    double infer_fresh, infer_cached, cache_build, infer_fresh_cpu, infer_cached_cpu;
    int has_vae;
    gv_bench_vae_result vae;
} preset_result;

/* MemAvailable of /proc/meminfo in bytes, or 0 when unknown. */
static double available_memory(void)
{
    FILE *f = fopen("/proc/meminfo", "r");
    char line[256];
    double kib = 0;
    while (f && fgets(line, sizeof line, f))
        if (sscanf(line, "MemAvailable: %lf kB", &kib) == 1) break;
    if (f) fclose(f);
    return kib * 1024.0;
}

/* Inference with the camera stream recomputed, then from its cache (docs/ARCHITECTURE.md 6.5). */
static int measure_cache(bench *b, int trials, preset_result *p)
{
    b->backward = 0;
    b->use_camera = b->use_vace = 1;
    p->infer_fresh = best_of(b, trials, &p->infer_fresh_cpu);
    double t0 = gv_now();
    if (p->infer_fresh < 0 || gv_dit_camera_cache_build(&b->m, b->plucker, &b->cache) != 0) return -1;
    p->cache_build = gv_now() - t0;
    b->use_cache = 1;
    p->infer_cached = best_of(b, trials, &p->infer_cached_cpu);
    gv_dit_camera_cache_free(&b->cache);
    b->use_cache = 0;
    return p->infer_cached < 0 ? -1 : 0;
}

static int run_preset(const gv_bench_model_options *o, const gv_model_config *c, preset_result *p)
{
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
    int n_cases = (int)(sizeof cases / sizeof cases[0]);
    p->forward_only = p->params > o->step_limit;
    int trials = o->quick || p->forward_only ? 0 : o->trials;
    if (p->forward_only) n_cases = 1;
    bench b;
    int rc = 0;
    for (int i = 0; rc == 0 && i < n_cases; i++) {
        if (i == 0 || cases[i].variant) {
            if (i > 0) bench_free(&b);
            rc = bench_init(&b, c, cases[i].variant, p->forward_only ? GV_DIT_FROZEN : GV_DIT_FINETUNE, o->frames,
                            o->height, o->width);
            if (rc) break;
        }
        b.use_camera = cases[i].camera && b.plucker, b.use_vace = cases[i].vace;
        rc = measure(&b, p->forward_only ? "forward (decomposed, frozen weights)" : cases[i].label, trials,
                     p->forward_only, &p->rows[p->n_rows]);
        if (rc == 0) p->n_rows++;
        if (rc == 0 && i == 0 && b.plucker) rc = measure_cache(&b, trials, p);
    }
    bench_free(&b);
    if (rc == 0 && !o->no_vae) {
        rc = gv_bench_model_vae(c, o->frames, o->height, o->width, trials, &p->vae);
        p->has_vae = rc == 0;
    }
    return rc;
}

/* Fills what is known before running and decides whether the preset fits in memory. */
static int plan_preset(const gv_bench_model_options *o, const char *spec, gv_model_config *c, preset_result *p)
{
    memset(p, 0, sizeof *p);
    if (gv_model_config_load(c, spec) != 0) return -1;
    snprintf(p->name, sizeof p->name, "%s", c->name);
    gv_model_cost cost;
    if (gv_model_cost_estimate(c, o->frames, o->height, o->width, &cost) != 0) return gv_fail_context("bench model: %s", spec);
    p->forward_gflop = cost.flops_total / 1e9;
    p->video_tokens = cost.video_tokens, p->camera_tokens = cost.camera_tokens;
    gv_weight_list l;
    gv_weight_counts n;
    if (gv_weight_list_build(&l, c) != 0) return -1;
    gv_weight_list_count(&l, &n);
    gv_weight_list_free(&l);
    p->params = n.total - n.params[GV_MODULE_VAE_ENCODER] - n.params[GV_MODULE_VAE_DECODER];
    double need = 4.0 * (double)n.total * 1.15, avail = available_memory();
    if (avail > 0 && need > 0.8 * avail)
        snprintf(p->skipped, sizeof p->skipped,
                 "its %.1f GB of float32 weights (+15%% for activations) exceed 80%% of the %.1f GB of available memory",
                 4.0 * (double)n.total / 1e9, avail / 1e9);
    return 0;
}

/* ---- output -------------------------------------------------------------------------------- */
static double mib(size_t bytes) { return bytes / 1048576.0; }

static void print_table(const preset_result *p, const gv_bench_model_options *o, FILE *out)
{
    fprintf(out, "\nmodel %s, clip %dx%dx%d: %d video + %d camera tokens, forward %.4g GFLOP (model_cost), "
                 "%.2f M parameters without the VAE\n",
            p->name, o->frames, o->height, o->width, p->video_tokens, p->camera_tokens, p->forward_gflop, p->params / 1e6);
    if (p->skipped[0]) {
        fprintf(out, "  skipped: %s\n", p->skipped);
        return;
    }
    fprintf(out, "  %-40s %9s %9s %11s %9s %9s %10s %11s\n", p->forward_only ? "(inference)" : "(LoRA + camera trainable)",
            "fwd ms", "cpu ms", "fwd+bwd ms", "cpu ms", "adamw ms", "peak MiB", "weights MiB");
    for (int i = 0; i < p->n_rows; i++) {
        const row *r = &p->rows[i];
        if (r->step >= 0)
            fprintf(out, "  %-40s %9.1f %9.1f %11.1f %9.1f %9.1f %10.1f %11.1f\n", r->label, 1e3 * r->fwd, 1e3 * r->fwd_cpu,
                    1e3 * r->step, 1e3 * r->step_cpu, 1e3 * r->adamw, mib(r->peak), mib(r->weights));
        else
            fprintf(out, "  %-40s %9.1f %9.1f %11s %9s %9s %10.1f %11.1f\n", r->label, 1e3 * r->fwd, 1e3 * r->fwd_cpu, "-",
                    "-", "-", mib(r->peak), mib(r->weights));
    }
    if (p->infer_cached > 0)
        fprintf(out, "  inference (no gradients): camera stream recomputed %.1f ms (cpu %.1f), from its cache %.1f ms "
                     "(cpu %.1f): %.2fx (cpu %.2fx); building the cache %.1f ms once per clip\n",
                1e3 * p->infer_fresh, 1e3 * p->infer_fresh_cpu, 1e3 * p->infer_cached, 1e3 * p->infer_cached_cpu,
                p->infer_fresh / p->infer_cached, p->infer_fresh_cpu / p->infer_cached_cpu, 1e3 * p->cache_build);
    if (p->has_vae)
        fprintf(out, "  VAE (%.2f M parameters), chunked as Wan: encode %.1f ms (cpu %.1f, peak %.1f MiB), decode %.1f ms "
                     "(cpu %.1f, peak %.1f MiB)\n",
                p->vae.params / 1e6, 1e3 * p->vae.encode_s, 1e3 * p->vae.encode_cpu_s, p->vae.encode_peak_mib,
                1e3 * p->vae.decode_s, 1e3 * p->vae.decode_cpu_s, p->vae.decode_peak_mib);
}

static cJSON *preset_json(const preset_result *p)
{
    cJSON *o = cJSON_CreateObject();
    cJSON_AddStringToObject(o, "preset", p->name);
    cJSON_AddNumberToObject(o, "parameters_without_vae", (double)p->params);
    cJSON_AddNumberToObject(o, "forward_gflop", p->forward_gflop);
    cJSON_AddNumberToObject(o, "video_tokens", p->video_tokens);
    cJSON_AddNumberToObject(o, "camera_tokens", p->camera_tokens);
    if (p->skipped[0]) {
        cJSON_AddStringToObject(o, "skipped", p->skipped);
        return o;
    }
    cJSON_AddBoolToObject(o, "forward_only", p->forward_only);
    cJSON *rows = cJSON_AddArrayToObject(o, "rows");
    for (int i = 0; i < p->n_rows; i++) {
        const row *r = &p->rows[i];
        cJSON *j = cJSON_CreateObject();
        const char *label = r->label;
        while (*label == ' ') label++;
        cJSON_AddStringToObject(j, "what", label);
        cJSON_AddNumberToObject(j, "forward_s", r->fwd);
        cJSON_AddNumberToObject(j, "forward_cpu_s", r->fwd_cpu);
        if (r->step >= 0) {
            cJSON_AddNumberToObject(j, "step_s", r->step);
            cJSON_AddNumberToObject(j, "step_cpu_s", r->step_cpu);
            cJSON_AddNumberToObject(j, "adamw_s", r->adamw);
        }
        cJSON_AddNumberToObject(j, "peak_mib", mib(r->peak));
        cJSON_AddNumberToObject(j, "weights_mib", mib(r->weights));
        cJSON_AddItemToArray(rows, j);
    }
    if (p->infer_cached > 0) {
        cJSON *c = cJSON_AddObjectToObject(o, "inference");
        cJSON_AddNumberToObject(c, "recomputed_s", p->infer_fresh);
        cJSON_AddNumberToObject(c, "cached_s", p->infer_cached);
        cJSON_AddNumberToObject(c, "cache_build_s", p->cache_build);
        cJSON_AddNumberToObject(c, "speedup", p->infer_fresh / p->infer_cached);
        cJSON_AddNumberToObject(c, "recomputed_cpu_s", p->infer_fresh_cpu);
        cJSON_AddNumberToObject(c, "cached_cpu_s", p->infer_cached_cpu);
    }
    if (p->has_vae) {
        cJSON *v = cJSON_AddObjectToObject(o, "vae");
        cJSON_AddNumberToObject(v, "parameters", (double)p->vae.params);
        cJSON_AddNumberToObject(v, "encode_s", p->vae.encode_s);
        cJSON_AddNumberToObject(v, "decode_s", p->vae.decode_s);
        cJSON_AddNumberToObject(v, "encode_cpu_s", p->vae.encode_cpu_s);
        cJSON_AddNumberToObject(v, "decode_cpu_s", p->vae.decode_cpu_s);
        cJSON_AddNumberToObject(v, "encode_peak_mib", p->vae.encode_peak_mib);
        cJSON_AddNumberToObject(v, "decode_peak_mib", p->vae.decode_peak_mib);
    }
    return o;
}

void gv_bench_model_defaults(gv_bench_model_options *o)
{
    memset(o, 0, sizeof *o);
    o->presets = "tiny,small";
    o->frames = 5, o->height = 144, o->width = 256;
    o->step_limit = 100000000;
    o->trials = 5;
}

int gv_bench_model(const gv_bench_model_options *o, FILE *out)
{
    char *list = strdup(o->presets), *save = NULL;
    if (!list) return gv_fail("bench model: out of memory");
    double load[3] = {0, 0, 0};
    if (getloadavg(load, 3) < 1) load[0] = -1;
    cJSON *root = o->json ? cJSON_CreateObject() : NULL, *presets = NULL;
    if (root) {
        cJSON_AddNumberToObject(root, "threads", omp_get_max_threads());
        cJSON_AddNumberToObject(root, "load_before", load[0]);
        cJSON *clip = cJSON_AddArrayToObject(root, "clip");
        const int dims[3] = {o->frames, o->height, o->width};
        for (int k = 0; k < 3; k++) cJSON_AddItemToArray(clip, cJSON_CreateNumber(dims[k]));
        presets = cJSON_AddArrayToObject(root, "presets");
    } else {
        fprintf(out, "bench model: %d threads, load average %.2f at the start; best of %d trials per time\n",
                omp_get_max_threads(), load[0], o->quick ? 1 : o->trials);
    }
    int rc = 0;
    for (char *spec = strtok_r(list, ",", &save); rc == 0 && spec; spec = strtok_r(NULL, ",", &save)) {
        gv_model_config c;
        preset_result *p = calloc(1, sizeof *p);
        rc = p ? plan_preset(o, spec, &c, p) : gv_fail("bench model: out of memory");
        if (rc == 0 && !p->skipped[0]) rc = run_preset(o, &c, p);
        if (rc == 0 && root) cJSON_AddItemToArray(presets, preset_json(p));
        else if (rc == 0) print_table(p, o, out);
        fflush(out);
        free(p);
    }
    if (getloadavg(load, 1) < 1) load[0] = -1;
    if (root && rc == 0) {
        cJSON_AddNumberToObject(root, "load_after", load[0]);
        char *text = cJSON_Print(root);
        if (text) fprintf(out, "%s\n", text);
        cJSON_free(text);
    } else if (rc == 0) {
        fprintf(out, "load average %.2f at the end\n", load[0]);
    }
    cJSON_Delete(root);
    free(list);
    return rc;
}

int gv_bench_model_command(int argc, char **argv)
{
    gv_bench_model_options o;
    gv_bench_model_defaults(&o);
    double step_limit = (double)o.step_limit;
    const gv_flag flags[] = {
        {"json", GV_FLAG_BOOL, &o.json, NULL, "print JSON instead of tables", 0},
        {"quick", GV_FLAG_BOOL, &o.quick, NULL, "one run per quantity, no warm-up (a smoke test)", 0},
        {"trials", GV_FLAG_INT, &o.trials, "N", "timed runs per quantity after a warm-up, the best counts (default 5)", 0},
        {"presets", GV_FLAG_STRING, &o.presets, "P,...", "presets or config files (default tiny,small)", 0},
        {"frames", GV_FLAG_INT, &o.frames, "N", "clip frames (default 5)", 0},
        {"height", GV_FLAG_INT, &o.height, "N", "clip height in pixels (default 144)", 0},
        {"width", GV_FLAG_INT, &o.width, "N", "clip width in pixels (default 256)", 0},
        {"step-limit", GV_FLAG_DOUBLE, &step_limit, "P",
         "presets with more parameters (VAE excluded) get one forward pass only (default 1e8)", 0},
        {"no-vae", GV_FLAG_BOOL, &o.no_vae, NULL, "skip the VAE encode/decode timings", 0},
    };
    const gv_command_spec spec = {
        "bench model", NULL, "restoration network speed: fine-tuning step per variant, camera cache, VAE",
        "For each preset, on one clip (default 5x144x256): the forward and forward+backward time\n"
        "of a GaussVid fine-tuning step (LoRA + camera encoder trainable, base frozen), its CPU time,\n"
        "AdamW, the arena peak (activations) and the weight memory, for the shipped network, without\n"
        "the camera stream or VACE, and for every variant; inference with the camera stream\n"
        "recomputed or cached; the VAE's chunked encode and decode. Larger presets (e.g.\n"
        "wan2.1-vace-1.3b) get one forward pass; presets whose weights do not fit in memory are\n"
        "skipped with the reason. Results: docs/BENCHMARKS.md.",
        flags, (int)(sizeof flags / sizeof flags[0]), 0, 0};
    int rc = gv_args_parse(&spec, argc, argv, NULL, NULL);
    if (rc != GV_ARGS_OK) return gv_args_exit_code(rc);
    if (o.frames < 1 || o.height < 1 || o.width < 1 || o.trials < 1 || !(step_limit >= 0)) {
        fprintf(stderr, "gaussvid bench model: --frames, --height, --width and --trials must be positive\n");
        return 2;
    }
    o.step_limit = (int64_t)step_limit;
    return gv_bench_model(&o, stdout) == 0 ? 0 : gv_report_failure();
}
