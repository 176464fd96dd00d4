/* Training throughput (issue 7 "Performance"; docs/BENCHMARKS.md): clips per second of base
 * pretraining and GaussVid fine-tuning of a preset, and the peak memory. */
#ifndef GAUSSVID_BENCH_TRAIN_H
#define GAUSSVID_BENCH_TRAIN_H

#include <stdio.h>

#include "bench/bench.h"

/* Runs the training loop of each objective (and the camera-less variant) on synthetic latents
 * of a 5-frame height x width clip of `preset`; prints a table or JSON. */
int gv_bench_train(const gv_bench_options *o, const char *preset, int height, int width, FILE *out);
/* `gaussvid bench train [--json] [--quick] [--preset P]` */
int gv_bench_train_command(int argc, char **argv);
/* `gaussvid bench import --dir DIR [--preset P] [--dtype BF16|F32] [--shards N]` (bench_import.c) */
int gv_bench_import_command(int argc, char **argv);
/* `gaussvid bench stream`: a Wan preset on random BF16 weights of the real shapes streamed from
 * the mapped file: one forward pass, one restore of a clip or one fine-tuning step, with its
 * CPU time and peak resident set (bench/bench_stream.c). */
int gv_bench_stream_command(int argc, char **argv);

#endif
