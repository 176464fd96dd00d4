/* Tensors in the arena, the graph that owns them, and initialisation from the Philox RNG. */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "nn/nn_internal.h"

void gv_graph_init(gv_graph *g, size_t arena_bytes)
{
    memset(g, 0, sizeof *g);
    gv_arena_init(&g->arena, arena_bytes);
    g->grad_enabled = 1;
    g->epoch = 1;
}

void gv_graph_free(gv_graph *g)
{
    gv_arena_free(&g->arena);
    free(g->tape);
    g->tape = NULL;
    g->n_tape = g->cap_tape = 0;
}

void gv_graph_reset(gv_graph *g)
{
    gv_arena_reset(&g->arena);
    g->n_tape = 0;
    g->epoch++;
}

int gv_graph_set_grad(gv_graph *g, int enabled)
{
    int previous = g->grad_enabled;
    g->grad_enabled = enabled != 0;
    return previous;
}

/* Validates a shape and returns its element count, or -1 after gv_fail. */
static int64_t shape_numel(const char *what, int ndim, const int *shape)
{
    if (ndim < 0 || ndim > GV_MAX_DIMS)
        return gv_fail("%s: %d dimensions (at most %d)", what, ndim, GV_MAX_DIMS);
    int64_t n = 1;
    for (int i = 0; i < ndim; i++) {
        if (shape[i] < 1) return gv_fail("%s: dimension %d has size %d", what, i, shape[i]);
        n *= shape[i];
        if (n > ((int64_t)1 << 40)) return gv_fail("%s: more than 2^40 elements", what);
    }
    return n;
}

gv_tensor *gv_tensor_new(gv_graph *g, int ndim, const int *shape)
{
    int64_t n = shape_numel("tensor", ndim, shape);
    if (n < 0) return NULL;
    gv_tensor *t = gv_arena_calloc(&g->arena, sizeof *t);
    if (!t) return NULL;
    t->ndim = ndim;
    for (int i = 0; i < ndim; i++) t->shape[i] = shape[i];
    t->numel = n;
    t->op = GV_OP_LEAF;
    t->data = gv_arena_calloc(&g->arena, (size_t)n * sizeof(float));
    return t->data ? t : NULL;
}

gv_tensor *gv_tensor_from(gv_graph *g, int ndim, const int *shape, const float *data)
{
    gv_tensor *t = gv_tensor_new(g, ndim, shape);
    if (t) memcpy(t->data, data, (size_t)t->numel * sizeof(float));
    return t;
}

gv_tensor *gv_detach(gv_graph *g, gv_tensor *t)
{
    if (!t) return NULL;
    gv_tensor *d = gv_arena_calloc(&g->arena, sizeof *d);
    if (!d) return NULL;
    d->ndim = t->ndim;
    memcpy(d->shape, t->shape, sizeof d->shape);
    d->numel = t->numel;
    d->data = t->data;
    d->op = GV_OP_LEAF;
    return d;
}

void gv_tensor_requires_grad(gv_tensor *t)
{
    if (t) t->requires_grad = 1;
}

int gv_dim(const gv_tensor *t, int axis)
{
    if (axis < 0) axis += t->ndim;
    return axis >= 0 && axis < t->ndim ? t->shape[axis] : 1;
}

const char *gv_shape_str(const gv_tensor *t, char *buf, size_t size)
{
    size_t used = (size_t)snprintf(buf, size, "[");
    for (int i = 0; i < t->ndim && used < size; i++)
        used += (size_t)snprintf(buf + used, size - used, i ? ", %d" : "%d", t->shape[i]);
    if (used < size) snprintf(buf + used, size - used, "]");
    return buf;
}

int gv_same_shape(const gv_tensor *a, const gv_tensor *b)
{
    if (a->ndim != b->ndim) return 0;
    for (int i = 0; i < a->ndim; i++)
        if (a->shape[i] != b->shape[i]) return 0;
    return 1;
}

/* Two normals per Philox block (Box-Muller's cosine and sine): element i uses block
 * (offset + i) / 2, so the value depends only on (seed, offset + i). */
void gv_fill_normal(float *x, int64_t n, uint64_t seed, uint64_t offset, float mean, float std)
{
#pragma omp parallel for schedule(static) if (n >= GV_OMP_MIN)
    for (int64_t i = 0; i < n; i++) {
        uint64_t position = offset + (uint64_t)i;
        uint32_t block[4];
        gv_philox4x32(seed, position >> 1, block);
        double u1 = 1.0 - block[0] * (1.0 / 4294967296.0); /* (0, 1] */
        double u2 = block[1] * (1.0 / 4294967296.0);
        double radius = sqrt(-2.0 * log(u1)), angle = 2.0 * M_PI * u2;
        double z = (position & 1) ? radius * sin(angle) : radius * cos(angle);
        x[i] = (float)(mean + std * z);
    }
}

void gv_fill_uniform(float *x, int64_t n, uint64_t seed, uint64_t offset, float lo, float hi)
{
#pragma omp parallel for schedule(static) if (n >= GV_OMP_MIN)
    for (int64_t i = 0; i < n; i++) {
        uint64_t position = offset + (uint64_t)i;
        uint32_t block[4];
        gv_philox4x32(seed, position >> 2, block);
        double u = block[position & 3] * (1.0 / 4294967296.0);
        x[i] = (float)(lo + (hi - lo) * u);
    }
}

uint64_t gv_seed_for_name(uint64_t base_seed, const char *name)
{
    uint64_t h = 1469598103934665603ull; /* FNV-1a 64-bit offset basis and prime */
    for (const unsigned char *p = (const unsigned char *)name; *p; p++) {
        h ^= *p;
        h *= 1099511628211ull;
    }
    return h ^ (base_seed * 0x9E3779B97F4A7C15ull);
}
