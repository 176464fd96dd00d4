/* A bounded unpickler for the one thing a PyTorch checkpoint's data.pkl must hold to be read
 * here: a state dict, i.e. a dict (or collections.OrderedDict) of tensor name to tensor, each
 * tensor rebuilt by torch._utils._rebuild_tensor_v2 from a storage named by a persistent id
 * ('storage', torch.<Type>Storage, key, location, numel). It interprets opcodes into plain
 * data, never imports or calls anything, and refuses every opcode and global outside that set
 * with one line naming the input, the byte and the opcode or global (docs/PTH.md lists the
 * accepted ones). Internal to src/io (and its tests). */
#ifndef GAUSSVID_IO_PICKLE_INTERNAL_H
#define GAUSSVID_IO_PICKLE_INTERNAL_H

#include <stddef.h>
#include <stdint.h>

#include "gaussvid/io/safetensors.h"

/* Bounds that hold long before a real state dict is near them (Wan2.1-VACE-14B's would be
 * about 100 KB of pickle and a few MB of objects): they keep a hostile file from making the
 * reader allocate or recurse without limit. */
#define GV_PICKLE_MAX_BYTES (64 << 20)     /* data.pkl size */
#define GV_PICKLE_MAX_OBJECTS_BYTES (256 << 20) /* memory for the decoded objects */
#define GV_PICKLE_MAX_STACK (1 << 20)      /* stack entries */
#define GV_PICKLE_MAX_MEMO (1 << 22)       /* memo index */
#define GV_PICKLE_MAX_RANK 8

typedef struct {
    const char *name;          /* the state dict's key */
    gv_st_dtype dtype;         /* from the storage class: FloatStorage -> F32, ... */
    const char *storage_key;   /* the storage's file is data/<key> in the zip */
    int64_t storage_numel;     /* elements of the storage, as the persistent id says */
    int64_t offset;            /* storage_offset, in elements */
    int rank;
    int64_t shape[GV_PICKLE_MAX_RANK], stride[GV_PICKLE_MAX_RANK]; /* strides in elements */
} gv_pickle_tensor;

typedef struct {
    int n;
    gv_pickle_tensor *tensors; /* in the dict's order */
    void *arena;               /* private: owns every string and the tensors */
} gv_pickle_state_dict;

/* Reads a state dict from the n bytes of a pickle; `what` names the input in messages (e.g.
 * "Wan2.1_VAE.pth: Wan2.1_VAE/data.pkl"). Shapes are checked for overflow and strides for
 * range here; whether a tensor fits its storage is the caller's check (it knows the storage's
 * bytes). On failure records one message and leaves *out empty. */
int gv_pickle_read_state_dict(const char *what, const uint8_t *data, size_t n, gv_pickle_state_dict *out);
void gv_pickle_state_dict_free(gv_pickle_state_dict *sd);

#endif
