/* PLY 1.0 reading shared by the point-cloud and the 3DGS readers: the header (format,
 * elements, typed properties, lists), skipping to one element, and its rows as doubles.
 * Formats: ascii, binary_little_endian, binary_big_endian. Internal to src/io. */
#ifndef GAUSSVID_IO_PLY_HEADER_H
#define GAUSSVID_IO_PLY_HEADER_H

#include <stdint.h>
#include <stdio.h>

enum { PLY_MAX_ELEMENTS = 16, PLY_MAX_PROPERTIES = 256, PLY_NAME_MAX = 64 };

typedef enum { PLY_ASCII, PLY_BINARY_LE, PLY_BINARY_BE } ply_format;

/* The eight PLY scalar types; int8/uint8/int16/uint16/int32/uint32/float32/float64 are
 * read as aliases of them. */
typedef enum {
    PLY_CHAR, PLY_UCHAR, PLY_SHORT, PLY_USHORT, PLY_INT, PLY_UINT, PLY_FLOAT, PLY_DOUBLE
} ply_type;

typedef struct {
    char name[PLY_NAME_MAX];
    ply_type type;        /* the value type; for a list, the type of its items */
    int is_list;
    ply_type count_type;  /* for a list: the type of its length */
    int offset;           /* byte offset in a binary row of a list-free element */
} ply_property;

typedef struct {
    char name[PLY_NAME_MAX];
    int64_t count;
    int first_property;   /* its properties are header.properties[first .. first + n) */
    int n_properties;
    int row_size;         /* bytes of one binary row; 0 when the element has a list */
} ply_element;

typedef struct {
    ply_format format;
    int n_elements, n_properties;
    ply_element elements[PLY_MAX_ELEMENTS];
    ply_property properties[PLY_MAX_PROPERTIES];
    int64_t data_offset;  /* first byte after the end_header line */
    int header_lines;     /* lines up to and including end_header */
} ply_header;

/* An open PLY file, positioned at the rows of one element. */
typedef struct {
    const char *path;
    FILE *f;
    int64_t file_size;
    ply_header header;
    const ply_element *element;  /* the element whose rows are read (after ply_seek_element) */
    int64_t rows_read;
    int64_t line;                /* ASCII: number of the last line read */
    char *text;                  /* ASCII: line buffer */
    size_t text_capacity;
    unsigned char *record;       /* binary: one row */
} ply_file;

/* Bytes of one value of type t. */
int ply_type_size(ply_type t);
/* The PLY name of a type ("float", "uchar", ...). */
const char *ply_type_name(ply_type t);

/* Parses the header of the open file f (at its start) of file_size bytes; errors name path. */
int ply_header_parse(const char *path, FILE *f, int64_t file_size, ply_header *h);
/* Index of the element's property called name, or -1. */
int ply_find_property(const ply_header *h, const ply_element *e, const char *name);

/* Opens path and parses its header. */
int ply_open(ply_file *pf, const char *path);
/* Skips the elements before the one called name and checks that its declared rows fit in
 * the rest of the file. Refuses list properties in it. */
int ply_seek_element(ply_file *pf, const char *name);
/* Reads the next row of the element: values[0 .. n_properties) in declaration order. */
int ply_read_row(ply_file *pf, double *values);
/* Names the current row in messages: "vertex 12" or "vertex 12 (line 25)". */
const char *ply_row_name(const ply_file *pf, char *buffer, size_t size);
void ply_close(ply_file *pf);

#endif
