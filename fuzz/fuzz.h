/* Shared by the libFuzzer harnesses (fuzz/fuzz_*.c, docs/RELIABILITY.md). The readers take
 * paths, as the program calls them, so each input is written to a scratch file first (on
 * /dev/shm when there is one: a write per execution). Besides the sanitizers, a harness
 * checks the error contract of docs/ARCHITECTURE.md section 4: a failing reader leaves one line that
 * names the file. */
#ifndef GAUSSVID_FUZZ_H
#define GAUSSVID_FUZZ_H

#include <dirent.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <time.h>
#include <omp.h>
#include <unistd.h>

#include "gaussvid/core/core.h"

/* A scratch folder of this process: /dev/shm/gv-fuzz-PID (else $TMPDIR or /tmp). */
static inline const char *fuzz_dir(void)
{
    static char dir[512];
    if (!dir[0]) {
        struct stat st;
        const char *base = stat("/dev/shm", &st) == 0 && S_ISDIR(st.st_mode) ? "/dev/shm"
                           : getenv("TMPDIR") ? getenv("TMPDIR") : "/tmp";
        snprintf(dir, sizeof dir, "%s/gv-fuzz-%ld", base, (long)getpid());
        mkdir(dir, 0700);
    }
    return dir;
}

/* Removes the scratch folder at exit (its files only: the harnesses make no subfolders). */
static inline void fuzz_remove_dir(void)
{
    DIR *d = opendir(fuzz_dir());
    if (!d) return;
    char path[600];
    for (struct dirent *e; (e = readdir(d));) {
        if (e->d_name[0] == '.') continue;
        snprintf(path, sizeof path, "%s/%s", fuzz_dir(), e->d_name);
        unlink(path);
    }
    closedir(d);
    rmdir(fuzz_dir());
}

/* Writes the input to fuzz_dir()/name and returns that path. */
static inline const char *fuzz_file(const char *name, const uint8_t *data, size_t size)
{
    static char path[4][600];
    static int next;
    char *p = path[next++ % 4];
    snprintf(p, sizeof path[0], "%s/%s", fuzz_dir(), name);
    FILE *f = fopen(p, "wb");
    if (!f || (size && fwrite(data, 1, size, f) != size) || fclose(f) != 0) {
        fprintf(stderr, "fuzz: cannot write %s\n", p);
        abort();
    }
    return p;
}

/* The error contract: after a failure, one non-empty line mentioning `needle` (the file's
 * name). A violation aborts, so libFuzzer keeps the input. */
static inline void fuzz_check_failure(int rc, const char *needle)
{
    if (rc == 0) return;
    const char *m = gv_last_error();
    if (!m[0] || strchr(m, '\n') || (needle && !strstr(m, needle))) {
        fprintf(stderr, "fuzz: failure message breaks the one-line contract (must name '%s'): '%s'\n",
                needle ? needle : "", m);
        abort();
    }
}

/* With FUZZ_VERBOSE set, says what became of an input (to check that seeds get past the
 * first checks: `FUZZ_VERBOSE=1 build-fuzz/fuzz_pth -runs=1 SEED...`). */
static inline void fuzz_report(int rc, const char *what)
{
    if (getenv("FUZZ_VERBOSE")) fprintf(stderr, "fuzz: %s\n", rc ? gv_last_error() : what);
}

/* Each harness defines this: one input through one reader. */
static int fuzz_one(const uint8_t *data, size_t size);

/* CPU seconds one input may take (FUZZ_CPU_LIMIT, default 1): CPU time, not wall time, so a
 * loaded machine does not make slow inputs of fast ones; libFuzzer's own -timeout (wall
 * time) stays as the backstop for inputs that never finish. */
static double fuzz_cpu_limit = 1.0;

/* Quiet logs (a warning per input would flood the run), one thread. */
int LLVMFuzzerInitialize(int *argc, char ***argv)
{
    (void)argc, (void)argv;
    gv_log_set_level(GV_LOG_QUIET);
    omp_set_num_threads(1);
    atexit(fuzz_remove_dir);
    const char *limit = getenv("FUZZ_CPU_LIMIT");
    if (limit && atof(limit) > 0) fuzz_cpu_limit = atof(limit);
    return 0;
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    clock_t start = clock();
    fuzz_one(data, size);
    double seconds = (double)(clock() - start) / CLOCKS_PER_SEC;
    if (seconds > fuzz_cpu_limit) {
        fprintf(stderr, "fuzz: slow input: %.2f s of CPU (limit %.2f s)\n", seconds, fuzz_cpu_limit);
        abort();
    }
    return 0;
}

#endif
