/* The bounded state-dict unpickler (pickle_internal.h, docs/PTH.md). Python's pickle is a
 * small stack machine; torch.save (protocol 2 by default) writes a state dict as
 *   GLOBAL collections.OrderedDict, EMPTY_TUPLE, REDUCE        -> the dict
 *   MARK, then per tensor: its name (BINUNICODE) and
 *     GLOBAL torch._utils._rebuild_tensor_v2, MARK,
 *       MARK 'storage' GLOBAL torch.FloatStorage '0' 'cpu' numel TUPLE, BINPERSID,
 *       offset, (sizes) TUPLE, (strides) TUPLE, NEWFALSE, OrderedDict() , TUPLE, REDUCE
 *   SETITEMS; then BUILD with the dict's "_metadata" attribute (dropped here); STOP
 * with BINPUT/BINGET memo references throughout. Each opcode here only builds plain data:
 * the three callable globals are interpreted by name (an empty dict, a tensor description),
 * nothing is imported or called, and anything else is refused. Every allocation is counted
 * against GV_PICKLE_MAX_OBJECTS_BYTES before it is made. */
#include "pth/pickle_internal.h"

#include <inttypes.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "gaussvid/core/core.h"
#include "io/safetensors_internal.h"

/* ---- objects and their arena ----------------------------------------------------------- */

typedef enum { PV_NONE, PV_BOOL, PV_INT, PV_STR, PV_TUPLE, PV_DICT, PV_GLOBAL, PV_STORAGE, PV_TENSOR } pv_kind;

/* The globals that may appear; the storage classes map to dtypes. */
typedef enum { G_ORDERED_DICT, G_REBUILD_TENSOR_V2, G_REBUILD_PARAMETER, G_STORAGE } global_kind;

typedef struct pv pv;
struct pv {
    pv_kind kind;
    union {
        int64_t i;                                            /* BOOL, INT */
        const char *str;                                      /* STR: NUL-terminated UTF-8 */
        struct { int n; pv **items; } tuple;                  /* TUPLE */
        struct { int n, cap; pv **keys, **values; } dict;     /* DICT */
        struct { global_kind kind; gv_st_dtype dtype; const char *name; } global; /* GLOBAL */
        struct { gv_st_dtype dtype; const char *key; int64_t numel; } storage;
        struct { const pv *storage; int64_t offset; int rank; int64_t shape[GV_PICKLE_MAX_RANK],
                 stride[GV_PICKLE_MAX_RANK]; } tensor;
    };
};

typedef struct block {
    struct block *next;
    size_t used, cap;
    _Alignas(16) unsigned char data[];
} block;

typedef struct {
    block *head;
    size_t total;
} arena;

static void arena_free(arena *a)
{
    for (block *b = a->head, *next; b; b = next) next = b->next, free(b);
    free(a);
}

/* ---- the machine ----------------------------------------------------------------------- */

typedef struct {
    const char *what;
    const uint8_t *start, *p, *end;
    size_t op_at;             /* byte of the opcode being run, for messages */
    arena *arena;
    pv **stack;
    int sp, stack_cap;
    int *marks;               /* stack heights at each MARK */
    int n_marks, marks_cap;
    pv **memo;
    uint32_t memo_cap;
} unpickler;

static int fail(const unpickler *u, const char *fmt, ...) __attribute__((format(printf, 2, 3)));
static int fail(const unpickler *u, const char *fmt, ...)
{
    char text[700];
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(text, sizeof text, fmt, ap);
    va_end(ap);
    return gv_fail("%s: byte %zu: %s", u->what, u->op_at, text);
}

static void *alloc(unpickler *u, size_t bytes)
{
    bytes = (bytes + 15) & ~(size_t)15;
    if (bytes > GV_PICKLE_MAX_OBJECTS_BYTES || u->arena->total + bytes > GV_PICKLE_MAX_OBJECTS_BYTES) {
        fail(u, "the pickle's objects need more than %d MiB (a state dict needs a few)", GV_PICKLE_MAX_OBJECTS_BYTES >> 20);
        return NULL;
    }
    block *b = u->arena->head;
    if (!b || b->cap - b->used < bytes) {
        size_t cap = bytes > (64u << 10) ? bytes : (64u << 10);
        if (!(b = malloc(sizeof *b + cap))) {
            fail(u, "out of memory");
            return NULL;
        }
        b->next = u->arena->head, b->used = 0, b->cap = cap;
        u->arena->head = b;
    }
    void *p = b->data + b->used;
    b->used += bytes;
    u->arena->total += bytes;
    memset(p, 0, bytes);
    return p;
}

static pv *new_pv(unpickler *u, pv_kind kind)
{
    pv *v = alloc(u, sizeof *v);
    if (v) v->kind = kind;
    return v;
}

/* Grows an array of pointers held outside the arena (stack, memo) up to `limit` entries. */
static int grow(unpickler *u, void *array_ptr, size_t elem, int64_t *cap, int64_t need, int64_t limit, const char *what)
{
    if (need <= *cap) return 0;
    if (need > limit) return fail(u, "%s of %" PRId64 " entries is beyond the limit of %" PRId64, what, need, limit);
    int64_t n = *cap ? *cap : 64;
    while (n < need) n *= 2;
    if (n > limit) n = limit;
    void **array = array_ptr;
    void *grown = realloc(*array, (size_t)n * elem);
    if (!grown) return fail(u, "out of memory for the %s", what);
    memset((char *)grown + (size_t)*cap * elem, 0, (size_t)(n - *cap) * elem);
    *array = grown;
    *cap = n;
    return 0;
}

static int push(unpickler *u, pv *v)
{
    if (!v) return -1;
    int64_t cap = u->stack_cap;
    if (grow(u, &u->stack, sizeof *u->stack, &cap, (int64_t)u->sp + 1, GV_PICKLE_MAX_STACK, "stack")) return -1;
    u->stack_cap = (int)cap;
    u->stack[u->sp++] = v;
    return 0;
}

/* The stack height at the last MARK must not be below the frame being used. */
static int floor_of_stack(const unpickler *u)
{
    return u->n_marks ? u->marks[u->n_marks - 1] : 0;
}

static pv *pop(unpickler *u)
{
    if (u->sp <= floor_of_stack(u)) {
        fail(u, "the stack is empty (malformed pickle)");
        return NULL;
    }
    return u->stack[--u->sp];
}

static pv *top(unpickler *u)
{
    if (u->sp <= floor_of_stack(u)) {
        fail(u, "the stack is empty (malformed pickle)");
        return NULL;
    }
    return u->stack[u->sp - 1];
}

/* Pops to the last MARK: *first is the index of the first object above it. */
static int pop_mark(unpickler *u, int *first)
{
    if (u->n_marks == 0) return fail(u, "no MARK to pop to (malformed pickle)");
    *first = u->marks[--u->n_marks];
    return 0;
}

static int need_bytes(unpickler *u, uint64_t n)
{
    if ((uint64_t)(u->end - u->p) < n)
        return fail(u, "the pickle ends %" PRIu64 " bytes early (truncated data.pkl?)", n - (uint64_t)(u->end - u->p));
    return 0;
}

static uint64_t read_le(unpickler *u, int n)
{
    uint64_t v = 0;
    for (int k = n - 1; k >= 0; k--) v = (v << 8) | u->p[k];
    u->p += n;
    return v;
}

static const char *kind_name(pv_kind k)
{
    static const char *const names[] = {"None", "a bool", "an int", "a string", "a tuple", "a dict", "a global",
                                        "a storage", "a tensor"};
    return names[k];
}

/* ---- opcodes --------------------------------------------------------------------------- */

static const char *opcode_name(uint8_t op)
{
    switch (op) {
    case '(': return "MARK"; case '.': return "STOP"; case '0': return "POP"; case '1': return "POP_MARK";
    case '2': return "DUP"; case 'F': return "FLOAT"; case 'I': return "INT"; case 'J': return "BININT";
    case 'K': return "BININT1"; case 'L': return "LONG"; case 'M': return "BININT2"; case 'N': return "NONE";
    case 'P': return "PERSID"; case 'Q': return "BINPERSID"; case 'R': return "REDUCE"; case 'S': return "STRING";
    case 'T': return "BINSTRING"; case 'U': return "SHORT_BINSTRING"; case 'V': return "UNICODE";
    case 'X': return "BINUNICODE"; case 'a': return "APPEND"; case 'b': return "BUILD"; case 'c': return "GLOBAL";
    case 'd': return "DICT"; case '}': return "EMPTY_DICT"; case 'e': return "APPENDS"; case 'g': return "GET";
    case 'h': return "BINGET"; case 'i': return "INST"; case 'j': return "LONG_BINGET"; case 'l': return "LIST";
    case ']': return "EMPTY_LIST"; case 'o': return "OBJ"; case 'p': return "PUT"; case 'q': return "BINPUT";
    case 'r': return "LONG_BINPUT"; case 's': return "SETITEM"; case 't': return "TUPLE"; case ')': return "EMPTY_TUPLE";
    case 'u': return "SETITEMS"; case 'G': return "BINFLOAT"; case 'B': return "BINBYTES"; case 'C': return "SHORT_BINBYTES";
    case 0x80: return "PROTO"; case 0x81: return "NEWOBJ"; case 0x82: return "EXT1"; case 0x83: return "EXT2";
    case 0x84: return "EXT4"; case 0x85: return "TUPLE1"; case 0x86: return "TUPLE2"; case 0x87: return "TUPLE3";
    case 0x88: return "NEWTRUE"; case 0x89: return "NEWFALSE"; case 0x8a: return "LONG1"; case 0x8b: return "LONG4";
    case 0x8c: return "SHORT_BINUNICODE"; case 0x8d: return "BINUNICODE8"; case 0x8e: return "BINBYTES8";
    case 0x8f: return "EMPTY_SET"; case 0x90: return "ADDITEMS"; case 0x91: return "FROZENSET"; case 0x92: return "NEWOBJ_EX";
    case 0x93: return "STACK_GLOBAL"; case 0x94: return "MEMOIZE"; case 0x95: return "FRAME"; case 0x96: return "BYTEARRAY8";
    case 0x97: return "NEXT_BUFFER"; case 0x98: return "READONLY_BUFFER";
    default: return NULL;
    }
}

/* A string of n bytes at the read position: UTF-8 without NUL bytes (names and keys only). */
static int op_string(unpickler *u, uint64_t n)
{
    if (need_bytes(u, n)) return -1;
    if (!gv_st_utf8_valid((const char *)u->p, (size_t)n)) return fail(u, "a string is not valid UTF-8");
    if (memchr(u->p, 0, (size_t)n)) return fail(u, "a string holds a NUL byte");
    char *s = alloc(u, (size_t)n + 1);
    pv *v = s ? new_pv(u, PV_STR) : NULL;
    if (!v) return -1;
    memcpy(s, u->p, (size_t)n);
    u->p += n;
    v->str = s;
    return push(u, v);
}

static int op_int(unpickler *u, int64_t value)
{
    pv *v = new_pv(u, PV_INT);
    if (v) v->i = value;
    return push(u, v);
}

/* LONG1: n little-endian two's-complement bytes; state dicts need at most 8. */
static int op_long1(unpickler *u)
{
    if (need_bytes(u, 1)) return -1;
    int n = *u->p++;
    if (n > 8) return fail(u, "LONG1 of %d bytes is beyond 64 bits", n);
    if (need_bytes(u, (uint64_t)n)) return -1;
    uint64_t v = read_le(u, n);
    if (n > 0 && n < 8 && (v >> (8 * n - 1)) & 1) v |= ~(uint64_t)0 << (8 * n); /* sign-extend */
    return op_int(u, (int64_t)v);
}

static int make_tuple(unpickler *u, int first)
{
    int n = u->sp - first;
    pv *t = new_pv(u, PV_TUPLE);
    pv **items = n ? alloc(u, (size_t)n * sizeof *items) : NULL;
    if (!t || (n && !items)) return -1;
    if (n) memcpy(items, u->stack + first, (size_t)n * sizeof *items);
    t->tuple.n = n, t->tuple.items = items;
    u->sp = first;
    return push(u, t);
}

static int op_tuple_n(unpickler *u, int n)
{
    if (u->sp - floor_of_stack(u) < n) return fail(u, "TUPLE%d with fewer than %d objects on the stack", n, n);
    return make_tuple(u, u->sp - n);
}

static int dict_set(unpickler *u, pv *d, pv *key, pv *value)
{
    if (d->kind != PV_DICT) return fail(u, "SETITEM(S) on %s, not a dict", kind_name(d->kind));
    if (d->dict.n == d->dict.cap) { /* arena arrays: the old ones stay behind (at most as much again) */
        int cap = d->dict.cap ? 2 * d->dict.cap : 8;
        pv **keys = alloc(u, (size_t)cap * sizeof *keys), **values = alloc(u, (size_t)cap * sizeof *values);
        if (!keys || !values) return -1;
        if (d->dict.n) {
            memcpy(keys, d->dict.keys, (size_t)d->dict.n * sizeof *keys);
            memcpy(values, d->dict.values, (size_t)d->dict.n * sizeof *values);
        }
        d->dict.keys = keys, d->dict.values = values, d->dict.cap = cap;
    }
    d->dict.keys[d->dict.n] = key;
    d->dict.values[d->dict.n++] = value;
    return 0;
}

static int op_setitems(unpickler *u)
{
    int first = 0;
    if (pop_mark(u, &first)) return -1;
    if ((u->sp - first) % 2) return fail(u, "SETITEMS with an odd number of objects");
    if (first <= floor_of_stack(u)) return fail(u, "SETITEMS with no dict below its MARK");
    pv *d = u->stack[first - 1];
    for (int k = first; k < u->sp; k += 2)
        if (dict_set(u, d, u->stack[k], u->stack[k + 1])) return -1;
    u->sp = first;
    return 0;
}

static int op_setitem(unpickler *u)
{
    pv *value = pop(u), *key = value ? pop(u) : NULL, *d = key ? top(u) : NULL;
    return d ? dict_set(u, d, key, value) : -1;
}

/* ---- globals, persistent ids, REDUCE ------------------------------------------------------ */

static const struct { const char *name; gv_st_dtype dtype; } storage_classes[] = {
    {"FloatStorage", GV_ST_F32}, {"DoubleStorage", GV_ST_F64}, {"HalfStorage", GV_ST_F16},
    {"BFloat16Storage", GV_ST_BF16}, {"LongStorage", GV_ST_I64}, {"IntStorage", GV_ST_I32},
    {"ShortStorage", GV_ST_I16}, {"CharStorage", GV_ST_I8}, {"ByteStorage", GV_ST_U8}, {"BoolStorage", GV_ST_BOOL},
};

static int push_global(unpickler *u, const char *module, const char *name)
{
    pv *g = new_pv(u, PV_GLOBAL);
    char *qualified = g ? alloc(u, strlen(module) + strlen(name) + 2) : NULL;
    if (!qualified) return -1;
    sprintf(qualified, "%s.%s", module, name);
    g->global.name = qualified;
    if (!strcmp(module, "collections") && !strcmp(name, "OrderedDict")) g->global.kind = G_ORDERED_DICT;
    else if (!strcmp(module, "torch._utils") && !strcmp(name, "_rebuild_tensor_v2")) g->global.kind = G_REBUILD_TENSOR_V2;
    else if (!strcmp(module, "torch._utils") && !strcmp(name, "_rebuild_parameter")) g->global.kind = G_REBUILD_PARAMETER;
    else {
        int found = 0;
        for (size_t k = 0; !found && !strcmp(module, "torch") && k < sizeof storage_classes / sizeof *storage_classes; k++)
            if (!strcmp(name, storage_classes[k].name)) {
                g->global.kind = G_STORAGE, g->global.dtype = storage_classes[k].dtype;
                found = 1;
            }
        if (!found)
            return fail(u, "global '%s.%s' is not accepted (only collections.OrderedDict, torch._utils._rebuild_tensor_v2, "
                           "torch._utils._rebuild_parameter and torch.<Type>Storage: a state dict of tensors)",
                        module, name);
    }
    return push(u, g);
}

/* GLOBAL: "module\nname\n" (printable ASCII lines, at most 256 bytes each). */
static int op_global(unpickler *u)
{
    char parts[2][257];
    for (int k = 0; k < 2; k++) {
        size_t len = 0;
        for (;;) {
            if (need_bytes(u, 1)) return -1;
            uint8_t c = *u->p++;
            if (c == '\n') break;
            if (c < 0x20 || c > 0x7e || len == 256) return fail(u, "GLOBAL with a malformed or over-long name");
            parts[k][len++] = (char)c;
        }
        parts[k][len] = '\0';
    }
    return push_global(u, parts[0], parts[1]);
}

static int op_stack_global(unpickler *u)
{
    pv *name = pop(u), *module = name ? pop(u) : NULL;
    if (!module) return -1;
    if (module->kind != PV_STR || name->kind != PV_STR) return fail(u, "STACK_GLOBAL of non-strings");
    return push_global(u, module->str, name->str);
}

static int is_int(const pv *v) { return v->kind == PV_INT || v->kind == PV_BOOL; }

/* BINPERSID: ('storage', torch.<Type>Storage, key, location, numel) -> a storage. */
static int op_binpersid(unpickler *u)
{
    pv *pid = pop(u);
    if (!pid) return -1;
    pv **it = pid->kind == PV_TUPLE ? pid->tuple.items : NULL;
    if (!it || pid->tuple.n != 5 || it[0]->kind != PV_STR || strcmp(it[0]->str, "storage") || it[1]->kind != PV_GLOBAL ||
        it[1]->global.kind != G_STORAGE || it[2]->kind != PV_STR || it[3]->kind != PV_STR || !is_int(it[4]))
        return fail(u, "a persistent id that is not ('storage', torch.<Type>Storage, key, location, numel)");
    if (it[4]->i < 0) return fail(u, "storage '%s' has a negative size %" PRId64, it[2]->str, it[4]->i);
    pv *s = new_pv(u, PV_STORAGE);
    if (!s) return -1;
    s->storage.dtype = it[1]->global.dtype, s->storage.key = it[2]->str, s->storage.numel = it[4]->i;
    return push(u, s);
}

/* A tuple of at most GV_PICKLE_MAX_RANK ints in [0, 2^62] into out. */
static int int_tuple(unpickler *u, const pv *t, const char *what, int64_t *out, int *n)
{
    if (t->kind != PV_TUPLE) return fail(u, "_rebuild_tensor_v2: %s is %s, not a tuple", what, kind_name(t->kind));
    if (t->tuple.n > GV_PICKLE_MAX_RANK)
        return fail(u, "_rebuild_tensor_v2: %d dimensions, more than %d", t->tuple.n, GV_PICKLE_MAX_RANK);
    for (int k = 0; k < t->tuple.n; k++) {
        const pv *e = t->tuple.items[k];
        if (!is_int(e) || e->i < 0 || e->i > ((int64_t)1 << 62))
            return fail(u, "_rebuild_tensor_v2: %s entry %d is not a size in [0, 2^62]", what, k);
        out[k] = e->i;
    }
    *n = t->tuple.n;
    return 0;
}

/* _rebuild_tensor_v2(storage, storage_offset, size, stride, requires_grad, backward_hooks[, metadata]) */
static pv *rebuild_tensor(unpickler *u, const pv *args)
{
    pv **a = args->tuple.items;
    int n = args->tuple.n, rank = 0, stride_rank = 0;
    if (n != 6 && n != 7) {
        fail(u, "_rebuild_tensor_v2 with %d arguments (expected 6 or 7)", n);
        return NULL;
    }
    if (a[0]->kind != PV_STORAGE || !is_int(a[1]) || a[1]->i < 0 || a[1]->i > ((int64_t)1 << 62)) {
        fail(u, "_rebuild_tensor_v2 without a storage and a storage offset");
        return NULL;
    }
    pv *t = new_pv(u, PV_TENSOR);
    if (!t || int_tuple(u, a[2], "size", t->tensor.shape, &rank) || int_tuple(u, a[3], "stride", t->tensor.stride, &stride_rank))
        return NULL;
    if (rank != stride_rank) {
        fail(u, "_rebuild_tensor_v2: %d sizes but %d strides", rank, stride_rank);
        return NULL;
    }
    t->tensor.storage = a[0], t->tensor.offset = a[1]->i, t->tensor.rank = rank;
    return t;
}

static int op_reduce(unpickler *u)
{
    pv *args = pop(u), *callable = args ? pop(u) : NULL;
    if (!callable) return -1;
    if (callable->kind != PV_GLOBAL || callable->global.kind == G_STORAGE)
        return fail(u, "REDUCE calls %s, which is not one of the accepted functions",
                    callable->kind == PV_GLOBAL ? callable->global.name : kind_name(callable->kind));
    if (args->kind != PV_TUPLE) return fail(u, "REDUCE with arguments that are not a tuple");
    switch (callable->global.kind) {
    case G_ORDERED_DICT:
        if (args->tuple.n != 0) return fail(u, "OrderedDict called with arguments (only OrderedDict() is accepted)");
        return push(u, new_pv(u, PV_DICT));
    case G_REBUILD_TENSOR_V2:
        return push(u, rebuild_tensor(u, args));
    default: /* _rebuild_parameter(data, requires_grad, backward_hooks): the tensor itself */
        if (args->tuple.n != 3 || args->tuple.items[0]->kind != PV_TENSOR)
            return fail(u, "_rebuild_parameter without a tensor as its first of 3 arguments");
        return push(u, args->tuple.items[0]);
    }
}

/* BUILD on a dict sets its attributes (a state dict's "_metadata": module versions); the
 * attributes are not used here, so the state is dropped. */
static int op_build(unpickler *u)
{
    pv *state = pop(u), *obj = state ? top(u) : NULL;
    if (!obj) return -1;
    if (obj->kind != PV_DICT || (state->kind != PV_DICT && state->kind != PV_NONE))
        return fail(u, "BUILD on %s (only a state dict's attributes are accepted)", kind_name(obj->kind));
    return 0;
}

/* ---- memo -------------------------------------------------------------------------------- */

static int memo_put(unpickler *u, uint64_t index)
{
    pv *v = top(u);
    if (!v) return -1;
    if (index >= GV_PICKLE_MAX_MEMO) return fail(u, "memo index %" PRIu64 " is beyond the limit of %d", index, GV_PICKLE_MAX_MEMO);
    int64_t cap = u->memo_cap;
    if (grow(u, &u->memo, sizeof *u->memo, &cap, (int64_t)index + 1, GV_PICKLE_MAX_MEMO, "memo")) return -1;
    u->memo_cap = (uint32_t)cap;
    u->memo[index] = v;
    return 0;
}

static int memo_get(unpickler *u, uint64_t index)
{
    if (index >= u->memo_cap || !u->memo[index]) return fail(u, "memo index %" PRIu64 " was never stored", index);
    return push(u, u->memo[index]);
}

/* ---- the loop ------------------------------------------------------------------------------ */

/* Runs one opcode; 1 at STOP. */
static int step(unpickler *u, uint64_t *memo_count)
{
    u->op_at = (size_t)(u->p - u->start);
    if (need_bytes(u, 1)) return -1;
    uint8_t op = *u->p++;
    switch (op) {
    case 0x80: /* PROTO */
        if (need_bytes(u, 1)) return -1;
        if (*u->p < 2 || *u->p > 5) return fail(u, "pickle protocol %d (2 to 5 are read)", *u->p);
        u->p++;
        return 0;
    case 0x95: /* FRAME: a length hint for buffered readers; the whole pickle is in memory */
        if (need_bytes(u, 8)) return -1;
        u->p += 8;
        return 0;
    case '.': return 1;
    case '(': {
        int64_t cap = u->marks_cap;
        if (grow(u, &u->marks, sizeof *u->marks, &cap, (int64_t)u->n_marks + 1, GV_PICKLE_MAX_STACK, "mark stack")) return -1;
        u->marks_cap = (int)cap;
        u->marks[u->n_marks++] = u->sp;
        return 0;
    }
    case '}': return push(u, new_pv(u, PV_DICT));
    case ')': return push(u, new_pv(u, PV_TUPLE));
    case 'N': return push(u, new_pv(u, PV_NONE));
    case 0x88: case 0x89: {
        pv *v = new_pv(u, PV_BOOL);
        if (v) v->i = op == 0x88;
        return push(u, v);
    }
    case 'K': if (need_bytes(u, 1)) return -1; return op_int(u, (int64_t)read_le(u, 1));
    case 'M': if (need_bytes(u, 2)) return -1; return op_int(u, (int64_t)read_le(u, 2));
    case 'J': if (need_bytes(u, 4)) return -1; return op_int(u, (int64_t)(int32_t)(uint32_t)read_le(u, 4));
    case 0x8a: return op_long1(u);
    case 'X': if (need_bytes(u, 4)) return -1; return op_string(u, read_le(u, 4));
    case 0x8c: if (need_bytes(u, 1)) return -1; return op_string(u, read_le(u, 1));
    case 0x8d: if (need_bytes(u, 8)) return -1; return op_string(u, read_le(u, 8));
    case 't': { int first = 0; return pop_mark(u, &first) ? -1 : make_tuple(u, first); }
    case 0x85: return op_tuple_n(u, 1);
    case 0x86: return op_tuple_n(u, 2);
    case 0x87: return op_tuple_n(u, 3);
    case 's': return op_setitem(u);
    case 'u': return op_setitems(u);
    case 'c': return op_global(u);
    case 0x93: return op_stack_global(u);
    case 'Q': return op_binpersid(u);
    case 'R': return op_reduce(u);
    case 'b': return op_build(u);
    case 'q': if (need_bytes(u, 1)) return -1; return memo_put(u, read_le(u, 1));
    case 'r': if (need_bytes(u, 4)) return -1; return memo_put(u, read_le(u, 4));
    case 0x94: return memo_put(u, (*memo_count)++);
    case 'h': if (need_bytes(u, 1)) return -1; return memo_get(u, read_le(u, 1));
    case 'j': if (need_bytes(u, 4)) return -1; return memo_get(u, read_le(u, 4));
    default: {
        const char *name = opcode_name(op);
        if (name) return fail(u, "opcode %s (0x%02x) is not accepted (only what a state dict of tensors needs)", name, op);
        return fail(u, "0x%02x is not a pickle opcode", op);
    }
    }
}

/* The result must be a dict of string to tensor. */
static int collect(unpickler *u, const pv *d, gv_pickle_state_dict *out)
{
    if (d->kind != PV_DICT) return gv_fail("%s: the pickle holds %s, not a state dict", u->what, kind_name(d->kind));
    out->tensors = d->dict.n ? alloc(u, (size_t)d->dict.n * sizeof *out->tensors) : NULL;
    if (d->dict.n && !out->tensors) return -1;
    for (int i = 0; i < d->dict.n; i++) {
        const pv *k = d->dict.keys[i], *v = d->dict.values[i];
        if (k->kind != PV_STR) return gv_fail("%s: a state dict key is %s, not a string", u->what, kind_name(k->kind));
        if (v->kind != PV_TENSOR)
            return gv_fail("%s: entry '%s' is %s, not a tensor (only a plain state dict is read)", u->what, k->str,
                           kind_name(v->kind));
        gv_pickle_tensor *t = &out->tensors[i];
        t->name = k->str;
        t->dtype = v->tensor.storage->storage.dtype;
        t->storage_key = v->tensor.storage->storage.key;
        t->storage_numel = v->tensor.storage->storage.numel;
        t->offset = v->tensor.offset;
        t->rank = v->tensor.rank;
        memcpy(t->shape, v->tensor.shape, sizeof t->shape);
        memcpy(t->stride, v->tensor.stride, sizeof t->stride);
    }
    out->n = d->dict.n;
    return 0;
}

int gv_pickle_read_state_dict(const char *what, const uint8_t *data, size_t n, gv_pickle_state_dict *out)
{
    memset(out, 0, sizeof *out);
    if (n > GV_PICKLE_MAX_BYTES)
        return gv_fail("%s: %zu bytes of pickle, more than the %d MiB a state dict may have", what, n, GV_PICKLE_MAX_BYTES >> 20);
    unpickler u = {.what = what, .start = data, .p = data, .end = data + n};
    if (!(u.arena = calloc(1, sizeof *u.arena))) return gv_fail("%s: out of memory", what);
    uint64_t memo_count = 0;
    int rc;
    while ((rc = step(&u, &memo_count)) == 0) {}
    if (rc == 1) {
        u.op_at = (size_t)(u.p - u.start) - 1;
        if (u.sp != 1 || u.n_marks) rc = fail(&u, "STOP with %d objects and %d marks on the stack (expected one object)", u.sp, u.n_marks);
        else if (u.p != u.end) rc = fail(&u, "%zu bytes after STOP", (size_t)(u.end - u.p));
        else rc = collect(&u, u.stack[0], out);
    }
    free(u.stack);
    free(u.marks);
    free(u.memo);
    if (rc) {
        arena_free(u.arena);
        memset(out, 0, sizeof *out);
        return -1;
    }
    out->arena = u.arena;
    return 0;
}

void gv_pickle_state_dict_free(gv_pickle_state_dict *sd)
{
    if (sd->arena) arena_free(sd->arena);
    memset(sd, 0, sizeof *sd);
}
