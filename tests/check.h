/* A minimal test harness: CHECK macros count passes and failures, and check_summary()
 * prints the closing line "N passed, N failed" that ctest logs show. */
#ifndef GAUSSVID_TESTS_CHECK_H
#define GAUSSVID_TESTS_CHECK_H

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

static int check_passed, check_failed;

#define CHECK(cond)                                                                     \
    do {                                                                                \
        if (cond) check_passed++;                                                       \
        else { check_failed++; fprintf(stderr, "%s:%d: CHECK failed: %s\n", __FILE__,   \
                                       __LINE__, #cond); }                              \
    } while (0)

#define CHECK_NEAR(a, b, tol)                                                           \
    do {                                                                                \
        double check_a_ = (a), check_b_ = (b);                                          \
        if (fabs(check_a_ - check_b_) <= (tol)) check_passed++;                         \
        else { check_failed++; fprintf(stderr, "%s:%d: CHECK_NEAR failed: %s = %.9g, %s = %.9g (tol %g)\n", \
                                       __FILE__, __LINE__, #a, check_a_, #b, check_b_, (double)(tol)); } \
    } while (0)

/* Checks that a library call failed and that its message mentions `needle`. */
#define CHECK_FAILS_WITH(call, needle)                                                  \
    do {                                                                                \
        gv_clear_error();                                                               \
        int check_rc_ = (call);                                                         \
        const char *check_msg_ = gv_last_error();                                       \
        if (check_rc_ != 0 && strstr(check_msg_, (needle))) check_passed++;             \
        else { check_failed++; fprintf(stderr, "%s:%d: expected failure mentioning '%s' from %s; got rc %d, '%s'\n", \
                                       __FILE__, __LINE__, (needle), #call, check_rc_, check_msg_); } \
    } while (0)

/* A CHECK that ends the calling void function when it fails (what follows would index nothing). */
#define REQUIRE(cond)                                                                   \
    do {                                                                                \
        if (cond) check_passed++;                                                       \
        else { check_failed++; fprintf(stderr, "%s:%d: REQUIRE failed: %s (%s)\n", __FILE__, \
                                       __LINE__, #cond, gv_last_error()); return; }     \
    } while (0)

/* The exit status of a test that cannot run here (its data is missing): ctest counts it as
 * skipped, not passed (SKIP_RETURN_CODE in tests/tests.cmake). */
enum { CHECK_SKIP = 77 };

static inline int check_summary(void)
{
    printf("%d passed, %d failed\n", check_passed, check_failed);
    return check_failed ? 1 : 0;
}

/* A fresh scratch directory for this test program (from GV_TMP, set by ctest). */
static inline const char *check_tmp_dir(void)
{
    static char dir[4096];
    const char *base = getenv("GV_TMP");
    if (base) snprintf(dir, sizeof dir, "%s", base);
    else snprintf(dir, sizeof dir, "/tmp/gaussvid-test-%ld", (long)getpid());
    char command[4200];
    snprintf(command, sizeof command, "rm -rf '%s' && mkdir -p '%s'", dir, dir);
    if (system(command) != 0) { fprintf(stderr, "cannot create %s\n", dir); exit(1); }
    return dir;
}

/* The shared data folder, or NULL (with a message) when it is not present: the test then
 * returns CHECK_SKIP. */
static inline const char *check_shared_scenes(void)
{
    static char dir[4096];
    const char *base = getenv("GV_SHARED_DATA");
    snprintf(dir, sizeof dir, "%s/scenes", base ? base : "data");
    FILE *f;
    char probe[4200];
    snprintf(probe, sizeof probe, "%s/courtyard/transforms.json", dir);
    if (!(f = fopen(probe, "r"))) {
        printf("shared scenes not found under %s: skipped\n", dir);
        return NULL;
    }
    fclose(f);
    return dir;
}

#endif
