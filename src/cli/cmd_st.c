/* gaussvid st: safetensors files. `st inspect FILE [--json]` checks a file as strictly as the
 * reference reader and lists its tensors (name, dtype, shape, bytes), sizes and metadata. */
#include <cjson/cJSON.h>
#include <inttypes.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "cli/commands.h"
#include "gaussvid/core/core.h"
#include "gaussvid/io/safetensors.h"

/* Metadata values longer than this are cut in the text listing (--json gives them whole). */
enum { VALUE_PREVIEW = 160 };

static const char *human_bytes(char *out, size_t size, uint64_t bytes)
{
    static const char *units[] = {"B", "KiB", "MiB", "GiB", "TiB"};
    double v = (double)bytes;
    int u = 0;
    while (v >= 1024 && u < 4) { v /= 1024; u++; }
    if (u == 0) snprintf(out, size, "%" PRIu64 " B", bytes);
    else snprintf(out, size, "%.1f %s", v, units[u]);
    return out;
}

/* The tensors in name order (the order Python's safe_open.keys() gives). */
static int by_tensor_name(const void *a, const void *b)
{
    return strcmp((*(const gv_st_tensor *const *)a)->name, (*(const gv_st_tensor *const *)b)->name);
}

static const gv_st_tensor **name_order(const gv_st_file *f)
{
    const gv_st_tensor **order = malloc(((size_t)f->n_tensors + 1) * sizeof *order);
    if (!order) return NULL;
    for (int i = 0; i < f->n_tensors; i++) order[i] = &f->tensors[i];
    qsort(order, (size_t)f->n_tensors, sizeof *order, by_tensor_name);
    return order;
}

/* One metadata value on one line: control bytes shown as spaces, long values cut at a
 * character boundary. */
static void print_value(const char *value)
{
    size_t len = strlen(value), shown = len;
    if (len > VALUE_PREVIEW) {
        shown = VALUE_PREVIEW;
        while (shown > 0 && ((unsigned char)value[shown] & 0xc0) == 0x80) shown--;
    }
    for (size_t i = 0; i < shown; i++)
        putchar((unsigned char)value[i] < 0x20 ? ' ' : value[i]);
    if (shown < len) printf(" ... (%zu bytes; --json shows all)", len);
    putchar('\n');
}

static void print_text(const gv_st_file *f, const gv_st_tensor **order)
{
    char size_text[32], shape[256];
    int width = 4;
    uint64_t elements = 0;
    for (int i = 0; i < f->n_tensors; i++) {
        int len = (int)strlen(f->tensors[i].name);
        width = len > width ? (len < 60 ? len : 60) : width;
        elements += (uint64_t)f->tensors[i].n_elements;
    }
    printf("%s: safetensors, %" PRIu64 " bytes (header %" PRIu64 ", data %" PRIu64 ")\n",
           f->path, f->file_size, f->header_size, f->data_size);
    printf("  %-*s %-7s %-20s %14s\n", width, "NAME", "DTYPE", "SHAPE", "BYTES");
    for (int i = 0; i < f->n_tensors; i++) {
        const gv_st_tensor *t = order[i];
        printf("  %-*s %-7s %-20s %14" PRIu64 "\n", width, t->name, gv_st_dtype_name(t->dtype),
               gv_st_shape_str(shape, sizeof shape, t->shape, t->rank), t->end - t->begin);
    }
    printf("total: %d tensors, %" PRIu64 " elements, %" PRIu64 " bytes (%s)\n", f->n_tensors,
           elements, f->data_size, human_bytes(size_text, sizeof size_text, f->data_size));
    printf("metadata: %d %s\n", f->n_metadata, f->n_metadata == 1 ? "entry" : "entries");
    for (int i = 0; i < f->n_metadata; i++) {
        printf("  %s: ", f->metadata_keys[i]);
        print_value(f->metadata_values[i]);
    }
}

static cJSON *tensor_json(const gv_st_tensor *t)
{
    cJSON *o = cJSON_CreateObject(), *shape = cJSON_CreateArray(), *offsets = cJSON_CreateArray();
    cJSON_AddStringToObject(o, "name", t->name);
    cJSON_AddStringToObject(o, "dtype", gv_st_dtype_name(t->dtype));
    for (int k = 0; k < t->rank; k++) cJSON_AddItemToArray(shape, cJSON_CreateNumber((double)t->shape[k]));
    cJSON_AddItemToObject(o, "shape", shape);
    cJSON_AddItemToArray(offsets, cJSON_CreateNumber((double)t->begin));
    cJSON_AddItemToArray(offsets, cJSON_CreateNumber((double)t->end));
    cJSON_AddItemToObject(o, "data_offsets", offsets);
    cJSON_AddNumberToObject(o, "bytes", (double)(t->end - t->begin));
    return o;
}

static int print_json(const gv_st_file *f, const gv_st_tensor **order)
{
    cJSON *root = cJSON_CreateObject(), *tensors = cJSON_CreateArray(), *meta = cJSON_CreateObject();
    uint64_t elements = 0;
    for (int i = 0; i < f->n_tensors; i++) {
        cJSON_AddItemToArray(tensors, tensor_json(order[i]));
        elements += (uint64_t)f->tensors[i].n_elements;
    }
    for (int i = 0; i < f->n_metadata; i++)
        cJSON_AddStringToObject(meta, f->metadata_keys[i], f->metadata_values[i]);
    cJSON_AddStringToObject(root, "file", f->path);
    cJSON_AddNumberToObject(root, "file_bytes", (double)f->file_size);
    cJSON_AddNumberToObject(root, "header_bytes", (double)f->header_size);
    cJSON_AddNumberToObject(root, "data_bytes", (double)f->data_size);
    cJSON_AddNumberToObject(root, "n_tensors", f->n_tensors);
    cJSON_AddNumberToObject(root, "n_elements", (double)elements);
    cJSON_AddItemToObject(root, "tensors", tensors);
    cJSON_AddItemToObject(root, "metadata", meta);
    char *text = cJSON_Print(root);
    cJSON_Delete(root);
    if (!text) return gv_fail("%s: out of memory for the JSON listing", f->path);
    printf("%s\n", text);
    free(text);
    return 0;
}

static int cmd_st_inspect(int argc, char **argv)
{
    int json = 0;
    const gv_flag flags[] = {
        {"json", GV_FLAG_BOOL, &json, NULL, "print the listing as JSON", 0},
    };
    const gv_command_spec spec = {
        "st inspect", "FILE", "check a safetensors file and list its tensors and metadata",
        "The file is checked as the reference reader checks it (header length, JSON, dtypes,\n"
        "shapes, offsets that tile the data exactly, unique names, string metadata); a bad\n"
        "file gives one line saying what is wrong and exit code 1. Tensors are listed by\n"
        "name with dtype, shape and size in bytes. See docs/SAFETENSORS.md.",
        flags, 1, 1, 1};
    char *positional[1];
    int n_positional = 0;
    int parsed = gv_args_parse(&spec, argc, argv, positional, &n_positional);
    if (parsed != GV_ARGS_OK) return gv_args_exit_code(parsed);

    gv_st_file f;
    if (gv_st_open(&f, positional[0]) != 0) return gv_report_failure();
    const gv_st_tensor **order = name_order(&f);
    int rc = 0;
    if (!order) rc = gv_fail("%s: out of memory", f.path);
    else if (json) rc = print_json(&f, order);
    else print_text(&f, order);
    free((void *)order);
    gv_st_close(&f);
    return rc ? gv_report_failure() : 0;
}

static const gv_subcommand st_commands[] = {
    {"inspect", cmd_st_inspect, "check a safetensors file; list its tensors and metadata"},
};

int cmd_st(int argc, char **argv)
{
    return gv_run_subcommand("st", st_commands, 1, argc, argv);
}
