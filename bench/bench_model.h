/* The restoration network's speed (DESIGN 11; issue 5 "Performance"): one GaussVid fine-tuning
 * step of a preset on one clip (forward + backward, LoRA and camera encoder trainable), a
 * breakdown by part, every variant, and the camera-stream cache at inference. */
#ifndef GAUSSVID_BENCH_MODEL_H
#define GAUSSVID_BENCH_MODEL_H

#include <stdio.h>

#include "bench/bench.h"

/* Times `preset` (default small) on a frames x height x width clip (default 5 x 144 x 256). */
int gv_bench_model(const gv_bench_options *o, const char *preset, int frames, int height, int width, FILE *out);

#endif
