/* PyTorch zip checkpoints (weight_files.h, docs/PTH.md): pickles and zip archives assembled
 * here byte by byte, as torch.save writes them (protocol 2 with BINPUT/BINGET memo, and the
 * protocol-4 forms FRAME, SHORT_BINUNICODE, STACK_GLOBAL, MEMOIZE; stored, deflated and ZIP64
 * archives), read back exactly: contiguous tensors, a tensor at an offset of a shared
 * storage, a transposed view gathered, BF16 and F16 bit patterns. Then every kind of bad
 * input is refused with one line naming the file and the problem: a global outside the
 * allowed set, opcodes that build other objects, truncated archives at every length, a
 * storage shorter than its tensor, absurd sizes, corrupt data; and mutated pickles never
 * crash the reader (this program also runs under ASan/UBSan). */
#include <stdint.h>
#include <zlib.h>

#include "check.h"
#include "gaussvid/core/core.h"
#include "gaussvid/io/safetensors.h"
#include "gaussvid/pth/weight_files.h"
#include "pth/pickle_internal.h"
#include "pth/zip_internal.h"

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

/* ---- a pickle assembler ------------------------------------------------------------------ */

typedef struct {
    uint8_t b[1 << 14];
    size_t n;
    int proto4;   /* protocol-4 encodings: SHORT_BINUNICODE, STACK_GLOBAL, MEMOIZE */
    int memo;     /* next memo index */
    int rebuild_memo; /* memo index of the _rebuild_tensor_v2 global, or -1 */
} pk;

static void byte(pk *p, uint8_t c) { p->b[p->n++] = c; }
static void le(pk *p, uint64_t v, int n) { for (int k = 0; k < n; k++) byte(p, (uint8_t)(v >> (8 * k))); }

static void put_memo(pk *p)
{
    if (p->proto4) byte(p, 0x94);
    else byte(p, 'q'), byte(p, (uint8_t)p->memo);
    p->memo++;
}

static void str(pk *p, const char *s)
{
    size_t len = strlen(s);
    if (p->proto4 && len < 256) byte(p, 0x8c), byte(p, (uint8_t)len);
    else byte(p, 'X'), le(p, len, 4);
    memcpy(p->b + p->n, s, len);
    p->n += len;
}

static void integer(pk *p, int64_t v)
{
    if (v >= 0 && v < 256) byte(p, 'K'), byte(p, (uint8_t)v);
    else if (v >= 0 && v < 65536) byte(p, 'M'), le(p, (uint64_t)v, 2);
    else if (v >= INT32_MIN && v <= INT32_MAX) byte(p, 'J'), le(p, (uint64_t)v, 4);
    else byte(p, 0x8a), byte(p, 8), le(p, (uint64_t)v, 8);
}

static void global(pk *p, const char *module, const char *name)
{
    if (p->proto4) {
        str(p, module);
        str(p, name);
        byte(p, 0x93);
    } else {
        byte(p, 'c');
        memcpy(p->b + p->n, module, strlen(module)), p->n += strlen(module), byte(p, '\n');
        memcpy(p->b + p->n, name, strlen(name)), p->n += strlen(name), byte(p, '\n');
    }
}

static void start(pk *p, int proto4)
{
    memset(p, 0, sizeof *p);
    p->proto4 = proto4;
    p->rebuild_memo = -1;
    byte(p, 0x80), byte(p, proto4 ? 4 : 2);
    if (proto4) byte(p, 0x95), le(p, 0, 8); /* FRAME: a length hint the reader skips */
    global(p, "collections", "OrderedDict");
    byte(p, ')'), byte(p, 'R');
    put_memo(p);
    byte(p, '(');
}

/* name: _rebuild_tensor_v2(storage, offset, size, stride, False, OrderedDict()) */
static void tensor(pk *p, const char *name, const char *storage_class, const char *key, int64_t numel, int64_t offset,
                   int rank, const int64_t *shape, const int64_t *stride)
{
    str(p, name);
    if (p->rebuild_memo >= 0 && !p->proto4) {
        byte(p, 'h'), byte(p, (uint8_t)p->rebuild_memo); /* BINGET: torch.save reuses the global */
    } else {
        global(p, "torch._utils", "_rebuild_tensor_v2");
        p->rebuild_memo = p->memo;
        put_memo(p);
    }
    byte(p, '(');
    byte(p, '('), str(p, "storage"), global(p, "torch", storage_class), str(p, key), str(p, "cpu"), integer(p, numel);
    byte(p, 't'), byte(p, 'Q');
    integer(p, offset);
    byte(p, '(');
    for (int k = 0; k < rank; k++) integer(p, shape[k]);
    byte(p, 't'), byte(p, '(');
    for (int k = 0; k < rank; k++) integer(p, stride[k]);
    byte(p, 't');
    byte(p, 0x89);
    global(p, "collections", "OrderedDict");
    byte(p, ')'), byte(p, 'R');
    byte(p, 't'), byte(p, 'R');
}

/* SETITEMS, then the state dict's _metadata attribute through BUILD, then STOP. */
static void finish(pk *p)
{
    byte(p, 'u');
    byte(p, '}'), byte(p, '('), str(p, "_metadata"), byte(p, '}'), str(p, "version"), integer(p, 1), byte(p, 's');
    byte(p, 'u'), byte(p, 'b');
    byte(p, '.');
}

/* ---- a zip writer -------------------------------------------------------------------------- */

typedef struct {
    const char *name;
    const void *data;
    size_t n;
    int deflate;
} zentry;

typedef struct {
    uint8_t *b;
    size_t n, cap;
} buf;

static void put(buf *z, const void *p, size_t n)
{
    if (z->n + n > z->cap) {
        z->cap = 2 * (z->n + n) + 1024;
        z->b = realloc(z->b, z->cap);
    }
    memcpy(z->b + z->n, p, n);
    z->n += n;
}

static void put_le(buf *z, uint64_t v, int n)
{
    for (int k = 0; k < n; k++) {
        uint8_t c = (uint8_t)(v >> (8 * k));
        put(z, &c, 1);
    }
}

static size_t deflate_raw(const void *in, size_t n, uint8_t *out, size_t cap)
{
    z_stream s;
    memset(&s, 0, sizeof s);
    deflateInit2(&s, 9, Z_DEFLATED, -MAX_WBITS, 8, Z_DEFAULT_STRATEGY);
    s.next_in = (Bytef *)(uintptr_t)in, s.avail_in = (uInt)n, s.next_out = out, s.avail_out = (uInt)cap;
    deflate(&s, Z_FINISH);
    size_t got = s.total_out;
    deflateEnd(&s);
    return got;
}

/* An archive of the entries; zip64 writes every size and offset in ZIP64 form. */
static buf make_zip(const zentry *e, int n, int zip64)
{
    buf z = {0};
    uint64_t local[32], csize[32];
    uint32_t crc[32];
    static uint8_t packed[32][1 << 14];
    for (int i = 0; i < n; i++) {
        local[i] = z.n;
        crc[i] = (uint32_t)crc32(0, e[i].data, (uInt)e[i].n);
        csize[i] = e[i].deflate ? deflate_raw(e[i].data, e[i].n, packed[i], sizeof packed[i]) : e[i].n;
        put_le(&z, 0x04034b50, 4), put_le(&z, 20, 2), put_le(&z, 0, 2), put_le(&z, e[i].deflate ? 8 : 0, 2);
        put_le(&z, 0, 4), put_le(&z, crc[i], 4), put_le(&z, csize[i], 4), put_le(&z, e[i].n, 4);
        put_le(&z, strlen(e[i].name), 2), put_le(&z, 0, 2), put(&z, e[i].name, strlen(e[i].name));
        put(&z, e[i].deflate ? packed[i] : e[i].data, csize[i]);
    }
    uint64_t dir = z.n;
    for (int i = 0; i < n; i++) {
        put_le(&z, 0x02014b50, 4), put_le(&z, 45, 2), put_le(&z, 45, 2), put_le(&z, 0, 2);
        put_le(&z, e[i].deflate ? 8 : 0, 2), put_le(&z, 0, 4), put_le(&z, crc[i], 4);
        put_le(&z, zip64 ? 0xffffffff : csize[i], 4), put_le(&z, zip64 ? 0xffffffff : e[i].n, 4);
        put_le(&z, strlen(e[i].name), 2), put_le(&z, zip64 ? 28 : 0, 2), put_le(&z, 0, 2), put_le(&z, 0, 2);
        put_le(&z, 0, 2), put_le(&z, 0, 4), put_le(&z, zip64 ? 0xffffffff : local[i], 4);
        put(&z, e[i].name, strlen(e[i].name));
        if (zip64) put_le(&z, 1, 2), put_le(&z, 24, 2), put_le(&z, e[i].n, 8), put_le(&z, csize[i], 8), put_le(&z, local[i], 8);
    }
    uint64_t dir_size = z.n - dir;
    if (zip64) {
        uint64_t at = z.n;
        put_le(&z, 0x06064b50, 4), put_le(&z, 44, 8), put_le(&z, 45, 2), put_le(&z, 45, 2), put_le(&z, 0, 4);
        put_le(&z, 0, 4), put_le(&z, (uint64_t)n, 8), put_le(&z, (uint64_t)n, 8), put_le(&z, dir_size, 8), put_le(&z, dir, 8);
        put_le(&z, 0x07064b50, 4), put_le(&z, 0, 4), put_le(&z, at, 8), put_le(&z, 1, 4);
    }
    put_le(&z, 0x06054b50, 4), put_le(&z, 0, 2), put_le(&z, 0, 2);
    put_le(&z, zip64 ? 0xffff : (uint64_t)n, 2), put_le(&z, zip64 ? 0xffff : (uint64_t)n, 2);
    put_le(&z, zip64 ? 0xffffffff : dir_size, 4), put_le(&z, zip64 ? 0xffffffff : dir, 4), put_le(&z, 0, 2);
    return z;
}

static void write_file(const char *path, const buf *z)
{
    FILE *f = fopen(path, "wb");
    if (!f) { fprintf(stderr, "cannot write %s\n", path); exit(1); }
    fwrite(z->b, 1, z->n, f);
    fclose(f);
}

/* ---- the good checkpoint ---------------------------------------------------------------------- */

/* storage 0: 12 F32 values 0..11; storage 1: 6 BF16 bit patterns; storage 2: 3 F16 ones */
static float s0[12];
static const uint16_t s1[6] = {0x3f80, 0xc040, 0x7f7f, 0x0001, 0x8000, 0xff80};
static const uint32_t s1_f32[6] = {0x3f800000, 0xc0400000, 0x7f7f0000, 0x00010000, 0x80000000, 0xff800000};
static const uint16_t s2[3] = {0x3c00, 0x7bff, 0x3555};
static const uint32_t s2_f32[3] = {0x3f800000, 0x477fe000, 0x3eaaa000};

/* a [2, 3] from storage 0; c [2] at offset 6 of storage 0; t [3, 2] = a transposed (strides
 * 1, 3) of storage 0; b [2, 3] BF16; h [3] F16 */
static void good_pickle(pk *p, int proto4)
{
    start(p, proto4);
    tensor(p, "a", "FloatStorage", "0", 12, 0, 2, (int64_t[]){2, 3}, (int64_t[]){3, 1});
    tensor(p, "b", "BFloat16Storage", "1", 6, 0, 2, (int64_t[]){2, 3}, (int64_t[]){3, 1});
    tensor(p, "c", "FloatStorage", "0", 12, 6, 1, (int64_t[]){2}, (int64_t[]){1});
    tensor(p, "t", "FloatStorage", "0", 12, 0, 2, (int64_t[]){3, 2}, (int64_t[]){1, 3});
    tensor(p, "h", "HalfStorage", "2", 3, 0, 1, (int64_t[]){3}, (int64_t[]){1});
    finish(p);
}

static buf good_zip(const pk *p, int deflate, int zip64)
{
    const zentry e[] = {
        {"ckpt/data.pkl", p->b, p->n, deflate},
        {"ckpt/byteorder", "little", 6, 0},
        {"ckpt/data/0", s0, sizeof s0, deflate},
        {"ckpt/data/1", s1, sizeof s1, 0},
        {"ckpt/data/2", s2, sizeof s2, deflate},
        {"ckpt/version", "3\n", 2, 0},
    };
    return make_zip(e, 6, zip64);
}

static void check_good_file(const char *path)
{
    gv_st_file f;
    int rc = gv_weights_open(&f, path);
    CHECK(rc == 0);
    if (rc) { fprintf(stderr, "%s\n", gv_last_error()); return; }
    CHECK(f.n_tensors == 5);
    float a[6], b[6], c[2], t[6], h[3];
    CHECK(gv_st_read_f32(&f, "a", a, (int64_t[]){2, 3}, 2) == 0);
    CHECK(gv_st_read_f32(&f, "b", b, (int64_t[]){2, 3}, 2) == 0);
    CHECK(gv_st_read_f32(&f, "c", c, (int64_t[]){2}, 1) == 0);
    CHECK(gv_st_read_f32(&f, "t", t, (int64_t[]){3, 2}, 2) == 0);
    CHECK(gv_st_read_f32(&f, "h", h, (int64_t[]){3}, 1) == 0);
    for (int i = 0; i < 6; i++) CHECK(a[i] == (float)i);
    for (int i = 0; i < 6; i++) CHECK(bits_of_float(b[i]) == s1_f32[i]);
    CHECK(c[0] == 6 && c[1] == 7);
    /* t[i][j] = a[j][i] */
    for (int i = 0; i < 3; i++)
        for (int j = 0; j < 2; j++) CHECK(t[i * 2 + j] == a[j * 3 + i]);
    for (int i = 0; i < 3; i++) CHECK(bits_of_float(h[i]) == s2_f32[i]);
    CHECK(gv_st_find(&f, "b")->dtype == GV_ST_BF16 && gv_st_find(&f, "h")->dtype == GV_ST_F16);
    gv_st_close(&f);
}

static void test_good(void)
{
    for (int i = 0; i < 12; i++) s0[i] = (float)i;
    char path[4200];
    for (int variant = 0; variant < 4; variant++) {
        pk p;
        good_pickle(&p, variant & 1);          /* protocol 2 / 4 */
        buf z = good_zip(&p, variant == 2, variant == 3); /* stored / deflated / ZIP64 */
        snprintf(path, sizeof path, "%s/good%d.pth", tmp, variant);
        write_file(path, &z);
        free(z.b);
        check_good_file(path);
    }
}

/* ---- refusals ------------------------------------------------------------------------------- */

static void check_open_fails(const char *path, const char *needle, int line)
{
    gv_st_file f;
    gv_clear_error();
    int rc = gv_weights_open(&f, path);
    const char *msg = gv_last_error();
    if (rc != 0 && strstr(msg, path) && strstr(msg, needle) && !strchr(msg, '\n')) {
        check_passed++;
    } else {
        check_failed++;
        fprintf(stderr, "line %d: expected %s to fail mentioning '%s'; got rc %d, '%s'\n", line, path, needle, rc, msg);
    }
    if (rc == 0) gv_st_close(&f);
}
#define CHECK_OPEN_FAILS(path, needle) check_open_fails(path, needle, __LINE__)

/* A checkpoint of the pickle p with storages as in the good file; returns its path. */
static const char *pth_of(const char *name, const pk *p)
{
    static char path[4200];
    buf z = good_zip(p, 0, 0);
    write_file(tmp_file(path, name), &z);
    free(z.b);
    return path;
}

static void test_refused_pickles(void)
{
    pk p;
    /* a global outside the allowed set: refused at the GLOBAL, before anything uses it */
    start(&p, 0);
    str(&p, "x");
    global(&p, "os", "system");
    str(&p, "echo hi"), byte(&p, 0x85), byte(&p, 'R');
    finish(&p);
    CHECK_OPEN_FAILS(pth_of("global.pth", &p), "global 'os.system' is not accepted");
    start(&p, 1);
    str(&p, "x");
    global(&p, "builtins", "eval");
    CHECK_OPEN_FAILS(pth_of("stack_global.pth", &p), "global 'builtins.eval' is not accepted");
    /* an allowed module with another name */
    start(&p, 0);
    global(&p, "torch._utils", "_rebuild_qtensor");
    CHECK_OPEN_FAILS(pth_of("qtensor.pth", &p), "global 'torch._utils._rebuild_qtensor' is not accepted");
    /* opcodes that build other objects */
    start(&p, 0);
    byte(&p, 'i');
    CHECK_OPEN_FAILS(pth_of("inst.pth", &p), "opcode INST (0x69) is not accepted");
    start(&p, 0);
    byte(&p, ']');
    CHECK_OPEN_FAILS(pth_of("list.pth", &p), "opcode EMPTY_LIST (0x5d) is not accepted");
    start(&p, 0);
    byte(&p, 0xfe);
    CHECK_OPEN_FAILS(pth_of("badop.pth", &p), "0xfe is not a pickle opcode");
    /* REDUCE of a storage class: a storage class is only a persistent id's tag */
    start(&p, 0);
    str(&p, "x"), global(&p, "torch", "FloatStorage"), byte(&p, ')'), byte(&p, 'R');
    CHECK_OPEN_FAILS(pth_of("reduce_storage.pth", &p), "REDUCE calls torch.FloatStorage, which is not one of the accepted");
    /* a value that is not a tensor */
    start(&p, 0);
    str(&p, "epoch"), integer(&p, 3);
    finish(&p);
    CHECK_OPEN_FAILS(pth_of("not_tensor.pth", &p), "entry 'epoch' is an int, not a tensor");
    /* not a dict at all */
    memset(&p, 0, sizeof p);
    byte(&p, 0x80), byte(&p, 2), byte(&p, ')'), byte(&p, '.');
    CHECK_OPEN_FAILS(pth_of("tuple.pth", &p), "the pickle holds a tuple, not a state dict");
    /* no STOP */
    start(&p, 0);
    CHECK_OPEN_FAILS(pth_of("nostop.pth", &p), "the pickle ends 1 bytes early");
    /* a persistent id of another form */
    start(&p, 0);
    str(&p, "x"), str(&p, "storage"), byte(&p, 'Q');
    CHECK_OPEN_FAILS(pth_of("persid.pth", &p), "a persistent id that is not ('storage'");
    /* stack misuse */
    memset(&p, 0, sizeof p);
    byte(&p, 0x80), byte(&p, 2), byte(&p, 'u');
    CHECK_OPEN_FAILS(pth_of("nomark.pth", &p), "no MARK to pop to");
    memset(&p, 0, sizeof p);
    byte(&p, 0x80), byte(&p, 2), byte(&p, 'h'), byte(&p, 7);
    CHECK_OPEN_FAILS(pth_of("memo.pth", &p), "memo index 7 was never stored");
    memset(&p, 0, sizeof p);
    byte(&p, 0x80), byte(&p, 9);
    CHECK_OPEN_FAILS(pth_of("proto.pth", &p), "pickle protocol 9");
}

static void test_absurd_sizes(void)
{
    pk p;
    /* shape whose element count overflows 64 bits */
    start(&p, 0);
    tensor(&p, "huge", "FloatStorage", "0", 12, 0, 3, (int64_t[]){1ll << 40, 1ll << 40, 1ll << 40}, (int64_t[]){0, 0, 0});
    finish(&p);
    CHECK_OPEN_FAILS(pth_of("overflow.pth", &p), "tensor 'huge': shape [1099511627776, 1099511627776, 1099511627776] with its strides overflows");
    /* a stride-0 view of 2^40 elements: fits the storage, but would be a 4 TB copy */
    start(&p, 0);
    tensor(&p, "broadcast", "FloatStorage", "0", 12, 0, 1, (int64_t[]){1ll << 40}, (int64_t[]){0});
    finish(&p);
    CHECK_OPEN_FAILS(pth_of("broadcast.pth", &p), "tensor 'broadcast' [1099511627776] is a view larger than the file");
    /* a size beyond 2^62 */
    start(&p, 0);
    tensor(&p, "neg", "FloatStorage", "0", 12, 0, 1, (int64_t[]){-5}, (int64_t[]){1});
    finish(&p);
    CHECK_OPEN_FAILS(pth_of("negative.pth", &p), "size entry 0 is not a size in [0, 2^62]");
    /* a string length of 4 GB in a small pickle */
    start(&p, 0);
    byte(&p, 'X'), le(&p, 0xfffffff0u, 4);
    CHECK_OPEN_FAILS(pth_of("longstring.pth", &p), "the pickle ends 4294967280 bytes early");
    memset(&p, 0, sizeof p);
    byte(&p, 0x80), byte(&p, 4), byte(&p, 0x8d), le(&p, UINT64_MAX, 8);
    CHECK_OPEN_FAILS(pth_of("longstring8.pth", &p), "bytes early");
    /* a memo index of 2^31 */
    start(&p, 0);
    str(&p, "x"), byte(&p, 'r'), le(&p, 1u << 31, 4);
    CHECK_OPEN_FAILS(pth_of("memo_index.pth", &p), "memo index 2147483648 is beyond the limit");
    /* nine dimensions */
    start(&p, 0);
    tensor(&p, "deep", "FloatStorage", "0", 12, 0, 9, (int64_t[]){1, 1, 1, 1, 1, 1, 1, 1, 1},
           (int64_t[]){1, 1, 1, 1, 1, 1, 1, 1, 1});
    finish(&p);
    CHECK_OPEN_FAILS(pth_of("rank9.pth", &p), "9 dimensions, more than 8");
    /* a storage numel whose byte count overflows */
    start(&p, 0);
    tensor(&p, "big", "DoubleStorage", "0", INT64_MAX, 0, 1, (int64_t[]){2}, (int64_t[]){1});
    finish(&p);
    CHECK_OPEN_FAILS(pth_of("numel.pth", &p), "tensor 'big': storage size 9223372036854775807 overflows");
    /* deep nesting of marks and tuples is bounded by the stack limit, not recursion */
    static pk deep;
    memset(&deep, 0, sizeof deep);
    byte(&deep, 0x80), byte(&deep, 2);
    for (int i = 0; i < 8000; i++) byte(&deep, '(');
    for (int i = 0; i < 8000; i++) byte(&deep, 't');
    byte(&deep, '.');
    CHECK_OPEN_FAILS(pth_of("nested.pth", &deep), "the pickle holds a tuple, not a state dict");
}

static void test_storages(void)
{
    pk p;
    /* a tensor reaching past its storage */
    start(&p, 0);
    tensor(&p, "long", "FloatStorage", "0", 12, 4, 2, (int64_t[]){3, 3}, (int64_t[]){3, 1});
    finish(&p);
    CHECK_OPEN_FAILS(pth_of("past.pth", &p), "tensor 'long' [3, 3] at offset 4 reaches element 12 of storage 0, which has 12 "
                                             "(storage shorter than its tensor)");
    /* a storage file shorter than the pickle says */
    start(&p, 0);
    tensor(&p, "a", "FloatStorage", "0", 20, 0, 1, (int64_t[]){20}, (int64_t[]){1});
    finish(&p);
    CHECK_OPEN_FAILS(pth_of("short.pth", &p), "tensor 'a': storage ckpt/data/0 holds 48 bytes, but the pickle says 20 "
                                              "elements of F32 (80 bytes)");
    /* a storage that is not there */
    start(&p, 0);
    tensor(&p, "a", "FloatStorage", "9", 12, 0, 1, (int64_t[]){12}, (int64_t[]){1});
    finish(&p);
    CHECK_OPEN_FAILS(pth_of("missing.pth", &p), "tensor 'a': its storage ckpt/data/9 is missing");
    /* the same name twice */
    start(&p, 0);
    tensor(&p, "a", "FloatStorage", "0", 12, 0, 1, (int64_t[]){12}, (int64_t[]){1});
    tensor(&p, "a", "FloatStorage", "0", 12, 0, 1, (int64_t[]){12}, (int64_t[]){1});
    finish(&p);
    CHECK_OPEN_FAILS(pth_of("twice.pth", &p), "tensor name 'a' appears twice");
}

static void test_bad_archives(void)
{
    char path[4200];
    pk p;
    good_pickle(&p, 0);
    buf z = good_zip(&p, 0, 0);
    /* truncated at every length: each refused with one line, none crashes */
    int refused = 0;
    for (size_t n = 0; n < z.n; n++) {
        buf cut = {z.b, n, n};
        write_file(tmp_file(path, "cut.pth"), &cut);
        gv_st_file f;
        gv_clear_error();
        int rc = gv_weights_open(&f, path);
        if (rc == 0) gv_st_close(&f);
        refused += rc != 0 && strstr(gv_last_error(), path) && !strchr(gv_last_error(), '\n');
    }
    CHECK(refused == (int)z.n);
    buf cut = {z.b, z.n - 30, 0};
    write_file(tmp_file(path, "cut30.pth"), &cut);
    CHECK_OPEN_FAILS(path, "no zip end-of-central-directory record (truncated file?)");
    /* the data.pkl bytes corrupted: its CRC catches it */
    buf bad = {malloc(z.n), z.n, z.n};
    memcpy(bad.b, z.b, z.n);
    bad.b[30 + 13 + 5] ^= 0x20; /* inside ckpt/data.pkl, after its 30 + 13 byte local header */
    write_file(tmp_file(path, "crc.pth"), &bad);
    CHECK_OPEN_FAILS(path, "entry 'ckpt/data.pkl' does not match its CRC-32");
    free(bad.b);
    free(z.b);

    /* big-endian storages, a zip without a pickle, a legacy checkpoint, an encrypted entry */
    const zentry be[] = {{"ckpt/data.pkl", p.b, p.n, 0}, {"ckpt/byteorder", "big", 3, 0}};
    z = make_zip(be, 2, 0);
    write_file(tmp_file(path, "big.pth"), &z);
    free(z.b);
    CHECK_OPEN_FAILS(path, "ckpt/byteorder is not \"little\"");
    const zentry none[] = {{"model.json", "{}", 2, 0}};
    z = make_zip(none, 1, 0);
    write_file(tmp_file(path, "nopickle.pth"), &z);
    free(z.b);
    CHECK_OPEN_FAILS(path, "a zip archive without <name>/data.pkl: not a PyTorch checkpoint");
    buf legacy = {(uint8_t *)"\x80\x02\x8a\x0a\x6c\xfc\x9c\x46\xf9\x20\x6a\xa8\x50\x19.", 15, 0};
    write_file(tmp_file(path, "legacy.pth"), &legacy);
    CHECK_OPEN_FAILS(path, "legacy (pre-1.6, not zip) format");
    const zentry one[] = {{"ckpt/data.pkl", p.b, p.n, 0}};
    z = make_zip(one, 1, 0);
    z.b[z.n - 22 - 46 - 13 + 8] |= 1; /* the central record's flags: encrypted */
    write_file(tmp_file(path, "encrypted.pth"), &z);
    free(z.b);
    CHECK_OPEN_FAILS(path, "entry 'ckpt/data.pkl' is encrypted");
    /* a directory claiming more entries than it has room for */
    z = make_zip(one, 1, 0);
    z.b[z.n - 22 + 10] = 0xe8, z.b[z.n - 22 + 11] = 0x03; /* 1000 */
    write_file(tmp_file(path, "count.pth"), &z);
    free(z.b);
    CHECK_OPEN_FAILS(path, "the zip directory claims 1000 entries in 59 bytes");
    /* a deflated entry claiming 4 GB */
    const zentry packed[] = {{"ckpt/data.pkl", p.b, p.n, 1}};
    z = make_zip(packed, 1, 0);
    size_t central = z.n - 22 - 46 - 13;
    z.b[central + 24] = 0xfe, z.b[central + 25] = 0xff, z.b[central + 26] = 0xff, z.b[central + 27] = 0xff;
    write_file(tmp_file(path, "bomb.pth"), &z);
    free(z.b);
    CHECK_OPEN_FAILS(path, "entry 'ckpt/data.pkl' has 4294967294 bytes, more than");
}

/* Mutated pickles: every byte flipped in turn and every prefix, straight into the
 * unpickler; each either reads or fails with a message, and never crashes. */
static void test_mutations(void)
{
    pk p;
    good_pickle(&p, 0);
    int ok = 1;
    uint8_t copy[sizeof p.b];
    for (size_t i = 0; i < p.n; i++)
        for (int flip = 0; flip < 3; flip++) {
            memcpy(copy, p.b, p.n);
            copy[i] ^= (uint8_t)(flip == 0 ? 0x01 : flip == 1 ? 0x80 : 0xff);
            gv_pickle_state_dict sd;
            gv_clear_error();
            int rc = gv_pickle_read_state_dict("m", copy, p.n, &sd);
            if (rc) ok &= strncmp(gv_last_error(), "m: ", 3) == 0;
            gv_pickle_state_dict_free(&sd);
        }
    for (size_t n = 0; n < p.n; n++) {
        gv_pickle_state_dict sd;
        ok &= gv_pickle_read_state_dict("m", p.b, n, &sd) != 0;
        gv_pickle_state_dict_free(&sd);
    }
    CHECK(ok);
}

int main(void)
{
    tmp = check_tmp_dir();
    test_good();
    test_refused_pickles();
    test_absurd_sizes();
    test_storages();
    test_bad_archives();
    test_mutations();
    return check_summary();
}
