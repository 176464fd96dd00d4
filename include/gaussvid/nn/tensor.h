/* Tensors with reverse-mode automatic differentiation (docs/ARCHITECTURE.md section 6.1).
 *
 * A gv_tensor is a dense, contiguous, row-major float32 array of 0..5 dimensions. Every
 * operation (ops.h) computes its output at once and, when gradients are wanted, records the
 * output on the graph's tape; gv_backward walks the tape in reverse and accumulates
 * gradients. Activations, their gradients and the tape live in an arena that is reset every
 * step; parameters live in a gv_params registry (name, shape, data, gradient, trainable flag,
 * AdamW moments) that outlives the graph. See docs/NN.md. */
#ifndef GAUSSVID_TENSOR_H
#define GAUSSVID_TENSOR_H

#include <stddef.h>
#include <stdint.h>

#define GV_MAX_DIMS 5

/* ---- Arena -------------------------------------------------------------------------------
 * A bump allocator of 64-byte aligned blocks. Reset frees nothing: it forgets everything at
 * once, and folds the blocks into one so the next step needs a single block. */
typedef struct {
    unsigned char *base;
    size_t size, used;
} gv_arena_block;

typedef struct {
    gv_arena_block *blocks;
    int n_blocks, cap_blocks;
    int current;        /* block being filled */
    size_t in_use;      /* bytes handed out since the last reset (block ends excluded) */
    size_t peak;        /* highest in_use seen since gv_arena_reset_peak */
    size_t limit;       /* 0 = no limit; otherwise allocations beyond it fail */
    size_t min_block;   /* smallest block reserved from the system */
} gv_arena;

typedef struct {
    int block;
    size_t used, in_use;
} gv_arena_mark;

void gv_arena_init(gv_arena *a, size_t first_block_bytes);
void gv_arena_free(gv_arena *a);
/* 64-byte aligned, uninitialised memory; NULL (with a message) when out of memory. */
void *gv_arena_alloc(gv_arena *a, size_t bytes);
/* Like gv_arena_alloc, zero-filled. */
void *gv_arena_calloc(gv_arena *a, size_t bytes);
/* Forgets every allocation (keeps the memory for the next step). */
void gv_arena_reset(gv_arena *a);
/* A position to come back to: everything allocated after it is released by rewind. */
gv_arena_mark gv_arena_get_mark(const gv_arena *a);
void gv_arena_rewind(gv_arena *a, gv_arena_mark m);
/* Bytes reserved from the system (all blocks). */
size_t gv_arena_capacity(const gv_arena *a);
void gv_arena_reset_peak(gv_arena *a);

/* ---- Tensors ----------------------------------------------------------------------------- */
typedef struct gv_tensor {
    int ndim;
    int shape[GV_MAX_DIMS];
    int64_t numel;
    float *data;
    float *grad;         /* same size as data, or NULL (no gradient wanted or none reached) */
    int requires_grad;   /* a gradient flows to this tensor */
    int op;              /* gv_op that produced it (GV_OP_LEAF for inputs and parameters) */
    int n_src;
    struct gv_tensor **src; /* inputs of the op */
    int iparam[16];      /* op settings (axes, strides, paddings, heads, ...) */
    float fparam[4];     /* op settings (eps, scale, ...) */
    void *saved;         /* values the op keeps for its backward pass (arena) */
    const char *name;    /* parameter name, or NULL */
    const void *grad_graph; /* graph whose arena holds grad (NULL: a parameter's own buffer) */
    uint64_t grad_epoch;    /* ... and that graph's step when it was allocated */
    const unsigned char *bf16; /* a frozen weight kept as little-endian bfloat16 elsewhere (then
                                  data is NULL): only gv_linear takes it, converting it to
                                  float32 at each use (gv_tensor_values) */
    int bf16_mapped;     /* bf16 points into a read-only file mapping: its pages are dropped
                            after each use, so the weights need not stay resident */
} gv_tensor;

/* ---- Graph: arena + tape ------------------------------------------------------------------ */
typedef struct {
    gv_arena arena;
    gv_tensor **tape;    /* op outputs that need a backward step, in creation order */
    int n_tape, cap_tape;
    int grad_enabled;    /* 0: no-grad mode, nothing is recorded */
    uint64_t epoch;      /* counts resets: a gradient from an earlier step is stale */
    int profile;         /* 1: add each op's forward and backward seconds to op_seconds */
    double op_seconds[64][2]; /* [gv_op][0 forward, 1 backward], summed until cleared */
} gv_graph;

void gv_graph_init(gv_graph *g, size_t arena_bytes);
void gv_graph_free(gv_graph *g);
/* Starts a new step: forgets all activations and the tape (parameters are untouched). */
void gv_graph_reset(gv_graph *g);
/* Turns recording on or off; returns the previous setting. Off = inference (no tape). */
int gv_graph_set_grad(gv_graph *g, int enabled);

/* A zero-filled tensor of the given shape in the arena (a leaf: no gradient). */
gv_tensor *gv_tensor_new(gv_graph *g, int ndim, const int *shape);
/* A leaf tensor holding a copy of data (numel floats). */
gv_tensor *gv_tensor_from(gv_graph *g, int ndim, const int *shape, const float *data);
/* A leaf sharing t's data: no gradient flows back through it (stop-gradient, or a value
 * computed once and reused, such as the camera stream's keys across sampling steps). */
gv_tensor *gv_detach(gv_graph *g, gv_tensor *t);
/* Marks a leaf as an input whose gradient is wanted. The gradient is allocated in the arena
 * of the graph that runs the backward pass, afresh at each of its steps, so a leaf may live in
 * a longer-lived graph; read t->grad after gv_backward (NULL: the loss does not depend on t). */
void gv_tensor_requires_grad(gv_tensor *t);
/* Size of dimension `axis` (negative counts from the end). */
int gv_dim(const gv_tensor *t, int axis);
/* "[2, 3, 4]" into buf (for messages). */
const char *gv_shape_str(const gv_tensor *t, char *buf, size_t size);
/* Whether a and b have the same shape. */
int gv_same_shape(const gv_tensor *a, const gv_tensor *b);

/* Fills x[i] = mean + std * N(0,1) drawn at Philox position offset + i of stream `seed`:
 * the values do not depend on the number of threads. */
void gv_fill_normal(float *x, int64_t n, uint64_t seed, uint64_t offset, float mean, float std);
/* Fills x[i] uniform in [lo, hi] (hi only by float rounding) at Philox position offset + i
 * of stream `seed`. */
void gv_fill_uniform(float *x, int64_t n, uint64_t seed, uint64_t offset, float lo, float hi);
/* A seed for one parameter from a base seed and its name (FNV-1a), so that adding a
 * parameter does not change the initial values of the others. */
uint64_t gv_seed_for_name(uint64_t base_seed, const char *name);

/* ---- Backward ----------------------------------------------------------------------------- */
/* Backpropagates from a one-element tensor (gradient 1). Gradients accumulate into every
 * leaf with requires_grad that the loss depends on, parameters included (call
 * gv_params_zero_grad between steps, or not, to accumulate). May be called again in the same
 * step (e.g. for a second loss): each call propagates only its own seed. */
int gv_backward(gv_graph *g, gv_tensor *loss);
/* Backpropagates from any tensor with the given output gradient (out->numel floats). */
int gv_backward_seed(gv_graph *g, gv_tensor *out, const float *out_grad);

/* ---- Parameters ------------------------------------------------------------------------------
 * Named, persistent (heap) tensors. Trainable ones own a gradient buffer and the two AdamW
 * moments; frozen ones own none of the three, so the backward pass skips their weight
 * gradients entirely. A loader fills them by name (gv_params_find). */
typedef struct {
    gv_tensor t;         /* t.name is the parameter name; t.grad is NULL when frozen */
    int trainable;
    int decay;           /* AdamW weight decay applies (default 1) */
    float *m, *v;        /* AdamW first and second moments (NULL when frozen) */
} gv_param;

typedef struct {
    gv_param **items;
    int n, cap;
    long step;           /* AdamW steps taken (for bias correction and checkpoints) */
} gv_params;

void gv_params_init(gv_params *ps);
void gv_params_free(gv_params *ps);
/* Registers a zero-filled parameter; returns its tensor, or NULL (duplicate name, bad shape,
 * out of memory). */
gv_tensor *gv_params_add(gv_params *ps, const char *name, int ndim, const int *shape,
                         int trainable);
/* The parameter of that name, or NULL. */
gv_param *gv_params_find(const gv_params *ps, const char *name);
/* The parameter owning tensor t, or NULL. */
gv_param *gv_params_of(const gv_params *ps, const gv_tensor *t);
/* Freezes or unfreezes one parameter (allocates or frees gradient and moments). */
int gv_param_set_trainable(gv_param *p, int trainable);
/* Sets the gradients of all trainable parameters to zero. */
void gv_params_zero_grad(gv_params *ps);
/* Number of floats in all parameters / in trainable ones. */
int64_t gv_params_count(const gv_params *ps, int trainable_only);
/* Fails naming the first parameter with a NaN or infinite value (what = "data" or "grad"). */
int gv_params_check_finite(const gv_params *ps, int check_grad);

/* ---- Weights kept in bfloat16 (bf16.c) ----------------------------------------------------
 * A frozen weight may stay in the bfloat16 bytes of a mapped file instead of a float32 copy:
 * half the memory, and with `mapped` its pages are dropped after every use (madvise
 * MADV_DONTNEED), so a model larger than the RAM runs one layer's weights at a time. */
/* Registers a parameter without values (data NULL): a loader gives it values with
 * gv_param_alloc (float32 zeros) or gv_param_set_bf16. */
gv_tensor *gv_params_add_empty(gv_params *ps, const char *name, int ndim, const int *shape);
/* Allocates a float32 zero buffer for a parameter that has none. */
int gv_param_alloc(gv_param *p);
/* The parameter's values become the numel bfloat16 values at bf16 (little-endian, any
 * alignment; the memory must outlive the parameter); its float32 buffer is freed. Frozen
 * parameters only. */
int gv_param_set_bf16(gv_param *p, const void *bf16, int mapped);
/* A bfloat16 parameter becomes float32 (a heap copy), e.g. before it is trained. */
int gv_param_materialize(gv_param *p);
/* n little-endian bfloat16 values to float32 (exact). */
void gv_bf16_to_f32_n(const unsigned char *src, float *dst, int64_t n);
/* The float32 values of t: t->data, or for a bfloat16 weight a converted copy in *scratch
 * (malloc'ed; the caller frees it), with the mapped pages dropped afterwards. NULL with a
 * message when out of memory or when a value is a NaN or infinite (a bad weight file). */
const float *gv_tensor_values(const gv_tensor *t, float **scratch);

#endif
