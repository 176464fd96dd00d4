/* Benchmarks run by `gaussvid bench GROUP`: each prints a table (or JSON) on `out`. */
#ifndef GAUSSVID_BENCH_H
#define GAUSSVID_BENCH_H

#include <stdio.h>

typedef struct {
    int json;   /* JSON instead of a table */
    int quick;  /* fewer shapes and shorter timings (a smoke test) */
} gv_bench_options;

/* Tensor engine: linear fwd+bwd against plain sgemm, attention fwd+bwd, and the time and
 * peak memory of one transformer block's forward+backward. */
int gv_bench_nn(const gv_bench_options *o, FILE *out);

/* Sparse-view 3DGS training (bench/bench_splat.c). */
typedef struct {
    int json;
    const char *scene;     /* NULL: the shared courtyard and livingroom */
    int interval;          /* 6 */
    int iterations;        /* 8000 (quick: 300) */
    int checkpoint_every;  /* kernel stages are timed every this many iterations (1000) */
    int sparse_adam;
    int modes;             /* bit 1 << m for each density control m to run (gv_splat_densify_mode) */
    int regularize;        /* the lean runs' regularisers (GV_REGULARIZE_* bits; splat train's
                            * default GV_REGULARIZE_USER); the reference and mcmc run plain */
    int resolution_start;  /* 0, or one more run: lean with this resolution schedule (1: full
                            * size, 2, 8; the default run has GV_RESOLUTION_USER) */
} gv_bench_splat_options;
/* Phase and kernel-stage times, Gaussian counts and final quality of a training run. */
int gv_bench_splat(const gv_bench_splat_options *o, FILE *out);
/* `gaussvid bench splat [--scene DIR] [--json] ...` */
int gv_bench_splat_command(int argc, char **argv);

/* `gaussvid bench raster --model M.ply --scene DIR`: CPU time of each stage of a training
 * iteration on a fixed model (bench/bench_raster.c). */
int gv_bench_raster_command(int argc, char **argv);

#endif
