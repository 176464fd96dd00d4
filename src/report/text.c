/* A growable text for building the pages in memory before one atomic write. An allocation
 * failure is remembered and reported once, at the write, so builders need not check each
 * append. */
#include "report_internal.h"

#include "gaussvid/core/core.h"

#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

static int reserve(report_text *t, size_t extra)
{
    if (t->failed) return -1;
    if (t->length + extra + 1 <= t->capacity) return 0;
    size_t capacity = t->capacity ? t->capacity : 4096;
    while (capacity < t->length + extra + 1) capacity *= 2;
    char *data = realloc(t->data, capacity);
    if (!data) {
        t->failed = 1;
        return -1;
    }
    t->data = data;
    t->capacity = capacity;
    return 0;
}

void text_append_n(report_text *t, const char *s, size_t n)
{
    if (reserve(t, n) != 0) return;
    memcpy(t->data + t->length, s, n);
    t->length += n;
    t->data[t->length] = '\0';
}

void text_append(report_text *t, const char *s) { text_append_n(t, s, strlen(s)); }

void text_printf(report_text *t, const char *fmt, ...)
{
    va_list ap;
    va_start(ap, fmt);
    int n = vsnprintf(NULL, 0, fmt, ap);
    va_end(ap);
    if (n < 0 || reserve(t, (size_t)n) != 0) return;
    va_start(ap, fmt);
    vsnprintf(t->data + t->length, (size_t)n + 1, fmt, ap);
    va_end(ap);
    t->length += (size_t)n;
}

void text_escaped(report_text *t, const char *s)
{
    for (; *s; s++) {
        switch (*s) {
        case '&': text_append(t, "&amp;"); break;
        case '<': text_append(t, "&lt;"); break;
        case '>': text_append(t, "&gt;"); break;
        case '"': text_append(t, "&quot;"); break;
        case '\'': text_append(t, "&#39;"); break;
        default: text_append_n(t, s, 1);
        }
    }
}

void text_free(report_text *t)
{
    free(t->data);
    memset(t, 0, sizeof *t);
}

int text_write_atomic(const report_text *t, const char *path)
{
    if (t->failed) return gv_fail("%s: out of memory building the page", path);
    gv_atomic_file af;
    if (gv_atomic_open(&af, path) != 0) return -1;
    if (t->length && fwrite(t->data, 1, t->length, af.f) != t->length) {
        gv_atomic_abort(&af);
        return gv_fail("%s: write error", path);
    }
    return gv_atomic_commit(&af);
}
