/* `gaussvid bench stream`: the Wan presets on random BF16 weights of the real shapes, with the
 * base streamed from the mapped file as restore and train run an imported release (dit.h
 * "Memory"; docs/WAN_WEIGHTS.md). Writes the DiT + VACE tensors of the preset in BF16 to one
 * safetensors file in --dir (pseudo-random values: the time does not depend on them), then
 * runs the work in a child process (this program again), so that its CPU time and peak
 * resident set (wait4's rusage) are the work's alone:
 *   forward  one DiT + VACE evaluation on a clip, with a text context of text_len tokens;
 *   restore  what `restore` does for one clip: three VAE encodes (the render; the inactive and
 *            reactive parts of the VACE context), the released sampler (10 Euler steps), two
 *            VAE decodes (residual decoding), the VAE with random weights of its real shapes;
 *   train    one GaussVid fine-tuning step on a cached clip: forward, loss, backward into the
 *            LoRA adapters (the base frozen in BF16), AdamW.
 * The child prints each block of a forward pass with its CPU time and resident set, so a run
 * stopped early says how far it got. The file is removed afterwards unless --keep. */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/resource.h>
#include <sys/wait.h>
#include <time.h>
#include <unistd.h>

#include "bench/bench_train.h"
#include "gaussvid/core/core.h"
#include "gaussvid/model/dit.h"
#include "gaussvid/restore/restore.h"
#include "gaussvid/io/safetensors.h"
#include "gaussvid/train/train.h"
#include "gaussvid/model/vae.h"

typedef struct {
    const char *preset, *work;
    int frames, height, width;
} stream_job;

static double process_cpu(void)
{
    struct timespec t;
    clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &t);
    return (double)t.tv_sec + t.tv_nsec / 1e9;
}

/* VmRSS and VmHWM of this process in GB. */
static void rss_gb(double *now, double *peak)
{
    FILE *f = fopen("/proc/self/status", "r");
    char line[256];
    *now = *peak = -1;
    while (f && fgets(line, sizeof line, f)) {
        if (!strncmp(line, "VmRSS:", 6)) *now = strtod(line + 6, NULL) * 1024 / 1e9;
        if (!strncmp(line, "VmHWM:", 6)) *peak = strtod(line + 6, NULL) * 1024 / 1e9;
    }
    if (f) fclose(f);
}

/* Bytes this process has caused to be read from the disk (read_bytes of /proc/self/io: page
 * cache hits are not counted), in GB; -1 where the kernel does not say. */
static double disk_read_gb(void)
{
    FILE *f = fopen("/proc/self/io", "r");
    char line[128];
    double gb = -1;
    while (f && fgets(line, sizeof line, f))
        if (!strncmp(line, "read_bytes:", 11)) gb = strtod(line + 11, NULL) / 1e9;
    if (f) fclose(f);
    return gb;
}

static void report(const char *what)
{
    double now, peak;
    rss_gb(&now, &peak);
    printf("  %s: %.1f CPU-s, resident %.2f GB, peak %.2f GB, read from disk %.2f GB\n", what, process_cpu(), now, peak,
           disk_read_gb());
    fflush(stdout);
}

static void block_done(void *ctx, int done, int total)
{
    (void)ctx;
    char what[64];
    snprintf(what, sizeof what, "block %d/%d", done, total);
    report(what);
}

static int job_config(const char *preset, gv_model_config *c)
{
    return gv_model_config_load(c, preset) || gv_model_config_set_variant(c, "camera=none", "bench stream") ? -1 : 0;
}

/* The DiT + VACE tensors of c in BF16 into path: every tensor takes its values from one
 * buffer of BF16 values of the largest size, at an offset of its own (raw bytes: no
 * conversion per tensor, so writing is disk-bound). */
static int write_base(const gv_model_config *c, const char *path, int64_t *bytes)
{
    gv_weight_list l;
    if (gv_weight_list_build(&l, c)) return -1;
    int64_t largest = 0;
    for (int i = 0; i < l.n; i++) largest = l.items[i].numel > largest ? l.items[i].numel : largest;
    int64_t span = largest + 4096;
    float *values = malloc((size_t)span * sizeof *values);
    uint16_t *bf16 = malloc((size_t)span * sizeof *bf16);
    if (!values || !bf16) {
        free(values), free(bf16);
        gv_weight_list_free(&l);
        return gv_fail("bench stream: out of memory");
    }
    gv_fill_uniform(values, span, 17, 0, -0.02f, 0.02f);
    for (int64_t k = 0; k < span; k++) bf16[k] = gv_f32_to_bf16(values[k]);
    free(values);
    gv_st_builder b;
    gv_st_builder_init(&b);
    int rc = 0;
    *bytes = 0;
    for (int i = 0; rc == 0 && i < l.n; i++) {
        const gv_weight_spec *w = &l.items[i];
        if (!(gv_module_part(w->module) & (GV_PART_DIT | GV_PART_VACE))) continue;
        rc = gv_st_add_raw(&b, w->name, GV_ST_BF16, w->shape, w->rank, bf16 + (i * 7919) % 4096);
        *bytes += 2 * w->numel;
    }
    if (rc == 0) rc = gv_st_add_metadata(&b, "format", "gaussvid-dit");
    if (rc == 0) rc = gv_st_write(&b, path);
    gv_st_builder_free(&b);
    gv_weight_list_free(&l);
    free(bf16);
    return rc;
}

static float *random_floats(int64_t n, uint64_t seed, float lo, float hi);

/* A random rank-r LoRA in the GaussVid release's naming (docs/GAUSSVID_RELEASE.md): PEFT
 * pairs pipe.dit.blocks.i.M.lora_{A,B}.default.weight and pipe.vace.vace_blocks.j.M... for
 * every q, k, v, o of both attentions and ffn.0, ffn.2, in BF16, values from one buffer. */
static int write_lora(const gv_model_config *c, int rank, const char *path, int64_t *bytes)
{
    static const char *const modules[] = {"self_attn.q", "self_attn.k", "self_attn.v", "self_attn.o", "cross_attn.q",
                                          "cross_attn.k", "cross_attn.v", "cross_attn.o", "ffn.0", "ffn.2"};
    const int D = c->dit.dim, Fd = c->dit.ffn_dim, n_mod = c->dit.cross_attn ? 10 : 6;
    const int64_t span = (int64_t)rank * (D > Fd ? D : Fd) + 4096;
    float *values = random_floats(span, 23, -0.01f, 0.01f);
    uint16_t *bf16 = malloc((size_t)span * sizeof *bf16);
    char (*names)[128] = calloc((size_t)2 * n_mod * (c->dit.num_layers + c->dit.n_vace_layers) + 1, sizeof *names);
    int rc = values && bf16 && names ? 0 : gv_fail("bench stream: out of memory");
    for (int64_t k = 0; rc == 0 && k < span; k++) bf16[k] = gv_f32_to_bf16(values[k]);
    gv_st_builder b;
    gv_st_builder_init(&b);
    *bytes = 0;
    int n = 0;
    for (int blk = 0; rc == 0 && blk < c->dit.num_layers + c->dit.n_vace_layers; blk++)
        for (int m = 0; rc == 0 && m < n_mod; m++) {
            int vace = blk >= c->dit.num_layers, i = vace ? blk - c->dit.num_layers : blk;
            int mi = c->dit.cross_attn ? m : (m < 4 ? m : m + 4);
            int64_t out = !strcmp(modules[mi], "ffn.0") ? Fd : D, in = !strcmp(modules[mi], "ffn.2") ? Fd : D;
            for (int ab = 0; rc == 0 && ab < 2; ab++, n++) {
                snprintf(names[n], sizeof names[n], "pipe.%s.%s.%d.%s.lora_%c.default.weight", vace ? "vace" : "dit",
                         vace ? "vace_blocks" : "blocks", i, modules[mi], ab ? 'B' : 'A');
                const int64_t shape[2] = {ab ? out : rank, ab ? rank : in};
                rc = gv_st_add_raw(&b, names[n], GV_ST_BF16, shape, 2, bf16 + (n * 7919) % 4096);
                *bytes += 2 * shape[0] * shape[1];
            }
        }
    if (rc == 0) rc = gv_st_write(&b, path);
    gv_st_builder_free(&b);
    free(values), free(bf16), free(names);
    return rc;
}

/* Runs this program with argv in a child; its CPU seconds, wall seconds and peak RSS (GB). */
static int timed_child(char *const argv[], double *cpu, double *wall, double *peak_gb)
{
    fflush(stdout);
    double t0 = gv_now();
    pid_t pid = fork();
    if (pid < 0) return gv_fail("bench stream: cannot fork");
    if (pid == 0) {
        execv("/proc/self/exe", argv);
        _exit(127);
    }
    int status = 0;
    struct rusage ru;
    int rc = wait4(pid, &status, 0, &ru) == pid && WIFEXITED(status) && WEXITSTATUS(status) == 0 ? 0 : -1;
    *cpu = (double)ru.ru_utime.tv_sec + ru.ru_utime.tv_usec / 1e6 + (double)ru.ru_stime.tv_sec + ru.ru_stime.tv_usec / 1e6;
    *wall = gv_now() - t0;
    *peak_gb = ru.ru_maxrss * 1024.0 / 1e9;
    return rc ? gv_fail("bench stream: %s %s failed (status %d)", argv[1], argv[2], status) : 0;
}

static float *random_floats(int64_t n, uint64_t seed, float lo, float hi)
{
    float *x = malloc((size_t)n * sizeof *x);
    if (x) gv_fill_uniform(x, n, seed, 0, lo, hi);
    return x;
}

/* Latents of a clip of the job's size: z_clean, z_corrupt (random or given) and the VACE context. */
static int clip_latents(const gv_model_config *c, const stream_job *j, gv_clip_latents *l)
{
    memset(l, 0, sizeof *l);
    l->frames = j->frames, l->height = j->height, l->width = j->width, l->batch = 1;
    l->z_dim = c->dit.in_dim, l->vace_dim = c->dit.vace_in_dim;
    l->latent_frames = 1 + (j->frames - 1) / c->vae.temporal_factor;
    l->lh = j->height / c->vae.spatial_factor, l->lw = j->width / c->vae.spatial_factor;
    int64_t nz = gv_clip_latents_z_count(l), nv = gv_clip_latents_vace_count(l);
    l->z_clean = random_floats(nz, 1, -1, 1), l->z_corrupt = random_floats(nz, 2, -1, 1), l->vace = random_floats(nv, 3, -1, 1);
    return l->z_clean && l->z_corrupt && l->vace ? 0 : gv_fail("bench stream: out of memory");
}

static int work_forward(gv_dit *m, const gv_clip_latents *l)
{
    gv_graph g;
    gv_graph_init(&g, 0);
    gv_graph_set_grad(&g, 0);
    float t = 500.0f;
    gv_dit_inputs in = gv_dit_inputs_default();
    in.latent = gv_tensor_from(&g, 5, (int[]){1, l->z_dim, l->latent_frames, l->lh, l->lw}, l->z_corrupt);
    in.vace = gv_tensor_from(&g, 5, (int[]){1, l->vace_dim, l->latent_frames, l->lh, l->lw}, l->vace);
    in.text = m->cfg.dit.cross_attn ? gv_dit_text_input(m, &g, 1) : NULL;
    in.timestep = &t;
    in.progress = block_done;
    gv_tensor *y = gv_dit_forward(m, &g, &in);
    gv_graph_free(&g);
    return y ? 0 : -1;
}

/* The sampler's velocity, reported after each DiT evaluation (its CPU, memory and disk read). */
static int reported_velocity(void *ctx, const float *x, double sigma, float *v)
{
    gv_restore_net *net = ctx;
    int rc = gv_restore_net_velocity(ctx, x, sigma, v);
    char what[64];
    snprintf(what, sizeof what, "DiT evaluation %d (sigma %.4f)", net->evaluations, sigma);
    if (rc == 0) report(what);
    return rc;
}

/* restore's work on one clip (restore_run.c): encodes, the sampler, decodes. */
static int work_restore(gv_dit *m, const gv_model_config *c, const stream_job *j, gv_clip_latents *l)
{
    gv_vae vae;
    if (gv_vae_init(&vae, c, 0, 5)) return -1;
    report("VAE built (random weights)");
    int64_t nv = (int64_t)3 * j->frames * j->height * j->width, nz = gv_clip_latents_z_count(l);
    float *video = random_floats(nv, 6, -1, 1), *z = malloc((size_t)nz * sizeof *z);
    int rc = video && z ? 0 : gv_fail("bench stream: out of memory");
    for (int k = 0; rc == 0 && k < 3; k++) { /* the render; the inactive and reactive parts */
        float *out = k == 0 ? l->z_corrupt : l->vace + (k - 1) * nz;
        rc = gv_vae_encode(&vae, video, j->frames, j->height, j->width, 0, c->vae.temporal_factor, out);
        report("VAE encode");
    }
    gv_sampler s;
    if (rc == 0) rc = gv_sampler_from_name("released", &s);
    if (rc == 0) rc = gv_restore_latent_with(m, l, &s, 7, reported_velocity, z);
    if (rc == 0) report("sampler: released, 10 Euler steps");
    for (int k = 0; rc == 0 && k < 2; k++) { /* residual decoding: D(z) and D(z-hat) */
        rc = gv_vae_decode(&vae, k ? l->z_corrupt : z, l->latent_frames, l->lh, l->lw, 0, 1, video);
        report("VAE decode");
    }
    free(video), free(z);
    gv_vae_free(&vae);
    return rc;
}

static int work_train(gv_dit *m, gv_clip_latents *l)
{
    if (gv_dit_set_train_mode(m, GV_DIT_FINETUNE)) return -1;
    printf("  trainable: %.1f M parameters (LoRA), BF16 base frozen\n", gv_params_count(&m->params, 1) / 1e6);
    gv_graph g;
    gv_graph_init(&g, 0);
    gv_sample_draw d;
    memset(&d, 0, sizeof d);
    d.t = 0.5f, d.w_cur = d.w_t = 1.0;
    int64_t nz = gv_clip_latents_z_count(l);
    float *eps = random_floats(nz, 8, -1.7f, 1.7f);
    gv_sample_losses losses;
    gv_params_zero_grad(&m->params);
    int rc = eps ? gv_train_sample(m, &g, l, GV_OBJECTIVE_FINETUNE, &d, eps, 1.0, 1, &losses) : -1;
    if (rc == 0) report("forward + backward");
    gv_adamw_config ac = gv_adamw_defaults();
    if (rc == 0) rc = gv_adamw_step(&m->params, &ac, 1e-4f);
    if (rc == 0) report("AdamW step");
    gv_graph_free(&g);
    free(eps);
    return rc;
}

/* The child: the model from the file (BF16 kept mapped), then the work. */
static int run_job(const char *path, const stream_job *j)
{
    gv_model_config c;
    if (job_config(j->preset, &c)) return -1;
    gv_dit m;
    const char *paths[1] = {path};
    if (gv_dit_init_parts(&m, &c, 1, GV_PART_DIT | GV_PART_VACE) || gv_dit_load(&m, paths, 1, GV_PART_DIT | GV_PART_VACE))
        return -1;
    int kept = 0;
    int64_t bf16 = gv_dit_bf16_bytes(&m, &kept);
    printf("  %s: %d linear weights kept in BF16 (%.2f GB mapped), %.2f GB in float32\n", c.name, kept, bf16 / 1e9,
           (gv_params_count(&m.params, 0) - bf16 / 2) * 4 / 1e9);
    if (c.dit.cross_attn) { /* a context of text_len tokens (the prompt's, padded, in use) */
        float *text = random_floats((int64_t)c.dit.text_len * c.dit.text_dim, 9, -0.2f, 0.2f);
        int rc = text ? gv_dit_set_text(&m, text) : -1;
        free(text);
        if (rc) return -1;
    }
    report("loaded");
    gv_clip_latents l;
    int rc = clip_latents(&c, j, &l);
    if (rc == 0) {
        if (!strcmp(j->work, "forward")) rc = work_forward(&m, &l);
        else if (!strcmp(j->work, "restore")) rc = work_restore(&m, &c, j, &l);
        else rc = work_train(&m, &l);
    }
    if (rc == 0) report("done");
    gv_clip_latents_free(&l);
    gv_dit_free(&m);
    return rc;
}

int gv_bench_stream_command(int argc, char **argv)
{
    stream_job j = {"wan2.1-vace-1.3b", "forward", 5, 144, 256};
    const char *dir = NULL, *run = NULL;
    int keep = 0, lora_rank = 0;
    const gv_flag flags[] = {
        {"dir", GV_FLAG_STRING, &dir, "DIR", "folder for the BF16 weight file (1.3B: 4.3 GB, 14B: 35 GB)", 0},
        {"preset", GV_FLAG_STRING, &j.preset, "P", "the network (default wan2.1-vace-1.3b)", 0},
        {"work", GV_FLAG_STRING, &j.work, "W", "forward (default), restore or train", 0},
        {"frames", GV_FLAG_INT, &j.frames, "N", "clip frames (default 5)", 0},
        {"height", GV_FLAG_INT, &j.height, "N", "clip height (default 144)", 0},
        {"width", GV_FLAG_INT, &j.width, "N", "clip width (default 256)", 0},
        {"keep", GV_FLAG_BOOL, &keep, NULL, "keep the weight file (and reuse it when it is there)", 0},
        {"lora-rank", GV_FLAG_INT, &lora_rank, "R",
         "also write a random rank-R LoRA in the GaussVid release's naming, fuse it (model merge, timed) and run on the "
         "fused file (docs/GAUSSVID_RELEASE.md)", 0},
        {"run", GV_FLAG_STRING, &run, "FILE", "(internal) the child: run the work on this weight file", 0},
    };
    const gv_command_spec spec = {"bench stream", NULL, "a Wan preset with BF16 weights streamed from the mapped file",
                                  NULL, flags, (int)(sizeof flags / sizeof flags[0]), 0, 0};
    int parsed = gv_args_parse(&spec, argc, argv, NULL, NULL);
    if (parsed != GV_ARGS_OK) return gv_args_exit_code(parsed);
    if (strcmp(j.work, "forward") && strcmp(j.work, "restore") && strcmp(j.work, "train")) {
        fprintf(stderr, "gaussvid bench stream: --work is forward, restore or train\n");
        return 2;
    }
    if (run) return run_job(run, &j) == 0 ? 0 : gv_report_failure();
    if (!dir) {
        fprintf(stderr, "gaussvid bench stream: --dir is required\n");
        return 2;
    }
    gv_model_config c;
    char path[4200], name[128];
    snprintf(name, sizeof name, "bench-stream-%s-bf16.safetensors", j.preset);
    if (job_config(j.preset, &c) || gv_mkdirs(dir) || gv_path_join(path, sizeof path, dir, name)) return gv_report_failure();
    double load[1] = {-1};
    getloadavg(load, 1);
    printf("bench stream: %s, %s on a %dx%dx%d clip, load average %.1f at the start\n", c.name, j.work, j.frames,
           j.height, j.width, load[0]);
    if (!keep || !gv_file_exists(path)) {
        double t0 = gv_now();
        int64_t bytes = 0;
        if (write_base(&c, path, &bytes)) return gv_report_failure();
        printf("  wrote %s: %.2f GB of BF16 DiT + VACE in %.0f s\n", path, bytes / 1e9, gv_now() - t0);
    }
    char lora[4200], fused[4200], *run_on = path;
    double cpu, wall, peak;
    int rc = 0, fused_written = 0;
    if (lora_rank > 0) { /* the GaussVid checkpoint: written, then fused into a copy of the base */
        int64_t bytes = 0;
        snprintf(lora, sizeof lora, "%s.lora%d.safetensors", path, lora_rank);
        snprintf(fused, sizeof fused, "%s.fused.safetensors", path);
        double t0 = gv_now();
        rc = write_lora(&c, lora_rank, lora, &bytes);
        if (rc == 0) printf("  wrote %s: %.2f GB rank-%d LoRA in %.0f s\n", lora, bytes / 1e9, lora_rank, gv_now() - t0);
        char *merge[] = {"gaussvid", "model", "merge", "--base", path, "--lora", lora, "--out", fused, "--quiet", NULL};
        if (rc == 0) rc = timed_child(merge, &cpu, &wall, &peak), fused_written = rc == 0;
        if (rc == 0)
            printf("bench stream: model merge (rank %d, bf16): %.1f CPU-s, %.0f s wall, peak resident set %.2f GB\n",
                   lora_rank, cpu, wall, peak);
        run_on = fused;
    }
    char frames[16], height[16], width[16];
    snprintf(frames, sizeof frames, "%d", j.frames), snprintf(height, sizeof height, "%d", j.height);
    snprintf(width, sizeof width, "%d", j.width);
    char *child[] = {"gaussvid", "bench", "stream", "--run", run_on, "--preset", (char *)j.preset, "--work", (char *)j.work,
                     "--frames", frames, "--height", height, "--width", width, NULL};
    if (rc == 0) rc = timed_child(child, &cpu, &wall, &peak);
    getloadavg(load, 1);
    if (rc == 0)
        printf("bench stream: %s %s: %.1f CPU-s, %.0f s wall, peak resident set %.2f GB (%.2f GiB); load average %.1f at "
               "the end\n", c.name, j.work, cpu, wall, peak, peak * 1e9 / 1073741824.0, load[0]);
    if (!keep && unlink(path) != 0) gv_warn("bench stream: could not remove %s", path);
    if (lora_rank > 0 && unlink(lora) != 0 && !keep) gv_warn("bench stream: could not remove %s", lora);
    if (fused_written && unlink(fused) != 0) gv_warn("bench stream: could not remove %s", fused);
    return rc ? gv_report_failure() : 0;
}
