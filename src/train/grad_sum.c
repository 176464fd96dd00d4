/* The gradient of a step: the sum over the batch's clips of each clip's own gradient, each
 * clip's computed from zero, added in batch order into one flat buffer of every trainable
 * float; under mpirun each rank sums its share of the clips and one MPI_Allreduce of that
 * buffer sums the ranks (docs/DISTRIBUTED.md). Computing every clip's gradient from zero is
 * what makes the result independent of where the clip ran: accumulating in place would round
 * a clip's contributions onto those of the clips before it on the same rank. */
#include <stdlib.h>
#include <string.h>

#include "gaussvid/core/core.h"
#include "gaussvid/core/dist.h"
#include "train/train_internal.h"

int gv_grad_sum_init(gv_grad_sum *s, const gv_params *ps)
{
    memset(s, 0, sizeof *s);
    for (int i = 0; i < ps->n; i++)
        if (ps->items[i]->t.grad) s->count += ps->items[i]->t.numel;
    s->sum = malloc((size_t)(s->count ? s->count : 1) * sizeof *s->sum);
    if (!s->sum) return gv_fail("training: out of memory for the gradient of %lld floats", (long long)s->count);
    return 0;
}

void gv_grad_sum_free(gv_grad_sum *s)
{
    free(s->sum);
    s->sum = NULL;
}

void gv_grad_sum_add(gv_grad_sum *s, gv_params *ps)
{
    int64_t at = 0;
    for (int i = 0; i < ps->n; i++) {
        gv_tensor *t = &ps->items[i]->t;
        if (!t->grad) continue;
        float *dst = s->sum + at;
        if (s->clips == 0) memcpy(dst, t->grad, (size_t)t->numel * sizeof *dst);
        else
            for (int64_t k = 0; k < t->numel; k++) dst[k] += t->grad[k];
        memset(t->grad, 0, (size_t)t->numel * sizeof *t->grad); /* the next clip starts from zero */
        at += t->numel;
    }
    s->clips++;
}

int gv_grad_sum_finish(gv_grad_sum *s, gv_params *ps)
{
    if (s->clips == 0) memset(s->sum, 0, (size_t)s->count * sizeof *s->sum);
    if (gv_dist_sum_floats(s->sum, s->count)) return -1;
    int64_t at = 0;
    for (int i = 0; i < ps->n; i++) {
        gv_tensor *t = &ps->items[i]->t;
        if (!t->grad) continue;
        memcpy(t->grad, s->sum + at, (size_t)t->numel * sizeof *t->grad);
        at += t->numel;
    }
    s->clips = 0;
    return 0;
}

uint64_t gv_params_checksum(const gv_params *ps)
{
    uint64_t h = 1469598103934665603ull; /* FNV-1a over the bytes of every trainable tensor */
    for (int i = 0; i < ps->n; i++) {
        const gv_tensor *t = &ps->items[i]->t;
        if (!t->grad) continue;
        const unsigned char *p = (const unsigned char *)t->data;
        for (size_t k = 0; k < (size_t)t->numel * sizeof(float); k++) h = (h ^ p[k]) * 1099511628211ull;
    }
    return h;
}
