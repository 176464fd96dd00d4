/* Weight files in the layouts models are published in, all read through the safetensors
 * handle (gv_st_file, safetensors.h), so every loader that takes a safetensors file takes
 * them too:
 *   - a safetensors file;
 *   - a sharded checkpoint's "*.safetensors.index.json" (its "weight_map" names the shard of
 *     every tensor): the shards are opened and presented as one file;
 *   - a PyTorch zip checkpoint (.pth/.pt, torch.save since PyTorch 1.6): its data.pkl is read
 *     by a small bounded unpickler that accepts only what a state dict needs and executes
 *     nothing, and its tensors point into the mapped data/N storages.
 * docs/SAFETENSORS.md ("Sharded checkpoints") and docs/PTH.md. Close with gv_st_close.
 * The PyTorch reader and this opener are the module src/pth/ (above io, whose safetensors
 * reader they build on). */
#ifndef GAUSSVID_WEIGHT_FILES_H
#define GAUSSVID_WEIGHT_FILES_H

#include "gaussvid/io/safetensors.h"

/* Opens any of the three, told apart by their first bytes (a zip starts "PK\3\4", an index
 * with "{", a safetensors file with its 8-byte header length, which is never either); the
 * index is opened by gv_st_index_open (safetensors.h). */
int gv_weights_open(gv_st_file *f, const char *path);
/* Opens a PyTorch zip checkpoint holding a state dict (a dict or OrderedDict of tensor name
 * to tensor). Tensors keep their storage's dtype (F32, F16, BF16, F64, integer types);
 * header_size is the pickle's size and data_size the storages'. */
int gv_pth_open(gv_st_file *f, const char *path);

#endif
