/* Checksums stream: gv_file_checksum of a file larger than the address space the process may
 * use (setrlimit RLIMIT_AS in a child, the file written sparse) equals FNV-1a 64 computed here
 * independently, and the limit binds (a buffer of the file's size cannot be had under it).
 * Under AddressSanitizer, whose shadow memory and failing malloc do not go with RLIMIT_AS,
 * only the unlimited half runs. */
#include <inttypes.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/resource.h>
#include <sys/wait.h>
#include <unistd.h>

#include "check.h"
#include "gaussvid/core/core.h"
#include "gaussvid/train/scene_adapt.h"

#define FILE_BYTES (384ll << 20) /* larger than the headroom the child gets */
#define HEADROOM (96ll << 20)    /* address space above what the child already uses */

/* Bytes set in the otherwise sparse (zero) file: position and value. */
static const struct { long long at; unsigned char value; } marks[] = {
    {0, 0x47}, {4095, 0x01}, {(1ll << 20) + 7, 0xa5}, {(200ll << 20) + 3, 0xff}, {FILE_BYTES - 1, 0x5a}};
#define N_MARKS (int)(sizeof marks / sizeof marks[0])

static int write_sparse(const char *path)
{
    FILE *f = fopen(path, "wb");
    if (!f) return -1;
    int rc = ftruncate(fileno(f), FILE_BYTES);
    for (int i = 0; rc == 0 && i < N_MARKS; i++)
        rc = fseeko(f, marks[i].at, SEEK_SET) || fputc(marks[i].value, f) == EOF ? -1 : 0;
    return fclose(f) || rc ? -1 : 0;
}

/* FNV-1a 64 (offset basis 14695981039346656037, prime 1099511628211) of the file's content,
 * generated here without reading it: zeros but for the marks. */
static void expected_checksum(char *out, size_t size)
{
    uint64_t h = 14695981039346656037ull;
    int next = 0;
    for (long long i = 0; i < FILE_BYTES; i++) {
        unsigned char b = 0;
        if (next < N_MARKS && marks[next].at == i) b = marks[next++].value;
        h = (h ^ b) * 1099511628211ull;
    }
    snprintf(out, size, "fnv1a64:%016" PRIx64, h);
}

/* The address space in use now (VmSize of /proc/self/status), in bytes; -1 unknown. */
static long long address_space_used(void)
{
    FILE *f = fopen("/proc/self/status", "r");
    char line[256];
    long long kb = -1;
    while (f && fgets(line, sizeof line, f))
        if (sscanf(line, "VmSize: %lld kB", &kb) == 1) break;
    if (f) fclose(f);
    return kb < 0 ? -1 : kb * 1024;
}

/* In a child under the limit: 0 when the checksum matched and a file-sized buffer was refused;
 * 1 checksum failed or differed; 2 the limit did not bind; 3 the limit could not be set. */
static int child(const char *path, const char *expected)
{
    long long used = address_space_used();
    if (used < 0) return 3;
    struct rlimit limit = {(rlim_t)(used + HEADROOM), (rlim_t)(used + HEADROOM)};
    if (setrlimit(RLIMIT_AS, &limit)) return 3;
    void *whole = malloc((size_t)FILE_BYTES);
    if (whole) return 2;
    char sum[48];
    if (gv_file_checksum(path, sum, sizeof sum)) {
        fprintf(stderr, "%s\n", gv_last_error());
        return 1;
    }
    if (strcmp(sum, expected)) fprintf(stderr, "checksum %s, expected %s\n", sum, expected);
    return strcmp(sum, expected) ? 1 : 0;
}

static void test_beyond_the_memory_limit(const char *dir)
{
    char path[4096], expected[48];
    snprintf(path, sizeof path, "%s/sparse.bin", dir);
    CHECK(write_sparse(path) == 0);
    expected_checksum(expected, sizeof expected);
#if defined(__SANITIZE_ADDRESS__)
    printf("AddressSanitizer: the RLIMIT_AS half is skipped\n");
#else
    fflush(NULL);
    pid_t pid = fork();
    if (pid == 0) _exit(child(path, expected));
    int status = 0;
    CHECK(pid > 0 && waitpid(pid, &status, 0) == pid && WIFEXITED(status));
    int code = WEXITSTATUS(status);
    if (code == 2) printf("the limit did not bind: malloc(%lld) succeeded under it\n", FILE_BYTES);
    CHECK(code == 0);
#endif
    char sum[48]; /* and without a limit: the same */
    CHECK(gv_file_checksum(path, sum, sizeof sum) == 0 && !strcmp(sum, expected));
    remove(path);
}

static void test_small_files(const char *dir)
{
    char path[4096], sum[48];
    snprintf(path, sizeof path, "%s/a.txt", dir);
    FILE *f = fopen(path, "wb");
    CHECK(f && fputs("a", f) >= 0 && fclose(f) == 0);
    /* FNV-1a 64 of "a": the published test vector af63dc4c8601ec8c */
    CHECK(gv_file_checksum(path, sum, sizeof sum) == 0 && !strcmp(sum, "fnv1a64:af63dc4c8601ec8c"));
    f = fopen(path, "wb");
    CHECK(f && fclose(f) == 0);
    CHECK(gv_file_checksum(path, sum, sizeof sum) == 0 && !strcmp(sum, "fnv1a64:cbf29ce484222325")); /* empty: the basis */
    snprintf(path, sizeof path, "%s/none", dir);
    CHECK_FAILS_WITH(gv_file_checksum(path, sum, sizeof sum), "none: cannot open");
}

int main(void)
{
    const char *dir = check_tmp_dir();
    test_small_files(dir);
    test_beyond_the_memory_limit(dir);
    return check_summary();
}
