/* The order in which training visits its clips: an endless stream of epochs, each a
 * permutation drawn from the Philox stream (seed, epoch), so that a position in the stream is
 * the whole state a checkpoint needs to continue with the same clips. */
#include <stdlib.h>

#include "gaussvid/core/core.h"
#include "gaussvid/train/train.h"

int gv_data_order_init(gv_data_order *d, int count, uint64_t seed)
{
    d->count = count;
    d->seed = seed;
    d->epoch = -1;
    d->perm = count > 0 ? malloc((size_t)count * sizeof *d->perm) : NULL;
    if (count < 1) return gv_fail("training: the data set has no clips");
    if (!d->perm) return gv_fail("training: out of memory for the order of %d clips", count);
    return 0;
}

void gv_data_order_free(gv_data_order *d)
{
    free(d->perm);
    d->perm = NULL;
}

/* Fisher-Yates with uniform draws of the epoch's own stream. */
static void shuffle(gv_data_order *d, long epoch)
{
    gv_rng r;
    gv_rng_init(&r, d->seed * 0x9E3779B97F4A7C15ULL + (uint64_t)epoch * 0xBF58476D1CE4E5B9ULL + 0x5EED);
    for (int i = 0; i < d->count; i++) d->perm[i] = i;
    for (int i = d->count - 1; i > 0; i--) {
        int j = (int)(gv_rng_uniform(&r) * (i + 1));
        if (j > i) j = i;
        int tmp = d->perm[i];
        d->perm[i] = d->perm[j];
        d->perm[j] = tmp;
    }
    d->epoch = epoch;
}

int gv_data_order_at(gv_data_order *d, long pos)
{
    if (pos < 0 || !d->perm) return gv_fail("training: bad position %ld in the data order", pos);
    long epoch = pos / d->count;
    if (epoch != d->epoch) shuffle(d, epoch);
    return d->perm[pos % d->count];
}
