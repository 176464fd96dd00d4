/* Sharded safetensors checkpoints through their index (weight_files.h): two shards with F32,
 * BF16 and F16 tensors whose bytes are written by hand, read back bit for bit as one file;
 * gv_weights_open telling the formats apart; and every disagreement between an index and its
 * shards refused with one line naming the index. */
#include <stdint.h>

#include "check.h"
#include "gaussvid/core/core.h"
#include "gaussvid/io/safetensors.h"
#include "gaussvid/pth/weight_files.h"

static const char *tmp;

static const char *tmp_file(char *out, const char *name)
{
    snprintf(out, 4200, "%s/%s", tmp, name);
    return out;
}

static uint32_t bits_of_float(float x)
{
    uint32_t u;
    memcpy(&u, &x, 4);
    return u;
}

static void write_text(const char *name, const char *text)
{
    char path[4200];
    FILE *f = fopen(tmp_file(path, name), "wb");
    if (!f) { fprintf(stderr, "cannot write %s\n", path); exit(1); }
    fputs(text, f);
    fclose(f);
}

/* BF16 and F16 bit patterns with their float32 values derived by hand:
 * BF16 is the top half of a float32; F16 is sign, 5-bit exponent (bias 15), 10-bit fraction. */
static const uint16_t bf16_bits[] = {0x3f80, 0xc040, 0x7f7f, 0x0001, 0x8000, 0xff80};
static const uint32_t bf16_as_f32[] = {0x3f800000, /* 1 */ 0xc0400000, /* -3 */ 0x7f7f0000, /* 3.3895e38 */
                                       0x00010000, /* subnormal 2^-133 */ 0x80000000, /* -0 */ 0xff800000 /* -inf */};
static const uint16_t f16_bits[] = {0x3c00, 0x7bff, 0x0001, 0x0400, 0xc500, 0x3555};
static const uint32_t f16_as_f32[] = {0x3f800000, /* 1 */ 0x477fe000, /* 65504 */ 0x33800000, /* 2^-24 */
                                      0x38800000, /* 2^-14 */ 0xc0a00000, /* -5 */ 0x3eaaa000 /* 0.333251953125 */};

/* shard 1: a.weight F32 [2, 2], b.bf16 BF16 [6]; shard 2: c.f16 F16 [2, 3] */
static void write_shards(void)
{
    char path[4200];
    static const float a[4] = {1, -2, 0.5f, 4};
    int64_t s22[2] = {2, 2}, s6 = 6, s23[2] = {2, 3};
    gv_st_builder b;
    gv_st_builder_init(&b);
    CHECK(gv_st_add_f32(&b, "a.weight", GV_ST_F32, s22, 2, a) == 0);
    CHECK(gv_st_add_raw(&b, "b.bf16", GV_ST_BF16, &s6, 1, bf16_bits) == 0);
    CHECK(gv_st_add_metadata(&b, "format", "pt") == 0);
    CHECK(gv_st_write(&b, tmp_file(path, "model-00001-of-00002.safetensors")) == 0);
    gv_st_builder_free(&b);
    gv_st_builder_init(&b);
    CHECK(gv_st_add_raw(&b, "c.f16", GV_ST_F16, s23, 2, f16_bits) == 0);
    CHECK(gv_st_add_metadata(&b, "format", "other") == 0);
    CHECK(gv_st_add_metadata(&b, "note", "second") == 0);
    CHECK(gv_st_write(&b, tmp_file(path, "model-00002-of-00002.safetensors")) == 0);
    gv_st_builder_free(&b);
}

#define SHARD1 "\"model-00001-of-00002.safetensors\""
#define SHARD2 "\"model-00002-of-00002.safetensors\""

static void test_good_index(void)
{
    char path[4200];
    write_shards();
    write_text("model.safetensors.index.json",
               "{\"metadata\": {\"total_size\": 36},\n \"weight_map\": {\"c.f16\": " SHARD2 ", \"a.weight\": " SHARD1
               ", \"b.bf16\": " SHARD1 "}}\n");
    gv_st_file f;
    CHECK(gv_weights_open(&f, tmp_file(path, "model.safetensors.index.json")) == 0);
    CHECK(f.n_tensors == 3);
    CHECK(!strcmp(f.path, path));
    float a[4], b[6], c[6];
    int64_t s22[2] = {2, 2}, s6 = 6, s23[2] = {2, 3};
    CHECK(gv_st_read_f32(&f, "a.weight", a, s22, 2) == 0 && a[1] == -2 && a[3] == 4);
    CHECK(gv_st_read_f32(&f, "b.bf16", b, &s6, 1) == 0);
    CHECK(gv_st_read_f32(&f, "c.f16", c, s23, 2) == 0);
    for (int i = 0; i < 6; i++) {
        CHECK(bits_of_float(b[i]) == bf16_as_f32[i]);
        CHECK(bits_of_float(c[i]) == f16_as_f32[i]);
    }
    CHECK(gv_st_find(&f, "nothing") == NULL);
    CHECK_FAILS_WITH(gv_st_read_f32(&f, "c.f16", c, &s6, 1), "model.safetensors.index.json: tensor 'c.f16'");
    /* metadata of all shards, the first shard's value winning */
    CHECK(gv_st_metadata(&f, "format") && !strcmp(gv_st_metadata(&f, "format"), "pt"));
    CHECK(gv_st_metadata(&f, "note") && !strcmp(gv_st_metadata(&f, "note"), "second"));
    gv_st_close(&f);

    /* a safetensors file still opens as itself */
    CHECK(gv_weights_open(&f, tmp_file(path, "model-00002-of-00002.safetensors")) == 0 && f.n_tensors == 1);
    gv_st_close(&f);
    /* an index with leading whitespace is still recognised */
    write_text("spaced.index.json", "\n  {\"weight_map\": {\"c.f16\": " SHARD2 "}}");
    CHECK(gv_weights_open(&f, tmp_file(path, "spaced.index.json")) == 0 && f.n_tensors == 1);
    gv_st_close(&f);
}

/* gv_weights_open of an index with this text must fail naming the index and `needle`. */
static void check_index_fails(const char *text, const char *needle, int line)
{
    char path[4200];
    write_text("bad.index.json", text);
    tmp_file(path, "bad.index.json");
    gv_st_file f;
    gv_clear_error();
    int rc = gv_weights_open(&f, path);
    const char *msg = gv_last_error();
    if (rc != 0 && strstr(msg, path) && strstr(msg, needle) && !strchr(msg, '\n')) {
        check_passed++;
    } else {
        check_failed++;
        fprintf(stderr, "line %d: expected the index to fail mentioning '%s'; got rc %d, '%s'\n", line, needle, rc, msg);
    }
    if (rc == 0) gv_st_close(&f);
}
#define CHECK_INDEX_FAILS(text, needle) check_index_fails(text, needle, __LINE__)

static void test_bad_index(void)
{
    CHECK_INDEX_FAILS("{\"weight_map\": {\"a.weight\": " SHARD1 ", \"b.bf16\": " SHARD2 ", \"c.f16\": " SHARD2 "}}",
                      "shard model-00001-of-00002.safetensors holds tensor 'b.bf16', which the index maps to "
                      "model-00002-of-00002.safetensors");
    CHECK_INDEX_FAILS("{\"weight_map\": {\"a.weight\": " SHARD1 ", \"c.f16\": " SHARD2 "}}",
                      "holds tensor 'b.bf16', which the index does not list");
    CHECK_INDEX_FAILS("{\"weight_map\": {\"a.weight\": " SHARD1 ", \"b.bf16\": " SHARD1 ", \"c.f16\": " SHARD2
                      ", \"d\": " SHARD2 "}}",
                      "tensor 'd' is mapped to shard model-00002-of-00002.safetensors, which does not hold it");
    CHECK_INDEX_FAILS("{\"weight_map\": {\"a.weight\": \"absent.safetensors\"}}", "absent.safetensors: cannot open");
    CHECK_INDEX_FAILS("{\"weight_map\": {\"a.weight\": \"../x.safetensors\"}}", "leaves the index's folder");
    CHECK_INDEX_FAILS("{\"weight_map\": {\"a.weight\": \"sub/../../x\"}}", "leaves the index's folder");
    CHECK_INDEX_FAILS("{\"weight_map\": {\"a.weight\": \"/etc/passwd\"}}", "is an absolute path");
    CHECK_INDEX_FAILS("{\"weight_map\": {\"a.weight\": 3}}", "weight_map entry 'a.weight' is not a file name");
    CHECK_INDEX_FAILS("{\"weight_map\": {\"a.weight\": \"\"}}", "mapped to an empty file name");
    CHECK_INDEX_FAILS("{\"weight_map\": {}}", "the weight_map is empty");
    CHECK_INDEX_FAILS("{\"metadata\": {}}", "no \"weight_map\" object");
    CHECK_INDEX_FAILS("{\"weight_map\": {\"a.weight\": " SHARD1 ", \"a.weight\": " SHARD1 "}}",
                      "tensor 'a.weight' is listed twice");
    CHECK_INDEX_FAILS("{\"weight_map\": ", "not a JSON object");
    CHECK_INDEX_FAILS("{} trailing", "not a JSON object");
    /* a shard that is itself malformed: its own message, prefixed by the index */
    char path[4200];
    FILE *f = fopen(tmp_file(path, "broken.safetensors"), "wb");
    if (f) fwrite("\x10\0\0\0\0\0\0\0{}", 1, 10, f), fclose(f);
    CHECK_INDEX_FAILS("{\"weight_map\": {\"a\": \"broken.safetensors\"}}", "broken.safetensors: header length 16");
}

int main(void)
{
    tmp = check_tmp_dir();
    test_good_index();
    test_bad_index();
    return check_summary();
}
