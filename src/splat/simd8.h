/* Eight floats at a time with the GCC/Clang vector extensions, for the rasteriser's loops
 * over the pixels of a tile row: one AVX register where the caller is compiled for AVX2,
 * two SSE (or NEON) registers otherwise, plain scalar code elsewhere. Comparisons give
 * lanes of all ones (true) or zeros; select() blends by such a mask. */
#ifndef GAUSSVID_SPLAT_SIMD8_H
#define GAUSSVID_SPLAT_SIMD8_H

#include <stdint.h>
#include <string.h>

/* The tile functions are compiled for AVX-512, AVX2 and the baseline (clones.h). */
#include "splat/clones.h"

/* Helpers that must be inlined into the cloned tile functions, declared `static SIMD8_INLINE`:
 * the `static` stays in sight of whoever reads (or indexes) the file, so a helper is never
 * taken for a definition another file could call. */
#define SIMD8_INLINE inline __attribute__((always_inline))

/* The helpers below take 32-byte vectors by value; they are always inlined, so GCC's note
 * about the ABI of such arguments without AVX ("-Wpsabi") does not apply: CMakeLists.txt
 * turns it off for the files that include this one. */

typedef float f8 __attribute__((vector_size(32)));
typedef int32_t i8 __attribute__((vector_size(32)));

static SIMD8_INLINE f8 f8_splat(float x)
{
    return (f8){x, x, x, x, x, x, x, x};
}

static SIMD8_INLINE f8 f8_load(const float *p)
{
    f8 v;
    memcpy(&v, p, sizeof v);
    return v;
}

static SIMD8_INLINE void f8_store(float *p, f8 v)
{
    memcpy(p, &v, sizeof v);
}

static SIMD8_INLINE i8 i8_load(const int32_t *p)
{
    i8 v;
    memcpy(&v, p, sizeof v);
    return v;
}

static SIMD8_INLINE void i8_store(int32_t *p, i8 v)
{
    memcpy(p, &v, sizeof v);
}

/* mask ? a : b, lane by lane */
static SIMD8_INLINE f8 f8_select(i8 mask, f8 a, f8 b)
{
    return (f8)((mask & (i8)a) | (~mask & (i8)b));
}

/* mask ? v : 0 */
static SIMD8_INLINE f8 f8_mask(i8 mask, f8 v)
{
    return (f8)(mask & (i8)v);
}

static SIMD8_INLINE i8 i8_select(i8 mask, i8 a, i8 b)
{
    return (mask & a) | (~mask & b);
}

static SIMD8_INLINE f8 f8_min(f8 a, f8 b)
{
    return f8_select(a < b, a, b);
}

static SIMD8_INLINE float f8_sum(f8 v)
{
    return ((v[0] + v[1]) + (v[2] + v[3])) + ((v[4] + v[5]) + (v[6] + v[7]));
}

static SIMD8_INLINE int i8_any(i8 m)
{
    typedef int64_t l4 __attribute__((vector_size(32)));
    typedef int64_t l2 __attribute__((vector_size(16)));
    l4 v = (l4)m;
    /* OR of the two 128-bit halves, then of its two 64-bit lanes: one vector OR and two
     * extractions instead of four */
    l2 halves = __builtin_shufflevector(v, v, 0, 1) | __builtin_shufflevector(v, v, 2, 3);
    return (halves[0] | halves[1]) != 0;
}

/* Number of true lanes. */
static SIMD8_INLINE int i8_count(i8 m)
{
    return -(((m[0] + m[1]) + (m[2] + m[3])) + ((m[4] + m[5]) + (m[6] + m[7])));
}

/* exp(x) for x <= 0 (Cephes expf: x = n ln 2 + r with |r| <= ln 2 / 2, degree-5 minimax
 * polynomial for e^r, 2^n through the exponent bits; relative error about 1e-7, the
 * accuracy of expf). Below -87 it returns e^-87, far under every threshold that uses it. */
static SIMD8_INLINE f8 f8_exp_neg(f8 x)
{
    x = f8_select(x > f8_splat(-87.0f), x, f8_splat(-87.0f));
    /* round to nearest by truncation, valid since x <= 0 */
    i8 ni = __builtin_convertvector(x * 1.44269504088896341f - 0.5f, i8);
    f8 n = __builtin_convertvector(ni, f8);
    f8 r = x - n * 0.693359375f + n * 2.12194440e-4f; /* ln 2 split in two parts */
    f8 p = f8_splat(1.9875691500e-4f);
    p = p * r + 1.3981999507e-3f;
    p = p * r + 8.3334519073e-3f;
    p = p * r + 4.1665795894e-2f;
    p = p * r + 1.6666665459e-1f;
    p = p * r + 5.0000001201e-1f;
    f8 y = p * r * r + r + 1.0f;
    return y * (f8)((ni + 127) << 23);
}

#endif
