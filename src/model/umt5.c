/* The umT5 encoder (include/gaussvid/model/umt5.h): Wan2.1's T5Encoder with per-layer relative
 * position embeddings (shared_pos False, as umt5_xxl builds it). Inference only, so it is
 * written as plain loops over CBLAS products rather than taped ops: nothing here is ever
 * trained, and the per-head relative-position bias has no place in gv_attention's shared
 * mask. Weight names are those of models_t5_umt5-xxl-enc-bf16.pth:
 *   token_embedding.weight [vocab, dim], norm.weight [dim], and per layer i
 *   blocks.i.norm1.weight [dim], blocks.i.attn.{q,k,v}.weight [dim_attn, dim],
 *   blocks.i.attn.o.weight [dim, dim_attn], blocks.i.norm2.weight [dim],
 *   blocks.i.ffn.gate.0.weight, blocks.i.ffn.fc1.weight [dim_ffn, dim],
 *   blocks.i.ffn.fc2.weight [dim, dim_ffn], blocks.i.pos_embedding.embedding.weight
 *   [num_buckets, num_heads]. No biases anywhere. */
#include "gaussvid/model/umt5.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "gaussvid/core/core.h"
#include "gaussvid/nn/ops.h"

enum { MAX_TOKENS = 4096, MAX_LAYERS = 256 };

void gv_umt5_config_xxl(gv_umt5_config *c)
{
    *c = (gv_umt5_config){.vocab = 256384, .dim = 4096, .dim_attn = 4096, .dim_ffn = 10240, .num_heads = 64,
                          .num_layers = 24, .num_buckets = 32, .max_dist = 128, .eps = 1e-6};
}

/* ---- names and shapes ---------------------------------------------------------------------- */

enum { W_NORM1, W_Q, W_K, W_V, W_O, W_NORM2, W_GATE, W_FC1, W_FC2, W_POS, N_LAYER_TENSORS };
static const char *const layer_names[N_LAYER_TENSORS] = {
    "norm1.weight", "attn.q.weight", "attn.k.weight", "attn.v.weight", "attn.o.weight", "norm2.weight",
    "ffn.gate.0.weight", "ffn.fc1.weight", "ffn.fc2.weight", "pos_embedding.embedding.weight"};

static void layer_shape(const gv_umt5_config *c, int which, int64_t shape[2], int *rank)
{
    int64_t d = c->dim, a = c->dim_attn, f = c->dim_ffn;
    const int64_t shapes[N_LAYER_TENSORS][2] = {{d, 0}, {a, d}, {a, d}, {a, d}, {d, a}, {d, 0},
                                                {f, d}, {f, d}, {d, f}, {c->num_buckets, c->num_heads}};
    shape[0] = shapes[which][0], shape[1] = shapes[which][1];
    *rank = shape[1] ? 2 : 1;
}

static const gv_st_tensor *layer_tensor(const gv_st_file *f, int layer, int which)
{
    char name[96];
    snprintf(name, sizeof name, "blocks.%d.%s", layer, layer_names[which]);
    return gv_st_find(f, name);
}

/* A size read from a tensor's shape, or -1 (with a message) when the tensor is not there. */
static int64_t dim_of(const gv_st_file *f, const char *name, int rank, int axis)
{
    const gv_st_tensor *t = gv_st_find(f, name);
    if (!t || t->rank != rank) {
        gv_fail("%s: no %d-dimensional tensor '%s' (not a umT5 encoder?)", f->path, rank, name);
        return -1;
    }
    return t->shape[axis];
}

int gv_umt5_config_from_file(const gv_st_file *f, gv_umt5_config *c)
{
    memset(c, 0, sizeof *c);
    int64_t vocab, dim, attn, ffn, buckets, heads; /* the first missing tensor is the one named */
    if ((vocab = dim_of(f, "token_embedding.weight", 2, 0)) < 0 || (dim = dim_of(f, "token_embedding.weight", 2, 1)) < 0 ||
        (attn = dim_of(f, "blocks.0.attn.q.weight", 2, 0)) < 0 || (ffn = dim_of(f, "blocks.0.ffn.fc1.weight", 2, 0)) < 0 ||
        (buckets = dim_of(f, "blocks.0.pos_embedding.embedding.weight", 2, 0)) < 0 ||
        (heads = dim_of(f, "blocks.0.pos_embedding.embedding.weight", 2, 1)) < 0)
        return -1;
    if (vocab < 1 || dim < 1 || attn < 1 || ffn < 1 || heads < 1 || attn % heads || buckets < 4 || buckets % 2 ||
        vocab > (1 << 30) || dim > (1 << 16) || attn > (1 << 16) || ffn > (1 << 18) || heads > 1024 || buckets > 1024)
        return gv_fail("%s: umT5 sizes out of range (vocab %lld, dim %lld, attention %lld in %lld heads, FFN %lld, "
                       "%lld buckets)", f->path, (long long)vocab, (long long)dim, (long long)attn, (long long)heads,
                       (long long)ffn, (long long)buckets);
    *c = (gv_umt5_config){.vocab = (int)vocab, .dim = (int)dim, .dim_attn = (int)attn, .dim_ffn = (int)ffn,
                          .num_heads = (int)heads, .num_buckets = (int)buckets, .max_dist = 128, .eps = 1e-6};
    while (c->num_layers < MAX_LAYERS && layer_tensor(f, c->num_layers, W_NORM1)) c->num_layers++;
    const gv_st_tensor *t;
    int64_t shape[2] = {dim, 0};
    if (gv_st_get(f, "norm.weight", -1, shape, 1, &t)) return -1;
    for (int l = 0; l < c->num_layers; l++)
        for (int w = 0; w < N_LAYER_TENSORS; w++) {
            char name[96];
            int rank;
            snprintf(name, sizeof name, "blocks.%d.%s", l, layer_names[w]);
            layer_shape(c, w, shape, &rank);
            if (gv_st_get(f, name, -1, shape, rank, &t)) return -1;
        }
    int expected = 2 + N_LAYER_TENSORS * c->num_layers;
    if (f->n_tensors != expected) /* every expected name was found, so some other name is there */
        for (int i = 0; i < f->n_tensors; i++) {
            const char *name = f->tensors[i].name;
            int l = -1, n = 0;
            if (sscanf(name, "blocks.%d.%n", &l, &n) == 1 && l >= 0 && l < c->num_layers) {
                int known = 0;
                for (int w = 0; w < N_LAYER_TENSORS; w++) known |= !strcmp(name + n, layer_names[w]);
                if (known) continue;
            } else if (!strcmp(name, "token_embedding.weight") || !strcmp(name, "norm.weight")) {
                continue;
            }
            return gv_fail("%s: tensor '%s' is no tensor of a %d-layer umT5 encoder", f->path, name, c->num_layers);
        }
    return 0;
}

/* ---- relative positions ---------------------------------------------------------------------- */

int gv_umt5_bucket(int rel, int num_buckets, int max_dist)
{
    int half = num_buckets / 2, exact = half / 2, bucket = rel > 0 ? half : 0, r = rel < 0 ? -rel : rel;
    if (r < exact) return bucket + r;
    /* Wan/HF: exact + long(log(r / exact) / log(max_dist / exact) * (half - exact)), in float32.
     * The value is an integer only where r / exact is a power of two (max_dist / exact = 16),
     * where float32 is exact too; elsewhere it stays over 0.01 from an integer. log2 keeps the
     * powers of two exact here, so the truncation matches. */
    double v = log2((double)r / exact) / log2((double)max_dist / exact) * (half - exact);
    int large = exact + (int)v;
    return bucket + (large < half - 1 ? large : half - 1);
}

/* ---- the forward pass ------------------------------------------------------------------------ */

typedef struct {
    float *w[N_LAYER_TENSORS];   /* one layer's weights as float32 */
    float *x, *h, *q, *k, *v, *att, *scores, *gate, *up;
    int *bucket;                 /* [n, n] bucket of (i, j) */
} workspace;

static void free_workspace(workspace *s)
{
    for (int w = 0; w < N_LAYER_TENSORS; w++) free(s->w[w]);
    free(s->x), free(s->h), free(s->q), free(s->k), free(s->v), free(s->att), free(s->scores);
    free(s->gate), free(s->up), free(s->bucket);
}

static int alloc_workspace(const gv_umt5_config *c, int n, workspace *s)
{
    memset(s, 0, sizeof *s);
    int ok = 1;
    for (int w = 0; w < N_LAYER_TENSORS; w++) {
        int64_t shape[2];
        int rank;
        layer_shape(c, w, shape, &rank);
        ok &= (s->w[w] = malloc((size_t)(shape[0] * (rank == 2 ? shape[1] : 1)) * sizeof(float))) != NULL;
    }
    size_t nd = (size_t)n * c->dim, na = (size_t)n * c->dim_attn, nf = (size_t)n * c->dim_ffn;
    ok &= (s->x = malloc(nd * sizeof(float))) && (s->h = malloc(nd * sizeof(float))) &&
          (s->q = malloc(na * sizeof(float))) && (s->k = malloc(na * sizeof(float))) &&
          (s->v = malloc(na * sizeof(float))) && (s->att = malloc(na * sizeof(float))) &&
          (s->scores = malloc((size_t)n * n * sizeof(float))) && (s->gate = malloc(nf * sizeof(float))) &&
          (s->up = malloc(nf * sizeof(float))) && (s->bucket = malloc((size_t)n * n * sizeof(int)));
    if (!ok) {
        free_workspace(s);
        return gv_fail("umT5: out of memory for %d tokens (one layer of weights is %.0f MB)", n,
                       4.0 * ((double)c->dim * c->dim_attn * 4 + 3.0 * c->dim * c->dim_ffn) / 1e6);
    }
    return 0;
}

/* y[i] = x[i] / sqrt(mean(x[i]^2) + eps) * w (T5LayerNorm: no mean subtracted, no bias). */
static void t5_layer_norm(const float *x, const float *w, float *y, int n, int dim, double eps)
{
#pragma omp parallel for schedule(static)
    for (int i = 0; i < n; i++) {
        const float *xi = x + (size_t)i * dim;
        double ss = 0;
        for (int d = 0; d < dim; d++) ss += (double)xi[d] * xi[d];
        float r = (float)(1.0 / sqrt(ss / dim + eps));
        for (int d = 0; d < dim; d++) y[(size_t)i * dim + d] = xi[d] * r * w[d];
    }
}

/* C [m, n] = A [m, k] B^T with B [n, k] (a PyTorch Linear without bias). */
static void linear(const float *a, const float *b, float *out, int m, int n, int k)
{
    gv_gemm_nt(m, n, k, a, k, b, k, out, n);
}

static int load_layer(const gv_umt5_config *c, const gv_st_file *f, int layer, workspace *s)
{
    for (int w = 0; w < N_LAYER_TENSORS; w++)
        if (gv_st_tensor_to_f32(f, layer_tensor(f, layer, w), s->w[w])) return -1;
    return 0;
}

/* Self-attention of one layer on s->h, added to s->x: no 1/sqrt(d) scaling (T5), the bias of
 * each head from its relative-position embedding. */
static void attention(const gv_umt5_config *c, int n, workspace *s)
{
    int da = c->dim_attn, hd = da / c->num_heads;
    linear(s->h, s->w[W_Q], s->q, n, da, c->dim);
    linear(s->h, s->w[W_K], s->k, n, da, c->dim);
    linear(s->h, s->w[W_V], s->v, n, da, c->dim);
    const float *pos = s->w[W_POS]; /* [buckets, heads] */
    for (int head = 0; head < c->num_heads; head++) {
        const float *q = s->q + head * hd, *k = s->k + head * hd, *v = s->v + head * hd;
        gv_gemm_nt(n, n, hd, q, da, k, da, s->scores, n);
#pragma omp parallel for schedule(static)
        for (int i = 0; i < n; i++) {
            float *row = s->scores + (size_t)i * n, top = -INFINITY;
            for (int j = 0; j < n; j++) {
                row[j] += pos[s->bucket[(size_t)i * n + j] * c->num_heads + head];
                if (row[j] > top) top = row[j];
            }
            double sum = 0;
            for (int j = 0; j < n; j++) sum += row[j] = expf(row[j] - top);
            float inv = (float)(1.0 / sum);
            for (int j = 0; j < n; j++) row[j] *= inv;
        }
        gv_gemm(n, hd, n, s->scores, n, v, da, s->att + head * hd, da);
    }
    linear(s->att, s->w[W_O], s->h, n, c->dim, da);
    for (size_t i = 0; i < (size_t)n * c->dim; i++) s->x[i] += s->h[i];
}

/* x += fc2(fc1(h) * gelu_tanh(gate(h))), Wan's T5FeedForward. */
static void feed_forward(const gv_umt5_config *c, int n, workspace *s)
{
    size_t nf = (size_t)n * c->dim_ffn;
    linear(s->h, s->w[W_GATE], s->gate, n, c->dim_ffn, c->dim);
    linear(s->h, s->w[W_FC1], s->up, n, c->dim_ffn, c->dim);
#pragma omp parallel for schedule(static)
    for (size_t i = 0; i < nf; i++) {
        float g = s->gate[i];
        s->up[i] *= 0.5f * g * (1.0f + tanhf(0.7978845608028654f * (g + 0.044715f * g * g * g)));
    }
    linear(s->up, s->w[W_FC2], s->h, n, c->dim, c->dim_ffn);
    for (size_t i = 0; i < (size_t)n * c->dim; i++) s->x[i] += s->h[i];
}

/* The embedding rows of the ids, converted one row at a time (the table is 1 G values). */
static int embed(const gv_umt5_config *c, const gv_st_file *f, const int32_t *ids, int n, float *x)
{
    const gv_st_tensor *table = gv_st_find(f, "token_embedding.weight");
    int elem = gv_st_dtype_bits(table->dtype) / 8;
    for (int i = 0; i < n; i++) {
        if (ids[i] < 0 || ids[i] >= c->vocab)
            return gv_fail("%s: token %d is id %d, outside the vocabulary of %d", f->path, i, ids[i], c->vocab);
        gv_st_tensor row = *table;
        row.n_elements = c->dim;
        row.data = (const uint8_t *)table->data + (size_t)ids[i] * c->dim * elem;
        if (gv_st_tensor_to_f32(f, &row, x + (size_t)i * c->dim)) return -1;
    }
    return 0;
}

int gv_umt5_encode(const gv_umt5_config *c, const gv_st_file *f, const int32_t *ids, int n, float *out)
{
    if (n < 1 || n > MAX_TOKENS) return gv_fail("umT5: %d tokens (1 to %d are encoded)", n, MAX_TOKENS);
    workspace s;
    if (alloc_workspace(c, n, &s)) return -1;
    for (int i = 0; i < n; i++)
        for (int j = 0; j < n; j++) s.bucket[(size_t)i * n + j] = gv_umt5_bucket(j - i, c->num_buckets, c->max_dist);
    int rc = embed(c, f, ids, n, s.x);
    for (int l = 0; rc == 0 && l < c->num_layers; l++) {
        rc = load_layer(c, f, l, &s);
        if (rc) break;
        t5_layer_norm(s.x, s.w[W_NORM1], s.h, n, c->dim, c->eps);
        attention(c, n, &s);
        t5_layer_norm(s.x, s.w[W_NORM2], s.h, n, c->dim, c->eps);
        feed_forward(c, n, &s);
    }
    if (rc == 0) rc = gv_st_tensor_to_f32(f, gv_st_find(f, "norm.weight"), s.w[W_NORM1]);
    if (rc == 0) t5_layer_norm(s.x, s.w[W_NORM1], out, n, c->dim, c->eps);
    for (size_t i = 0; rc == 0 && i < (size_t)n * c->dim; i++)
        if (!isfinite(out[i])) rc = gv_fail("%s: the umT5 encoding is not finite (element %zu)", f->path, i);
    free_workspace(&s);
    return rc;
}
