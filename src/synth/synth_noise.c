/* Hashes, value noise, band-limited fractal noise and box-filtered line patterns: the
 * building blocks of the procedural textures. Band-limiting (fading octaves whose period
 * nears the pixel footprint, integrating line patterns over it) is what keeps textures free
 * of aliasing and shimmer without many samples per pixel. */
#include "synth/synth_internal.h"

/* An integer finaliser with good avalanche (the "lowbias32" constants of C. Wellons'
 * hash-prospector). */
uint32_t sy_hash(uint32_t x)
{
    x ^= x >> 16;
    x *= 0x7feb352du;
    x ^= x >> 15;
    x *= 0x846ca68bu;
    x ^= x >> 16;
    return x;
}

/* Lattice hash: the coordinates mixed by odd multipliers, then one finaliser round (one
 * round instead of one per coordinate: noise lookups are a third of the rendering time). */
uint32_t sy_hash3(int32_t x, int32_t y, int32_t z, uint32_t seed)
{
    return sy_hash((uint32_t)x * 0x8da6b343u + (uint32_t)y * 0xd8163841u + (uint32_t)z * 0xcb1ab31fu +
                   sy_hash(seed));
}

double sy_hash_unit(uint32_t h) { return (double)h * (1.0 / 4294967296.0); }

/* Value in [-1, 1) at a lattice point; `key` is the already hashed seed. */
static inline double lattice(int32_t x, int32_t y, int32_t z, uint32_t key)
{
    uint32_t h = sy_hash((uint32_t)x * 0x8da6b343u + (uint32_t)y * 0xd8163841u + (uint32_t)z * 0xcb1ab31fu + key);
    return 2.0 * sy_hash_unit(h) - 1.0;
}

/* Quintic fade (Perlin 2002): continuous second derivative, so no grid lines in shading. */
static inline double fade(double t) { return t * t * t * (t * (t * 6 - 15) + 10); }

double sy_noise2(double x, double y, uint32_t seed)
{
    double fx = floor(x), fy = floor(y);
    int32_t ix = (int32_t)fx, iy = (int32_t)fy;
    double tx = fade(x - fx), ty = fade(y - fy);
    seed = sy_hash(seed);
    double a = sy_mix(lattice(ix, iy, 0, seed), lattice(ix + 1, iy, 0, seed), tx);
    double b = sy_mix(lattice(ix, iy + 1, 0, seed), lattice(ix + 1, iy + 1, 0, seed), tx);
    return sy_mix(a, b, ty);
}

double sy_noise3(sy_vec p, uint32_t seed)
{
    double fx = floor(p.x), fy = floor(p.y), fz = floor(p.z);
    int32_t ix = (int32_t)fx, iy = (int32_t)fy, iz = (int32_t)fz;
    double tx = fade(p.x - fx), ty = fade(p.y - fy), tz = fade(p.z - fz);
    seed = sy_hash(seed);
    double c[2];
    for (int k = 0; k < 2; k++) {
        double a = sy_mix(lattice(ix, iy, iz + k, seed), lattice(ix + 1, iy, iz + k, seed), tx);
        double b = sy_mix(lattice(ix, iy + 1, iz + k, seed), lattice(ix + 1, iy + 1, iz + k, seed), tx);
        c[k] = sy_mix(a, b, ty);
    }
    return sy_mix(c[0], c[1], tz);
}

/* Weight of an octave of frequency f (cycles per metre) under a footprint w: value noise has
 * most of its energy below f, so it stays until f w = 0.15 and is gone at f w = 0.45, just
 * under the sampling limit of one sample per footprint. */
static inline double octave_weight(double f, double w) { return 1.0 - sy_smoothstep(0.15, 0.45, f * w); }

double sy_fbm2(double x, double y, double freq, int octaves, double footprint, uint32_t seed)
{
    double sum = 0, norm = 0, amp = 1, f = freq;
    for (int i = 0; i < octaves; i++) {
        norm += amp;
        double weight = octave_weight(f, footprint);
        if (weight > 0) /* octaves are shifted so their lattices do not line up */
            sum += amp * weight * sy_noise2(x * f + 17.3 * i, y * f - 9.1 * i, seed + 101u * i);
        amp *= 0.5;
        f *= 2.03;
    }
    return sum / norm;
}

double sy_fbm3(sy_vec p, double freq, int octaves, double footprint, uint32_t seed)
{
    double sum = 0, norm = 0, amp = 1, f = freq;
    for (int i = 0; i < octaves; i++) {
        norm += amp;
        double weight = octave_weight(f, footprint);
        if (weight > 0) {
            sy_vec q = sy_v(p.x * f + 17.3 * i, p.y * f - 9.1 * i, p.z * f + 5.7 * i);
            sum += amp * weight * sy_noise3(q, seed + 101u * i);
        }
        amp *= 0.5;
        f *= 2.03;
    }
    return sum / norm;
}

/* Integral from 0 to x of the indicator of lines [k P, k P + width). */
static double lines_integral(double x, double period, double width)
{
    double k = floor(x / period);
    double r = x - k * period;
    return k * width + (r < width ? r : width);
}

double sy_lines(double x, double period, double width, double w)
{
    x += 0.5 * width; /* centre the lines on the multiples of the period */
    if (w < 1e-9 * period) {
        double r = x - period * floor(x / period);
        return r < width ? 1.0 : 0.0;
    }
    if (w > 8 * period) return width / period;
    return (lines_integral(x + 0.5 * w, period, width) - lines_integral(x - 0.5 * w, period, width)) / w;
}

double sy_square(double x, double period, double w)
{
    return sy_lines(x - 0.25 * period, period, 0.5 * period, w);
}

double sy_detail(double size, double w) { return 1.0 - sy_smoothstep(0.25, 0.8, w / size); }
