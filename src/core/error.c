/* Per-thread error message: one line naming the input and what is wrong. */
#include "gaussvid/core/core.h"

#include <stdarg.h>
#include <stdio.h>
#include <string.h>

static _Thread_local char error_message[1024];

/* A message quotes what it found in the file (a key, a name, a line), and the file may hold
 * any byte: a control byte (a newline in a JSON key, say) becomes '?', so the message stays
 * the one line docs/ARCHITECTURE.md section 4 promises. */
static void keep_one_line(char *s)
{
    for (; *s; s++)
        if ((unsigned char)*s < 0x20 || *s == 0x7f) *s = '?';
}

int gv_fail(const char *fmt, ...)
{
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(error_message, sizeof error_message, fmt, ap);
    va_end(ap);
    keep_one_line(error_message);
    return -1;
}

int gv_fail_context(const char *fmt, ...)
{
    char prefix[512], previous[1024];
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(prefix, sizeof prefix, fmt, ap);
    va_end(ap);
    memcpy(previous, error_message, sizeof previous);
    snprintf(error_message, sizeof error_message, "%s: %s", prefix,
             previous[0] ? previous : "failed");
    keep_one_line(error_message);
    return -1;
}

const char *gv_last_error(void)
{
    return error_message[0] ? error_message : "unknown error";
}

void gv_clear_error(void)
{
    error_message[0] = '\0';
}

int gv_report_failure(void)
{
    fprintf(stderr, "gaussvid: %s\n", gv_last_error());
    return 1;
}
