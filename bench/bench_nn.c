/* `gaussvid bench nn`: speed of the tensor engine at the restorer's transformer shapes.
 * - linear forward+backward (y = x W^T + b, dx, dW, db) in GFLOP/s against the three plain
 *   sgemm calls it is made of, on the same shapes (the engine's overhead);
 * - attention forward and forward+backward time;
 * - one Wan-style block (adaLN modulation, q/k RMSNorm, 3D RoPE, attention, GELU FFN):
 *   forward+backward time and the arena's peak, with trainable and with frozen weights. */
#include <cblas.h>
#include <math.h>
#include <omp.h>
#include <stdlib.h>
#include <string.h>

#include "bench/bench.h"
#include "gaussvid/core/core.h"
#include "gaussvid/nn/nn.h"

typedef int (*step_fn)(void *ctx);

/* How long to time each quantity: `trials` trials sharing `seconds`. */
typedef struct {
    double seconds;
    int trials;
} plan;

/* Mean seconds per call over one trial of at least `seconds`. */
static double trial(step_fn fn, void *ctx, double seconds)
{
    int reps = 0;
    double start = gv_now(), elapsed;
    do {
        if (fn(ctx) != 0) return -1;
        reps++;
        elapsed = gv_now() - start;
    } while (elapsed < seconds);
    return elapsed / reps;
}

/* Times fn_a and fn_b (fn_b may be NULL) in alternating trials after a warm-up call each and
 * keeps each one's best trial: on a machine shared with other work, the best trial is the
 * least disturbed, and alternating exposes both to the same disturbances. */
static int time_pair(step_fn fn_a, step_fn fn_b, void *ctx, plan p, double *ta, double *tb)
{
    if (fn_a(ctx) != 0 || (fn_b && fn_b(ctx) != 0)) return -1;
    *ta = *tb = 1e30;
    for (int t = 0; t < p.trials; t++) {
        double a = trial(fn_a, ctx, p.seconds / p.trials);
        double b = fn_b ? trial(fn_b, ctx, p.seconds / p.trials) : 0;
        if (a < 0 || b < 0) return -1;
        if (a < *ta) *ta = a;
        if (b < *tb) *tb = b;
    }
    return 0;
}

static gv_tensor *param(gv_params *ps, const char *name, int rows, int cols, int trainable, float std)
{
    gv_tensor *t = cols ? gv_params_add(ps, name, 2, (int[]){rows, cols}, trainable)
                        : gv_params_add(ps, name, 1, (int[]){rows}, trainable);
    if (t) gv_fill_normal(t->data, t->numel, gv_seed_for_name(1, name), 0, 0.0f, std);
    return t;
}

/* ---- linear --------------------------------------------------------------------------- */
typedef struct {
    gv_graph g;
    gv_params ps;
    gv_tensor *x, *w, *b;
    float *dy, *y_ref;
    int n, in, out;
} linear_bench;

static int linear_step(void *p)
{
    linear_bench *c = p;
    gv_graph_reset(&c->g);
    gv_tensor *y = gv_linear(&c->g, c->x, c->w, c->b);
    return y ? gv_backward_seed(&c->g, y, c->dy) : -1;
}

static int sgemm_step(void *p)
{
    linear_bench *c = p;
    cblas_sgemm(CblasRowMajor, CblasNoTrans, CblasTrans, c->n, c->out, c->in, 1.0f, c->x->data,
                c->in, c->w->data, c->in, 0.0f, c->y_ref, c->out);
    cblas_sgemm(CblasRowMajor, CblasNoTrans, CblasNoTrans, c->n, c->in, c->out, 1.0f, c->dy,
                c->out, c->w->data, c->in, 1.0f, c->x->grad, c->in);
    cblas_sgemm(CblasRowMajor, CblasTrans, CblasNoTrans, c->out, c->in, c->n, 1.0f, c->dy, c->out,
                c->x->data, c->in, 1.0f, c->w->grad, c->in);
    return 0;
}

static int bench_linear(int n, int in, int out, plan timing, double *linear_gflops, double *sgemm_gflops)
{
    linear_bench c = {.n = n, .in = in, .out = out};
    gv_graph_init(&c.g, 0);
    gv_params_init(&c.ps);
    c.x = param(&c.ps, "x", n, in, 1, 1.0f);
    c.w = param(&c.ps, "w", out, in, 1, 0.05f);
    c.b = param(&c.ps, "b", out, 0, 1, 0.05f);
    c.dy = malloc((size_t)n * out * sizeof(float));
    c.y_ref = malloc((size_t)n * out * sizeof(float));
    int rc = -1;
    if (c.x && c.w && c.b && c.dy && c.y_ref) {
        gv_fill_normal(c.dy, (int64_t)n * out, 2, 0, 0.0f, 1.0f);
        double flops = 6.0 * n * in * out, t_sgemm, t_linear;
        if (time_pair(sgemm_step, linear_step, &c, timing, &t_sgemm, &t_linear) == 0) {
            *linear_gflops = flops / t_linear * 1e-9;
            *sgemm_gflops = flops / t_sgemm * 1e-9;
            rc = 0;
        }
    }
    free(c.dy), free(c.y_ref);
    gv_params_free(&c.ps);
    gv_graph_free(&c.g);
    return rc;
}

/* ---- attention ------------------------------------------------------------------------- */
typedef struct {
    gv_graph g;
    gv_params ps;
    gv_tensor *q, *k, *v;
    float *dy;
    int heads, backward;
} attention_bench;

static int attention_step(void *p)
{
    attention_bench *c = p;
    gv_graph_reset(&c->g);
    gv_graph_set_grad(&c->g, c->backward);
    float scale = 1.0f / sqrtf((float)(c->q->shape[1] / c->heads));
    gv_tensor *y = gv_attention(&c->g, c->q, c->k, c->v, NULL, c->heads, scale);
    if (!y) return -1;
    return c->backward ? gv_backward_seed(&c->g, y, c->dy) : 0;
}

static int bench_attention(int n, int d, int heads, plan timing, double *fwd_ms, double *fwd_bwd_ms)
{
    attention_bench c = {.heads = heads};
    gv_graph_init(&c.g, 0);
    gv_params_init(&c.ps);
    c.q = param(&c.ps, "q", n, d, 1, 1.0f);
    c.k = param(&c.ps, "k", n, d, 1, 1.0f);
    c.v = param(&c.ps, "v", n, d, 1, 1.0f);
    c.dy = malloc((size_t)n * d * sizeof(float));
    int rc = -1;
    if (c.q && c.k && c.v && c.dy) {
        gv_fill_normal(c.dy, (int64_t)n * d, 3, 0, 0.0f, 1.0f);
        double t_fwd, t_all, unused;
        int ok = time_pair(attention_step, NULL, &c, timing, &t_fwd, &unused) == 0;
        c.backward = 1;
        ok = ok && time_pair(attention_step, NULL, &c, timing, &t_all, &unused) == 0;
        if (ok) *fwd_ms = t_fwd * 1e3, *fwd_bwd_ms = t_all * 1e3, rc = 0;
    }
    free(c.dy);
    gv_params_free(&c.ps);
    gv_graph_free(&c.g);
    return rc;
}

/* ---- one transformer block --------------------------------------------------------------- */
typedef struct {
    gv_graph g;
    gv_params ps;
    gv_tensor *x, *e, *table;
    float *dy;
    int n, d, heads;
} block_bench;

static gv_tensor *P(block_bench *c, const char *name) { return &gv_params_find(&c->ps, name)->t; }

static gv_tensor *modulate(gv_graph *g, gv_tensor *x, gv_tensor *mod, int shift_i, int d)
{
    gv_tensor *shift = gv_slice(g, mod, 1, shift_i * d, d), *scale = gv_slice(g, mod, 1, (shift_i + 1) * d, d);
    return gv_add(g, gv_mul(g, gv_layer_norm(g, x, NULL, NULL, 1e-6f), gv_affine(g, scale, 1, 1)), shift);
}

/* Wan's block (reference section 2.5) without cross-attention. */
static int block_step(void *p)
{
    block_bench *c = p;
    gv_graph *g = &c->g;
    int d = c->d;
    gv_graph_reset(g);
    gv_tensor *mod = gv_linear(g, gv_silu(g, c->e), P(c, "modulation.weight"), P(c, "modulation.bias"));
    gv_tensor *h = modulate(g, c->x, mod, 0, d);
    gv_tensor *q = gv_rms_norm(g, gv_linear(g, h, P(c, "q.weight"), P(c, "q.bias")), P(c, "norm_q.weight"), 1e-6f);
    gv_tensor *k = gv_rms_norm(g, gv_linear(g, h, P(c, "k.weight"), P(c, "k.bias")), P(c, "norm_k.weight"), 1e-6f);
    gv_tensor *v = gv_linear(g, h, P(c, "v.weight"), P(c, "v.bias"));
    q = gv_rope(g, q, c->table, c->heads);
    k = gv_rope(g, k, c->table, c->heads);
    gv_tensor *a = gv_attention(g, q, k, v, NULL, c->heads, 1.0f / sqrtf((float)(d / c->heads)));
    gv_tensor *x = gv_add(g, c->x, gv_mul(g, gv_linear(g, a, P(c, "o.weight"), P(c, "o.bias")), gv_slice(g, mod, 1, 2 * d, d)));
    gv_tensor *f = gv_gelu(g, gv_linear(g, modulate(g, x, mod, 3, d), P(c, "ffn.0.weight"), P(c, "ffn.0.bias")));
    f = gv_linear(g, f, P(c, "ffn.2.weight"), P(c, "ffn.2.bias"));
    x = gv_add(g, x, gv_mul(g, f, gv_slice(g, mod, 1, 5 * d, d)));
    return x ? gv_backward_seed(g, x, c->dy) : -1;
}

/* profile (may be NULL): seconds per op [GV_OP_COUNT][2] of one profiled step. */
static int bench_block(int n, int d, int trainable, plan timing, double *ms, double *peak_mb,
                       double *param_mb, double (*profile)[2])
{
    block_bench c = {.n = n, .d = d, .heads = d / 64};
    gv_graph_init(&c.g, 0);
    gv_params_init(&c.ps);
    int rc = -1, ok = 1;
    c.x = param(&c.ps, "x", n, d, 1, 1.0f);
    c.e = param(&c.ps, "e", 1, d, 0, 1.0f);
    ok &= param(&c.ps, "modulation.weight", 6 * d, d, trainable, 0.02f) && param(&c.ps, "modulation.bias", 6 * d, 0, trainable, 0.02f);
    const char *names[4] = {"q", "k", "v", "o"};
    char name[64];
    for (int i = 0; i < 4; i++) {
        snprintf(name, sizeof name, "%s.weight", names[i]);
        ok &= param(&c.ps, name, d, d, trainable, 0.05f) != NULL;
        snprintf(name, sizeof name, "%s.bias", names[i]);
        ok &= param(&c.ps, name, d, 0, trainable, 0.02f) != NULL;
    }
    ok &= param(&c.ps, "norm_q.weight", d, 0, trainable, 1.0f) && param(&c.ps, "norm_k.weight", d, 0, trainable, 1.0f);
    ok &= param(&c.ps, "ffn.0.weight", 4 * d, d, trainable, 0.05f) && param(&c.ps, "ffn.0.bias", 4 * d, 0, trainable, 0.02f);
    ok &= param(&c.ps, "ffn.2.weight", d, 4 * d, trainable, 0.05f) && param(&c.ps, "ffn.2.bias", d, 0, trainable, 0.02f);
    gv_graph consts;
    gv_graph_init(&consts, 0);
    int side = 1;
    while (side * side * 2 < n) side++; /* tokens as 2 frames of a near-square grid */
    c.table = gv_rope3d_table_grid(&consts, 2, side, (n / 2 + side - 1) / side, d / c.heads);
    if (c.table && c.table->shape[0] != n) c.table = gv_slice(&consts, c.table, 0, 0, n);
    c.dy = malloc((size_t)n * d * sizeof(float));
    if (ok && c.table && c.dy) {
        gv_fill_normal(c.dy, (int64_t)n * d, 4, 0, 0.0f, 1.0f);
        double seconds, unused;
        int timed = time_pair(block_step, NULL, &c, timing, &seconds, &unused) == 0;
        *ms = seconds * 1e3;
        gv_graph_reset(&c.g);
        gv_arena_reset_peak(&c.g.arena);
        if (timed && block_step(&c) == 0) { /* block_step resets the graph first */
            *peak_mb = c.g.arena.peak / 1048576.0;
            int64_t weights = gv_params_count(&c.ps, 0) - c.x->numel - c.e->numel;
            *param_mb = weights * 4.0 * (trainable ? 4 : 1) / 1048576.0; /* data, grad, m, v */
            rc = 0;
            if (profile) {
                c.g.profile = 1;
                memset(c.g.op_seconds, 0, sizeof c.g.op_seconds);
                if (block_step(&c) != 0) rc = -1;
                memcpy(profile, c.g.op_seconds, GV_OP_COUNT * sizeof *profile);
            }
        }
    }
    free(c.dy);
    gv_graph_free(&consts);
    gv_params_free(&c.ps);
    gv_graph_free(&c.g);
    return rc;
}

/* ---- report ---------------------------------------------------------------------------------- */
static void cpu_model(char *buf, size_t size)
{
    snprintf(buf, size, "unknown");
    FILE *f = fopen("/proc/cpuinfo", "r");
    if (!f) return;
    char line[512];
    while (fgets(line, sizeof line, f)) {
        char *colon = strchr(line, ':');
        if (!strncmp(line, "model name", 10) && colon) {
            snprintf(buf, size, "%s", colon + 2);
            buf[strcspn(buf, "\n")] = 0;
            break;
        }
    }
    fclose(f);
}

int gv_bench_nn(const gv_bench_options *o, FILE *out)
{
    static const int tokens_full[3] = {288, 720, 1440}, widths_full[3] = {256, 384, 512};
    int n_tokens = o->quick ? 1 : 3, n_widths = o->quick ? 1 : 3;
    plan timing = {o->quick ? 0.01 : 1.0, o->quick ? 1 : 5}; /* per timed quantity */
    char cpu[256];
    cpu_model(cpu, sizeof cpu);
    if (o->json)
        fprintf(out, "{\n  \"machine\": {\"cpu\": \"%s\", \"threads\": %d, \"openblas\": \"%s\"},\n  \"linear\": [\n",
                cpu, omp_get_max_threads(), openblas_get_config());
    else
        fprintf(out, "tensor engine benchmark: %s, %d threads, OpenBLAS %s\n\n%-24s %14s %14s %7s\n",
                cpu, omp_get_max_threads(), openblas_get_config(), "linear fwd+bwd N x in->out",
                "engine GFLOP/s", "sgemm GFLOP/s", "ratio");
    int first = 1;
    for (int ti = 0; ti < n_tokens; ti++)
        for (int wi = 0; wi < n_widths; wi++)
            for (int ffn = 0; ffn < 2; ffn++) {
                int n = tokens_full[ti], in = widths_full[wi], outw = ffn ? 4 * in : in;
                double lin, ref;
                if (bench_linear(n, in, outw, timing, &lin, &ref) != 0) return -1;
                if (o->json)
                    fprintf(out, "%s    {\"tokens\": %d, \"in\": %d, \"out\": %d, \"linear_gflops\": %.1f, \"sgemm_gflops\": %.1f}",
                            first ? "" : ",\n", n, in, outw, lin, ref);
                else
                    fprintf(out, "%6d x %4d -> %-8d %14.1f %14.1f %6.0f%%\n", n, in, outw, lin, ref, 100 * lin / ref);
                first = 0;
            }
    if (o->json) fprintf(out, "\n  ],\n  \"attention\": [\n");
    else fprintf(out, "\n%-28s %12s %16s %10s\n", "attention N x D (heads)", "forward ms", "fwd+bwd ms", "GFLOP/s");
    first = 1;
    for (int ti = 0; ti < n_tokens; ti++)
        for (int wi = 0; wi < n_widths; wi += o->quick ? 1 : 2) {
            int n = tokens_full[ti], d = widths_full[wi], heads = d / 64;
            double fwd, all;
            if (bench_attention(n, d, heads, timing, &fwd, &all) != 0) return -1;
            double gflops = 4.0 * n * n * d * 3.5 / (all * 1e-3) * 1e-9; /* 2 GEMMs fwd, 5 bwd */
            if (o->json)
                fprintf(out, "%s    {\"tokens\": %d, \"width\": %d, \"heads\": %d, \"forward_ms\": %.2f, \"forward_backward_ms\": %.2f}",
                        first ? "" : ",\n", n, d, heads, fwd, all);
            else
                fprintf(out, "%5d x %3d (%d heads of 64) %12.2f %16.2f %10.1f\n", n, d, heads, fwd, all, gflops);
            first = 0;
        }
    if (o->json) fprintf(out, "\n  ],\n  \"block\": [\n");
    else fprintf(out, "\n%-32s %10s %14s %14s\n", "block fwd+bwd N x D (FFN 4D)", "ms", "arena peak MB", "weights MB");
    first = 1;
    double profile[GV_OP_COUNT][2];
    for (int bi = 0; bi < (o->quick ? 1 : 2); bi++)
        for (int trainable = 1; trainable >= 0; trainable--) {
            int n = bi ? 1440 : 288, d = bi ? 512 : 256, last = bi == (o->quick ? 0 : 1) && trainable;
            double ms, peak, pmb;
            if (bench_block(n, d, trainable, timing, &ms, &peak, &pmb, last ? profile : NULL) != 0) return -1;
            if (o->json)
                fprintf(out, "%s    {\"tokens\": %d, \"width\": %d, \"weights\": \"%s\", \"forward_backward_ms\": %.2f, \"arena_peak_mb\": %.1f, \"weights_mb\": %.1f}",
                        first ? "" : ",\n", n, d, trainable ? "trainable" : "frozen", ms, peak, pmb);
            else
                fprintf(out, "%5d x %3d, %-9s weights %10.2f %14.1f %14.1f\n", n, d,
                        trainable ? "trainable" : "frozen", ms, peak, pmb);
            first = 0;
        }
    /* Where the time of the last trainable block goes, op by op. */
    if (o->json) fprintf(out, "\n  ],\n  \"block_profile_ms\": {");
    else fprintf(out, "\n%-32s %10s %14s\n", "that block, per op", "forward ms", "backward ms");
    first = 1;
    for (int op = 1; op < GV_OP_COUNT; op++) {
        if (profile[op][0] == 0 && profile[op][1] == 0) continue;
        if (o->json)
            fprintf(out, "%s\"%s\": [%.2f, %.2f]", first ? "" : ", ", gv_op_name(op), profile[op][0] * 1e3,
                    profile[op][1] * 1e3);
        else
            fprintf(out, "  %-30s %10.2f %14.2f\n", gv_op_name(op), profile[op][0] * 1e3, profile[op][1] * 1e3);
        first = 0;
    }
    if (o->json) fprintf(out, "}\n}\n");
    return 0;
}
