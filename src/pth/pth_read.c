/* PyTorch zip checkpoints (torch.save since PyTorch 1.6; .pth/.pt): a zip archive whose
 * entries are "<archive>/data.pkl" (the pickled object), "<archive>/data/<key>" (the raw
 * little-endian bytes of each storage), "<archive>/byteorder" and version records. The
 * archive is mapped read-only; data.pkl goes through the bounded state-dict unpickler
 * (pickle.c), and each tensor becomes a gv_st_tensor pointing into its storage's bytes in
 * the mapping, so nothing is copied unless an entry is deflated or a tensor is a
 * non-contiguous view. docs/PTH.md. */
#include <errno.h>
#include <fcntl.h>
#include <inttypes.h>
#include <stdlib.h>
#include <string.h>
#include <sys/mman.h>
#include <sys/stat.h>
#include <unistd.h>

#include "gaussvid/core/core.h"
#include "gaussvid/pth/weight_files.h"
#include "pth/pickle_internal.h"
#include "io/safetensors_internal.h"
#include "pth/zip_internal.h"

/* What a checkpoint's gv_st_file owns besides the mapping: inflated entries and gathered views. */
typedef struct {
    void **buffers;
    int n, cap;
} pth_owner;

static void release_buffers(void *owner)
{
    pth_owner *o = owner;
    for (int i = 0; i < o->n; i++) free(o->buffers[i]);
    free(o->buffers);
    free(o);
}

static int keep(pth_owner *o, void *buffer)
{
    if (!buffer) return 0;
    if (o->n == o->cap) {
        int cap = o->cap ? 2 * o->cap : 8;
        void **b = realloc(o->buffers, (size_t)cap * sizeof *b);
        if (!b) {
            free(buffer);
            return gv_fail("out of memory");
        }
        o->buffers = b, o->cap = cap;
    }
    o->buffers[o->n++] = buffer;
    return 0;
}

static int map_archive(gv_st_file *f)
{
    int fd = open(f->path, O_RDONLY | O_CLOEXEC);
    if (fd < 0) return gv_fail("%s: cannot open: %s", f->path, strerror(errno));
    struct stat st;
    int rc = 0;
    if (fstat(fd, &st) != 0 || !S_ISREG(st.st_mode)) rc = gv_fail("%s: not a regular file", f->path);
    else if ((f->file_size = (uint64_t)st.st_size) > 0) {
        void *map = mmap(NULL, (size_t)f->file_size, PROT_READ, MAP_PRIVATE, fd, 0);
        if (map == MAP_FAILED) rc = gv_fail("%s: cannot map: %s", f->path, strerror(errno));
        else f->map = map;
    }
    close(fd);
    return rc;
}

/* The archive's "<prefix>/data.pkl" (torch names the folder after the file it first saved). */
static const gv_zip_entry *find_pickle(const gv_zip *z, char *prefix, size_t size)
{
    const gv_zip_entry *found = NULL;
    for (int i = 0; i < z->n; i++) {
        const char *name = z->entries[i].name, *slash = strchr(name, '/');
        if (!slash || slash == name || strcmp(slash + 1, "data.pkl")) continue;
        if (found) {
            gv_fail("%s: two pickles (%s and %s): not one PyTorch checkpoint", z->path, found->name, name);
            return NULL;
        }
        found = &z->entries[i];
    }
    if (!found) {
        gv_fail("%s: a zip archive without <name>/data.pkl: not a PyTorch checkpoint", z->path);
        return NULL;
    }
    snprintf(prefix, size, "%.*s", (int)(strchr(found->name, '/') - found->name + 1), found->name);
    return found;
}

/* Storages hold little-endian bytes; a big-endian writer records "big" here. */
static int check_byteorder(const gv_zip *z, const char *prefix)
{
    char name[600];
    snprintf(name, sizeof name, "%sbyteorder", prefix);
    const gv_zip_entry *e = gv_zip_find(z, name);
    if (!e) return 0; /* written since PyTorch 1.11; older files are little-endian */
    const uint8_t *bytes;
    void *owned;
    if (gv_zip_read(z, e, 16, 1, &bytes, &owned)) return -1;
    int little = e->size == 6 && !memcmp(bytes, "little", 6);
    free(owned);
    return little ? 0 : gv_fail("%s: %s is not \"little\": big-endian storages are not read", z->path, name);
}

/* Elements reached by a view: the last element's index, or -1 when it has none; fails on overflow. */
static int view_extent(const gv_pickle_tensor *t, int64_t *numel, int64_t *last)
{
    int64_t n = 1, end = t->offset;
    for (int k = 0; k < t->rank; k++) {
        if (__builtin_mul_overflow(n, t->shape[k], &n)) return -1;
        int64_t reach;
        if (t->shape[k] > 0 && (__builtin_mul_overflow(t->shape[k] - 1, t->stride[k], &reach) ||
                                __builtin_add_overflow(end, reach, &end)))
            return -1;
    }
    *numel = n;
    *last = n ? end : -1;
    return 0;
}

static int is_contiguous(const gv_pickle_tensor *t)
{
    int64_t expect = 1;
    for (int k = t->rank - 1; k >= 0; k--) {
        if (t->shape[k] != 1 && t->stride[k] != expect) return 0;
        expect *= t->shape[k];
    }
    return 1;
}

/* Copies a strided view into a new row-major buffer of numel elements. */
static void gather(const gv_pickle_tensor *t, const uint8_t *storage, int elem, uint8_t *out, int64_t numel)
{
    int64_t index[GV_PICKLE_MAX_RANK] = {0};
    for (int64_t i = 0; i < numel; i++) {
        int64_t at = t->offset;
        for (int k = 0; k < t->rank; k++) at += index[k] * t->stride[k];
        memcpy(out + i * elem, storage + at * elem, (size_t)elem);
        for (int k = t->rank - 1; k >= 0 && ++index[k] == t->shape[k]; k--) index[k] = 0;
    }
}

typedef struct {
    gv_st_file *f;
    const gv_zip *z;
    const char *prefix;
    pth_owner *owner;
    const uint8_t **storage_bytes; /* per zip entry, once read */
    uint64_t gathered;             /* bytes of views copied so far */
} build_state;

/* The bytes of a tensor's storage, checked to be exactly as long as the pickle says. */
static int storage_bytes(build_state *b, const gv_pickle_tensor *t, int elem, const uint8_t **out)
{
    char name[600];
    snprintf(name, sizeof name, "%sdata/%s", b->prefix, t->storage_key);
    const gv_zip_entry *e = gv_zip_find(b->z, name);
    if (!e) return gv_fail("%s: tensor '%s': its storage %s is missing", b->f->path, t->name, name);
    uint64_t need;
    if (__builtin_mul_overflow((uint64_t)t->storage_numel, (uint64_t)elem, &need))
        return gv_fail("%s: tensor '%s': storage size %" PRId64 " overflows", b->f->path, t->name, t->storage_numel);
    if (e->size != need)
        return gv_fail("%s: tensor '%s': storage %s holds %" PRIu64 " bytes, but the pickle says %" PRId64 " elements of %s "
                       "(%" PRIu64 " bytes)", b->f->path, t->name, name, e->size, t->storage_numel,
                       gv_st_dtype_name(t->dtype), need);
    size_t slot = (size_t)(e - b->z->entries);
    if (!b->storage_bytes[slot]) {
        void *owned;
        /* stored storages are not CRC-checked: that would read every byte of a multi-GB file at open */
        if (gv_zip_read(b->z, e, need, 0, &b->storage_bytes[slot], &owned) || keep(b->owner, owned)) return -1;
        b->f->data_size += e->size;
    }
    *out = b->storage_bytes[slot];
    return 0;
}

static int add_tensor(build_state *b, const gv_pickle_tensor *t, gv_st_tensor *out)
{
    int elem = gv_st_dtype_bits(t->dtype) / 8;
    int64_t numel, last;
    char shape[200];
    gv_st_shape_str(shape, sizeof shape, t->shape, t->rank);
    if (view_extent(t, &numel, &last))
        return gv_fail("%s: tensor '%s': shape %s with its strides overflows", b->f->path, t->name, shape);
    if (last >= t->storage_numel)
        return gv_fail("%s: tensor '%s' %s at offset %" PRId64 " reaches element %" PRId64 " of storage %s, which has %" PRId64
                       " (storage shorter than its tensor)", b->f->path, t->name, shape, t->offset, last, t->storage_key,
                       t->storage_numel);
    const uint8_t *bytes = NULL;
    if (storage_bytes(b, t, elem, &bytes)) return -1;
    out->dtype = t->dtype;
    out->rank = t->rank;
    memcpy(out->shape, t->shape, (size_t)t->rank * sizeof *t->shape);
    out->n_elements = numel;
    if (numel == 0 || is_contiguous(t)) {
        out->data = numel ? bytes + t->offset * elem : bytes;
    } else {
        /* a view of another layout: copied, at most the file's size in all (stride 0 could
         * otherwise make a huge tensor out of one element) */
        uint64_t n = (uint64_t)numel * (uint64_t)elem;
        if (n > b->f->file_size || b->gathered + n > b->f->file_size)
            return gv_fail("%s: tensor '%s' %s is a view larger than the file", b->f->path, t->name, shape);
        uint8_t *copy = malloc((size_t)n);
        if (!copy) return gv_fail("%s: out of memory for tensor '%s'", b->f->path, t->name);
        gather(t, bytes, elem, copy, numel);
        if (keep(b->owner, copy)) return -1;
        b->gathered += n;
        out->data = copy;
    }
    out->begin = out->data >= (const void *)b->f->map && out->data < (const void *)(b->f->map + b->f->file_size)
                     ? (uint64_t)((const uint8_t *)out->data - b->f->map) : 0;
    out->end = out->begin + (uint64_t)numel * (uint64_t)elem;
    return 0;
}

/* The tensors of the state dict, their names copied into f->strings. */
static int build_tensors(build_state *b, const gv_pickle_state_dict *sd)
{
    gv_st_file *f = b->f;
    size_t names = 0;
    for (int i = 0; i < sd->n; i++) names += strlen(sd->tensors[i].name) + 1;
    f->tensors = calloc((size_t)sd->n + 1, sizeof *f->tensors);
    f->strings = malloc(names + 1);
    b->storage_bytes = calloc((size_t)b->z->n + 1, sizeof *b->storage_bytes);
    if (!f->tensors || !f->strings || !b->storage_bytes) return gv_fail("%s: out of memory", f->path);
    char *s = f->strings;
    for (int i = 0; i < sd->n; i++) {
        gv_st_tensor *t = &f->tensors[i];
        size_t len = strlen(sd->tensors[i].name) + 1;
        memcpy(s, sd->tensors[i].name, len);
        t->name = s;
        s += len;
        if (add_tensor(b, &sd->tensors[i], t)) return -1;
        f->n_tensors++;
    }
    return gv_st_build_name_index(f);
}

static int read_checkpoint(gv_st_file *f, pth_owner *owner)
{
    gv_zip z;
    if (gv_zip_open(&z, f->path, f->map, f->file_size)) return -1;
    char prefix[520], what[4800];
    const gv_zip_entry *pickle = find_pickle(&z, prefix, sizeof prefix);
    const uint8_t *bytes = NULL;
    void *owned = NULL;
    int rc = pickle ? check_byteorder(&z, prefix) : -1;
    if (rc == 0) rc = gv_zip_read(&z, pickle, GV_PICKLE_MAX_BYTES, 1, &bytes, &owned);
    gv_pickle_state_dict sd = {0};
    if (rc == 0) {
        snprintf(what, sizeof what, "%s: %s", f->path, pickle->name);
        rc = gv_pickle_read_state_dict(what, bytes, (size_t)pickle->size, &sd);
        f->header_size = pickle->size;
    }
    free(owned);
    build_state b = {f, &z, prefix, owner, NULL, 0};
    if (rc == 0) rc = build_tensors(&b, &sd);
    free(b.storage_bytes);
    gv_pickle_state_dict_free(&sd);
    gv_zip_close(&z);
    return rc;
}

int gv_pth_open(gv_st_file *f, const char *path)
{
    memset(f, 0, sizeof *f);
    pth_owner *owner = calloc(1, sizeof *owner);
    if (!owner || !(f->path = strdup(path))) {
        free(owner);
        return gv_fail("%s: out of memory", path);
    }
    f->owner = owner, f->release = release_buffers;
    if (map_archive(f) || read_checkpoint(f, owner)) {
        gv_st_close(f);
        return -1;
    }
    return 0;
}
