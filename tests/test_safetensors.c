/* safetensors: half/bfloat16 conversions against hand-derived bit patterns and an independent
 * rounding in double precision; the writer's canonical bytes; round trips of every dtype;
 * a hand-built file read exactly; and every kind of malformed file refused with a message
 * naming the file and the problem. */
#include <omp.h>
#include <stdint.h>
#include <sys/stat.h>
#include <unistd.h>

#include "check.h"
#include "gaussvid/core/core.h"
#include "gaussvid/io/safetensors.h"

static const char *tmp;

static const char *tmp_file(char *out, const char *name)
{
    snprintf(out, 4200, "%s/%s", tmp, name);
    return out;
}

static float float_of_bits(uint32_t u)
{
    float x;
    memcpy(&x, &u, 4);
    return x;
}

static uint32_t bits_of_float(float x)
{
    uint32_t u;
    memcpy(&u, &x, 4);
    return u;
}

/* ---- conversions -------------------------------------------------------------------- */

static void test_f16_known_values(void)
{
    static const struct { uint32_t in; uint16_t out; } narrow[] = {
        {0x00000000, 0x0000}, {0x80000000, 0x8000},   /* +0, -0 */
        {0x3f800000, 0x3c00}, {0xc0000000, 0xc000},   /* 1, -2 */
        {0x3dcccccd, 0x2e66},                         /* 0.1 -> 0.0999755859375 */
        {0x477fe000, 0x7bff},                         /* 65504, the largest half */
        {0x477fefff, 0x7bff},                         /* just below the tie at 65520 */
        {0x477ff000, 0x7c00},                         /* 65520: tie, 0x7bff is odd -> inf */
        {0x49742400, 0x7c00}, {0x7f800000, 0x7c00}, {0xff800000, 0xfc00},  /* 1e6, +-inf */
        {0x38800000, 0x0400},                         /* 2^-14, smallest normal */
        {0x33800000, 0x0001},                         /* 2^-24, smallest subnormal */
        {0x33000000, 0x0000},                         /* 2^-25: tie between 0 and 1 -> 0 */
        {0x33000001, 0x0001},                         /* just above that tie */
        {0x33c00000, 0x0002},                         /* 1.5 * 2^-24: tie 1|2 -> 2 */
        {0x387fc000, 0x03ff},                         /* 1023 * 2^-24, largest subnormal */
        {0x387fe000, 0x0400},                         /* 1023.5 * 2^-24: tie -> 1024 = normal */
        {0x3f801000, 0x3c00},                         /* 1 + 2^-11: tie -> even 0x3c00 */
        {0x3f803000, 0x3c02},                         /* 1 + 3*2^-11: tie -> even 0x3c02 */
        {0x3f801001, 0x3c01},                         /* just above 1 + 2^-11 */
        {0x00000001, 0x0000}, {0x80000001, 0x8000},   /* float subnormals -> signed zero */
    };
    for (size_t i = 0; i < sizeof narrow / sizeof narrow[0]; i++) {
        uint16_t got = gv_f32_to_f16(float_of_bits(narrow[i].in));
        if (got != narrow[i].out)
            fprintf(stderr, "f16(0x%08x) = 0x%04x, expected 0x%04x\n", narrow[i].in, got,
                    narrow[i].out);
        CHECK(got == narrow[i].out);
    }
    uint16_t nan = gv_f32_to_f16(float_of_bits(0x7fc00000)), snan = gv_f32_to_f16(float_of_bits(0xff800001));
    CHECK((nan & 0x7c00) == 0x7c00 && (nan & 0x3ff) != 0);
    CHECK((snan & 0x7c00) == 0x7c00 && (snan & 0x3ff) != 0 && (snan & 0x8000));

    static const struct { uint16_t in; uint32_t out; } widen[] = {
        {0x0000, 0x00000000}, {0x8000, 0x80000000}, {0x3c00, 0x3f800000}, {0xc000, 0xc0000000},
        {0x0001, 0x33800000}, {0x03ff, 0x387fc000}, {0x0400, 0x38800000}, {0x7bff, 0x477fe000},
        {0x7c00, 0x7f800000}, {0xfc00, 0xff800000}, {0x3555, 0x3eaaa000}, {0x8001, 0xb3800000},
    };
    for (size_t i = 0; i < sizeof widen / sizeof widen[0]; i++)
        CHECK(bits_of_float(gv_f16_to_f32(widen[i].in)) == widen[i].out);
    CHECK(isnan(gv_f16_to_f32(0x7e00)) && isnan(gv_f16_to_f32(0xfc01)));
}

static void test_bf16_known_values(void)
{
    static const struct { uint32_t in; uint16_t out; } narrow[] = {
        {0x00000000, 0x0000}, {0x80000000, 0x8000}, {0x3f800000, 0x3f80},
        {0x40490fdb, 0x4049},                         /* pi: 0x0fdb < half -> down */
        {0x3f808000, 0x3f80},                         /* tie, 0x3f80 even -> down */
        {0x3f818000, 0x3f82},                         /* tie, 0x3f81 odd -> up */
        {0x3f808001, 0x3f81},                         /* just above a tie -> up */
        {0x7f7fffff, 0x7f80},                         /* FLT_MAX rounds up to inf */
        {0x7f7f7fff, 0x7f7f},                         /* below the tie stays finite */
        {0x7f800000, 0x7f80}, {0xff800000, 0xff80},   /* +-inf */
        {0x00000001, 0x0000}, {0x00008000, 0x0000},   /* subnormal; tie to even 0 */
        {0x00018000, 0x0002},                         /* subnormal tie -> even */
        {0x80010000, 0x8001},
    };
    for (size_t i = 0; i < sizeof narrow / sizeof narrow[0]; i++) {
        uint16_t got = gv_f32_to_bf16(float_of_bits(narrow[i].in));
        if (got != narrow[i].out)
            fprintf(stderr, "bf16(0x%08x) = 0x%04x, expected 0x%04x\n", narrow[i].in, got,
                    narrow[i].out);
        CHECK(got == narrow[i].out);
    }
    CHECK(gv_f32_to_bf16(float_of_bits(0x7fc00000)) == 0x7fc0);
    CHECK(gv_f32_to_bf16(float_of_bits(0x7f800001)) == 0x7fc0);  /* signalling NaN stays NaN */
    CHECK(gv_f32_to_bf16(float_of_bits(0xffffffff)) == 0xffff);
    CHECK(bits_of_float(gv_bf16_to_f32(0x3f80)) == 0x3f800000);
    CHECK(bits_of_float(gv_bf16_to_f32(0x8001)) == 0x80010000);
    CHECK(bits_of_float(gv_bf16_to_f32(0xff80)) == 0xff800000);
}

/* The value of x rounded to `mantissa` fraction bits (ties to even) with exponents clamped
 * below at min_exponent (subnormals), and +-inf above `largest`: computed in double, exactly,
 * independently of the bit manipulation under test. */
static float round_reference(float x, int mantissa, int min_exponent, double largest)
{
    if (x == 0 || isinf(x)) return x;
    int e;
    frexp(fabs((double)x), &e);
    int exponent = e - 1 < min_exponent ? min_exponent : e - 1;
    double ulp = ldexp(1.0, exponent - mantissa);
    double r = nearbyint((double)x / ulp) * ulp;
    if (fabs(r) > largest) return x < 0 ? -INFINITY : INFINITY;
    return (float)r;
}

static void test_conversions_against_reference(void)
{
    gv_rng rng;
    gv_rng_init(&rng, 1234);
    int bad_bf16 = 0, bad_f16 = 0;
    for (int i = 0; i < 200000; i++) {
        float x = float_of_bits(gv_rng_u32(&rng));  /* every exponent, for bfloat16 */
        if (isnan(x)) continue;
        float want = round_reference(x, 7, -126, 0x1.fep127);
        float got = gv_bf16_to_f32(gv_f32_to_bf16(x));
        if (bits_of_float(got) != bits_of_float(want) && bad_bf16++ < 3)
            fprintf(stderr, "bf16 of %a: got %a, expected %a\n", x, got, want);
        /* half: exponents from -27 to 16 cover underflow, subnormals, normals and overflow */
        int exponent = (int)(gv_rng_u32(&rng) % 44) - 27;
        float y = ldexpf(1.0f + (float)(gv_rng_u32(&rng) & 0x7fffff) * 0x1p-23f, exponent);
        if (gv_rng_u32(&rng) & 1) y = -y;
        want = round_reference(y, 10, -14, 65504.0);
        got = gv_f16_to_f32(gv_f32_to_f16(y));
        if (bits_of_float(got) != bits_of_float(want) && bad_f16++ < 3)
            fprintf(stderr, "f16 of %a: got %a, expected %a\n", y, got, want);
    }
    CHECK(bad_bf16 == 0);
    CHECK(bad_f16 == 0);
    /* every half value survives half -> float -> half */
    int bad_round_trip = 0;
    for (uint32_t h = 0; h < 0x10000; h++) {
        if ((h & 0x7c00) == 0x7c00 && (h & 0x3ff)) continue;  /* NaNs */
        bad_round_trip += gv_f32_to_f16(gv_f16_to_f32((uint16_t)h)) != h;
    }
    CHECK(bad_round_trip == 0);
}

/* ---- helpers for files ---------------------------------------------------------------- */

static void write_bytes(const char *path, const void *bytes, size_t n)
{
    FILE *f = fopen(path, "wb");
    if (!f || fwrite(bytes, 1, n, f) != n) { fprintf(stderr, "cannot write %s\n", path); exit(1); }
    fclose(f);
}

static unsigned char *read_bytes(const char *path, size_t *n)
{
    char *data;
    if (gv_read_file(path, &data, n)) return NULL;
    return (unsigned char *)data;
}

/* A file with the given header length field, header text and data bytes. */
static void write_st_raw(const char *path, uint64_t length, const char *header, const void *data,
                         size_t data_len)
{
    size_t h = strlen(header);
    unsigned char *bytes = malloc(8 + h + data_len + 1);
    for (int k = 0; k < 8; k++) bytes[k] = (unsigned char)(length >> (8 * k));
    memcpy(bytes + 8, header, h);
    if (data_len) memcpy(bytes + 8 + h, data, data_len);
    write_bytes(path, bytes, 8 + h + data_len);
    free(bytes);
}

static void write_st(const char *path, const char *header, const void *data, size_t data_len)
{
    write_st_raw(path, strlen(header), header, data, data_len);
}

/* gv_st_open must fail with a message naming the file and containing `needle`. */
static void check_open_fails(const char *path, const char *needle, int line)
{
    gv_st_file f;
    gv_clear_error();
    int rc = gv_st_open(&f, path);
    const char *msg = gv_last_error();
    if (rc != 0 && strstr(msg, path) && strstr(msg, needle) && !strchr(msg, '\n')) {
        check_passed++;
    } else {
        check_failed++;
        fprintf(stderr, "line %d: expected open of %s to fail mentioning '%s'; got rc %d, '%s'\n",
                line, path, needle, rc, msg);
    }
    if (rc == 0) gv_st_close(&f);
}
#define CHECK_OPEN_FAILS(path, needle) check_open_fails(path, needle, __LINE__)

/* ---- the writer's canonical bytes ------------------------------------------------------ */

static void test_canonical_bytes(void)
{
    char path[4200];
    size_t n;
    /* one F32 tensor: the header is exactly 64 bytes, so no padding */
    float values[6] = {0, 1, 2, 3, 4, 5};
    int64_t shape[3] = {1, 2, 3};
    gv_st_builder b;
    gv_st_builder_init(&b);
    CHECK(gv_st_add_f32(&b, "attn.0", GV_ST_F32, shape, 3, values) == 0);
    CHECK(gv_st_write(&b, tmp_file(path, "one.safetensors")) == 0);
    gv_st_builder_free(&b);
    const char *header = "{\"attn.0\":{\"dtype\":\"F32\",\"shape\":[1,2,3],\"data_offsets\":[0,24]}}";
    CHECK(strlen(header) == 64);
    unsigned char *bytes = read_bytes(path, &n);
    CHECK(bytes && n == 8 + 64 + 24);
    if (bytes && n == 96) {
        CHECK(bytes[0] == 64 && !bytes[1] && !bytes[2] && !bytes[7]);
        CHECK(memcmp(bytes + 8, header, 64) == 0);
        CHECK(memcmp(bytes + 72, values, 24) == 0);
    }
    free(bytes);

    /* no tensors, one metadata entry: 35 bytes of JSON padded with 5 spaces to 40 */
    gv_st_builder_init(&b);
    CHECK(gv_st_add_metadata(&b, "framework", "pt") == 0);
    CHECK(gv_st_write(&b, tmp_file(path, "empty.safetensors")) == 0);
    gv_st_builder_free(&b);
    bytes = read_bytes(path, &n);
    CHECK(bytes && n == 48 && bytes[0] == 40);
    if (bytes && n == 48)
        CHECK(memcmp(bytes + 8, "{\"__metadata__\":{\"framework\":\"pt\"}}     ", 40) == 0);
    free(bytes);

    /* order: dtype alignment descending (I64 > F32 > BF16 > U8), then name; metadata keys
     * sorted; names escaped as serde_json escapes them */
    uint8_t u8[4] = {1, 2, 3, 4};
    int64_t i64 = -5;
    float f[2] = {1.0f, -2.0f};
    int64_t one = 1, two = 2, three = 3;
    gv_st_builder_init(&b);
    CHECK(gv_st_add_raw(&b, "b", GV_ST_U8, &three, 1, u8) == 0);
    CHECK(gv_st_add_raw(&b, "a", GV_ST_U8, &one, 1, u8 + 3) == 0);
    CHECK(gv_st_add_f32(&b, "z", GV_ST_F32, &one, 1, f) == 0);
    CHECK(gv_st_add_raw(&b, "c", GV_ST_I64, NULL, 0, &i64) == 0);
    CHECK(gv_st_add_f32(&b, "m\"\n", GV_ST_BF16, &two, 1, f) == 0);
    CHECK(gv_st_add_metadata(&b, "step", "7") == 0);
    CHECK(gv_st_add_metadata(&b, "config", "{\"dim\": 64}\x01") == 0);
    CHECK(gv_st_write(&b, tmp_file(path, "order.safetensors")) == 0);
    gv_st_builder_free(&b);
    const char *expected =
        "{\"__metadata__\":{\"config\":\"{\\\"dim\\\": 64}\\u0001\",\"step\":\"7\"},"
        "\"c\":{\"dtype\":\"I64\",\"shape\":[],\"data_offsets\":[0,8]},"
        "\"z\":{\"dtype\":\"F32\",\"shape\":[1],\"data_offsets\":[8,12]},"
        "\"m\\\"\\n\":{\"dtype\":\"BF16\",\"shape\":[2],\"data_offsets\":[12,16]},"
        "\"a\":{\"dtype\":\"U8\",\"shape\":[1],\"data_offsets\":[16,17]},"
        "\"b\":{\"dtype\":\"U8\",\"shape\":[3],\"data_offsets\":[17,20]}}";
    size_t len = strlen(expected), padded = (len + 7) / 8 * 8;
    bytes = read_bytes(path, &n);
    CHECK(bytes && n == 8 + padded + 20);
    if (bytes && n == 8 + padded + 20) {
        uint64_t field = 0;
        for (int k = 7; k >= 0; k--) field = (field << 8) | bytes[k];
        CHECK(field == padded);
        CHECK(memcmp(bytes + 8, expected, len) == 0);
        for (size_t k = len; k < padded; k++) CHECK(bytes[8 + k] == ' ');
        const unsigned char *data = bytes + 8 + padded;
        static const unsigned char want[20] = {0xfb, 0xff, 0xff, 0xff, 0xff, 0xff, 0xff, 0xff,
                                               0x00, 0x00, 0x80, 0x3f, 0x80, 0x3f, 0x00, 0xc0,
                                               4, 1, 2, 3};
        CHECK(memcmp(data, want, 20) == 0);
    }
    free(bytes);
}

/* ---- round trip ----------------------------------------------------------------------- */

static void test_round_trip(void)
{
    enum { N = 300007 };  /* odd and large enough for the parallel conversion paths */
    float *big = malloc(N * sizeof *big), *back1 = malloc(N * sizeof *back1),
          *back2 = malloc(N * sizeof *back2);
    for (int i = 0; i < N; i++) big[i] = (float)gv_normal_at(5, (uint64_t)i) * 100.0f;
    float small[6] = {0.5f, -1.25f, 3.0f, 0x1p-10f, -0.0f, 65504.0f};
    uint8_t frames[2 * 3 * 4] = {0};
    for (int i = 0; i < 24; i++) frames[i] = (uint8_t)(i * 11);
    int8_t i8[3] = {-128, 0, 127};
    int32_t i32[4] = {INT32_MIN, -1, 0, INT32_MAX};
    int64_t i64[2] = {INT64_MIN, 1234567890123LL};
    uint8_t flags[3] = {1, 0, 1};
    double f64[3] = {1.0 / 3.0, -1e300, 2.5};
    uint16_t u16[2] = {0, 65535};
    float scalar = 42.0f;
    int64_t s_big = N, s_small[2] = {2, 3}, s_frames[3] = {2, 3, 4}, s3 = 3, s4 = 4, s2 = 2;
    int64_t s_rank8[8] = {1, 1, 2, 1, 1, 3, 1, 1}, s_empty[2] = {0, 5};

    gv_st_builder b;
    gv_st_builder_init(&b);
    CHECK(gv_st_add_f32(&b, "big.bf16", GV_ST_BF16, &s_big, 1, big) == 0);
    CHECK(gv_st_add_f32(&b, "big.f16", GV_ST_F16, &s_big, 1, big) == 0);
    CHECK(gv_st_add_f32(&b, "big.f32", GV_ST_F32, &s_big, 1, big) == 0);
    CHECK(gv_st_add_f32(&b, "small", GV_ST_F32, s_small, 2, small) == 0);
    CHECK(gv_st_add_f32(&b, "rank8", GV_ST_F16, s_rank8, 8, small) == 0);
    CHECK(gv_st_add_f32(&b, "scalar", GV_ST_F32, NULL, 0, &scalar) == 0);
    CHECK(gv_st_add_f32(&b, "empty", GV_ST_BF16, s_empty, 2, NULL) == 0);
    CHECK(gv_st_add_raw(&b, "frames", GV_ST_U8, s_frames, 3, frames) == 0);
    CHECK(gv_st_add_raw(&b, "i8", GV_ST_I8, &s3, 1, i8) == 0);
    CHECK(gv_st_add_raw(&b, "i32", GV_ST_I32, &s4, 1, i32) == 0);
    CHECK(gv_st_add_raw(&b, "i64", GV_ST_I64, &s2, 1, i64) == 0);
    CHECK(gv_st_add_raw(&b, "bool", GV_ST_BOOL, &s3, 1, flags) == 0);
    CHECK(gv_st_add_raw(&b, "f64", GV_ST_F64, &s3, 1, f64) == 0);
    CHECK(gv_st_add_raw(&b, "u16", GV_ST_U16, &s2, 1, u16) == 0);
    CHECK(gv_st_add_metadata(&b, "step", "1200") == 0);
    CHECK(gv_st_add_metadata(&b, "config", "{\"dim\": 64, \"name\": \"tiny\"}") == 0);
    CHECK(gv_st_add_metadata(&b, "scene", "caf\xc3\xa9 \xe2\x86\x92 \"room\"\n") == 0);
    char path[4200];
    CHECK(gv_st_write(&b, tmp_file(path, "round.safetensors")) == 0);
    gv_st_builder_free(&b);

    gv_st_file f;
    CHECK(gv_st_open(&f, path) == 0);
    CHECK(f.n_tensors == 14 && f.n_metadata == 3);
    CHECK(f.header_size % 8 == 0);
    int aligned = 1;
    for (int i = 0; i < f.n_tensors; i++) {
        int size = gv_st_dtype_bits(f.tensors[i].dtype) / 8;
        aligned &= (uintptr_t)f.tensors[i].data % (uintptr_t)size == 0;
    }
    CHECK(aligned);
    CHECK(gv_st_metadata(&f, "step") && !strcmp(gv_st_metadata(&f, "step"), "1200"));
    CHECK(gv_st_metadata(&f, "config") &&
          !strcmp(gv_st_metadata(&f, "config"), "{\"dim\": 64, \"name\": \"tiny\"}"));
    CHECK(gv_st_metadata(&f, "scene") &&
          !strcmp(gv_st_metadata(&f, "scene"), "caf\xc3\xa9 \xe2\x86\x92 \"room\"\n"));
    CHECK(gv_st_metadata(&f, "absent") == NULL && gv_st_find(&f, "absent") == NULL);

    /* float tensors; BF16/F16 give the rounding of each value, checked bit for bit, with
     * one and with two threads */
    CHECK(gv_st_read_f32(&f, "big.f32", back1, &s_big, 1) == 0);
    CHECK(memcmp(back1, big, N * sizeof *big) == 0);
    int bad = 0;
    for (int t = 1; t <= 2; t++) {
        omp_set_num_threads(t);
        CHECK(gv_st_read_f32(&f, "big.bf16", back1, &s_big, 1) == 0);
        CHECK(gv_st_read_f32(&f, "big.f16", back2, NULL, -1) == 0);
        for (int i = 0; i < N; i++) {
            bad += bits_of_float(back1[i]) != bits_of_float(gv_bf16_to_f32(gv_f32_to_bf16(big[i])));
            bad += bits_of_float(back2[i]) != bits_of_float(gv_f16_to_f32(gv_f32_to_f16(big[i])));
        }
    }
    CHECK(bad == 0);
    float got[6];
    CHECK(gv_st_read_f32(&f, "small", got, s_small, 2) == 0);
    CHECK(memcmp(got, small, sizeof small) == 0);
    CHECK(gv_st_read_f32(&f, "rank8", got, s_rank8, 8) == 0);
    CHECK(memcmp(got, small, sizeof small) == 0);  /* all six are exact in half */
    CHECK(gv_st_read_f32(&f, "scalar", got, NULL, 0) == 0 && got[0] == 42.0f);
    CHECK(gv_st_read_f32(&f, "f64", got, &s3, 1) == 0);
    CHECK(got[0] == (float)(1.0 / 3.0) && isinf(got[1]) && got[1] < 0 && got[2] == 2.5f);
    const gv_st_tensor *t;
    CHECK(gv_st_get(&f, "empty", GV_ST_BF16, s_empty, 2, &t) == 0 && t->n_elements == 0 &&
          t->begin == t->end);

    /* raw tensors come back byte for byte */
    uint8_t frames_back[24];
    int32_t i32_back[4];
    int64_t i64_back[2];
    CHECK(gv_st_read_raw(&f, "frames", GV_ST_U8, s_frames, 3, frames_back) == 0);
    CHECK(memcmp(frames_back, frames, 24) == 0);
    CHECK(gv_st_read_raw(&f, "i32", GV_ST_I32, &s4, 1, i32_back) == 0);
    CHECK(memcmp(i32_back, i32, sizeof i32) == 0);
    CHECK(gv_st_read_raw(&f, "i64", GV_ST_I64, &s2, 1, i64_back) == 0);
    CHECK(memcmp(i64_back, i64, sizeof i64) == 0);
    CHECK(gv_st_get(&f, "i8", GV_ST_I8, &s3, 1, &t) == 0 && memcmp(t->data, i8, 3) == 0);
    CHECK(gv_st_get(&f, "bool", GV_ST_BOOL, &s3, 1, &t) == 0 && memcmp(t->data, flags, 3) == 0);
    CHECK(gv_st_get(&f, "u16", -1, NULL, -1, &t) == 0 && t->dtype == GV_ST_U16 &&
          memcmp(t->data, u16, 4) == 0);

    /* expectation mismatches: one line naming the file, the tensor, expected and found */
    int64_t wrong[2] = {3, 2};
    CHECK_FAILS_WITH(gv_st_read_f32(&f, "small", got, wrong, 2),
                     "tensor 'small': expected F32/F16/BF16/F64 [3, 2], found F32 [2, 3]");
    CHECK(strstr(gv_last_error(), path) != NULL);
    CHECK_FAILS_WITH(gv_st_read_f32(&f, "small", got, s_small, 1), "expected F32/F16/BF16/F64 [2]");
    CHECK_FAILS_WITH(gv_st_read_f32(&f, "frames", got, s_frames, 3),
                     "tensor 'frames': expected F32/F16/BF16/F64 [2, 3, 4], found U8 [2, 3, 4]");
    CHECK_FAILS_WITH(gv_st_read_raw(&f, "i32", GV_ST_I64, &s4, 1, i64_back),
                     "tensor 'i32': expected I64 [4], found I32 [4]");
    CHECK_FAILS_WITH(gv_st_get(&f, "scalar", GV_ST_F32, &s2, 1, &t), "expected F32 [2], found F32 []");
    CHECK_FAILS_WITH(gv_st_read_f32(&f, "nope", got, NULL, -1), "no tensor named 'nope'");
    CHECK(strstr(gv_last_error(), path) != NULL);
    CHECK_FAILS_WITH(gv_st_tensor_to_f32(&f, gv_st_find(&f, "i8"), got), "does not convert");
    gv_st_close(&f);
    gv_st_close(&f);  /* closing twice is harmless */
    free(big);
    free(back1);
    free(back2);
}

/* ---- a file built byte by byte -------------------------------------------------------- */

static void test_hand_written(void)
{
    /* 146-byte header (not a multiple of 8: the data is unaligned), leading and trailing JSON
     * whitespace, tensors listed out of offset order, metadata last */
    const char *header =
        "\t\n{\"b\":{\"dtype\":\"U8\",\"shape\":[3],\"data_offsets\":[4,7],\"extra\":1},"
        "\"a\":{\"dtype\":\"F16\",\"shape\":[2],\"data_offsets\":[0,4]},\"__metadata__\":{\"k\":\"v\"}} \r\n";
    const unsigned char data[7] = {0x00, 0x3c, 0x00, 0xc0, 7, 8, 9};  /* 1.0, -2.0 in half */
    char path[4200];
    write_st(tmp_file(path, "hand.safetensors"), header, data, sizeof data);
    gv_st_file f;
    CHECK(gv_st_open(&f, path) == 0);
    CHECK(f.n_tensors == 2 && f.n_metadata == 1 && f.header_size == strlen(header));
    CHECK(f.data_size == 7 && f.file_size == 8 + strlen(header) + 7);
    CHECK(!strcmp(f.tensors[0].name, "a") && !strcmp(f.tensors[1].name, "b"));  /* offset order */
    float v[2] = {0, 0};
    int64_t two = 2, three = 3;
    CHECK(gv_st_read_f32(&f, "a", v, &two, 1) == 0 && v[0] == 1.0f && v[1] == -2.0f);
    uint8_t u[3];
    CHECK(gv_st_read_raw(&f, "b", GV_ST_U8, &three, 1, u) == 0 && u[0] == 7 && u[1] == 8 && u[2] == 9);
    CHECK(gv_st_metadata(&f, "k") && !strcmp(gv_st_metadata(&f, "k"), "v"));
    gv_st_close(&f);

    /* an empty file: "{}" and nothing after, and null metadata */
    write_st(tmp_file(path, "nothing.safetensors"), "{\"__metadata__\":null}", NULL, 0);
    CHECK(gv_st_open(&f, path) == 0 && f.n_tensors == 0 && f.n_metadata == 0);
    gv_st_close(&f);
}

/* ---- malformed files ------------------------------------------------------------------ */

static void test_malformed(void)
{
    char path[4200];
    const unsigned char zeros[64] = {0};
#define BAD(file, header, data_len, needle)                                          \
    do {                                                                              \
        write_st(tmp_file(path, file), header, zeros, data_len);                      \
        CHECK_OPEN_FAILS(path, needle);                                               \
    } while (0)
#define T(name, dtype, shape, b, e) \
    "\"" name "\":{\"dtype\":\"" dtype "\",\"shape\":" shape ",\"data_offsets\":[" #b "," #e "]}"

    write_st_raw(tmp_file(path, "beyond.safetensors"), 1000, "{}", NULL, 0);
    CHECK_OPEN_FAILS(path, "header length 1000 runs past the end of the 10-byte file");
    write_st_raw(tmp_file(path, "absurd.safetensors"), 1ull << 40, "{}", NULL, 0);
    CHECK_OPEN_FAILS(path, "beyond the format's limit");
    write_bytes(tmp_file(path, "short.safetensors"), "\x02\0\0", 3);
    CHECK_OPEN_FAILS(path, "too short");
    CHECK_OPEN_FAILS(tmp_file(path, "missing.safetensors"), "cannot open");
    CHECK_OPEN_FAILS(tmp, "not a regular file");

    BAD("json.safetensors", "{\"a\":", 0, "not valid JSON");
    BAD("garbage.safetensors", "{} x", 0, "not valid JSON");
    BAD("array.safetensors", "[1, 2]", 0, "not a JSON object");
    BAD("empty_header.safetensors", "", 0, "not valid JSON");
    BAD("overlap.safetensors", "{" T("a", "F32", "[2]", 0, 8) "," T("b", "F32", "[2]", 4, 12) "}",
        12, "tensors 'a' [0, 8] and 'b' [4, 12] overlap");
    BAD("range.safetensors", "{" T("a", "F32", "[2]", 0, 8) "}", 4,
        "tensor 'a': data_offsets [0, 8] run past the 4-byte data region");
    BAD("hole.safetensors", "{" T("a", "F32", "[1]", 0, 4) "," T("b", "F32", "[1]", 8, 12) "}",
        12, "hole of 4 bytes between tensors 'a' and 'b'");
    BAD("hole0.safetensors", "{" T("a", "F32", "[1]", 4, 8) "}", 8, "hole of 4 bytes before tensor 'a'");
    BAD("tail.safetensors", "{" T("a", "F32", "[1]", 0, 4) "}", 6,
        "2 bytes after the last tensor are not covered");
    BAD("size.safetensors", "{" T("a", "F32", "[3]", 0, 8) "}", 8,
        "tensor 'a': data_offsets [0, 8] hold 8 bytes but F32 [3] needs 12");
    BAD("dtype.safetensors", "{" T("a", "F33", "[1]", 0, 4) "}", 4, "tensor 'a': unknown dtype F33");
    BAD("dtype_type.safetensors", "{\"a\":{\"dtype\":7,\"shape\":[],\"data_offsets\":[0,1]}}", 1,
        "unknown dtype");
    BAD("duplicate.safetensors", "{" T("a", "F32", "[1]", 0, 4) "," T("a", "F32", "[1]", 4, 8) "}",
        8, "tensor name 'a' appears twice");
    BAD("meta_type.safetensors", "{\"__metadata__\":{\"n\":5}}", 0,
        "metadata value of 'n' is not a string");
    BAD("meta_obj.safetensors", "{\"__metadata__\":[\"a\"]}", 0, "\"__metadata__\" is not an object");
    BAD("meta_dup.safetensors", "{\"__metadata__\":{\"k\":\"1\",\"k\":\"2\"}}", 0,
        "metadata key 'k' appears twice");
    BAD("meta_twice.safetensors", "{\"__metadata__\":{},\"__metadata__\":{}}", 0,
        "\"__metadata__\" appears twice");
    BAD("reversed.safetensors", "{" T("a", "U8", "[0]", 8, 4) "}", 8, "end before they begin");
    BAD("negative.safetensors", "{" T("a", "U8", "[-1]", 0, 0) "}", 0, "non-negative integers");
    BAD("fraction.safetensors", "{" T("a", "U8", "[2.5]", 0, 2) "}", 2, "non-negative integers");
    BAD("rank9.safetensors", "{" T("a", "U8", "[1,1,1,1,1,1,1,1,1]", 0, 1) "}", 1,
        "more than 8 dimensions");
    BAD("noshape.safetensors", "{\"a\":{\"dtype\":\"U8\",\"data_offsets\":[0,1]}}", 1,
        "tensor 'a': missing \"shape\"");
    BAD("offsets3.safetensors", "{\"a\":{\"dtype\":\"U8\",\"shape\":[1],\"data_offsets\":[0,1,2]}}",
        1, "\"data_offsets\" must be two non-negative integers");
    BAD("field_twice.safetensors",
        "{\"a\":{\"dtype\":\"U8\",\"dtype\":\"U8\",\"shape\":[1],\"data_offsets\":[0,1]}}", 1,
        "field \"dtype\" appears twice");
    BAD("entry.safetensors", "{\"a\":[1]}", 0, "tensor 'a': entry is not an object");
    BAD("f4.safetensors", "{" T("a", "F4", "[3]", 0, 2) "}", 2, "not a whole number of bytes");
    BAD("overflow.safetensors", "{" T("a", "F64", "[4294967296,4294967296]", 0, 0) "}", 0,
        "overflows");
    BAD("utf8.safetensors", "{\"\xc3\x28\":{}}", 0, "not valid UTF-8");
    BAD("overlong.safetensors", "{\"\xc0\xaf\":{}}", 0, "not valid UTF-8");
    BAD("control.safetensors", "{\"a\x01\":{}}", 0, "raw control byte 0x01");
    char deep[300];
    memset(deep, '[', 100);
    memset(deep + 100, ']', 100);
    deep[200] = '\0';
    BAD("deep.safetensors", deep, 0, "nests deeper than");

    /* a good file cut short by one byte */
    float v[4] = {1, 2, 3, 4};
    int64_t four = 4;
    gv_st_builder b;
    gv_st_builder_init(&b);
    CHECK(gv_st_add_f32(&b, "w", GV_ST_F32, &four, 1, v) == 0);
    CHECK(gv_st_write(&b, tmp_file(path, "cut.safetensors")) == 0);
    gv_st_builder_free(&b);
    struct stat st;
    CHECK(stat(path, &st) == 0 && st.st_size == 8 + 56 + 16);  /* 55-byte JSON padded to 56 */
    CHECK(truncate(path, 8 + 56 + 15) == 0);
    CHECK_OPEN_FAILS(path, "run past the 15-byte data region (truncated file?)");
    CHECK(truncate(path, 40) == 0);
    CHECK_OPEN_FAILS(path, "runs past the end of the 40-byte file");
#undef BAD
#undef T
}

/* ---- the builder's own checks ------------------------------------------------------------ */

static void test_builder_errors(void)
{
    char path[4200];
    float v[2] = {1, 2};
    int64_t two = 2, negative = -1, nine[9] = {1, 1, 1, 1, 1, 1, 1, 1, 1};
    gv_st_builder b;
    gv_st_builder_init(&b);
    CHECK_FAILS_WITH(gv_st_add_f32(&b, "x", GV_ST_U8, &two, 1, v), "stored as F32, BF16 or F16");
    CHECK_FAILS_WITH(gv_st_add_f32(&b, "x", GV_ST_F32, nine, 9, v), "rank 9");
    CHECK_FAILS_WITH(gv_st_add_f32(&b, "x", GV_ST_F32, &negative, 1, v), "negative dimension");
    CHECK_FAILS_WITH(gv_st_add_f32(&b, "__metadata__", GV_ST_F32, &two, 1, v), "reserved");
    CHECK_FAILS_WITH(gv_st_add_f32(&b, "", GV_ST_F32, &two, 1, v), "empty tensor name");
    CHECK_FAILS_WITH(gv_st_add_f32(&b, "bad\xff", GV_ST_F32, &two, 1, v), "not valid UTF-8");
    CHECK_FAILS_WITH(gv_st_add_raw(&b, "x", GV_ST_F4, &two, 1, v), "cannot write dtype F4");
    CHECK_FAILS_WITH(gv_st_add_f32(&b, "x", GV_ST_F32, &two, 1, NULL), "no data");
    CHECK_FAILS_WITH(gv_st_add_metadata(&b, "k", "\xe2\x82"), "not valid UTF-8");
    CHECK(b.n_tensors == 0 && b.n_metadata == 0);

    /* duplicates are refused at write time, and nothing is left on disk */
    CHECK(gv_st_add_f32(&b, "x", GV_ST_F32, &two, 1, v) == 0);
    CHECK(gv_st_add_f32(&b, "x", GV_ST_BF16, &two, 1, v) == 0);
    tmp_file(path, "dup.safetensors");
    CHECK_FAILS_WITH(gv_st_write(&b, path), "tensor name 'x' appears twice");
    CHECK(strstr(gv_last_error(), path) != NULL);
    CHECK(!gv_file_exists(path));
    gv_st_builder_free(&b);

    gv_st_builder_init(&b);
    CHECK(gv_st_add_metadata(&b, "k", "1") == 0 && gv_st_add_metadata(&b, "k", "2") == 0);
    CHECK_FAILS_WITH(gv_st_write(&b, path), "metadata key 'k' appears twice");
    gv_st_builder_free(&b);

    gv_st_builder_init(&b);
    CHECK(gv_st_add_f32(&b, "x", GV_ST_F32, &two, 1, v) == 0);
    CHECK_FAILS_WITH(gv_st_write(&b, tmp_file(path, "no/such/dir/x.safetensors")), "no/such/dir");
    gv_st_builder_free(&b);

    /* rewriting a file replaces it whole, and no temporary file is left behind */
    float w[3] = {7, 8, 9};
    int64_t three = 3;
    tmp_file(path, "rewrite.safetensors");
    gv_st_builder_init(&b);
    CHECK(gv_st_add_f32(&b, "old", GV_ST_F32, &two, 1, v) == 0);
    CHECK(gv_st_write(&b, path) == 0);
    gv_st_builder_free(&b);
    gv_st_builder_init(&b);
    CHECK(gv_st_add_f32(&b, "new", GV_ST_F16, &three, 1, w) == 0);
    CHECK(gv_st_write(&b, path) == 0);
    gv_st_builder_free(&b);
    gv_st_file f;
    float back[3] = {0};
    CHECK(gv_st_open(&f, path) == 0);
    CHECK(f.n_tensors == 1 && gv_st_find(&f, "old") == NULL);
    CHECK(gv_st_read_f32(&f, "new", back, &three, 1) == 0 && back[0] == 7 && back[2] == 9);
    gv_st_close(&f);
    char command[8600];
    snprintf(command, sizeof command, "ls '%s' | grep -q tmp", tmp);
    CHECK(system(command) != 0);
}

int main(void)
{
    tmp = check_tmp_dir();
    test_f16_known_values();
    test_bf16_known_values();
    test_conversions_against_reference();
    test_canonical_bytes();
    test_round_trip();
    test_hand_written();
    test_malformed();
    test_builder_errors();
    return check_summary();
}
