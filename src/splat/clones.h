/* Hot loops compiled more than once on x86-64, for AVX2 and for the baseline, with the loader
 * picking one for the machine (GCC function multi-versioning). AVX2 without FMA: no fused
 * multiply-adds, so both versions round every operation the same way. */
#ifndef GAUSSVID_SPLAT_CLONES_H
#define GAUSSVID_SPLAT_CLONES_H

#if defined(__x86_64__) && defined(__GNUC__) && !defined(__clang__)
#define SIMD8_CLONES __attribute__((target_clones("avx2", "default")))
/* The rasteriser's tile functions also get an AVX-512 version (x86-64-v4: F, BW, DQ, VL):
 * the same eight-lane vectors, with comparisons into mask registers and masked blends. Its
 * files are compiled with -ffp-contract=off (CMakeLists.txt), so that AVX-512's FMA is not
 * used either and all three versions give the same bits. */
#define RASTER_CLONES __attribute__((target_clones("arch=x86-64-v4", "avx2", "default")))
#else
#define SIMD8_CLONES
#define RASTER_CLONES
#endif

#endif
