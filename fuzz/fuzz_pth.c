/* PyTorch zip checkpoints (.pth, docs/PTH.md) opened by gv_weights_open, as every weight
 * loader and `model import` open them, then every tensor read (fuzz_weights.h). The first
 * byte picks how the rest becomes the file:
 *   0: the rest is the file itself (the zip reader: end record, ZIP64, central and local
 *      headers, methods; then the pickle and storages inside);
 *   1, 2, 3: the rest is data.pkl, then the storages data/0, data/1, ... separated by
 *      "#PIECE#", and the harness packs them into a well-formed archive (1 stored, 2 stored
 *      with the data aligned to 64 bytes as torch.save aligns it, 3 deflated), so that a
 *      change to the pickle reaches the unpickler instead of failing the CRC-32. */
#include <zlib.h>

#include "fuzz_weights.h"
#include "gaussvid/pth/weight_files.h"

enum { MAX_STORAGES = 16, MAX_ENTRIES = MAX_STORAGES + 2 };

typedef struct {
    uint8_t *bytes;
    size_t size, cap;
} buffer;

static void put(buffer *b, const void *data, size_t n)
{
    if (b->size + n > b->cap) {
        b->cap = (b->size + n) * 2 + 256;
        if (!(b->bytes = realloc(b->bytes, b->cap))) abort();
    }
    if (n) memcpy(b->bytes + b->size, data, n);
    b->size += n;
}

static void put_le(buffer *b, uint64_t v, int n)
{
    uint8_t le[8];
    for (int k = 0; k < n; k++) le[k] = (uint8_t)(v >> (8 * k));
    put(b, le, (size_t)n);
}

/* Raw deflate (zip method 8) of n bytes into a new buffer. */
static uint8_t *deflate_raw(const uint8_t *data, size_t n, size_t *out_n)
{
    z_stream s;
    memset(&s, 0, sizeof s);
    if (deflateInit2(&s, 6, Z_DEFLATED, -MAX_WBITS, 8, Z_DEFAULT_STRATEGY) != Z_OK) abort();
    size_t cap = deflateBound(&s, (uLong)n) + 16;
    uint8_t *out = malloc(cap);
    if (!out) abort();
    s.next_in = (Bytef *)(uintptr_t)data, s.avail_in = (uInt)n;
    s.next_out = out, s.avail_out = (uInt)cap;
    if (deflate(&s, Z_FINISH) != Z_STREAM_END) abort();
    *out_n = s.total_out;
    deflateEnd(&s);
    return out;
}

typedef struct {
    char name[32];
    const uint8_t *data;
    size_t size;
} entry;

/* A zip archive of the entries as torch.save writes one (version 2.0, no data descriptors). */
static void pack(buffer *zip, const entry *e, int n, int mode)
{
    uint64_t offsets[MAX_ENTRIES];
    uint32_t crcs[MAX_ENTRIES];
    size_t stored[MAX_ENTRIES];
    uint8_t *deflated[MAX_ENTRIES] = {0};
    for (int i = 0; i < n; i++) {
        const uint8_t *data = e[i].data;
        stored[i] = e[i].size;
        crcs[i] = (uint32_t)crc32(0L, data, (uInt)e[i].size);
        if (mode == 3) data = deflated[i] = deflate_raw(e[i].data, e[i].size, &stored[i]);
        size_t name_len = strlen(e[i].name);
        /* mode 2: an extra field pads the data to 64 bytes, as PyTorch's writer does */
        size_t pad = mode == 2 ? (64 - (zip->size + 30 + name_len + 4) % 64) % 64 : 0;
        offsets[i] = zip->size;
        put_le(zip, 0x04034b50, 4), put_le(zip, 20, 2), put_le(zip, 0, 2), put_le(zip, mode == 3 ? 8 : 0, 2);
        put_le(zip, 0, 4), put_le(zip, crcs[i], 4), put_le(zip, stored[i], 4), put_le(zip, e[i].size, 4);
        put_le(zip, name_len, 2), put_le(zip, mode == 2 ? pad + 4 : 0, 2);
        put(zip, e[i].name, name_len);
        if (mode == 2) {
            put_le(zip, 0x4246, 2), put_le(zip, pad, 2);
            for (size_t k = 0; k < pad; k++) put(zip, "Z", 1);
        }
        put(zip, data, stored[i]);
    }
    uint64_t directory = zip->size;
    for (int i = 0; i < n; i++) {
        size_t name_len = strlen(e[i].name);
        put_le(zip, 0x02014b50, 4), put_le(zip, 20, 2), put_le(zip, 20, 2), put_le(zip, 0, 2);
        put_le(zip, mode == 3 ? 8 : 0, 2), put_le(zip, 0, 4), put_le(zip, crcs[i], 4), put_le(zip, stored[i], 4);
        put_le(zip, e[i].size, 4), put_le(zip, name_len, 2), put_le(zip, 0, 2), put_le(zip, 0, 2);
        put_le(zip, 0, 2), put_le(zip, 0, 2), put_le(zip, 0, 4), put_le(zip, offsets[i], 4);
        put(zip, e[i].name, name_len);
        free(deflated[i]);
    }
    uint64_t directory_size = zip->size - directory;
    put_le(zip, 0x06054b50, 4), put_le(zip, 0, 2), put_le(zip, 0, 2), put_le(zip, (uint64_t)n, 2);
    put_le(zip, (uint64_t)n, 2), put_le(zip, directory_size, 4), put_le(zip, directory, 4), put_le(zip, 0, 2);
}

static int fuzz_one(const uint8_t *data, size_t size)
{
    if (size < 1) return 0;
    int mode = data[0] % 4;
    const char *path;
    if (mode == 0) {
        path = fuzz_file("weights.pth", data + 1, size - 1);
    } else {
        fuzz_piece pieces[MAX_STORAGES + 1];
        int n = fuzz_split(data + 1, size - 1, pieces, MAX_STORAGES + 1);
        entry e[MAX_ENTRIES];
        int k = 0;
        e[k++] = (entry){"archive/data.pkl", pieces[0].data, pieces[0].size};
        e[k++] = (entry){"archive/byteorder", (const uint8_t *)"little", 6};
        for (int i = 1; i < n; i++) {
            e[k] = (entry){"", pieces[i].data, pieces[i].size};
            snprintf(e[k].name, sizeof e[k].name, "archive/data/%d", i - 1);
            k++;
        }
        buffer zip = {0};
        pack(&zip, e, k, mode);
        path = fuzz_file("weights.pth", zip.bytes, zip.size);
        free(zip.bytes);
    }
    gv_st_file f;
    gv_clear_error();
    int rc = gv_weights_open(&f, path);
    fuzz_check_failure(rc, "weights.pth");
    if (rc) return fuzz_report(rc, NULL), 0;
    fuzz_read_tensors(&f, "weights.pth");
    char what[64];
    snprintf(what, sizeof what, "opened: %d tensors", f.n_tensors);
    fuzz_report(0, what);
    gv_st_close(&f);
    return 0;
}
