/* gaussvid bench: the benchmark group (the code is in bench/); one entry per subsystem. */
#include <stdio.h>

#include "bench/bench.h"
#include "bench/bench_model.h"
#include "bench/bench_train.h"
#include "cli/commands.h"
#include "gaussvid/core/core.h"

static int cmd_bench_nn(int argc, char **argv)
{
    gv_bench_options o = {0};
    const gv_flag flags[] = {
        {"json", GV_FLAG_BOOL, &o.json, NULL, "print JSON (each shape with linear_gflops and sgemm_gflops)", 0},
        {"quick", GV_FLAG_BOOL, &o.quick, NULL, "one small shape, short timings (a smoke test)", 0},
    };
    const gv_command_spec spec = {
        "bench nn", NULL, "tensor engine speed: linear vs sgemm, attention, one transformer block",
        "Linear forward+backward GFLOP/s against the plain sgemm calls on the same shapes\n"
        "(288 to 1440 tokens, width 256 to 512), attention forward and forward+backward time,\n"
        "and the time and arena peak of one Wan-style block's forward+backward. Results for\n"
        "this project's machine are in docs/BENCHMARKS.md.",
        flags, 2, 0, 0};
    int rc = gv_args_parse(&spec, argc, argv, NULL, NULL);
    if (rc != GV_ARGS_OK) return gv_args_exit_code(rc);
    return gv_bench_nn(&o, stdout) == 0 ? 0 : gv_report_failure();
}

/* Every benchmark in turn, as `make bench` runs them (add new groups here too). */
static int cmd_bench_all(int argc, char **argv)
{
    const gv_flag flags[] = {{"quick", GV_FLAG_BOOL, NULL, NULL, "short timings", 0}};
    gv_bench_options o = {0};
    gv_flag f = flags[0];
    f.value = &o.quick;
    const gv_command_spec spec = {"bench all", NULL, "run every benchmark (tables)", NULL, &f, 1, 0, 0};
    int rc = gv_args_parse(&spec, argc, argv, NULL, NULL);
    if (rc != GV_ARGS_OK) return gv_args_exit_code(rc);
    if (gv_bench_nn(&o, stdout) != 0) return gv_report_failure();
    gv_bench_model_options mo;
    gv_bench_model_defaults(&mo);
    mo.quick = o.quick;
    if (gv_bench_model(&mo, stdout) != 0) return gv_report_failure();
    if (gv_bench_train(&o, "small", 144, 256, stdout) != 0) return gv_report_failure();
    gv_bench_splat_options so = {.interval = 6, .iterations = o.quick ? 300 : 8000,
                                 .checkpoint_every = o.quick ? 100 : 1000, .modes = 3};
    return gv_bench_splat(&so, stdout) == 0 ? 0 : gv_report_failure();
}

static const gv_subcommand bench_commands[] = {
    {"nn", cmd_bench_nn, "tensor engine: linear vs sgemm, attention, transformer block"},
    {"splat", gv_bench_splat_command, "sparse-view 3DGS training: phases, kernel stages, quality"},
    {"raster", gv_bench_raster_command, "3DGS kernels: CPU time per stage of an iteration on a fixed model"},
    {"model", gv_bench_model_command, "restoration network: fine-tuning step per variant, camera cache, VAE"},
    {"train", gv_bench_train_command, "training throughput: pretraining and fine-tuning clips/s, peak memory"},
    {"import", gv_bench_import_command, "model import on a stand-in Wan2.1-VACE release of the real shapes"},
    {"stream", gv_bench_stream_command, "a Wan preset on BF16 weights streamed from the file: forward, restore, train step"},
    {"all", cmd_bench_all, "every benchmark above, as tables"},
};

int cmd_bench(int argc, char **argv)
{
    return gv_run_subcommand("bench", bench_commands,
                             (int)(sizeof bench_commands / sizeof bench_commands[0]), argc, argv);
}
