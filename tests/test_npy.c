/* NPY float32 files (src/io/npy.c): the exact bytes numpy.save writes for a float32 array
 * (header text, padding to 64 bytes), round trips of ranks 1-3, version 2.0 headers and
 * reordered keys as numpy may write them, and malformed files refused with the file named. */
#include <stdint.h>

#include "check.h"
#include "gaussvid/core/core.h"
#include "gaussvid/io/npy.h"

static char path_buf[4300];

static const char *tmp_path(const char *name)
{
    static const char *dir;
    if (!dir) dir = check_tmp_dir();
    snprintf(path_buf, sizeof path_buf, "%s/%s", dir, name);
    return path_buf;
}

static void write_bytes(const char *path, const void *bytes, size_t n)
{
    FILE *f = fopen(path, "wb");
    fwrite(bytes, 1, n, f);
    fclose(f);
}

/* What numpy.save(path, np.zeros((2, 3), np.float32) + values) writes: the 10-byte prefix,
 * the dict, spaces to byte 127 and a newline, then the 24 data bytes. */
static void test_numpy_layout(void)
{
    const char *path = tmp_path("a.npy");
    float values[6] = {0, 1.5f, -2, 3.25f, 1e-8f, 65504};
    int64_t shape[2] = {2, 3};
    CHECK(gv_npy_write_f32(path, 2, shape, values) == 0);
    char *bytes;
    size_t size;
    CHECK(gv_read_file(path, &bytes, &size) == 0);
    CHECK(size == 128 + 24);
    CHECK(memcmp(bytes, "\x93NUMPY\x01\x00\x76\x00", 10) == 0); /* header length 118 */
    const char *dict = "{'descr': '<f4', 'fortran_order': False, 'shape': (2, 3), }";
    CHECK(memcmp(bytes + 10, dict, strlen(dict)) == 0);
    int spaces = 1;
    for (size_t i = 10 + strlen(dict); i < 127; i++) spaces &= bytes[i] == ' ';
    CHECK(spaces && bytes[127] == '\n');
    CHECK(memcmp(bytes + 128, values, 24) == 0);
    free(bytes);

    int rank;
    int64_t got[GV_NPY_MAX_RANK];
    float *data;
    CHECK(gv_npy_read_f32(path, &rank, got, &data) == 0);
    CHECK(rank == 2 && got[0] == 2 && got[1] == 3);
    CHECK(memcmp(data, values, sizeof values) == 0);
    free(data);
}

static void test_round_trips(void)
{
    /* rank 1 is written "(5,)" as Python writes a 1-tuple */
    float v[60];
    for (int i = 0; i < 60; i++) v[i] = (float)i / 7;
    int64_t s1[1] = {5}, s3[3] = {4, 5, 3};
    const char *path = tmp_path("r1.npy");
    CHECK(gv_npy_write_f32(path, 1, s1, v) == 0);
    char *bytes;
    size_t size;
    CHECK(gv_read_file(path, &bytes, &size) == 0);
    CHECK(strstr(bytes + 10, "'shape': (5,), }") != NULL);
    CHECK(size == 128 + 20);
    free(bytes);
    int rank;
    int64_t got[GV_NPY_MAX_RANK];
    float *data;
    CHECK(gv_npy_read_f32(path, &rank, got, &data) == 0);
    CHECK(rank == 1 && got[0] == 5 && memcmp(data, v, 20) == 0);
    free(data);
    path = tmp_path("r3.npy");
    CHECK(gv_npy_write_f32(path, 3, s3, v) == 0);
    CHECK(gv_npy_read_f32(path, &rank, got, &data) == 0);
    CHECK(rank == 3 && got[0] == 4 && got[1] == 5 && got[2] == 3);
    CHECK(memcmp(data, v, sizeof v) == 0);
    free(data);
}

/* A file with the given header dict (version 1.0 or 2.0), padded as numpy pads, and `n`
 * data floats. */
static void write_npy(const char *path, int version, const char *dict, int n)
{
    unsigned char buf[512];
    int prefix = version == 1 ? 10 : 12, len = (int)strlen(dict);
    int total = (prefix + len + 1 + 63) / 64 * 64, header = total - prefix;
    memcpy(buf, "\x93NUMPY", 6);
    buf[6] = (unsigned char)version, buf[7] = 0;
    buf[8] = (unsigned char)header, buf[9] = (unsigned char)(header >> 8);
    if (version == 2) buf[10] = buf[11] = 0;
    memcpy(buf + prefix, dict, (size_t)len);
    memset(buf + prefix + len, ' ', (size_t)(total - prefix - len - 1));
    buf[total - 1] = '\n';
    for (int i = 0; i < n; i++) {
        float x = (float)i;
        memcpy(buf + total + 4 * i, &x, 4);
    }
    write_bytes(path, buf, (size_t)total + 4 * (size_t)n);
}

static void test_other_writers(void)
{
    int rank;
    int64_t got[GV_NPY_MAX_RANK];
    float *data;
    const char *path = tmp_path("v2.npy");
    write_npy(path, 2, "{'shape': (3, 2), 'fortran_order': False, 'descr': '<f4'}", 6);
    CHECK(gv_npy_read_f32(path, &rank, got, &data) == 0);
    CHECK(rank == 2 && got[0] == 3 && got[1] == 2 && data[5] == 5);
    free(data);
}

static void test_bad_files(void)
{
    int rank;
    int64_t got[GV_NPY_MAX_RANK];
    float *data;
    const char *path = tmp_path("bad.npy");
    write_npy(path, 1, "{'descr': '<f8', 'fortran_order': False, 'shape': (2,), }", 4);
    CHECK_FAILS_WITH(gv_npy_read_f32(path, &rank, got, &data), "'<f8' is not float32");
    CHECK_FAILS_WITH(gv_npy_read_f32(path, &rank, got, &data), "bad.npy");
    write_npy(path, 1, "{'descr': '<f4', 'fortran_order': True, 'shape': (2, 2), }", 4);
    CHECK_FAILS_WITH(gv_npy_read_f32(path, &rank, got, &data), "Fortran");
    write_npy(path, 1, "{'descr': '<f4', 'fortran_order': False, 'shape': (2, 3), }", 5);
    CHECK_FAILS_WITH(gv_npy_read_f32(path, &rank, got, &data), "20 data bytes, the shape needs 24");
    write_npy(path, 1, "{'descr': '<f4', 'fortran_order': False, 'shape': (2, x), }", 4);
    CHECK_FAILS_WITH(gv_npy_read_f32(path, &rank, got, &data), "malformed NPY shape");
    write_npy(path, 1, "{'descr': '<f4', 'fortran_order': False}", 4);
    CHECK_FAILS_WITH(gv_npy_read_f32(path, &rank, got, &data), "lacks");
    write_npy(path, 1, "{'descr': '<f4', 'fortran_order': False, 'shape': (1, 1, 1, 1, 1), }", 1);
    CHECK_FAILS_WITH(gv_npy_read_f32(path, &rank, got, &data), "malformed NPY shape");
    write_npy(path, 4, "{'descr': '<f4', 'fortran_order': False, 'shape': (1,), }", 1);
    CHECK_FAILS_WITH(gv_npy_read_f32(path, &rank, got, &data), "version 4.0");
    write_bytes(path, "\x93NUMPY\x01\x00\x76\x00{'descr'", 17);
    CHECK_FAILS_WITH(gv_npy_read_f32(path, &rank, got, &data), "truncated");
    write_bytes(path, "PNG not numpy", 13);
    CHECK_FAILS_WITH(gv_npy_read_f32(path, &rank, got, &data), "not an NPY file");
    CHECK_FAILS_WITH(gv_npy_read_f32(tmp_path("missing.npy"), &rank, got, &data), "missing.npy");
    int64_t bad_shape[2] = {2, 0};
    float v[4] = {0};
    CHECK_FAILS_WITH(gv_npy_write_f32(tmp_path("w.npy"), 2, bad_shape, v), "not positive");
    CHECK_FAILS_WITH(gv_npy_write_f32(tmp_path("w.npy"), 0, bad_shape, v), "rank 0");
    CHECK(!gv_file_exists(tmp_path("w.npy")));
    CHECK_FAILS_WITH(gv_npy_write_f32(tmp_path("no/such/dir/w.npy"), 1, bad_shape, v), "w.npy");
}

int main(void)
{
    test_numpy_layout();
    test_round_trips();
    test_other_writers();
    test_bad_files();
    return check_summary();
}
