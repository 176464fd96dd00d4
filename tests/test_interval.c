/* The interval rule (scene.h): the one parser of interval lists (items, ranges, repeats, bad
 * text), the validity check of each use against the rule written out here independently,
 * and the advice: every n the range text names is taken, every n taken is named. */
#include <stdio.h>
#include <string.h>

#include "check.h"
#include "gaussvid/core/core.h"
#include "gaussvid/scene/scene.h"

#define MAX 256

static void test_parse(void)
{
    int v[MAX], n;
    CHECK(gv_interval_parse("6:26:2", GV_INTERVAL_CLIPS, v, MAX, &n) == 0 && n == 11);
    int ok = n == 11;
    for (int i = 0; ok && i < 11; i++) ok &= v[i] == 6 + 2 * i;
    CHECK(ok);
    /* in the order given, ranges expanded where they stand */
    CHECK(gv_interval_parse("12,6:10:2,7", GV_INTERVAL_CLIPS, v, MAX, &n) == 0);
    CHECK(n == 5 && v[0] == 12 && v[1] == 6 && v[2] == 8 && v[3] == 10 && v[4] == 7);
    CHECK(gv_interval_parse("6:7", GV_INTERVAL_CLIPS, v, MAX, &n) == 0 && n == 2 && v[0] == 6 && v[1] == 7);
    CHECK(gv_interval_parse("6:25:4", GV_INTERVAL_CLIPS, v, MAX, &n) == 0 && n == 5 && v[4] == 22);
    CHECK(gv_interval_parse("16,1,4", GV_INTERVAL_RECONSTRUCT, v, MAX, &n) == 0 && n == 3 && v[1] == 1);
    CHECK(gv_interval_parse("100000", GV_INTERVAL_SPLIT, v, MAX, &n) == 0 && n == 1 && v[0] == 100000);
    CHECK(gv_interval_parse("1", GV_INTERVAL_SPLIT, v, MAX, &n) == 0 && n == 1 && v[0] == 1);

    /* repeats: plain, and through overlapping ranges */
    CHECK_FAILS_WITH(gv_interval_parse("6,6", GV_INTERVAL_CLIPS, v, MAX, &n), "intervals '6,6': 6 is listed twice");
    CHECK_FAILS_WITH(gv_interval_parse("6:10,8", GV_INTERVAL_CLIPS, v, MAX, &n), "8 is listed twice");
    CHECK_FAILS_WITH(gv_interval_parse("4:8:2,5:9:3", GV_INTERVAL_CLIPS, v, MAX, &n), "8 is listed twice");

    /* values outside the use's range, each named with the range */
    CHECK_FAILS_WITH(gv_interval_parse("1", GV_INTERVAL_CLIPS, v, MAX, &n),
                     "intervals '1': interval 1: a clip takes 2 <= n <= 100000");
    CHECK_FAILS_WITH(gv_interval_parse("6,3", GV_INTERVAL_RECONSTRUCT, v, MAX, &n),
                     "interval 3: reconstruct takes n = 1 or 4 <= n <= 100000");
    CHECK_FAILS_WITH(gv_interval_parse("1:8", GV_INTERVAL_RECONSTRUCT, v, MAX, &n), "interval 2: reconstruct");
    CHECK_FAILS_WITH(gv_interval_parse("0", GV_INTERVAL_SPLIT, v, MAX, &n), "interval 0: a split takes 1 <= n <= 100000");
    CHECK_FAILS_WITH(gv_interval_parse("100001", GV_INTERVAL_SPLIT, v, MAX, &n), "interval 100001");
    CHECK_FAILS_WITH(gv_interval_parse("99999999999999999999999", GV_INTERVAL_SPLIT, v, MAX, &n), "a split takes");
    CHECK_FAILS_WITH(gv_interval_parse("2:1000", GV_INTERVAL_CLIPS, v, MAX, &n), "more than 256 values");
    CHECK_FAILS_WITH(gv_interval_parse("4,5,6", GV_INTERVAL_CLIPS, v, 2, &n), "more than 2 values");

    /* bad text: one message naming the text */
    const char *bad[] = {"", "6:", ":8", "x", "6:26:0", "26:6", "6:8:2:1", "6,,8", "6 ", " 6", "-6", "6,", "+6", "6;8", "6:x"};
    for (int i = 0; i < (int)(sizeof bad / sizeof bad[0]); i++) {
        char needle[32];
        snprintf(needle, sizeof needle, "intervals '%s'", bad[i]);
        CHECK_FAILS_WITH(gv_interval_parse(bad[i], GV_INTERVAL_SPLIT, v, MAX, &n), needle);
    }
}

/* The rule of scene.h, written out again: the use's smallest n, n <= F - 1, n <= MAX. */
static int takes(gv_interval_use use, int n, int n_frames)
{
    int in_range = use == GV_INTERVAL_SPLIT ? n >= 1 : use == GV_INTERVAL_CLIPS ? n >= 2 : n == 1 || n >= 4;
    return in_range && n <= GV_INTERVAL_MAX && (n_frames == 0 || n <= n_frames - 1);
}

/* Whether the advice text names n: "no n", "n = A", "n = 1 or n = B", "n = 1 or A <= n <= B",
 * "A <= n <= B". -1: a text of none of these forms. */
static int names(const char *text, int n)
{
    int a, b;
    char rest;
    if (!strcmp(text, "no n")) return 0;
    if (sscanf(text, "n = 1 or n = %d%c", &a, &rest) == 1) return n == 1 || n == a;
    if (sscanf(text, "n = 1 or %d <= n <= %d%c", &a, &b, &rest) == 2) return n == 1 || (n >= a && n <= b);
    if (sscanf(text, "n = %d%c", &a, &rest) == 1) return n == a;
    if (sscanf(text, "%d <= n <= %d%c", &a, &b, &rest) == 2) return n >= a && n <= b;
    return -1;
}

static void test_rule_and_advice(void)
{
    const gv_interval_use uses[3] = {GV_INTERVAL_SPLIT, GV_INTERVAL_CLIPS, GV_INTERVAL_RECONSTRUCT};
    int agree = 1, advised = 1;
    for (int u = 0; u < 3; u++) {
        for (int f = 0; f <= 40; f++) {
            char text[64];
            gv_interval_range(uses[u], f, text, sizeof text);
            for (int n = -1; n <= 45; n++) {
                int taken = gv_interval_check(n, f, uses[u]) == 0;
                if (taken != takes(uses[u], n, f)) agree = 0, printf("use %d n %d frames %d: %d\n", u, n, f, taken);
                if (f > 0 && n >= 1 && names(text, n) != takes(uses[u], n, f))
                    advised = 0, printf("use %d frames %d: '%s' and n = %d\n", u, f, text, n);
            }
        }
    }
    CHECK(agree);
    CHECK(advised);
    char text[64];
    gv_interval_range(GV_INTERVAL_RECONSTRUCT, 0, text, sizeof text);
    CHECK(!strcmp(text, "n = 1 or 4 <= n <= 100000"));
    gv_interval_range(GV_INTERVAL_RECONSTRUCT, 5, text, sizeof text);
    CHECK(!strcmp(text, "n = 1 or n = 4"));
    gv_interval_range(GV_INTERVAL_CLIPS, 2, text, sizeof text);
    CHECK(!strcmp(text, "no n"));
    gv_interval_range(GV_INTERVAL_SPLIT, 10, text, sizeof text);
    CHECK(!strcmp(text, "1 <= n <= 9"));
    /* issue 41: three photos; the advice is what reconstruct takes, not "at most 2" */
    CHECK_FAILS_WITH(gv_interval_check(8, 3, GV_INTERVAL_RECONSTRUCT),
                     "interval 8 leaves 1 training frame of the scene's 3 frames (frames 0, n, 2n, ...); at least 2 "
                     "are needed: reconstruct takes n = 1 on this scene");
    CHECK_FAILS_WITH(gv_interval_check(2, 3, GV_INTERVAL_RECONSTRUCT), "interval 2: reconstruct takes n = 1 on this scene");
    CHECK_FAILS_WITH(gv_interval_check(3, 20, GV_INTERVAL_RECONSTRUCT), "n = 1 or 4 <= n <= 19 on this scene");
}

int main(void)
{
    test_parse();
    test_rule_and_advice();
    return check_summary();
}
