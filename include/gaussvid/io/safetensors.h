/* safetensors files (the huggingface/safetensors format): an 8-byte little-endian header
 * length N, N bytes of UTF-8 JSON giving each tensor's dtype, shape and data_offsets (plus an
 * optional "__metadata__" object of strings), then the raw little-endian tensor bytes.
 * Model weights, checkpoints and dataset clips all use it (docs/SAFETENSORS.md).
 *
 * Reading maps the file read-only and checks it as strictly as the reference reader does;
 * writing produces the reference writer's canonical layout, so the Python `safetensors`
 * package reads our files and we read its files. */
#ifndef GAUSSVID_SAFETENSORS_H
#define GAUSSVID_SAFETENSORS_H

#include <stddef.h>
#include <stdint.h>

/* Element types, in the reference's declaration order (increasing alignment): the writer
 * stores tensors by this order, descending, as the reference writer does. */
typedef enum {
    GV_ST_BOOL, GV_ST_F4, GV_ST_F6_E2M3, GV_ST_F6_E3M2, GV_ST_U8, GV_ST_I8, GV_ST_F8_E5M2,
    GV_ST_F8_E4M3, GV_ST_F8_E8M0, GV_ST_F8_E4M3FNUZ, GV_ST_F8_E5M2FNUZ, GV_ST_I16, GV_ST_U16,
    GV_ST_F16, GV_ST_BF16, GV_ST_I32, GV_ST_U32, GV_ST_F32, GV_ST_C64, GV_ST_F64, GV_ST_I64,
    GV_ST_U64, GV_ST_N_DTYPES
} gv_st_dtype;

#define GV_ST_MAX_RANK 8
/* The reference's MAX_HEADER_SIZE: longer headers are refused by every reader. */
#define GV_ST_MAX_HEADER 100000000

/* One tensor of an open file. `data` points into the read-only mapping; it is aligned to
 * the element size when the writer aligned it (ours and the reference's do), so copy with
 * memcpy when reading files of unknown origin through wider types. */
typedef struct {
    const char *name;
    gv_st_dtype dtype;
    int rank;
    int64_t shape[GV_ST_MAX_RANK];
    int64_t n_elements;
    uint64_t begin, end;    /* data_offsets: bytes [begin, end) of the data region */
    const void *data;
} gv_st_tensor;

/* An open file. The public fields are read-only; tensors are in file (offset) order and
 * metadata in header order. */
typedef struct {
    char *path;
    int n_tensors;
    gv_st_tensor *tensors;
    int n_metadata;
    const char **metadata_keys, **metadata_values;
    uint64_t file_size, header_size, data_size;
    /* private */
    const uint8_t *map;
    int *by_name;           /* tensor indices sorted by name, for lookup */
    char *strings;          /* names, keys and values */
    /* Readers of the other release formats (a sharded index, a PyTorch zip: weight_files.h)
     * present their tensors through this struct; gv_st_close hands what they own back. */
    void *owner;
    void (*release)(void *owner);
} gv_st_file;

/* ---- dtypes ------------------------------------------------------------------------- */
/* The format's name of a dtype ("F32", "BF16", ...). */
const char *gv_st_dtype_name(gv_st_dtype dtype);
/* The dtype of a name, or -1 when the name is not a safetensors dtype. */
int gv_st_dtype_from_name(const char *name);
/* Bits per element (4 and 6 for the packed microscaling types, else 8 to 64). */
int gv_st_dtype_bits(gv_st_dtype dtype);
/* IEEE half <-> float32; the narrowing rounds to nearest even, overflows to infinity and
 * keeps NaN a (quiet) NaN. */
float gv_f16_to_f32(uint16_t h);
uint16_t gv_f32_to_f16(float x);
/* bfloat16 <-> float32, with the same rounding rules. */
float gv_bf16_to_f32(uint16_t b);
uint16_t gv_f32_to_bf16(float x);

/* ---- reading ------------------------------------------------------------------------ */
/* Maps and checks a file: header length, JSON, dtypes, shapes, offsets (contiguous, no
 * overlap, no hole, covering the data exactly), unique names, string metadata. */
int gv_st_open(gv_st_file *f, const char *path);
/* Opens the shards of a sharded checkpoint's "*.safetensors.index.json" (its "weight_map"
 * names the shard of every tensor; relative to the index's folder) as one file: every tensor
 * of the weight map must be in the shard it names, and every tensor of a shard in the map
 * under that shard. Metadata: the shards' "__metadata__", the first shard's value winning.
 * docs/SAFETENSORS.md ("Sharded checkpoints"). */
int gv_st_index_open(gv_st_file *f, const char *path);
/* Hands every byte of an open file, in order, to each(ctx, bytes, n) in pieces of at most
 * GV_ST_STREAM_PIECE bytes read through its mapping; each piece's pages are released after it
 * (the resident memory stays one piece whatever the file's size). Stops at the first nonzero
 * return of each and returns it. Fails for a file another reader presents (a shard index, a
 * PyTorch zip). */
#define GV_ST_STREAM_PIECE (16u << 20)
int gv_st_stream(const gv_st_file *f, int (*each)(void *ctx, const void *bytes, size_t n), void *ctx);
/* Unmaps and frees; safe on a zeroed or failed handle. */
void gv_st_close(gv_st_file *f);
/* The tensor of that name, or NULL (no message) when there is none. */
const gv_st_tensor *gv_st_find(const gv_st_file *f, const char *name);
/* The metadata value of that key, or NULL when there is none. */
const char *gv_st_metadata(const gv_st_file *f, const char *key);
/* Finds a tensor and checks it against the caller's expectation: dtype (-1: any) and shape
 * (rank -1: any; rank 0: a scalar). A miss or mismatch fails with one line naming the file,
 * the tensor, and the expected and found dtype and shape. */
int gv_st_get(const gv_st_file *f, const char *name, int dtype, const int64_t *shape, int rank,
              const gv_st_tensor **out);
/* Reads a F32, F16, BF16 or F64 tensor of the expected shape (rank -1: any; then dst must
 * hold the tensor's n_elements) into float32. Parallel over elements. */
int gv_st_read_f32(const gv_st_file *f, const char *name, float *dst, const int64_t *shape,
                   int rank);
/* Copies the raw little-endian bytes of a tensor of the expected dtype and shape. */
int gv_st_read_raw(const gv_st_file *f, const char *name, gv_st_dtype dtype,
                   const int64_t *shape, int rank, void *dst);
/* Converts any F32, F16, BF16 or F64 tensor into t->n_elements floats. */
int gv_st_tensor_to_f32(const gv_st_file *f, const gv_st_tensor *t, float *dst);
/* The pages of a mapped tensor's bytes leave the resident set (a read-only file mapping
 * reads them back when touched again); nothing for a tensor not in a mapping. */
void gv_st_tensor_drop_pages(const gv_st_tensor *t);
/* Formats a shape as "[2, 3]" into out (size bytes) and returns out. */
const char *gv_st_shape_str(char *out, size_t size, const int64_t *shape, int rank);

/* ---- writing ------------------------------------------------------------------------ */
/* Collects tensors and metadata, then writes them in one go. Tensor data is not copied: it
 * must stay valid until gv_st_write. Names, shapes and metadata are copied. */
struct gv_st_entry;
typedef struct {
    int n_tensors, cap_tensors;
    struct gv_st_entry *tensors;
    int n_metadata, cap_metadata;
    char **metadata_keys, **metadata_values;
    /* Set when the raw data added lives in read-only file mappings (a release being
     * re-packaged): each tensor's pages leave the resident set once written, so writing a
     * file larger than memory keeps one tensor resident at a time. */
    int drop_source_pages;
} gv_st_builder;
void gv_st_builder_init(gv_st_builder *b);
void gv_st_builder_free(gv_st_builder *b);
/* Adds float32 values to be stored as F32, BF16 or F16 (converted when written). */
int gv_st_add_f32(gv_st_builder *b, const char *name, gv_st_dtype dtype, const int64_t *shape,
                  int rank, const float *data);
/* Adds bytes already in the dtype's little-endian layout (U8, I32, I64, BOOL, F64, ...). */
int gv_st_add_raw(gv_st_builder *b, const char *name, gv_st_dtype dtype, const int64_t *shape,
                  int rank, const void *data);
/* Adds a tensor whose bytes are made when the file is written, one tensor at a time:
 * produce(ctx, dst, n_bytes) fills dst with the tensor's n_bytes little-endian bytes and
 * returns 0, or fails (gv_fail) and returns -1, which fails the write. So a file of tensors
 * computed from others (a LoRA fused into a base) never holds more than one in memory. */
typedef int (*gv_st_produce_fn)(void *ctx, void *dst, uint64_t n_bytes);
int gv_st_add_produced(gv_st_builder *b, const char *name, gv_st_dtype dtype, const int64_t *shape,
                       int rank, gv_st_produce_fn produce, void *ctx);
/* Adds a "__metadata__" entry (both strings are copied). */
int gv_st_add_metadata(gv_st_builder *b, const char *key, const char *value);
/* Writes the file atomically (temporary name + rename) in the canonical layout: tensors by
 * descending dtype alignment then name, header padded with spaces to a multiple of 8. */
int gv_st_write(const gv_st_builder *b, const char *path);

#endif
