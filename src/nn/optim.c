/* Gradient clipping by global norm and learning-rate schedules. */
#include <stdlib.h>
#include <string.h>

#include "gaussvid/nn/optim.h"
#include "nn/nn_internal.h"

#define NORM_CHUNK 65536

/* Sum of squares of x in fixed chunks, added in chunk order. */
static double sum_squares(const float *x, int64_t n)
{
    int64_t n_chunks = (n + NORM_CHUNK - 1) / NORM_CHUNK;
    double total = 0;
    double part[64];
    for (int64_t c0 = 0; c0 < n_chunks; c0 += 64) {
        int64_t count = n_chunks - c0 < 64 ? n_chunks - c0 : 64;
#pragma omp parallel for schedule(static) if (n >= GV_OMP_MIN)
        for (int64_t c = 0; c < count; c++) {
            int64_t start = (c0 + c) * NORM_CHUNK, end = start + NORM_CHUNK < n ? start + NORM_CHUNK : n;
            double s = 0;
            for (int64_t i = start; i < end; i++) s += (double)x[i] * x[i];
            part[c] = s;
        }
        for (int64_t c = 0; c < count; c++) total += part[c];
    }
    return total;
}

double gv_grad_norm(const gv_params *ps)
{
    double total = 0;
    for (int i = 0; i < ps->n; i++)
        if (ps->items[i]->trainable) total += sum_squares(ps->items[i]->t.grad, ps->items[i]->t.numel);
    return sqrt(total);
}

double gv_clip_grad_norm(gv_params *ps, double max_norm)
{
    double norm = gv_grad_norm(ps);
    if (!(norm > max_norm) || !isfinite(norm)) return norm;
    float coef = (float)(max_norm / (norm + 1e-6));
    for (int i = 0; i < ps->n; i++) {
        gv_param *p = ps->items[i];
        if (!p->trainable) continue;
#pragma omp parallel for simd schedule(static) if (p->t.numel >= GV_OMP_MIN)
        for (int64_t j = 0; j < p->t.numel; j++) p->t.grad[j] *= coef;
    }
    return norm;
}

double gv_lr_at(const gv_lr_schedule *s, long step)
{
    if (step < s->warmup_steps) return s->lr * (double)(step + 1) / (double)s->warmup_steps;
    if (s->kind == GV_LR_CONSTANT) return s->lr;
    long span = s->total_steps - s->warmup_steps;
    double progress = span > 0 ? (double)(step - s->warmup_steps) / (double)span : 1.0;
    if (progress > 1.0) progress = 1.0;
    if (s->kind == GV_LR_LINEAR) return s->min_lr + (s->lr - s->min_lr) * (1.0 - progress);
    return s->min_lr + 0.5 * (s->lr - s->min_lr) * (1.0 + cos(M_PI * progress));
}

static const char *const lr_kind_names[] = {"constant", "cosine", "linear"};

const char *gv_lr_kind_name(gv_lr_kind kind)
{
    return (unsigned)kind < 3 ? lr_kind_names[kind] : "unknown";
}

int gv_lr_kind_from_name(const char *name, gv_lr_kind *out)
{
    for (int k = 0; k < 3; k++)
        if (!strcmp(name, lr_kind_names[k])) {
            *out = (gv_lr_kind)k;
            return 0;
        }
    return gv_fail("learning-rate schedule '%s': expected constant, cosine or linear", name);
}
