/* Which frames make a clip (paper section 3.2, "Anchor-Based Clip Sampling"): two training
 * views as clean anchors and three held-out frames between them; and which clips a
 * (scene, n) run keeps. The rules are in include/gaussvid/data/dataset.h. */
#include <stdlib.h>
#include <string.h>

#include "gaussvid/core/core.h"
#include "gaussvid/data/dataset.h"

static const char *sampling_names[] = {"uniform", "random", "released"};

const char *gv_sampling_name(gv_clip_sampling sampling)
{
    if ((unsigned)sampling > GV_SAMPLING_RELEASED) return "unknown";
    return sampling_names[sampling];
}

int gv_sampling_from_name(const char *name, gv_clip_sampling *out)
{
    for (int i = 0; i <= GV_SAMPLING_RELEASED; i++) {
        if (!strcmp(name, sampling_names[i])) {
            *out = (gv_clip_sampling)i;
            return 0;
        }
    }
    return gv_fail("sampling '%s': expected uniform, random or released", name);
}

int gv_clip_check_interval(int n_frames, int interval, int anchor_gap)
{
    if (gv_interval_check(interval, 0, GV_INTERVAL_CLIPS)) return -1;
    if (anchor_gap < 1) return gv_fail("anchor gap %d: must be at least 1", anchor_gap);
    long gap = (long)anchor_gap * interval;
    if (gap > n_frames - 1)
        return gv_fail("interval %d with anchor gap %d spans %ld frames, but the scene has %d "
                       "frames (0..%d): no clip fits", interval, anchor_gap, gap, n_frames,
                       n_frames - 1);
    if ((long)anchor_gap * (interval - 1) < 3)
        return gv_fail("interval %d with anchor gap %d leaves %ld held-out frame(s) between the "
                       "anchors; a clip needs 3", interval, anchor_gap,
                       (long)anchor_gap * (interval - 1));
    return 0;
}

int gv_clip_anchor_count(int n_frames, int interval, int anchor_gap)
{
    if (interval < 1 || anchor_gap < 1) return 0;
    long gap = (long)anchor_gap * interval;
    if (gap > n_frames - 1) return 0;
    return (int)((n_frames - 1 - gap) / interval + 1); /* s = 0, n, ... with s + gap <= F - 1 */
}

/* Held-out frames strictly between a and b (exclusive) for interval n. */
static int held_out_between(int a, int b, int n)
{
    int count = 0;
    for (int f = a + 1; f < b; f++) count += !gv_scene_is_train(f, n);
    return count;
}

/* round(num / 4) with ties to even (Python's round), num >= 0. */
static int round_quarters(long num)
{
    long q = num / 4, r = num % 4;
    if (r > 2 || (r == 2 && (q & 1))) q++;
    return (int)q;
}

/* The held-out frame for the exact position num / 4: the rounded position when it is a free
 * held-out frame, else the nearest free one (lower on a tie). Free: after prev, before e, not
 * a training frame, and leaving `after` held-out frames before e for the positions still to
 * place. Returns -1 when there is none. */
static int place_frame(long num, int prev, int e, int n, int after)
{
    int p = round_quarters(num);
    int best = -1;
    long best_distance = 0;
    for (int c = prev + 1; c < e; c++) {
        if (gv_scene_is_train(c, n) || held_out_between(c, e, n) < after) continue;
        if (c == p) return c;
        long distance = labs(4L * c - num);
        if (best < 0 || distance < best_distance) best = c, best_distance = distance;
    }
    return best;
}

/* Three distinct held-out frames drawn uniformly from (s, e), sorted. */
static int random_frames(int s, int e, int n, gv_rng *rng, int out[3])
{
    int pool[3] = {0};
    int count = 0, chosen = 0;
    int size = held_out_between(s, e, n);
    /* Selection sampling (Knuth's algorithm S): each held-out frame in order is taken with
     * probability (still needed) / (still available), which yields a uniform 3-subset. */
    for (int f = s + 1; f < e && chosen < 3; f++) {
        if (gv_scene_is_train(f, n)) continue;
        double u = gv_rng_uniform(rng);
        if ((double)(size - count) * u < (double)(3 - chosen)) pool[chosen++] = f;
        count++;
    }
    if (chosen != 3) return gv_fail("random sampling found %d of 3 held-out frames", chosen);
    memcpy(out, pool, sizeof pool);
    return 0;
}

int gv_clip_frames(int n_frames, int interval, int anchor_gap, gv_clip_sampling sampling,
                   int s, gv_rng *rng, int frames[GV_CLIP_FRAMES])
{
    if (gv_clip_check_interval(n_frames, interval, anchor_gap) != 0) return -1;
    int gap = anchor_gap * interval, e = s + gap;
    if (s < 0 || !gv_scene_is_train(s, interval) || e > n_frames - 1)
        return gv_fail("first anchor %d: not a training view with a second anchor at %d within "
                       "the scene's %d frames (interval %d)", s, e, n_frames, interval);
    frames[0] = s;
    frames[4] = e;
    if (sampling == GV_SAMPLING_RANDOM) {
        if (!rng) return gv_fail("random sampling needs a random number generator");
        return random_frames(s, e, interval, rng, frames + 1);
    }
    long num[3]; /* exact positions times 4 */
    if (sampling == GV_SAMPLING_UNIFORM) {
        for (int j = 1; j <= 3; j++) num[j - 1] = 4L * s + (long)j * gap;
    } else if (sampling == GV_SAMPLING_RELEASED) {
        num[0] = 4L * (s + 1);
        num[1] = 4L * (s + gap / 2);
        num[2] = 4L * (e - 1);
    } else {
        return gv_fail("sampling %d: unknown", (int)sampling);
    }
    int prev = s;
    for (int j = 0; j < 3; j++) {
        int f = place_frame(num[j], prev, e, interval, 2 - j);
        if (f < 0) return gv_fail("no held-out frame left for position %d of the clip at %d", j + 1, s);
        frames[1 + j] = prev = f;
    }
    return 0;
}

static int compare_clips(const void *a, const void *b)
{
    const int *x = a, *y = b;
    for (int i = 0; i < GV_CLIP_FRAMES; i++)
        if (x[i] != y[i]) return x[i] < y[i] ? -1 : 1;
    return 0;
}

static int is_duplicate(int (*frames)[GV_CLIP_FRAMES], int count, const int *clip)
{
    for (int i = 0; i < count; i++)
        if (!memcmp(frames[i], clip, sizeof frames[i])) return 1;
    return 0;
}

/* Fisher-Yates shuffle of 0..count-1. */
static void shuffle(int *order, int count, gv_rng *rng)
{
    for (int i = 0; i < count; i++) order[i] = i;
    for (int i = count - 1; i > 0; i--) {
        int j = (int)(gv_rng_uniform(rng) * (i + 1));
        int t = order[i];
        order[i] = order[j];
        order[j] = t;
    }
}

#define RANDOM_RETRIES 64 /* draws per clip before random sampling gives up on a new one */

int gv_sample_clips(int n_frames, int interval, int anchor_gap, gv_clip_sampling sampling,
                    int k, uint64_t seed, int (*frames)[GV_CLIP_FRAMES], int *n_clips)
{
    *n_clips = 0;
    if (k < 1) return gv_fail("clips per run %d: must be at least 1", k);
    if (gv_clip_check_interval(n_frames, interval, anchor_gap) != 0) return -1;
    int pairs = gv_clip_anchor_count(n_frames, interval, anchor_gap);
    int *order = malloc((size_t)pairs * sizeof *order);
    if (!order) return gv_fail("out of memory for %d anchor pairs", pairs);
    gv_rng rng;
    gv_rng_init(&rng, seed);
    int wanted = sampling == GV_SAMPLING_RANDOM ? k : (k < pairs ? k : pairs);
    int count = 0;
    for (int i = 0; i < wanted; i++) {
        if (i % pairs == 0) shuffle(order, pairs, &rng); /* every pair once per cycle */
        int s = order[i % pairs] * interval;
        int clip[GV_CLIP_FRAMES];
        int tries = sampling == GV_SAMPLING_RANDOM ? RANDOM_RETRIES : 1;
        for (int t = 0; t < tries; t++) {
            if (gv_clip_frames(n_frames, interval, anchor_gap, sampling, s, &rng, clip) != 0) {
                free(order);
                return -1;
            }
            if (!is_duplicate(frames, count, clip)) {
                memcpy(frames[count++], clip, sizeof clip);
                break;
            }
        }
    }
    free(order);
    qsort(frames, (size_t)count, sizeof frames[0], compare_clips);
    *n_clips = count;
    return 0;
}
