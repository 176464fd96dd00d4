/* Core: Philox known answers, RNG thread independence, flags, atomic files, errors. */
#include <omp.h>

#include "check.h"
#include "gaussvid/core/core.h"

static void test_philox_known_answers(void)
{
    /* Random123 known-answer vectors for philox4x32_10. */
    uint32_t out[4];
    gv_philox4x32(0, 0, out);
    CHECK(out[0] == 0x6627e8d5u && out[1] == 0xe169c58du && out[2] == 0xbc57ac4cu &&
          out[3] == 0x9b00dbd8u);
}

static void test_rng_thread_independent(void)
{
    enum { N = 10007 };
    static double one[N], two[N];
    omp_set_num_threads(1);
#pragma omp parallel for
    for (int i = 0; i < N; i++) one[i] = gv_normal_at(42, (uint64_t)i);
    omp_set_num_threads(2);
#pragma omp parallel for
    for (int i = 0; i < N; i++) two[i] = gv_normal_at(42, (uint64_t)i);
    CHECK(memcmp(one, two, sizeof one) == 0);
    double mean = 0, var = 0;
    for (int i = 0; i < N; i++) mean += one[i] / N;
    for (int i = 0; i < N; i++) var += (one[i] - mean) * (one[i] - mean) / N;
    CHECK_NEAR(mean, 0.0, 0.05);
    CHECK_NEAR(var, 1.0, 0.05);

    gv_rng r;
    gv_rng_init(&r, 7);
    double lo = 1, hi = 0;
    for (int i = 0; i < 100000; i++) {
        double u = gv_rng_uniform(&r);
        lo = u < lo ? u : lo;
        hi = u > hi ? u : hi;
    }
    CHECK(lo >= 0 && lo < 0.001 && hi < 1 && hi > 0.999);
}

static void test_flags(void)
{
    int n = 3, flag = 0;
    double x = 0;
    const char *s = NULL;
    const gv_flag flags[] = {
        {"count", GV_FLAG_INT, &n, "N", "a count", 0},
        {"on", GV_FLAG_BOOL, &flag, NULL, "a switch", 0},
        {"x", GV_FLAG_DOUBLE, &x, NULL, "a number", 0},
        {"out", GV_FLAG_STRING, &s, "FILE", "output", 1},
    };
    gv_command_spec spec = {"test", "A B", "a test", NULL, flags, 4, 1, 2};
    char *pos[2];
    int npos = 0;
    char *ok_argv[] = {"test", "a", "--count", "5", "--on", "--x=2.5", "--out", "o", "b"};
    CHECK(gv_args_parse(&spec, 9, ok_argv, pos, &npos) == GV_ARGS_OK);
    CHECK(n == 5 && flag == 1 && x == 2.5 && s && !strcmp(s, "o") && npos == 2);
    CHECK(!strcmp(pos[0], "a") && !strcmp(pos[1], "b"));
    char *missing[] = {"test", "a"};
    CHECK(gv_args_parse(&spec, 2, missing, pos, &npos) == GV_ARGS_ERROR);
    char *bad_int[] = {"test", "a", "--out", "o", "--count", "5x"};
    CHECK(gv_args_parse(&spec, 6, bad_int, pos, &npos) == GV_ARGS_ERROR);
    char *unknown[] = {"test", "a", "--out", "o", "--nope"};
    CHECK(gv_args_parse(&spec, 5, unknown, pos, &npos) == GV_ARGS_ERROR);
    char *too_many[] = {"test", "a", "b", "c", "--out", "o"};
    CHECK(gv_args_parse(&spec, 6, too_many, pos, &npos) == GV_ARGS_ERROR);
}

/* A list flag: values up to the next option, "=" and commas, repeated; none is an error. */
static void test_list_flag(void)
{
    gv_flag_list l = {.n = 0};
    int on = 0;
    const gv_flag flags[] = {{"dirs", GV_FLAG_LIST, &l, "DIR...", "folders", 1}, {"on", GV_FLAG_BOOL, &on, NULL, "a switch", 0}};
    gv_command_spec spec = {"test", NULL, "a test", NULL, flags, 2, 0, 0};
    char a[] = "a", bc[] = "b,c", d[] = "--dirs=d", e[] = "e";
    char *ok[] = {"test", "--dirs", a, bc, "--on", d, "--dirs", e};
    CHECK(gv_args_parse(&spec, 8, ok, NULL, NULL) == GV_ARGS_OK && on == 1 && l.n == 5);
    CHECK(l.n == 5 && !strcmp(l.items[0], "a") && !strcmp(l.items[2], "c") && !strcmp(l.items[3], "d") &&
          !strcmp(l.items[4], "e"));
    l.n = 0;
    char *empty[] = {"test", "--dirs", "--on"}, *none[] = {"test", "--on"};
    CHECK(gv_args_parse(&spec, 3, empty, NULL, NULL) == GV_ARGS_ERROR);
    CHECK(gv_args_parse(&spec, 2, none, NULL, NULL) == GV_ARGS_ERROR);
}

static void test_atomic_file(void)
{
    const char *dir = check_tmp_dir();
    char path[4200];
    snprintf(path, sizeof path, "%s/a/b/out.txt", dir);
    char parent[4200];
    snprintf(parent, sizeof parent, "%s/a/b", dir);
    CHECK(gv_mkdirs(parent) == 0);
    gv_atomic_file af;
    CHECK(gv_atomic_open(&af, path) == 0);
    fputs("hello", af.f);
    CHECK(!gv_file_exists(path)); /* not visible before commit */
    CHECK(gv_atomic_commit(&af) == 0);
    char *data;
    size_t size;
    CHECK(gv_read_file(path, &data, &size) == 0 && size == 5 && !strcmp(data, "hello"));
    free(data);
    CHECK(gv_atomic_open(&af, path) == 0);
    fputs("partial", af.f);
    gv_atomic_abort(&af);
    CHECK(gv_read_file(path, &data, &size) == 0 && !strcmp(data, "hello"));
    free(data);
    CHECK_FAILS_WITH(gv_read_file("/nonexistent/file", &data, &size), "/nonexistent/file");
}

int main(void)
{
    test_philox_known_answers();
    test_rng_thread_independent();
    test_flags();
    test_list_flag();
    test_atomic_file();
    return check_summary();
}
