/* The umT5 encoder (include/gaussvid/model/umt5.h) on the committed tiny encoder
 * (tests/fixtures/release/tiny-vace-bf16/models_t5_umt5-xxl-enc-bf16.pth: Wan's names, BF16
 * storages, 2 layers): relative-position buckets derived by hand for T5's bidirectional
 * scheme; the config read from the file; one layer and then the whole encoder against an
 * independent computation written out here in double precision (T5LayerNorm, unscaled
 * attention with the per-head bias of each (i, j), the gated-GELU FFN); and bad inputs. */
#include <stdint.h>

#include "check.h"
#include "gaussvid/core/core.h"
#include "gaussvid/model/umt5.h"
#include "gaussvid/pth/weight_files.h"

static char fixtures[4096];

/* T5's bidirectional buckets, 32 of them, max distance 128: rel = key - query. rel <= 0 uses
 * buckets 0..15, rel > 0 buckets 16..31. |rel| < 8 is its own bucket; from 8 on the bucket is
 * 8 + floor(8 log(|rel| / 8) / log(16)) = 8 + floor(2 log2(|rel| / 8)), at most 15:
 *   |rel| 8..11 -> 8 (2 log2(11/8) = 0.92), 12..15 -> 9 (2 log2(12/8) = 1.17), 16 -> 10,
 *   45 -> 12 (2 log2(45/8) = 4.98), 64 -> 14, 127 -> 15 (7.98), 128 and beyond -> 15 (16 capped). */
static void test_buckets(void)
{
    static const int cases[][2] = {
        {0, 0},   {-1, 1},   {1, 17},   {-7, 7},    {7, 23},   {-8, 8},   {8, 24},    {-11, 8},  {-12, 9},
        {-15, 9}, {-16, 10}, {16, 26},  {-22, 10},  {-23, 11}, {-32, 12}, {-45, 12},  {-46, 13}, {-64, 14},
        {64, 30}, {-90, 14}, {-91, 15}, {-127, 15}, {-128, 15}, {128, 31}, {-5000, 15}, {5000, 31},
    };
    int bad = 0;
    for (size_t i = 0; i < sizeof cases / sizeof *cases; i++) {
        int got = gv_umt5_bucket(cases[i][0], 32, 128);
        if (got != cases[i][1] && bad++ < 5) fprintf(stderr, "bucket(%d) = %d, expected %d\n", cases[i][0], got, cases[i][1]);
    }
    CHECK(bad == 0);
    /* monotone in |rel| on each side; every bucket used but 16 (rel = 0 takes bucket 0) */
    int used[32] = {0}, monotone = 1;
    for (int r = -300; r <= 300; r++) {
        int b = gv_umt5_bucket(r, 32, 128);
        used[b] = 1;
        if (r > 1) monotone &= b >= gv_umt5_bucket(r - 1, 32, 128);
        if (r < 0) monotone &= b >= gv_umt5_bucket(r + 1, 32, 128);
    }
    int all = 1;
    for (int b = 0; b < 32; b++) all &= used[b] == (b != 16);
    CHECK(monotone && all);
}

/* ---- the independent computation --------------------------------------------------------- */

typedef struct {
    const gv_st_file *f;
    int dim, ffn, heads, hd;
} ref_model;

/* A weight as doubles (BF16 widened exactly). */
static double *weight(const ref_model *m, const char *fmt, int layer)
{
    char name[96];
    snprintf(name, sizeof name, fmt, layer);
    const gv_st_tensor *t = gv_st_find(m->f, name);
    if (!t) { fprintf(stderr, "missing %s\n", name); exit(1); }
    float *tmp = malloc((size_t)t->n_elements * sizeof *tmp);
    double *out = malloc((size_t)t->n_elements * sizeof *out);
    gv_st_tensor_to_f32(m->f, t, tmp);
    for (int64_t i = 0; i < t->n_elements; i++) out[i] = tmp[i];
    free(tmp);
    return out;
}

static void ref_norm(const double *x, const double *w, double *y, int n, int dim)
{
    for (int i = 0; i < n; i++) {
        double ss = 0;
        for (int d = 0; d < dim; d++) ss += x[i * dim + d] * x[i * dim + d];
        for (int d = 0; d < dim; d++) y[i * dim + d] = x[i * dim + d] / sqrt(ss / dim + 1e-6) * w[d];
    }
}

/* y [n, out] = x [n, in] W^T, W [out, in] */
static void ref_linear(const double *x, const double *w, double *y, int n, int in, int out)
{
    for (int i = 0; i < n; i++)
        for (int o = 0; o < out; o++) {
            double s = 0;
            for (int k = 0; k < in; k++) s += x[i * in + k] * w[o * in + k];
            y[i * out + o] = s;
        }
}

/* One layer, x updated in place; n <= 8 so every bucket is exact: rel <= 0 -> -rel,
 * rel > 0 -> 16 + rel. */
static void ref_layer(const ref_model *m, int l, double *x, int n)
{
    int D = m->dim, F = m->ffn;
    double *n1 = weight(m, "blocks.%d.norm1.weight", l), *wq = weight(m, "blocks.%d.attn.q.weight", l);
    double *wk = weight(m, "blocks.%d.attn.k.weight", l), *wv = weight(m, "blocks.%d.attn.v.weight", l);
    double *wo = weight(m, "blocks.%d.attn.o.weight", l), *n2 = weight(m, "blocks.%d.norm2.weight", l);
    double *wg = weight(m, "blocks.%d.ffn.gate.0.weight", l), *w1 = weight(m, "blocks.%d.ffn.fc1.weight", l);
    double *w2 = weight(m, "blocks.%d.ffn.fc2.weight", l), *pos = weight(m, "blocks.%d.pos_embedding.embedding.weight", l);
    double h[8 * 64], q[8 * 64], k[8 * 64], v[8 * 64], att[8 * 64] = {0}, y[8 * 64], g[8 * 64], u[8 * 64];
    ref_norm(x, n1, h, n, D);
    ref_linear(h, wq, q, n, D, D), ref_linear(h, wk, k, n, D, D), ref_linear(h, wv, v, n, D, D);
    for (int head = 0; head < m->heads; head++)
        for (int i = 0; i < n; i++) {
            double s[8], top = -1e300, sum = 0;
            for (int j = 0; j < n; j++) {
                int rel = j - i, bucket = rel > 0 ? 16 + rel : -rel;
                s[j] = pos[bucket * m->heads + head]; /* the bias, then the unscaled product */
                for (int c = 0; c < m->hd; c++) s[j] += q[i * D + head * m->hd + c] * k[j * D + head * m->hd + c];
                if (s[j] > top) top = s[j];
            }
            for (int j = 0; j < n; j++) sum += s[j] = exp(s[j] - top);
            for (int j = 0; j < n; j++)
                for (int c = 0; c < m->hd; c++) att[i * D + head * m->hd + c] += s[j] / sum * v[j * D + head * m->hd + c];
        }
    ref_linear(att, wo, y, n, D, D);
    for (int i = 0; i < n * D; i++) x[i] += y[i];
    ref_norm(x, n2, h, n, D);
    ref_linear(h, wg, g, n, D, F), ref_linear(h, w1, u, n, D, F);
    for (int i = 0; i < n * F; i++) u[i] *= 0.5 * g[i] * (1 + tanh(sqrt(2 / M_PI) * (g[i] + 0.044715 * g[i] * g[i] * g[i])));
    ref_linear(u, w2, y, n, F, D);
    for (int i = 0; i < n * D; i++) x[i] += y[i];
    free(n1), free(wq), free(wk), free(wv), free(wo), free(n2), free(wg), free(w1), free(w2), free(pos);
}

static void ref_encode(const ref_model *m, int layers, const int32_t *ids, int n, double *out)
{
    double *emb = weight(m, "token_embedding.weight", 0), *norm = weight(m, "norm.weight", 0), x[8 * 64];
    for (int i = 0; i < n; i++)
        for (int d = 0; d < m->dim; d++) x[i * m->dim + d] = emb[ids[i] * m->dim + d];
    for (int l = 0; l < layers; l++) ref_layer(m, l, x, n);
    ref_norm(x, norm, out, n, m->dim);
    free(emb), free(norm);
}

static void test_encoder(void)
{
    char path[4200];
    snprintf(path, sizeof path, "%s/tiny-vace-bf16/models_t5_umt5-xxl-enc-bf16.pth", fixtures);
    gv_st_file f;
    CHECK(gv_weights_open(&f, path) == 0);
    gv_umt5_config c;
    CHECK(gv_umt5_config_from_file(&f, &c) == 0);
    CHECK(c.vocab == 64 && c.dim == 16 && c.dim_attn == 16 && c.dim_ffn == 24 && c.num_heads == 2 && c.num_layers == 2 &&
          c.num_buckets == 32 && c.max_dist == 128);
    CHECK(gv_st_find(&f, "blocks.0.attn.q.weight")->dtype == GV_ST_BF16);
    ref_model m = {&f, c.dim, c.dim_ffn, c.num_heads, c.dim_attn / c.num_heads};
    const int32_t ids[6] = {3, 17, 42, 5, 63, 1};
    float got[6 * 16];
    double want[6 * 16];
    /* one layer by hand, then both */
    for (int layers = 1; layers <= 2; layers++) {
        gv_umt5_config one = c;
        one.num_layers = layers;
        CHECK(gv_umt5_encode(&one, &f, ids, 6, got) == 0);
        ref_encode(&m, layers, ids, 6, want);
        double worst = 0, scale = 0;
        for (int i = 0; i < 6 * 16; i++) {
            worst = fmax(worst, fabs(got[i] - want[i]));
            scale = fmax(scale, fabs(want[i]));
        }
        printf("umT5 tiny, %d layer%s, 6 tokens: max |C - reference| = %.3g (values up to %.3g)\n", layers,
               layers > 1 ? "s" : "", worst, scale);
        CHECK(worst < 1e-4 * scale);
    }
    /* attention is bidirectional: appending a token changes the first token's row */
    float longer[7 * 16];
    const int32_t more[7] = {3, 17, 42, 5, 63, 1, 9};
    CHECK(gv_umt5_encode(&c, &f, more, 7, longer) == 0 && memcmp(longer, got, 16 * sizeof(float)) != 0);
    /* bad inputs: one line naming the file */
    const int32_t bad[2] = {3, 64};
    CHECK_FAILS_WITH(gv_umt5_encode(&c, &f, bad, 2, got), "token 1 is id 64, outside the vocabulary of 64");
    CHECK_FAILS_WITH(gv_umt5_encode(&c, &f, ids, 0, got), "0 tokens");
    gv_st_close(&f);
    snprintf(path, sizeof path, "%s/tiny-vace-bf16/Wan2.1_VAE.pth", fixtures);
    CHECK(gv_weights_open(&f, path) == 0);
    CHECK_FAILS_WITH(gv_umt5_config_from_file(&f, &c), "no 2-dimensional tensor 'token_embedding.weight'");
    gv_st_close(&f);
}

int main(void)
{
    snprintf(fixtures, sizeof fixtures, "%s", __FILE__);
    char *slash = strrchr(fixtures, '/');
    if (slash) *slash = '\0';
    else snprintf(fixtures, sizeof fixtures, ".");
    strncat(fixtures, "/fixtures/release", sizeof fixtures - strlen(fixtures) - 1);
    test_buckets();
    test_encoder();
    return check_summary();
}
