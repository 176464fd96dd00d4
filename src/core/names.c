/* Items found by name (core.h): an order of their positions sorted by name, built once, and a
 * bisection over it. The safetensors reader, the PyTorch zip reader and the model's weight
 * list each index their names this way. */
#include <stdlib.h>
#include <string.h>

#include "gaussvid/core/core.h"

typedef struct {
    const char *name;
    int index;
} named;

static int by_name(const void *a, const void *b)
{
    return strcmp(((const named *)a)->name, ((const named *)b)->name);
}

int gv_names_order(const void *items, int n, gv_name_of name_of, int *order, const char **repeat)
{
    *repeat = NULL;
    named *pairs = malloc(((size_t)n + 1) * sizeof *pairs);
    if (!pairs) return gv_fail("out of memory for an index of %d names", n);
    for (int i = 0; i < n; i++) pairs[i] = (named){name_of(items, i), i};
    qsort(pairs, (size_t)n, sizeof *pairs, by_name);
    for (int i = 0; i < n; i++) {
        order[i] = pairs[i].index;
        if (i > 0 && !*repeat && !strcmp(pairs[i].name, pairs[i - 1].name)) *repeat = name_of(items, pairs[i].index);
    }
    free(pairs);
    return 0;
}

const void *gv_names_find(const void *items, size_t size, const int *order, int n, gv_name_of name_of,
                          const char *name)
{
    int lo = 0, hi = n - 1;
    while (lo <= hi) {
        int mid = lo + (hi - lo) / 2, at = order ? order[mid] : mid;
        int c = strcmp(name, name_of(items, at));
        if (c == 0) return (const char *)items + (size_t)at * size;
        if (c < 0) hi = mid - 1;
        else lo = mid + 1;
    }
    return NULL;
}
