/* The activation arena: a bump allocator over a list of blocks. Allocation is a pointer
 * increment; a step's memory is released all at once by gv_arena_reset, which also folds the
 * blocks into one so that, after the first step, every step runs in a single block. */
#include <stdlib.h>
#include <string.h>

#include "gaussvid/core/core.h"
#include "gaussvid/nn/tensor.h"

#define ARENA_ALIGN 64

static size_t round_up(size_t n) { return (n + ARENA_ALIGN - 1) / ARENA_ALIGN * ARENA_ALIGN; }

void gv_arena_init(gv_arena *a, size_t first_block_bytes)
{
    memset(a, 0, sizeof *a);
    a->min_block = round_up(first_block_bytes ? first_block_bytes : ((size_t)1 << 20));
}

void gv_arena_free(gv_arena *a)
{
    for (int i = 0; i < a->n_blocks; i++) free(a->blocks[i].base);
    free(a->blocks);
    size_t min_block = a->min_block;
    memset(a, 0, sizeof *a);
    a->min_block = min_block;
}

size_t gv_arena_capacity(const gv_arena *a)
{
    size_t total = 0;
    for (int i = 0; i < a->n_blocks; i++) total += a->blocks[i].size;
    return total;
}

static int add_block(gv_arena *a, size_t size)
{
    if (a->n_blocks == a->cap_blocks) {
        int cap = a->cap_blocks ? 2 * a->cap_blocks : 8;
        gv_arena_block *blocks = realloc(a->blocks, (size_t)cap * sizeof *blocks);
        if (!blocks) return gv_fail("arena: out of memory for the block list");
        a->blocks = blocks;
        a->cap_blocks = cap;
    }
    unsigned char *base = aligned_alloc(ARENA_ALIGN, size);
    if (!base)
        return gv_fail("arena: out of memory reserving %zu MiB (%zu MiB in use)", size >> 20,
                       a->in_use >> 20);
    a->blocks[a->n_blocks++] = (gv_arena_block){base, size, 0};
    return 0;
}

void *gv_arena_alloc(gv_arena *a, size_t bytes)
{
    bytes = round_up(bytes ? bytes : 1);
    if (a->limit && a->in_use + bytes > a->limit) {
        gv_fail("arena: allocating %zu bytes would pass the limit of %zu MiB", bytes,
                a->limit >> 20);
        return NULL;
    }
    for (;;) {
        if (a->current < a->n_blocks) {
            gv_arena_block *b = &a->blocks[a->current];
            if (b->size - b->used >= bytes) {
                void *p = b->base + b->used;
                b->used += bytes;
                a->in_use += bytes;
                if (a->in_use > a->peak) a->peak = a->in_use;
                return p;
            }
            if (a->current + 1 < a->n_blocks) { /* later blocks are empty */
                a->current++;
                continue;
            }
        }
        /* Grow geometrically so that a step needs few blocks before the first reset. */
        size_t size = gv_arena_capacity(a);
        if (size < a->min_block) size = a->min_block;
        if (size < bytes) size = bytes;
        if (add_block(a, size) != 0) return NULL;
        a->current = a->n_blocks - 1;
    }
}

void *gv_arena_calloc(gv_arena *a, size_t bytes)
{
    void *p = gv_arena_alloc(a, bytes);
    if (p) memset(p, 0, bytes);
    return p;
}

void gv_arena_reset(gv_arena *a)
{
    if (a->n_blocks > 1) {
        size_t total = gv_arena_capacity(a);
        for (int i = 0; i < a->n_blocks; i++) free(a->blocks[i].base);
        a->n_blocks = 0;
        if (add_block(a, total) != 0) gv_clear_error(); /* retried lazily by the next alloc */
    }
    for (int i = 0; i < a->n_blocks; i++) a->blocks[i].used = 0;
    a->current = 0;
    a->in_use = 0;
}

gv_arena_mark gv_arena_get_mark(const gv_arena *a)
{
    gv_arena_mark m = {a->current, 0, a->in_use};
    if (a->current < a->n_blocks) m.used = a->blocks[a->current].used;
    return m;
}

void gv_arena_rewind(gv_arena *a, gv_arena_mark m)
{
    for (int i = m.block + 1; i < a->n_blocks; i++) a->blocks[i].used = 0;
    if (m.block < a->n_blocks) a->blocks[m.block].used = m.used;
    a->current = m.block;
    a->in_use = m.in_use;
}

void gv_arena_reset_peak(gv_arena *a) { a->peak = a->in_use; }
