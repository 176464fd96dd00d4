/* The run-time environment that libgomp and OpenBLAS read when they are loaded, before main:
 * set here when the user has not, followed by one re-execution (if that fails the program
 * runs as it is). */
#include <cblas.h>
#include <stdio.h>
#include <stdlib.h>
#include <strings.h>
#include <unistd.h>

#include "cli/commands.h"
#include "gaussvid/core/core.h"

/* OpenBLAS picks its kernels from the CPU's model number; on a virtual CPU whose model it does
 * not know ("Intel(R) Xeon(R) Processor") it falls back to the SSE3 "Prescott" kernels, which
 * ran sgemm 6x slower than the AVX-512 ones on such a machine (docs/BENCHMARKS.md). The kernel
 * the CPU's feature flags allow, when OpenBLAS chose a pre-AVX2 one; NULL otherwise. */
static const char *better_blas_core(void)
{
    static const char *const pre_avx2[] = {"Prescott", "Core2", "Penryn", "Dunnington", "Nehalem", "Atom",
                                           "Sandybridge", "Katmai", "Coppermine", "Northwood", "Banias", NULL};
    const char *core = openblas_get_corename();
    int weak = 0;
    for (int i = 0; core && pre_avx2[i]; i++) weak |= !strcasecmp(core, pre_avx2[i]);
    if (!weak) return NULL;
    __builtin_cpu_init();
    if (__builtin_cpu_supports("avx512f") && __builtin_cpu_supports("avx512bw") &&
        __builtin_cpu_supports("avx512dq") && __builtin_cpu_supports("avx512vl"))
        return "SkylakeX";
    if (__builtin_cpu_supports("avx2") && __builtin_cpu_supports("fma")) return "Haswell";
    return NULL;
}

/* How long a thread that waits for the others spins before it sleeps. Sleeping at once
 * (OMP_WAIT_POLICY=passive) costs a wake-up of an idle core, about 40 us on a virtual machine,
 * at each of the dozens of parallel regions and barriers of a 3DGS iteration: 20 % of
 * splat train's time on an idle machine. Spinning long (libgomp's default of about 3 ms, or
 * OMP_WAIT_POLICY=active) spins against a peer that waits for a core as soon as another job
 * shares them: two-thread runs 6-9x slower. 30 us kept the whole idle gain and cost 7-12 %
 * under that load (docs/BENCHMARKS.md, "the program's own wait policy"). */
enum { SPIN_NS = 30000 };

/* GOMP_SPINCOUNT counts rounds of a loop around one pause instruction, whose latency ranges
 * from about 10 to 150 cycles between CPUs: the rounds that take SPIN_NS here, from the
 * fastest of three timings (a preemption only makes one slower). */
static long spin_rounds(void)
{
#if defined(__x86_64__) || defined(__i386__)
    enum { ROUNDS = 1000 };
    double best_ns = 0;
    for (int trial = 0; trial < 3; trial++) {
        double t0 = gv_now();
        for (int i = 0; i < ROUNDS; i++) __builtin_ia32_pause();
        double ns = (gv_now() - t0) * 1e9;
        if (trial == 0 || ns < best_ns) best_ns = ns;
    }
    long rounds = best_ns > 0 ? (long)(SPIN_NS * (double)ROUNDS / best_ns) : 3000;
    return rounds < 100 ? 100 : rounds > 30000 ? 30000 : rounds;
#else
    return SPIN_NS / 10; /* libgomp's own estimate: 100 rounds per microsecond */
#endif
}

void gv_prefer_runtime_env(char **argv)
{
    int changed = 0;
    if (!getenv("OMP_WAIT_POLICY") && !getenv("GOMP_SPINCOUNT")) {
        char rounds[32];
        snprintf(rounds, sizeof rounds, "%ld", spin_rounds());
        changed |= setenv("GOMP_SPINCOUNT", rounds, 1) == 0;
    }
    const char *core = getenv("OPENBLAS_CORETYPE") ? NULL : better_blas_core();
    if (core) changed |= setenv("OPENBLAS_CORETYPE", core, 1) == 0;
    if (changed) execv("/proc/self/exe", argv);
}
