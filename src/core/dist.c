/* Ranks of an MPI job (dist.h; docs/DISTRIBUTED.md). Compiled with MPI when CMake found it
 * (GV_HAVE_MPI); the program joins a job only when mpirun started it, so a plain `gaussvid`
 * run never initialises MPI and behaves exactly as a build without it. */
#include "gaussvid/core/dist.h"

#include <signal.h>
#include <stdio.h>
#include <time.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "gaussvid/core/core.h"

void gv_dist_share(long count, long *first, long *end)
{
    long k = gv_dist_size(), r = gv_dist_rank();
    *first = count * r / k;
    *end = count * (r + 1) / k;
}

int gv_dist_is_root(void) { return gv_dist_rank() == 0; }

/* One rank's bytes as the gathered whole. */
static int gather_alone(const void *mine, size_t bytes, char **all, size_t **sizes)
{
    *all = malloc(bytes + 1);
    *sizes = malloc(sizeof **sizes);
    if (!*all || !*sizes) {
        free(*all), free(*sizes);
        *all = NULL, *sizes = NULL;
        return gv_fail("out of memory for %zu bytes", bytes);
    }
    memcpy(*all, mine, bytes);
    **sizes = bytes;
    return 0;
}

#ifdef GV_HAVE_MPI
#include <mpi.h>

static int rank, size = 1, joined;
static int kept_stderr = -1;       /* ranks > 0: the real error output */
static FILE *held_stderr;          /* ranks > 0: where their error output goes meanwhile */

/* mpirun (Open MPI, or any PMI launcher) tells its processes who they are in the environment. */
static int started_by_mpirun(void)
{
    return getenv("OMPI_COMM_WORLD_SIZE") || getenv("PMIX_RANK") || getenv("PMI_RANK");
}

static int mpi_fail(int err, const char *call)
{
    char text[MPI_MAX_ERROR_STRING];
    int len = 0;
    if (MPI_Error_string(err, text, &len) != MPI_SUCCESS) snprintf(text, sizeof text, "error %d", err);
    return gv_fail("%s (rank %d of %d): %s", call, rank, size, text);
}

/* Ranks > 0: standard output to /dev/null, error output to an unnamed file until the end. */
static void hold_output(void)
{
    FILE *null = fopen("/dev/null", "w");
    if (null) {
        fflush(stdout);
        dup2(fileno(null), STDOUT_FILENO);
        fclose(null);
    }
    held_stderr = tmpfile();
    if (!held_stderr) return;
    fflush(stderr);
    kept_stderr = dup(STDERR_FILENO);
    if (kept_stderr < 0 || dup2(fileno(held_stderr), STDERR_FILENO) < 0) {
        fclose(held_stderr);
        held_stderr = NULL;
    }
}

/* The last line the rank wrote on its error output, on the real one, with the rank's number. */
static void release_last_line(void)
{
    if (!held_stderr) return;
    fflush(stderr);
    char line[1200] = "", last[1200] = "";
    rewind(held_stderr);
    while (fgets(line, sizeof line, held_stderr))
        if (line[0] && line[0] != '\n') memcpy(last, line, sizeof last);
    if (!last[0]) snprintf(last, sizeof last, "gaussvid: failed\n");
    dprintf(kept_stderr, "[rank %d of %d] %s%s", rank, size, last, strchr(last, '\n') ? "" : "\n");
}

/* Rank 0: mpirun ends the survivors of a job one of whose ranks died or failed with SIGTERM;
 * one line says what happened, since the dead rank could not. */
static void ended_by_mpirun(int sig)
{
    static const char line[] = "gaussvid: the job was ended by mpirun: a rank died or failed (its line, if it could "
                               "write one, is above); run the same command with --resume to continue from the last "
                               "checkpoint\n";
    ssize_t written = write(STDERR_FILENO, line, sizeof line - 1);
    (void)written;
    _exit(128 + sig);
}

void gv_dist_start(int *argc, char ***argv)
{
    if (!started_by_mpirun()) return;
    int provided;
    /* Funneled: OpenMP threads compute, only the main thread talks to the other ranks. */
    if (MPI_Init_thread(argc, argv, MPI_THREAD_FUNNELED, &provided) != MPI_SUCCESS) {
        fprintf(stderr, "gaussvid: MPI_Init failed: cannot join the job mpirun started\n");
        exit(1);
    }
    joined = 1;
    /* A failed call returns its error to us, which ends the job with a line naming it. */
    MPI_Comm_set_errhandler(MPI_COMM_WORLD, MPI_ERRORS_RETURN);
    MPI_Comm_rank(MPI_COMM_WORLD, &rank);
    MPI_Comm_size(MPI_COMM_WORLD, &size);
    if (rank > 0) {
        gv_log_set_level(GV_LOG_QUIET); /* rank 0 shows the progress and the lines */
        hold_output();
    } else if (size > 1) {
        struct sigaction sa;
        memset(&sa, 0, sizeof sa);
        sa.sa_handler = ended_by_mpirun;
        sigaction(SIGTERM, &sa, NULL);
    }
}

int gv_dist_end(int code)
{
    if (!joined) return code;
    if (code == 0) {
        MPI_Finalize();
        return 0;
    }
    if (rank > 0) {
        /* When rank 0 failed as well (the same bad input on every rank), its line is the one
         * the user needs: it ends the job, and this rank, within these seconds. */
        sleep(2);
        release_last_line();
    }
    fflush(stdout), fflush(stderr);
    signal(SIGTERM, SIG_DFL); /* this rank's own line is the one to read */
    MPI_Abort(MPI_COMM_WORLD, code);
    return code;
}

int gv_dist_rank(void) { return rank; }
int gv_dist_size(void) { return size; }

const char *gv_dist_library(void)
{
    static char text[96];
    if (!text[0]) {
        char version[MPI_MAX_LIBRARY_VERSION_STRING];
        int len = 0;
        MPI_Get_library_version(version, &len);
        version[strcspn(version, ",\n")] = '\0';
        snprintf(text, sizeof text, "%s", version);
    }
    return text;
}

int gv_dist_sum_floats(float *x, int64_t n)
{
    const int64_t chunk = (int64_t)1 << 30;
    if (size > 1 && gv_dist_barrier()) return -1;
    for (int64_t at = 0; size > 1 && at < n; at += chunk) {
        int count = (int)(n - at < chunk ? n - at : chunk);
        int err = MPI_Allreduce(MPI_IN_PLACE, x + at, count, MPI_FLOAT, MPI_SUM, MPI_COMM_WORLD);
        if (err != MPI_SUCCESS) return mpi_fail(err, "MPI_Allreduce of the gradients");
    }
    return 0;
}

int gv_dist_sum_doubles(double *x, int n)
{
    if (size < 2) return 0;
    int err = MPI_Allreduce(MPI_IN_PLACE, x, n, MPI_DOUBLE, MPI_SUM, MPI_COMM_WORLD);
    return err == MPI_SUCCESS ? 0 : mpi_fail(err, "MPI_Allreduce");
}

int gv_dist_after_root(int root_status, const char *what)
{
    if (size < 2) return root_status;
    int status = root_status ? 1 : 0;
    if (gv_dist_barrier()) return -1;
    int err = MPI_Bcast(&status, 1, MPI_INT, 0, MPI_COMM_WORLD);
    if (err != MPI_SUCCESS) return mpi_fail(err, "MPI_Bcast");
    if (rank == 0) return root_status;
    return status ? gv_fail("%s: rank 0 failed (its line says why)", what) : 0;
}

int gv_dist_same(uint64_t value, int *same)
{
    *same = 1;
    if (size < 2) return 0;
    unsigned long long v[2] = {value, ~value}; /* max of both: the largest and ~the smallest */
    int err = MPI_Allreduce(MPI_IN_PLACE, v, 2, MPI_UNSIGNED_LONG_LONG, MPI_MAX, MPI_COMM_WORLD);
    if (err != MPI_SUCCESS) return mpi_fail(err, "MPI_Allreduce");
    *same = v[0] == value && ~v[1] == value;
    return 0;
}

int gv_dist_gather(const void *mine, size_t bytes, char **all, size_t **sizes)
{
    if (size < 2) return gather_alone(mine, bytes, all, sizes);
    *all = NULL, *sizes = NULL;
    if (gv_dist_barrier()) return -1;
    if (bytes > 1u << 30) return gv_fail("rank %d: %zu bytes to gather: more than 1 GiB", rank, bytes);
    int count = (int)bytes, *counts = NULL, *offsets = NULL, err;
    if (rank == 0) {
        counts = calloc((size_t)size, sizeof *counts);
        offsets = calloc((size_t)size, sizeof *offsets);
        *sizes = calloc((size_t)size, sizeof **sizes);
        if (!counts || !offsets || !*sizes) {
            free(counts), free(offsets), free(*sizes);
            *sizes = NULL;
            return gv_fail("out of memory gathering from %d ranks", size);
        }
    }
    err = MPI_Gather(&count, 1, MPI_INT, counts, 1, MPI_INT, 0, MPI_COMM_WORLD);
    long total = 0;
    for (int r = 0; rank == 0 && err == MPI_SUCCESS && r < size; r++) {
        offsets[r] = (int)total;
        (*sizes)[r] = (size_t)counts[r];
        total += counts[r];
    }
    if (rank == 0 && err == MPI_SUCCESS && (total > 1L << 30 || !(*all = malloc((size_t)total + 1)))) {
        free(counts), free(offsets), free(*sizes);
        *sizes = NULL;
        return gv_fail("gathering %ld bytes from %d ranks: too many or out of memory", total, size);
    }
    if (err == MPI_SUCCESS)
        err = MPI_Gatherv(mine, count, MPI_BYTE, *all, counts, offsets, MPI_BYTE, 0, MPI_COMM_WORLD);
    free(counts), free(offsets);
    if (err != MPI_SUCCESS) {
        free(*all), free(*sizes);
        *all = NULL, *sizes = NULL;
        return mpi_fail(err, "MPI_Gather");
    }
    return 0;
}

/* Open MPI waits for a message by polling: a rank blocked in a collective keeps a core busy,
 * which on a shared machine (or while rank 0 writes a checkpoint or validates) takes it from
 * the ranks still computing. Waiting here sleeps between tests after the first millisecond,
 * so the collective that follows starts when every rank is there and polls only while the
 * data moves. */
int gv_dist_barrier(void)
{
    if (size < 2) return 0;
    MPI_Request request;
    int err = MPI_Ibarrier(MPI_COMM_WORLD, &request), done = 0;
    double start = gv_now();
    while (err == MPI_SUCCESS && !done) {
        err = MPI_Test(&request, &done, MPI_STATUS_IGNORE);
        if (!done && gv_now() - start > 1e-3) nanosleep(&(struct timespec){0, 1000000}, NULL);
    }
    return err == MPI_SUCCESS ? 0 : mpi_fail(err, "MPI_Ibarrier");
}

#else /* one process */

void gv_dist_start(int *argc, char ***argv) {}
int gv_dist_end(int code) { return code; }
int gv_dist_rank(void) { return 0; }
int gv_dist_size(void) { return 1; }
const char *gv_dist_library(void) { return "not compiled in"; }
int gv_dist_sum_floats(float *x, int64_t n) { return 0; }
int gv_dist_sum_doubles(double *x, int n) { return 0; }
int gv_dist_after_root(int root_status, const char *what) { return root_status; }
int gv_dist_same(uint64_t value, int *same) { *same = 1; return 0; }
int gv_dist_barrier(void) { return 0; }

int gv_dist_gather(const void *mine, size_t bytes, char **all, size_t **sizes)
{
    return gather_alone(mine, bytes, all, sizes);
}

#endif
