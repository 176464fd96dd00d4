/* The restoration network's speed (docs/ARCHITECTURE.md 11; issue 5 "Performance"), `gaussvid bench model`:
 * per preset, one GaussVid fine-tuning step on one clip (forward + backward, LoRA and camera
 * encoder trainable) for every variant with its arena peak and weight memory, the camera-stream
 * cache at inference, and the VAE's encode and decode time. Presets too large for a training
 * step here get one forward pass; presets whose weights do not fit in memory are skipped with
 * the reason. Results: docs/BENCHMARKS.md. */
#ifndef GAUSSVID_BENCH_MODEL_H
#define GAUSSVID_BENCH_MODEL_H

#include <stdint.h>
#include <stdio.h>

#include "gaussvid/model/model_config.h"

typedef struct {
    int json;              /* JSON instead of tables */
    int quick;             /* one run per quantity, no warm-up (a smoke test) */
    int trials;            /* timed runs per quantity after a warm-up; the best counts (default 5) */
    const char *presets;   /* comma-separated presets or config files (default "tiny,small") */
    int frames, height, width;   /* the clip (default 5 x 144 x 256) */
    int64_t step_limit;    /* presets above this many parameters: forward only (default 1e8) */
    int no_vae;            /* skip the VAE timings */
} gv_bench_model_options;

void gv_bench_model_defaults(gv_bench_model_options *o);
/* Runs the benchmark of every preset of o->presets and prints it on `out`. */
int gv_bench_model(const gv_bench_model_options *o, FILE *out);
/* `gaussvid bench model [--json] [--quick] [--presets P,...] [--frames N --height N --width N]` */
int gv_bench_model_command(int argc, char **argv);

/* ---- the VAE part (bench/bench_model_vae.c) ---------------------------------------------- */
typedef struct {
    double encode_s, decode_s;          /* chunked, as Wan encodes and decodes (best wall time) */
    double encode_cpu_s, decode_cpu_s;  /* the least process CPU time of one pass */
    double encode_peak_mib, decode_peak_mib; /* arena peak of one chunk's graph, the largest */
    double weights_mib;
    int64_t params;
} gv_bench_vae_result;
/* Times the VAE of c (random weights: the time does not depend on the values) on a clip. */
int gv_bench_model_vae(const gv_model_config *c, int frames, int height, int width, int trials,
                       gv_bench_vae_result *r);

#endif
