/* safetensors internals shared by the reader's files. Internal to src/io. */
#ifndef GAUSSVID_IO_SAFETENSORS_INTERNAL_H
#define GAUSSVID_IO_SAFETENSORS_INTERNAL_H

#include <stddef.h>

#include "gaussvid/io/safetensors.h"

/* gv_st_open of a file already open as fd (read-only), which it closes whatever happens:
 * whoever looked at the first bytes (weights_open.c) does not open the file twice. */
int gv_st_open_fd(gv_st_file *f, const char *path, int fd);

/* Parses and checks the header JSON `text` (n bytes, text[n] == '\0') of f->path, whose data
 * region holds f->data_size bytes; fills f's tensors (sorted by offset, data pointers unset),
 * name index and metadata. On failure records one message; gv_st_close frees what was set. */
int gv_st_parse_header(gv_st_file *f, const char *text, size_t n);
/* Builds f->by_name (tensor indices sorted by name) for gv_st_find; fails, naming f->path,
 * when a name appears twice. */
int gv_st_build_name_index(gv_st_file *f);
/* The name of tensors[i] (gv_name_of, core.h). */
const char *gv_st_tensor_name(const void *tensors, int i);
/* Whether the n bytes at s are valid UTF-8 (no overlong forms, surrogates or values above
 * U+10FFFF): the reference decodes headers as UTF-8 and refuses anything else. */
int gv_st_utf8_valid(const char *s, size_t n);
/* Fails, naming `path` and `what` (e.g. "metadata key"), when two of the n strings are equal. */
int gv_st_check_unique(const char *path, const char *what, const char **strings, int n);

#endif
