/* Log lines on stderr, filtered by one process-wide level (set once from --quiet). */
#include "gaussvid/core/core.h"

#include <stdarg.h>
#include <stdio.h>
#include <time.h>

static int log_level = GV_LOG_INFO;

void gv_log_set_level(int level) { log_level = level; }
int gv_log_level(void) { return log_level; }

static void log_line(const char *prefix, const char *fmt, va_list ap)
{
    fputs(prefix, stderr);
    vfprintf(stderr, fmt, ap);
    fputc('\n', stderr);
}

void gv_info(const char *fmt, ...)
{
    if (log_level < GV_LOG_INFO) return;
    va_list ap;
    va_start(ap, fmt);
    log_line("", fmt, ap);
    va_end(ap);
}

void gv_debug(const char *fmt, ...)
{
    if (log_level < GV_LOG_DEBUG) return;
    va_list ap;
    va_start(ap, fmt);
    log_line("debug: ", fmt, ap);
    va_end(ap);
}

void gv_warn(const char *fmt, ...)
{
    va_list ap;
    va_start(ap, fmt);
    log_line("warning: ", fmt, ap);
    va_end(ap);
}

double gv_now(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (double)ts.tv_sec + 1e-9 * (double)ts.tv_nsec;
}

double gv_cpu_now(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &ts);
    return (double)ts.tv_sec + 1e-9 * (double)ts.tv_nsec;
}
