/* The PLY 1.0 header (Turk's format): "ply", one "format" line, "comment" and "obj_info"
 * lines, "element NAME COUNT" each followed by its "property TYPE NAME" or
 * "property list COUNT_TYPE ITEM_TYPE NAME" lines, and "end_header". */
#include "io/ply_header.h"

#include <errno.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>

#include "gaussvid/core/core.h"

/* A header longer than this is not a header: a binary file without end_header. */
enum { PLY_HEADER_MAX_BYTES = 1 << 20, PLY_LINE_MAX = 1024, PLY_MAX_TOKENS = 8 };

static const struct { const char *name; ply_type type; } type_names[] = {
    {"char", PLY_CHAR},   {"uchar", PLY_UCHAR},   {"short", PLY_SHORT}, {"ushort", PLY_USHORT},
    {"int", PLY_INT},     {"uint", PLY_UINT},     {"float", PLY_FLOAT}, {"double", PLY_DOUBLE},
    {"int8", PLY_CHAR},   {"uint8", PLY_UCHAR},   {"int16", PLY_SHORT}, {"uint16", PLY_USHORT},
    {"int32", PLY_INT},   {"uint32", PLY_UINT},   {"float32", PLY_FLOAT},
    {"float64", PLY_DOUBLE},
};

int ply_type_size(ply_type t)
{
    static const int sizes[] = {1, 1, 2, 2, 4, 4, 4, 8};
    return sizes[t];
}

const char *ply_type_name(ply_type t)
{
    return type_names[t].name;  /* the first eight entries are in enum order */
}

static int parse_type(const char *word, ply_type *t)
{
    for (size_t i = 0; i < sizeof type_names / sizeof type_names[0]; i++) {
        if (!strcmp(word, type_names[i].name)) {
            *t = type_names[i].type;
            return 0;
        }
    }
    return -1;
}

/* Reads one header line (without its "\n" or "\r\n") into line. Returns 1 for a line, 0 at
 * the end of the file, -1 (with a message) for a line that cannot be a header line. */
static int read_header_line(const char *path, FILE *f, int number, char *line, int64_t *bytes)
{
    int length = 0, c;
    while ((c = getc(f)) != EOF) {
        if (++*bytes > PLY_HEADER_MAX_BYTES)
            return gv_fail("%s: no end_header in the first %d bytes", path, PLY_HEADER_MAX_BYTES);
        if (c == '\n') break;
        if (c == '\0') return gv_fail("%s: header line %d: binary data before end_header", path, number);
        if (length == PLY_LINE_MAX - 1) return gv_fail("%s: header line %d is too long", path, number);
        line[length++] = (char)c;
    }
    if (c == EOF && length == 0) return 0;
    if (length > 0 && line[length - 1] == '\r') length--;
    line[length] = '\0';
    return 1;
}

static int split(char *line, char **tokens)
{
    int n = 0;
    char *save = NULL;
    for (char *t = strtok_r(line, " \t", &save); t; t = strtok_r(NULL, " \t", &save)) {
        if (n == PLY_MAX_TOKENS) return n + 1;
        tokens[n++] = t;
    }
    return n;
}

static int parse_format(const char *path, int number, char **tok, int n, ply_header *h)
{
    if (n != 3) return gv_fail("%s: header line %d: expected 'format TYPE 1.0'", path, number);
    if (!strcmp(tok[1], "ascii")) h->format = PLY_ASCII;
    else if (!strcmp(tok[1], "binary_little_endian")) h->format = PLY_BINARY_LE;
    else if (!strcmp(tok[1], "binary_big_endian")) h->format = PLY_BINARY_BE;
    else return gv_fail("%s: header line %d: unknown format '%s'", path, number, tok[1]);
    if (strcmp(tok[2], "1.0") && strcmp(tok[2], "1"))
        return gv_fail("%s: header line %d: unsupported PLY version '%s' (only 1.0)", path,
                       number, tok[2]);
    return 0;
}

static int parse_element(const char *path, int number, char **tok, int n, ply_header *h)
{
    if (n != 3) return gv_fail("%s: header line %d: expected 'element NAME COUNT'", path, number);
    if (h->n_elements == PLY_MAX_ELEMENTS)
        return gv_fail("%s: more than %d elements", path, PLY_MAX_ELEMENTS);
    if (strlen(tok[1]) >= PLY_NAME_MAX)
        return gv_fail("%s: header line %d: element name too long", path, number);
    char *end;
    errno = 0;
    long long count = strtoll(tok[2], &end, 10);
    if (errno || *end || end == tok[2] || count < 0)
        return gv_fail("%s: header line %d: bad count '%s' for element '%s'", path, number,
                       tok[2], tok[1]);
    for (int i = 0; i < h->n_elements; i++)
        if (!strcmp(h->elements[i].name, tok[1]))
            return gv_fail("%s: header line %d: element '%s' declared twice", path, number, tok[1]);
    ply_element *e = &h->elements[h->n_elements++];
    memset(e, 0, sizeof *e);
    strcpy(e->name, tok[1]);
    e->count = count;
    e->first_property = h->n_properties;
    return 0;
}

static int parse_property(const char *path, int number, char **tok, int n, ply_header *h)
{
    if (h->n_elements == 0)
        return gv_fail("%s: header line %d: property before any element", path, number);
    ply_element *e = &h->elements[h->n_elements - 1];
    if (h->n_properties == PLY_MAX_PROPERTIES)
        return gv_fail("%s: more than %d properties", path, PLY_MAX_PROPERTIES);
    ply_property p = {0};
    int is_list = n >= 2 && !strcmp(tok[1], "list");
    if (n != (is_list ? 5 : 3))
        return gv_fail("%s: header line %d: expected 'property TYPE NAME' or 'property list "
                       "COUNT_TYPE ITEM_TYPE NAME'", path, number);
    const char *name = tok[n - 1];
    p.is_list = is_list;
    if (is_list && parse_type(tok[2], &p.count_type))
        return gv_fail("%s: header line %d: unknown type '%s'", path, number, tok[2]);
    if (is_list && (p.count_type == PLY_FLOAT || p.count_type == PLY_DOUBLE))
        return gv_fail("%s: header line %d: list length type '%s' is not an integer type",
                       path, number, tok[2]);
    if (parse_type(tok[n - 2], &p.type))
        return gv_fail("%s: header line %d: unknown type '%s'", path, number, tok[n - 2]);
    if (strlen(name) >= PLY_NAME_MAX)
        return gv_fail("%s: header line %d: property name too long", path, number);
    if (ply_find_property(h, e, name) >= 0)
        return gv_fail("%s: header line %d: property '%s' declared twice in element '%s'", path,
                       number, name, e->name);
    strcpy(p.name, name);
    p.offset = e->row_size;
    h->properties[h->n_properties++] = p;
    e->n_properties++;
    /* Rows with a list have no fixed size; row_size stays 0 from then on. */
    int listed = is_list;
    for (int i = 0; i < e->n_properties - 1; i++)
        listed |= h->properties[e->first_property + i].is_list;
    e->row_size = listed ? 0 : e->row_size + ply_type_size(p.type);
    return 0;
}

int ply_header_parse(const char *path, FILE *f, int64_t file_size, ply_header *h)
{
    memset(h, 0, sizeof *h);
    char line[PLY_LINE_MAX], *tok[PLY_MAX_TOKENS];
    int64_t bytes = 0;
    int have_format = 0;
    for (int number = 1;; number++) {
        int got = read_header_line(path, f, number, line, &bytes);
        if (got < 0) return -1;
        if (got == 0) {
            if (number == 1) return gv_fail("%s: empty file, not a PLY file", path);
            return gv_fail("%s: header has no end_header line", path);
        }
        if (number == 1) {
            if (strcmp(line, "ply")) return gv_fail("%s: not a PLY file (no 'ply' first line)", path);
            continue;
        }
        int n = split(line, tok);
        if (n == 0) continue;  /* a blank line */
        if (n > PLY_MAX_TOKENS && strcmp(tok[0], "comment") && strcmp(tok[0], "obj_info"))
            return gv_fail("%s: header line %d has too many words", path, number);
        int rc = 0;
        if (!strcmp(tok[0], "comment") || !strcmp(tok[0], "obj_info")) continue;
        if (!strcmp(tok[0], "end_header")) {
            if (!have_format) return gv_fail("%s: header has no format line", path);
            h->data_offset = bytes;
            h->header_lines = number;
            if (bytes > file_size) return gv_fail("%s: file changed while reading", path);
            return 0;
        }
        if (!strcmp(tok[0], "format")) {
            if (have_format) return gv_fail("%s: header line %d: second format line", path, number);
            rc = parse_format(path, number, tok, n, h);
            have_format = 1;
        } else if (!strcmp(tok[0], "element")) {
            if (!have_format)
                return gv_fail("%s: header line %d: element before the format line", path, number);
            rc = parse_element(path, number, tok, n, h);
        } else if (!strcmp(tok[0], "property")) {
            rc = parse_property(path, number, tok, n, h);
        } else {
            /* A number where a keyword should be: data rows, so end_header was left out. */
            int data = strchr("0123456789-+.", tok[0][0]) != NULL;
            return gv_fail("%s: header line %d: unknown keyword '%.32s'%s", path, number, tok[0],
                           data ? " (data before end_header: no end_header line?)" : "");
        }
        if (rc) return -1;
    }
}

int ply_find_property(const ply_header *h, const ply_element *e, const char *name)
{
    for (int i = 0; i < e->n_properties; i++)
        if (!strcmp(h->properties[e->first_property + i].name, name)) return i;
    return -1;
}

int ply_open(ply_file *pf, const char *path)
{
    memset(pf, 0, sizeof *pf);
    pf->path = path;
    pf->f = fopen(path, "rb");
    if (!pf->f) return gv_fail("%s: cannot open: %s", path, strerror(errno));
    struct stat st;
    if (fstat(fileno(pf->f), &st) != 0 || !S_ISREG(st.st_mode)) {
        ply_close(pf);
        return gv_fail("%s: not a regular file", path);
    }
    pf->file_size = (int64_t)st.st_size;
    if (ply_header_parse(path, pf->f, pf->file_size, &pf->header) != 0) {
        ply_close(pf);
        return -1;
    }
    pf->line = pf->header.header_lines;
    return 0;
}

void ply_close(ply_file *pf)
{
    if (pf->f) fclose(pf->f);
    free(pf->text);
    free(pf->record);
    pf->f = NULL;
    pf->text = NULL;
    pf->record = NULL;
}
