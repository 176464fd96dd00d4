/* Ranks of a run started by `mpirun -np K gaussvid ...` (docs/DISTRIBUTED.md): the one place
 * that knows about MPI. Without MPI at build time, or when the program was not started by
 * mpirun, there is one rank and every call below is what a single process would do. */
#ifndef GAUSSVID_DIST_H
#define GAUSSVID_DIST_H

#include <stddef.h>
#include <stdint.h>

/* Joins the job when mpirun started this process (MPI_Init); on ranks other than 0 the
 * standard output is discarded and the error output kept aside, so that one line of the
 * failing rank, not K copies of every line, reaches the user (gv_dist_end). */
void gv_dist_start(int *argc, char ***argv);
/* Leaves the job with a command's exit code: 0 finalises; otherwise the whole job is ended
 * (MPI_Abort), since the other ranks may be waiting for this one; a rank other than 0 first
 * prints its last error line, prefixed with its rank, unless rank 0 ends the job first.
 * Returns code (single process: does nothing else). */
int gv_dist_end(int code);

int gv_dist_rank(void);
int gv_dist_size(void);
/* 1 on rank 0: the rank that writes files, logs and progress. */
int gv_dist_is_root(void);
/* "Open MPI v4.1.4" (the library the program runs with) or "not compiled in". */
const char *gv_dist_library(void);

/* The share [*first, *end) of `count` items that this rank takes: contiguous, in rank order,
 * sizes differing by at most one. */
void gv_dist_share(long count, long *first, long *end);

/* In place: x becomes the element-wise sum over the ranks of their x (one MPI_Allreduce for up
 * to 2^30 floats). Every rank receives the same bits. */
int gv_dist_sum_floats(float *x, int64_t n);
int gv_dist_sum_doubles(double *x, int n);
/* Rank 0's outcome to every rank: rank 0 calls it after doing something the others need done
 * first (writing a cache, sweeping a folder) with its status, the others call it before
 * reading the result and fail when rank 0 did. Returns 0 or -1. */
int gv_dist_after_root(int root_status, const char *what);
/* 1 in *same when every rank passes the same value (e.g. a checksum of the weights). */
int gv_dist_same(uint64_t value, int *same);
/* Rank 0 receives every rank's bytes, in rank order, in *all (malloc'd; *sizes holds
 * gv_dist_size() lengths, malloc'd); other ranks only send and get NULLs. */
int gv_dist_gather(const void *mine, size_t bytes, char **all, size_t **sizes);
/* Waits until every rank gets here, asleep after the first millisecond: Open MPI's own waits
 * poll and would take a core from the ranks still computing. The collectives above wait here
 * first, so they poll only while their data moves. */
int gv_dist_barrier(void);

#endif
