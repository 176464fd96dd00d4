/* The sparse-view split and the interval rule (docs/ARCHITECTURE.md section 5;
 * include/gaussvid/scene/scene.h): for an interval n, frames 0, n, 2n, ... (in image-name order)
 * are the training views and every other frame is held out; which n a use accepts, and the one
 * parser of interval lists. */
#include <stdio.h>
#include <stdlib.h>

#include "gaussvid/core/core.h"
#include "gaussvid/scene/scene.h"

int gv_scene_is_train(int frame, int interval)
{
    return frame % interval == 0;
}

/* The smallest n above 1 that the use takes (n = 1 is taken by every use but clips). */
static int range_start(gv_interval_use use)
{
    return use == GV_INTERVAL_RECONSTRUCT ? GV_INTERVAL_CLIP_HELD_OUT + 1 : use == GV_INTERVAL_CLIPS ? 2 : 1;
}

static const char *use_name(gv_interval_use use)
{
    return use == GV_INTERVAL_RECONSTRUCT ? "reconstruct" : use == GV_INTERVAL_CLIPS ? "a clip" : "a split";
}

static const char *use_reason(gv_interval_use use)
{
    switch (use) {
    case GV_INTERVAL_CLIPS: return "at n = 1 no frame is held out";
    case GV_INTERVAL_RECONSTRUCT:
        return "a clip restores 3 held-out frames between two training views; n = 1 trains on every view and "
               "restores a smooth path between them";
    default: return "frames 0, n, 2n, ... train";
    }
}

void gv_interval_range(gv_interval_use use, int n_frames, char *out, size_t size)
{
    int last = n_frames > 0 && n_frames - 1 < GV_INTERVAL_MAX ? n_frames - 1 : GV_INTERVAL_MAX;
    int start = range_start(use), one = use != GV_INTERVAL_CLIPS && last >= 1;
    if (start > last && !one) snprintf(out, size, "no n");
    else if (start > last || (start == 1 && last == 1)) snprintf(out, size, "n = 1");
    else if (start == last) snprintf(out, size, one && start > 1 ? "n = 1 or n = %d" : "n = %d", last);
    else if (one && start > 1) snprintf(out, size, "n = 1 or %d <= n <= %d", start, last);
    else snprintf(out, size, "%d <= n <= %d", start, last);
}

int gv_interval_check(int n, int n_frames, gv_interval_use use)
{
    char range[64];
    gv_interval_range(use, n_frames, range, sizeof range);
    if (n_frames > 0 && n >= 1 && n > n_frames - 1)
        return gv_fail("interval %d leaves 1 training frame of the scene's %d frame%s (frames 0, n, 2n, ...); at "
                       "least 2 are needed: %s takes %s on this scene", n, n_frames, n_frames == 1 ? "" : "s",
                       use_name(use), range);
    if (n < 1 || n > GV_INTERVAL_MAX || (n < range_start(use) && !(n == 1 && use != GV_INTERVAL_CLIPS)))
        return gv_fail("interval %d: %s takes %s%s (%s)", n, use_name(use), range, n_frames > 0 ? " on this scene" : "",
                       use_reason(use));
    return 0;
}

int gv_scene_split(int n_frames, int interval, int *train, int *n_train, int *held_out,
                   int *n_held_out)
{
    *n_train = *n_held_out = 0;
    if (n_frames < 2) return gv_fail("the scene has %d frame(s); a split needs at least 2", n_frames);
    if (gv_interval_check(interval, n_frames, GV_INTERVAL_SPLIT)) return -1;
    for (int i = 0; i < n_frames; i++) {
        if (gv_scene_is_train(i, interval)) train[(*n_train)++] = i;
        else held_out[(*n_held_out)++] = i;
    }
    return 0;
}

/* Reads one positive decimal number at *p (digits only), advancing it; 0 when none or too big. */
static long read_count(const char **p)
{
    long v = 0;
    if (**p < '0' || **p > '9') return 0;
    while (**p >= '0' && **p <= '9') {
        if (v <= GV_INTERVAL_MAX) v = v * 10 + (**p - '0');
        (*p)++;
    }
    return v;
}

/* Appends a..b step s to the list, each value checked, none listed before. */
static int add_values(const char *text, long a, long b, long s, gv_interval_use use, int *intervals, int max,
                      int *count)
{
    for (long x = a; x <= b; x += s) {
        if (gv_interval_check((int)x, 0, use)) return gv_fail_context("intervals '%s'", text);
        for (int i = 0; i < *count; i++)
            if (intervals[i] == x) return gv_fail("intervals '%s': %ld is listed twice", text, x);
        if (*count == max) return gv_fail("intervals '%s': more than %d values", text, max);
        intervals[(*count)++] = (int)x;
    }
    return 0;
}

int gv_interval_parse(const char *text, gv_interval_use use, int *intervals, int max, int *count)
{
    *count = 0;
    const char *p = text;
    for (;;) {
        long v[3] = {0, 0, 1};
        int parts = 0;
        do {
            if (parts == 3) return gv_fail("intervals '%s': an item has more than 3 parts (a:b:s)", text);
            if (parts > 0) p++; /* the ':' */
            const char *at = p;
            if ((v[parts++] = read_count(&p)) == 0 && at == p)
                return gv_fail("intervals '%s': expected a number at '%s'", text, at);
        } while (*p == ':');
        if (*p && *p != ',') return gv_fail("intervals '%s': unexpected '%c'", text, *p);
        if (parts == 1) v[1] = v[0];
        if (parts > 1 && (v[0] > v[1] || v[2] < 1))
            return gv_fail("intervals '%s': a range a:b:s needs a <= b and a step s >= 1", text);
        if (add_values(text, v[0], v[1], v[2], use, intervals, max, count)) return -1;
        if (!*p) break;
        p++; /* the ',' */
    }
    return 0;
}
