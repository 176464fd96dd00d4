/* The parameter registry: named heap tensors that outlive the graph. A trainable parameter
 * owns a gradient and the AdamW moments; a frozen one owns neither, so ops see grad == NULL
 * and skip its weight gradient. */
#include <stdlib.h>
#include <string.h>

#include "nn/nn_internal.h"

void gv_params_init(gv_params *ps) { memset(ps, 0, sizeof *ps); }

static void param_free(gv_param *p)
{
    free((char *)p->t.name);
    free(p->t.data);
    free(p->t.grad);
    free(p->m);
    free(p->v);
    free(p);
}

void gv_params_free(gv_params *ps)
{
    for (int i = 0; i < ps->n; i++) param_free(ps->items[i]);
    free(ps->items);
    memset(ps, 0, sizeof *ps);
}

gv_param *gv_params_find(const gv_params *ps, const char *name)
{
    for (int i = 0; i < ps->n; i++)
        if (!strcmp(ps->items[i]->t.name, name)) return ps->items[i];
    return NULL;
}

gv_param *gv_params_of(const gv_params *ps, const gv_tensor *t)
{
    for (int i = 0; i < ps->n; i++)
        if (&ps->items[i]->t == t) return ps->items[i];
    return NULL;
}

int gv_param_set_trainable(gv_param *p, int trainable)
{
    size_t bytes = (size_t)p->t.numel * sizeof(float);
    if (trainable && !p->t.data && gv_param_materialize(p) != 0) return -1; /* trained in float32 */
    if (trainable && !p->trainable) {
        p->t.grad = calloc(1, bytes);
        p->m = calloc(1, bytes);
        p->v = calloc(1, bytes);
        if (!p->t.grad || !p->m || !p->v) {
            free(p->t.grad), free(p->m), free(p->v);
            p->t.grad = p->m = p->v = NULL;
            return gv_fail("%s: out of memory for the gradient and AdamW moments", p->t.name);
        }
    } else if (!trainable && p->trainable) {
        free(p->t.grad), free(p->m), free(p->v);
        p->t.grad = p->m = p->v = NULL;
    }
    p->trainable = trainable != 0;
    p->t.requires_grad = p->trainable;
    return 0;
}

gv_tensor *gv_params_add(gv_params *ps, const char *name, int ndim, const int *shape,
                         int trainable)
{
    if (!name || !*name) {
        gv_fail("parameter: empty name");
        return NULL;
    }
    if (gv_params_find(ps, name)) {
        gv_fail("%s: parameter registered twice", name);
        return NULL;
    }
    if (ndim < 1 || ndim > GV_MAX_DIMS) {
        gv_fail("%s: %d dimensions (1 to %d allowed)", name, ndim, GV_MAX_DIMS);
        return NULL;
    }
    int64_t numel = 1;
    for (int i = 0; i < ndim; i++) {
        if (shape[i] < 1) {
            gv_fail("%s: dimension %d has size %d", name, i, shape[i]);
            return NULL;
        }
        numel *= shape[i];
    }
    if (ps->n == ps->cap) {
        int cap = ps->cap ? 2 * ps->cap : 64;
        gv_param **items = realloc(ps->items, (size_t)cap * sizeof *items);
        if (!items) {
            gv_fail("%s: out of memory for the parameter list", name);
            return NULL;
        }
        ps->items = items;
        ps->cap = cap;
    }
    gv_param *p = calloc(1, sizeof *p);
    char *copy = strdup(name);
    float *data = calloc((size_t)numel, sizeof(float));
    if (!p || !copy || !data) {
        free(p), free(copy), free(data);
        gv_fail("%s: out of memory for %lld floats", name, (long long)numel);
        return NULL;
    }
    p->t.ndim = ndim;
    for (int i = 0; i < ndim; i++) p->t.shape[i] = shape[i];
    p->t.numel = numel;
    p->t.data = data;
    p->t.op = GV_OP_LEAF;
    p->t.name = copy;
    p->decay = 1;
    if (gv_param_set_trainable(p, trainable) != 0) {
        param_free(p);
        return NULL;
    }
    ps->items[ps->n++] = p;
    return &p->t;
}

void gv_params_zero_grad(gv_params *ps)
{
    for (int i = 0; i < ps->n; i++)
        if (ps->items[i]->t.grad)
            memset(ps->items[i]->t.grad, 0, (size_t)ps->items[i]->t.numel * sizeof(float));
}

int64_t gv_params_count(const gv_params *ps, int trainable_only)
{
    int64_t n = 0;
    for (int i = 0; i < ps->n; i++)
        if (!trainable_only || ps->items[i]->trainable) n += ps->items[i]->t.numel;
    return n;
}

int gv_params_check_finite(const gv_params *ps, int check_grad)
{
    for (int i = 0; i < ps->n; i++) {
        const gv_tensor *t = &ps->items[i]->t;
        const float *x = check_grad ? t->grad : t->data;
        if (!x) continue;
        for (int64_t j = 0; j < t->numel; j++)
            if (!isfinite(x[j]))
                return gv_fail("%s: %s element %lld is %g", t->name, check_grad ? "gradient" : "value",
                               (long long)j, (double)x[j]);
    }
    return 0;
}
