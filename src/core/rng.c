/* Philox-4x32-10 counter-based generator (Salmon, Moraes, Dror, Shaw: "Parallel random
 * numbers: as easy as 1, 2, 3", SC 2011). Constants are the paper's. */
#include "gaussvid/core/core.h"

#include <math.h>

#define PHILOX_M0 0xD2511F53u
#define PHILOX_M1 0xCD9E8D57u
#define PHILOX_W0 0x9E3779B9u
#define PHILOX_W1 0xBB67AE85u

static inline uint32_t mulhilo(uint32_t a, uint32_t b, uint32_t *hi)
{
    uint64_t product = (uint64_t)a * b;
    *hi = (uint32_t)(product >> 32);
    return (uint32_t)product;
}

void gv_philox4x32(uint64_t seed, uint64_t counter, uint32_t out[4])
{
    uint32_t c0 = (uint32_t)counter, c1 = (uint32_t)(counter >> 32), c2 = 0, c3 = 0;
    uint32_t k0 = (uint32_t)seed, k1 = (uint32_t)(seed >> 32);
    for (int round = 0; round < 10; round++) {
        uint32_t hi0, hi1;
        uint32_t lo0 = mulhilo(PHILOX_M0, c0, &hi0);
        uint32_t lo1 = mulhilo(PHILOX_M1, c2, &hi1);
        c0 = hi1 ^ c1 ^ k0;
        c1 = lo1;
        c2 = hi0 ^ c3 ^ k1;
        c3 = lo0;
        k0 += PHILOX_W0;
        k1 += PHILOX_W1;
    }
    out[0] = c0; out[1] = c1; out[2] = c2; out[3] = c3;
}

void gv_rng_init(gv_rng *r, uint64_t seed)
{
    r->seed = seed;
    r->counter = 0;
    r->used = 4;
}

uint32_t gv_rng_u32(gv_rng *r)
{
    if (r->used == 4) {
        gv_philox4x32(r->seed, r->counter++, r->block);
        r->used = 0;
    }
    return r->block[r->used++];
}

/* 32 random bits to a double in [0, 1) (and in (0, 1] for the logarithm below). */
static inline double to_unit(uint32_t x) { return (double)x * (1.0 / 4294967296.0); }

double gv_rng_uniform(gv_rng *r) { return to_unit(gv_rng_u32(r)); }

static double box_muller(uint32_t a, uint32_t b)
{
    double u1 = 1.0 - to_unit(a); /* (0, 1]: log is finite */
    double u2 = to_unit(b);
    return sqrt(-2.0 * log(u1)) * cos(2.0 * M_PI * u2);
}

double gv_rng_normal(gv_rng *r)
{
    uint32_t a = gv_rng_u32(r);
    uint32_t b = gv_rng_u32(r);
    return box_muller(a, b);
}

double gv_uniform_at(uint64_t seed, uint64_t index)
{
    uint32_t block[4];
    gv_philox4x32(seed, index, block);
    return to_unit(block[0]);
}

double gv_normal_at(uint64_t seed, uint64_t index)
{
    uint32_t block[4];
    gv_philox4x32(seed, index, block);
    return box_muller(block[0], block[1]);
}
