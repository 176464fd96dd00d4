/* Hot loops compiled twice on x86-64, for AVX2 and for the baseline, with the loader
 * picking one for the machine (GCC function multi-versioning). AVX2 without FMA: no fused
 * multiply-adds, so both versions round every operation the same way. */
#ifndef GAUSSVID_SPLAT_CLONES_H
#define GAUSSVID_SPLAT_CLONES_H

#if defined(__x86_64__) && defined(__GNUC__) && !defined(__clang__)
#define SIMD8_CLONES __attribute__((target_clones("avx2", "default")))
#else
#define SIMD8_CLONES
#endif

#endif
