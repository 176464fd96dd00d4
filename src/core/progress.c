/* Progress bar with rate and ETA: redrawn in place on a terminal, plain lines otherwise. */
#include "gaussvid/core/core.h"

#include <stdarg.h>
#include <string.h>
#include <unistd.h>

#define BAR_WIDTH 24
#define TERMINAL_REDRAW_SECONDS 0.1
#define PLAIN_LINE_SECONDS 5.0

static _Thread_local int muted;

void gv_progress_mute_thread(int m) { muted = m; }

void gv_progress_start(gv_progress *p, const char *label, long total)
{
    memset(p, 0, sizeof *p);
    snprintf(p->label, sizeof p->label, "%s", label);
    p->total = total;
    p->start = gv_now();
    p->last_draw = p->start;
    p->enabled = gv_log_level() >= GV_LOG_INFO && !muted;
    p->on_terminal = isatty(fileno(stderr));
}

static void format_duration(char *out, size_t size, double seconds)
{
    if (seconds < 0 || seconds > 1e7) { snprintf(out, size, "--:--"); return; }
    long s = (long)(seconds + 0.5);
    if (s >= 3600) snprintf(out, size, "%ld:%02ld:%02ld", s / 3600, (s / 60) % 60, s % 60);
    else snprintf(out, size, "%02ld:%02ld", s / 60, s % 60);
}

static void draw(gv_progress *p, const char *extra, int final)
{
    double elapsed = gv_now() - p->start;
    double rate = elapsed > 0 ? (double)p->done / elapsed : 0;
    double eta = rate > 0 ? (double)(p->total - p->done) / rate : -1;
    char eta_text[32], elapsed_text[32];
    format_duration(eta_text, sizeof eta_text, eta);
    format_duration(elapsed_text, sizeof elapsed_text, elapsed);
    double fraction = p->total > 0 ? (double)p->done / (double)p->total : 0;
    if (fraction > 1) fraction = 1;
    /* slow items (a restored clip takes seconds): seconds each, not "0.0/s" */
    char rate_text[32];
    if (rate > 0 && rate < 1) snprintf(rate_text, sizeof rate_text, "%.1f s each", 1 / rate);
    else snprintf(rate_text, sizeof rate_text, "%.1f/s", rate);

    if (p->on_terminal) {
        char bar[BAR_WIDTH + 1];
        int filled = (int)(fraction * BAR_WIDTH + 0.5);
        for (int i = 0; i < BAR_WIDTH; i++) bar[i] = i < filled ? '#' : '.';
        bar[BAR_WIDTH] = '\0';
        fprintf(stderr, "\r\033[K%s [%s] %ld/%ld %s %s %s%s%s", p->label, bar, p->done,
                p->total, rate_text, final ? elapsed_text : eta_text, final ? "" : "left",
                extra && extra[0] ? "  " : "", extra ? extra : "");
        if (final) fputc('\n', stderr);
    } else {
        fprintf(stderr, "%s %ld/%ld (%3.0f%%) %s elapsed %s eta %s%s%s\n", p->label, p->done,
                p->total, 100 * fraction, rate_text, elapsed_text, final ? "00:00" : eta_text,
                extra && extra[0] ? "  " : "", extra ? extra : "");
    }
    fflush(stderr);
}

void gv_progress_update(gv_progress *p, long done, const char *extra, ...)
{
    p->done = done;
    if (!p->enabled) return;
    double now = gv_now();
    double interval = p->on_terminal ? TERMINAL_REDRAW_SECONDS : PLAIN_LINE_SECONDS;
    if (now - p->last_draw < interval && done < p->total) return;
    p->last_draw = now;
    char text[256] = "";
    if (extra) {
        va_list ap;
        va_start(ap, extra);
        vsnprintf(text, sizeof text, extra, ap);
        va_end(ap);
    }
    if (done < p->total) draw(p, text, 0);
}

void gv_progress_note(gv_progress *p, const char *fmt, ...)
{
    if (gv_log_level() < GV_LOG_INFO) return;
    if (p->enabled && p->on_terminal) fputs("\r\033[K", stderr); /* the bar's line, redrawn next update */
    va_list ap;
    va_start(ap, fmt);
    vfprintf(stderr, fmt, ap);
    va_end(ap);
    fputc('\n', stderr);
    fflush(stderr);
    p->last_draw = 0;
}

void gv_progress_finish(gv_progress *p)
{
    if (!p->enabled) return;
    draw(p, "", 1);
}
