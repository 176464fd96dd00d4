/* gaussvid report's page (src/report, docs/REPORT.md) on a hand-made folder: the table's
 * numbers read back exactly as metrics.json has them, the plot's points map back to the
 * per-frame PSNRs, the error map equals an independent computation on a hand-made pair of
 * images, every image is embedded, and a malformed metrics.json or a missing image gives one
 * message naming the key or the file while the previous report stays. */
#define _GNU_SOURCE /* strcasestr */
#include "check.h"

#include <cjson/cJSON.h>

#include "gaussvid/core/core.h"
#include "gaussvid/io/image.h"
#include "gaussvid/report/report.h"

static char dir[4096];
enum { W = 8, H = 4 };

/* The hand-made pair of frame 2: render and ground truth differ per pixel by a chosen amount. */
static const int DIFF[W * H][3] = {
    {0, 0, 0},    {16, 16, 16}, {32, 32, 32}, {48, 48, 48}, {64, 64, 64}, {100, 100, 100}, {8, 8, 8}, {10, 20, 30},
    {1, 0, 0},    {2, 2, 0},    {40, 0, 0},   {0, 0, 90},   {24, 24, 24}, {56, 56, 56},    {60, 0, 0}, {5, 5, 5},
    {12, 12, 12}, {3, 3, 3},    {0, 7, 0},    {44, 44, 44}, {20, 30, 40}, {63, 63, 63},    {65, 65, 65}, {255, 255, 255},
    {9, 9, 9},    {33, 33, 33}, {31, 31, 31}, {17, 17, 17}, {15, 15, 15}, {49, 47, 48},    {47, 47, 47}, {80, 10, 0},
};

static void write_png(const char *rel, int frame, int offset_pair)
{
    char path[8192];
    snprintf(path, sizeof path, "%s/%s", dir, rel);
    char folder[8192];
    snprintf(folder, sizeof folder, "%s", path);
    *strrchr(folder, '/') = '\0';
    if (gv_mkdirs(folder) != 0) exit(1);
    gv_image img;
    if (gv_image_alloc(&img, W, H, 3) != 0) exit(1);
    for (int i = 0; i < W * H; i++)
        for (int c = 0; c < 3; c++) {
            int base = (frame * 37 + i * 11 + c * 5) % 100; /* below 256 - 255 is not needed: clamp */
            int v = offset_pair ? base + DIFF[i][c] : base;
            img.pixels[3 * i + c] = (uint8_t)(v > 255 ? 255 : v);
        }
    if (gv_image_write_png(path, &img) != 0) { fprintf(stderr, "%s\n", gv_last_error()); exit(1); }
    gv_image_free(&img);
}

/* Per-frame PSNRs of the held-out run (n = 6, frames 1, 2, 3): frame 2 is where restoration
 * lost most (-1.5 dB), frame 3 where it gained most (+0.75 dB). */
static const char METRICS[] =
    "{\"format\": \"gaussvid-reconstruct-1\", \"scene\": \"hand<made>\", \"scene_dir\": \"%s/scene\",\n"
    " \"width\": 8, \"height\": 4,\n"
    " \"restorer\": {\"checkpoint\": \"models/x.safetensors\", \"kind\": \"scene\", \"gate\": \"open\"},\n"
    " \"runs\": [\n"
    "  {\"interval\": 6, \"train_frames\": [0, 6], \"path\": \"held-out\", \"gaussians\": {\"sparse\": 1234, \"refined\": null},\n"
    "   \"frames\": [\n"
    "    {\"frame\": 1, \"images\": {\"render\": \"n6/r1.png\", \"restored\": \"n6/s1.png\", \"refined\": \"n6/f1.png\", \"ground_truth\": \"%s/scene/g1.png\"},\n"
    "     \"sparse\": {\"psnr\": 27.123456789012345, \"ssim\": 0.91, \"lpips\": null}, \"restored\": {\"psnr\": 27.5, \"ssim\": 0.92, \"lpips\": null}, \"refined\": {\"psnr\": 28.25, \"ssim\": 0.93}},\n"
    "    {\"frame\": 2, \"images\": {\"render\": \"n6/r2.png\", \"restored\": \"n6/s2.png\", \"refined\": null, \"ground_truth\": \"%s/scene/g2.png\"},\n"
    "     \"sparse\": {\"psnr\": 30.0, \"ssim\": 0.95, \"lpips\": null}, \"restored\": {\"psnr\": 28.5, \"ssim\": 0.94, \"lpips\": null}, \"refined\": null},\n"
    "    {\"frame\": 3, \"images\": {\"render\": \"n6/r3.png\", \"restored\": \"n6/s3.png\", \"refined\": \"n6/f3.png\", \"ground_truth\": \"%s/scene/g3.png\"},\n"
    "     \"sparse\": {\"psnr\": 24.0, \"ssim\": 0.81, \"lpips\": null}, \"restored\": {\"psnr\": 24.75, \"ssim\": 0.83, \"lpips\": null}, \"refined\": {\"psnr\": 25.0, \"ssim\": 0.85}}\n"
    "   ],\n"
    "   \"means\": {\"sparse\": {\"psnr\": 27.041152263004115, \"ssim\": 0.89, \"lpips\": 0.125, \"frames\": 3},\n"
    "             \"restored\": {\"psnr\": 26.916666666666668, \"ssim\": 0.8966666666666666, \"lpips\": 0.1171875, \"frames\": 3},\n"
    "             \"refined\": {\"psnr\": 26.625, \"ssim\": 0.89, \"lpips\": null, \"frames\": 2}},\n"
    "   \"all_held_out\": {\"sparse\": {\"psnr\": 26.5, \"ssim\": 0.875, \"lpips\": null, \"frames\": 4},\n"
    "                    \"refined\": {\"psnr\": 26.0625, \"ssim\": 0.88, \"lpips\": null, \"frames\": 4}},\n"
    "   \"restorer\": {\"checkpoint\": \"n6/restorer.safetensors\", \"kind\": \"scene\", \"gate\": \"closed\"},\n"
    "   \"decisions\": {\"restore_with\": \"adapted\", \"gate\": \"closed\", \"adaptation\": {\"ran\": true, \"why\": null},\n"
    "                 \"restoration\": {\"ran\": false, \"why\": \"the gate is <closed> (-0.12 dB)\"}, \"refinement\": null},\n"
    "   \"inputs\": {\"iters\": 3000, \"refine_weight\": 0.3, \"adapt\": true, \"lpips\": null},\n"
    "   \"stages\": [{\"name\": \"train\", \"seconds\": 12.5, \"cpu_seconds\": 20.25, \"summary\": \"1234 Gaussians <fast>\"},\n"
    "              {\"name\": \"restore\", \"seconds\": 3.25}]},\n"
    "  {\"interval\": 4, \"train_frames\": [0, 4], \"path\": \"smooth\",\n"
    "   \"frames\": [{\"frame\": 0, \"images\": {\"render\": \"n4/r0.png\", \"restored\": \"n4/s0.png\", \"refined\": \"n4/f0.png\", \"ground_truth\": null},\n"
    "                \"sparse\": null, \"restored\": null, \"refined\": null}],\n"
    "   \"means\": null, \"stages\": []}\n"
    " ]}\n";

static void write_metrics(const char *text)
{
    char path[8192];
    snprintf(path, sizeof path, "%s/metrics.json", dir);
    if (gv_write_text_atomic(path, text) != 0) exit(1);
}

static void write_good_metrics(void)
{
    static char text[8192];
    snprintf(text, sizeof text, METRICS, dir, dir, dir, dir);
    write_metrics(text);
}

static char *read_report(void)
{
    char path[8192], *text;
    size_t size;
    snprintf(path, sizeof path, "%s/report.html", dir);
    if (gv_read_file(path, &text, &size) != 0) return NULL;
    return text;
}

/* The value of attribute name="..." inside the tag that starts at tag. */
static int attribute(const char *tag, const char *name, char *out, size_t size)
{
    const char *end = strchr(tag, '>');
    char needle[64];
    snprintf(needle, sizeof needle, " %s=\"", name);
    const char *at = strstr(tag, needle);
    if (!at || (end && at > end)) return -1;
    at += strlen(needle);
    const char *close = strchr(at, '"');
    snprintf(out, size, "%.*s", (int)(close - at), at);
    return 0;
}

/* The number a table key names in metrics.json: "n6.restored.psnr", "n6.refined.ssim_change"
 * (the means) or "n6.all_held_out.refined.psnr" (every held-out view). */
static int expected_value(const cJSON *root, const char *key, double *out)
{
    int n;
    char group[32] = "means", model[32], metric[32];
    if (sscanf(key, "n%d.all_held_out.%31[a-z].%31[a-z_]", &n, model, metric) == 3) strcpy(group, "all_held_out");
    else if (sscanf(key, "n%d.%31[a-z].%31[a-z_]", &n, model, metric) != 3) return -1;
    const cJSON *run = NULL, *r;
    cJSON_ArrayForEach(r, cJSON_GetObjectItem(root, "runs"))
        if (cJSON_GetObjectItem(r, "interval")->valueint == n) run = r;
    if (!run) return -1;
    const cJSON *means = cJSON_GetObjectItem(run, group);
    char *change = strstr(metric, "_change");
    if (change) *change = '\0';
    const cJSON *v = cJSON_GetObjectItem(cJSON_GetObjectItem(means, model), metric);
    if (!cJSON_IsNumber(v)) return -1;
    *out = v->valuedouble;
    if (change) {
        const cJSON *base = cJSON_GetObjectItem(cJSON_GetObjectItem(means, "sparse"), metric);
        if (!cJSON_IsNumber(base)) return -1;
        *out = v->valuedouble - base->valuedouble;
    }
    return 0;
}

static void test_table(const char *html, const cJSON *root)
{
    int cells = 0;
    for (const char *p = strstr(html, "data-key=\""); p; p = strstr(p + 1, "data-key=\"")) {
        const char *tag = p;
        while (tag > html && *tag != '<') tag--;
        char key[64], value[64];
        REQUIRE(attribute(tag, "data-key", key, sizeof key) == 0 && attribute(tag, "data-value", value, sizeof value) == 0);
        double expected = NAN, shown;
        CHECK(expected_value(root, key, &expected) == 0);
        CHECK(strtod(value, NULL) == expected); /* exactly: %.17g reads back to the same double */
        /* the text shown is the value rounded: 2 decimals for PSNR, 4 for SSIM and LPIPS */
        const char *text = strchr(tag, '>') + 1;
        char want[64];
        snprintf(want, sizeof want, strstr(key, "_change") ? (strstr(key, "psnr") ? "%+.2f" : "%+.4f")
                                                           : (strstr(key, "psnr") ? "%.2f" : "%.4f"), expected);
        CHECK(strncmp(text, want, strlen(want)) == 0 && text[strlen(want)] == '<');
        shown = strtod(text, NULL);
        CHECK_NEAR(shown, expected, strstr(key, "psnr") ? 0.005 : 0.00005);
        cells++;
    }
    /* n = 6: PSNR, SSIM, LPIPS of three models (refined has no LPIPS) and the changes of the
     * two others (restored's LPIPS change; refined's has no value): 3 + 3 + 2 + 2 + 2 + 1;
     * all held-out views: sparse's PSNR and SSIM, refined's with their changes: 2 + 4 */
    CHECK(cells == 19);
    CHECK(strstr(html, "data-key=\"n6.all_held_out.refined.psnr_change\" data-value=\"-0.4375\">-0.44<") != NULL);
    CHECK(strstr(html, "no ground truth, no metrics") != NULL); /* the smooth run's row */
    CHECK(strstr(html, "data-key=\"n6.restored.psnr_change\" data-value=\"-0.12448559633744694\"") != NULL);
}

/* Every polyline point maps back to a frame and its PSNR through the mapping on the <svg>. */
static void test_plot(const char *html, const cJSON *root)
{
    const char *svg = strstr(html, "<svg class=\"psnr-plot\"");
    REQUIRE(svg != NULL);
    CHECK(strstr(svg + 1, "<svg class=\"psnr-plot\"") == NULL); /* the smooth run has no plot */
    char v[64];
    double box[8];
    const char *names[8] = {"data-frame-min", "data-frame-max", "data-psnr-min", "data-psnr-max",
                            "data-left", "data-top", "data-width", "data-height"};
    for (int k = 0; k < 8; k++) {
        REQUIRE(attribute(svg, names[k], v, sizeof v) == 0);
        box[k] = strtod(v, NULL);
    }
    CHECK(box[0] == 1 && box[1] == 3);     /* frames 1..3 */
    CHECK(box[2] == 24 && box[3] == 30);   /* PSNRs 24.0 .. 30.0, rounded out to whole dB */
    const cJSON *frames = cJSON_GetObjectItem(cJSON_GetArrayItem(cJSON_GetObjectItem(root, "runs"), 0), "frames");
    const char *models[3] = {"sparse", "restored", "refined"};
    int points = 0;
    for (int m = 0; m < 3; m++) {
        char needle[64];
        snprintf(needle, sizeof needle, "<polyline data-series=\"%s\"", models[m]);
        const char *line = strstr(svg, needle);
        REQUIRE(line != NULL);
        const char *p = strstr(line, "points=\"") + 8;
        const cJSON *f;
        cJSON_ArrayForEach(f, frames) {
            const cJSON *score = cJSON_GetObjectItem(f, models[m]);
            if (!cJSON_IsObject(score)) continue;
            double x, y;
            int used;
            REQUIRE(sscanf(p, "%lf,%lf%n", &x, &y, &used) == 2);
            p += used;
            double frame = box[0] + (x - box[4]) / box[6] * (box[1] - box[0]);
            double psnr = box[3] - (y - box[5]) / box[7] * (box[3] - box[2]);
            /* points are written to 0.01 px: 0.005 px of error at most */
            CHECK_NEAR(frame, cJSON_GetObjectItem(f, "frame")->valuedouble, 0.0051 / box[6] * (box[1] - box[0]));
            CHECK_NEAR(psnr, cJSON_GetObjectItem(score, "psnr")->valuedouble, 0.0051 / box[7] * (box[3] - box[2]));
            points++;
        }
        CHECK(*p == '"'); /* no more points than frames with a score */
    }
    CHECK(points == 8); /* 3 sparse, 3 restored, 2 refined */
}

/* The colour map of docs/REPORT.md, written again here: stops black, blue, red, yellow, white
 * at 0, 16, 32, 48, 64 levels, linear between, rounded to nearest; white above 64. */
static void reference_colour(double e, uint8_t out[3])
{
    static const double stops[5][3] = {{0, 0, 0}, {0, 0, 255}, {255, 0, 0}, {255, 255, 0}, {255, 255, 255}};
    if (e >= 64) e = 64;
    int k = (int)(e / 16);
    if (k > 3) k = 3;
    double f = (e - 16 * k) / 16;
    for (int c = 0; c < 3; c++) out[c] = (uint8_t)floor(stops[k][c] + f * (stops[k + 1][c] - stops[k][c]) + 0.5);
}

static int colour_is(double error, int r, int g, int b)
{
    uint8_t rgb[3];
    gv_error_colour(error, rgb);
    return rgb[0] == r && rgb[1] == g && rgb[2] == b;
}

static void test_error_map(const char *html)
{
    /* exact values at the stops and between */
    CHECK(colour_is(0, 0, 0, 0));
    CHECK(colour_is(16, 0, 0, 255));
    CHECK(colour_is(32, 255, 0, 0));
    CHECK(colour_is(48, 255, 255, 0));
    CHECK(colour_is(64, 255, 255, 255));
    CHECK(colour_is(255, 255, 255, 255));
    CHECK(colour_is(8, 0, 0, 128));   /* 127.5 rounds up */
    CHECK(colour_is(20, 64, 0, 191)); /* 63.75, 191.25 */

    /* The strip of frame 2 (the worst) embeds |render - ground truth| of the hand-made pair. */
    const char *figure = strstr(html, "<figure class=\"strip\" data-frame=\"2\">");
    REQUIRE(figure != NULL);
    CHECK(strstr(html, "<figure class=\"strip\" data-frame=\"3\">") != NULL); /* the best */
    CHECK(strstr(html, "<figure class=\"strip\" data-frame=\"1\">") == NULL);
    const char *end = strstr(figure, "</figure>");
    REQUIRE(end != NULL);
    const char *restored_cell = strstr(figure, "data-image=\"restored\"");
    CHECK(restored_cell == NULL || restored_cell > end); /* a skipped restoration: copies not shown */
    const char *cell = strstr(figure, "data-image=\"error-render\"");
    REQUIRE(cell != NULL);
    const char *src = strstr(cell, "src=\"data:image/png;base64,");
    REQUIRE(src != NULL);
    src += strlen("src=\"data:image/png;base64,");
    uint8_t *png;
    size_t size;
    REQUIRE(gv_base64_decode(src, strcspn(src, "\""), &png, &size) == 0);
    char path[8192];
    snprintf(path, sizeof path, "%s/error_map.png", dir);
    FILE *f = fopen(path, "wb");
    REQUIRE(f && fwrite(png, 1, size, f) == size);
    fclose(f);
    free(png);
    gv_image map;
    REQUIRE(gv_image_read_png(path, &map) == 0);
    REQUIRE(map.width == W && map.height == H && map.channels == 3);
    int mismatches = 0;
    for (int i = 0; i < W * H; i++) {
        /* the pair's difference after the writer clamped the ground truth at 255 */
        int sum = 0;
        for (int c = 0; c < 3; c++) {
            int base = (2 * 37 + i * 11 + c * 5) % 100, truth = base + DIFF[i][c];
            sum += (truth > 255 ? 255 : truth) - base;
        }
        uint8_t want[3];
        reference_colour(sum / 3.0, want);
        mismatches += memcmp(want, map.pixels + 3 * i, 3) != 0;
    }
    CHECK(mismatches == 0);
    /* hand values: pixel 1 differs by 16 (blue), pixel 2 by 32 (red), pixel 7 by (10,20,30) */
    CHECK(map.pixels[3 * 1 + 2] == 255 && map.pixels[3 * 1 + 0] == 0);
    CHECK(map.pixels[3 * 2 + 0] == 255 && map.pixels[3 * 2 + 2] == 0);
    CHECK(map.pixels[3 * 7 + 0] == 64 && map.pixels[3 * 7 + 2] == 191);
    gv_image_free(&map);

    /* the smooth run: no ground truth, change maps against the render */
    const char *smooth = strstr(html, "<section class=\"run\" id=\"n4\">");
    REQUIRE(smooth != NULL);
    CHECK(strstr(smooth, "data-image=\"change-restored\"") != NULL);
    CHECK(strstr(smooth, "data-image=\"ground-truth\"") == NULL);
}

static void test_self_contained(const char *html)
{
    CHECK(strcasestr(html, "http") == NULL);
    CHECK(strcasestr(html, "<script") == NULL);
    CHECK(strcasestr(html, "<link") == NULL);
    int images = 0, embedded = 0;
    for (const char *p = strstr(html, "src=\""); p; p = strstr(p + 1, "src=\"")) {
        images++;
        embedded += !strncmp(p, "src=\"data:image/png;base64,", 27);
    }
    /* frames 2 and 3 of the n = 6 run, whose restoration was skipped: the render and the
     * ground truth and one error map each; the smooth frame: 3 images + 2 change maps */
    CHECK(images == 11 && embedded == images);
    CHECK(strstr(html, "hand&lt;made&gt;") != NULL && strstr(html, "hand<made>") == NULL);
    CHECK(strstr(html, "open: the scene's held-back pairs said restoring helps") != NULL);
    CHECK(strstr(html, "data-value=\"12.5\">12.5</td>") != NULL); /* a stage's time */
    CHECK(strstr(html, "data-value=\"20.25\">20.2</td>") != NULL); /* its CPU time (%.1f: half to even) */
    CHECK(strstr(html, "1234 Gaussians &lt;fast&gt;") != NULL);     /* its summary */
    /* the run's decisions in words, a sentence each, the why's parentheses the only ones; the
     * refinement, not decided yet, is left out */
    CHECK(strstr(html, "<p class=\"decisions\"><b>Decided:</b> Restoration mode adapted. Adaptation ran. The gate is "
                       "closed. Restoration skipped: the gate is &lt;closed&gt; (-0.12 dB). The restored frames are the "
                       "renders.</p>") != NULL);
    /* the run's own restorer (another than the folder's) and its options */
    CHECK(strstr(html, "Restorer of this run") != NULL && strstr(html, "n6/restorer.safetensors") != NULL);
    CHECK(strstr(html, "closed: the scene's held-back pairs said restoring hurts") != NULL);
    CHECK(strstr(html, "Options: iters 3000, refine_weight 0.3, adapt yes</p>") != NULL);
}

/* Replaces the first `from` in the good metrics.json by `to`, writes it and expects a failure
 * naming `needle`; the previous report.html stays as it was. */
/* The first `from` in text (of `size` bytes) replaced by `to`; -1 when text has no `from`. */
static int replace_once(char *text, size_t size, const char *from, const char *to)
{
    static char out[8192];
    const char *at = strstr(text, from);
    if (!at) { fprintf(stderr, "test bug: '%s' not in the metrics\n", from); check_failed++; return -1; }
    snprintf(out, sizeof out, "%.*s%s%s", (int)(at - text), text, to, at + strlen(from));
    snprintf(text, size, "%s", out);
    return 0;
}

static void expect_bad(const char *from, const char *to, const char *needle, const char *before)
{
    static char bad[8192];
    snprintf(bad, sizeof bad, METRICS, dir, dir, dir, dir);
    if (replace_once(bad, sizeof bad, from, to) != 0) return;
    write_metrics(bad);
    CHECK_FAILS_WITH(gv_report_write_html(dir), needle);
    CHECK(strchr(gv_last_error(), '\n') == NULL);
    char *after = read_report();
    CHECK(after && !strcmp(after, before));
    free(after);
}

static void test_bad_input(const char *before)
{
    expect_bad("\"psnr\": 30.0", "\"psnr\": \"30\"", "metrics.json: runs[0].frames[1].sparse.psnr: expected a number, found a string", before);
    expect_bad("\"interval\": 6, ", "", "metrics.json: runs[0].interval: missing", before);
    expect_bad("\"path\": \"held-out\"", "\"path\": \"sideways\"", "runs[0].path: expected \"held-out\" or \"smooth\", found \"sideways\"", before);
    expect_bad("gaussvid-reconstruct-1", "gaussvid-reconstruct-9", "metrics.json: format: expected \"gaussvid-reconstruct-1\"", before);
    expect_bad("\"width\": 8", "\"width\": -8", "metrics.json: width: -8 is outside", before);
    expect_bad("\"render\": \"n6/r2.png\"", "\"render\": null", "runs[0].frames[1].images.render: expected a string, found null", before);
    expect_bad("\"ssim\": 0.89, \"lpips\": 0.125", "\"ssim\": 0.89, \"lpips\": \"low\"", "runs[0].means.sparse.lpips: expected a number, found a string", before);
    expect_bad("\"name\": \"train\", \"seconds\": 12.5,", "\"name\": \"train\",", "runs[0].stages[0].seconds: missing", before);
    expect_bad("\"cpu_seconds\": 20.25", "\"cpu_seconds\": \"20\"", "runs[0].stages[0].cpu_seconds: expected a number", before);
    expect_bad("\"refined\": {\"psnr\": 26.0625", "\"refined\": {\"PSNR\": 26.0625", "runs[0].all_held_out.refined.psnr: missing", before);
    expect_bad("\"gate\": \"closed\"", "\"gate\": 0", "runs[0].restorer.gate: expected a string or null, found a number", before);
    expect_bad("\"train_frames\": [0, 6]", "\"train_frames\": [0, -6]", "runs[0].train_frames[1]: expected a frame index", before);
    expect_bad(" \"runs\": [", " \"runs\": {", "not valid JSON", before);
    expect_bad("\"ran\": false", "\"ran\": \"no\"", "metrics.json: runs[0].decisions.restoration.ran: expected true or false", before);
    expect_bad("\"why\": null", "\"why\": 3", "runs[0].decisions.adaptation.why: expected a string or null, found a number", before);
    expect_bad("\"restored\": \"n6/s1.png\"", "\"restored\": \"/abs/s1.png\"", "images.restored: expected a path relative to the folder", before);

    /* a missing image: named with its path */
    write_good_metrics();
    char path[8192];
    snprintf(path, sizeof path, "%s/n6/r2.png", dir);
    remove(path);
    CHECK_FAILS_WITH(gv_report_write_html(dir), "n6/r2.png: image named in metrics.json does not exist");
    write_png("n6/r2.png", 2, 0);
    snprintf(path, sizeof path, "%s/metrics.json", dir);
    remove(path);
    CHECK_FAILS_WITH(gv_report_write_html(dir), "metrics.json: missing");
    char nowhere[8192];
    snprintf(nowhere, sizeof nowhere, "%s/nowhere", dir);
    CHECK_FAILS_WITH(gv_report_write_html(nowhere), "nowhere: no such folder");
}

/* When restoration changed no frame's PSNR (a closed gate kept the renders), the strips
 * show the frames with the lowest and highest sparse PSNR: frame 3 (24.0 dB) and frame 2 (30.0). */
static void test_unchanged_restoration(void)
{
    static char text[8192];
    snprintf(text, sizeof text, METRICS, dir, dir, dir, dir);
    const char *from[3] = {"\"restored\": {\"psnr\": 27.5", "\"restored\": {\"psnr\": 28.5", "\"restored\": {\"psnr\": 24.75"};
    const char *to[3] = {"\"restored\": {\"psnr\": 27.123456789012345", "\"restored\": {\"psnr\": 30.0",
                         "\"restored\": {\"psnr\": 24.0"};
    for (int k = 0; k < 3; k++) REQUIRE(replace_once(text, sizeof text, from[k], to[k]) == 0);
    write_metrics(text);
    REQUIRE(gv_report_write_html(dir) == 0);
    char *html = read_report();
    REQUIRE(html != NULL);
    const char *run = strstr(html, "id=\"n6\"");
    REQUIRE(run != NULL);
    const char *worst = strstr(run, "<figure class=\"strip\" data-frame=\"3\">");
    const char *best = strstr(run, "<figure class=\"strip\" data-frame=\"2\">");
    CHECK(worst != NULL && best != NULL && worst < best);
    CHECK(strstr(run, "<figure class=\"strip\" data-frame=\"1\">") == NULL);
    CHECK(strstr(run, "Shown: restoration changed no frame&#39;s PSNR") != NULL); /* text_escaped: ' is &#39; */
    free(html);
}

/* The rows of a table in order: the data-frame of each, from the table's start to its end. */
static int table_rows(const char *html, const char *table, int *frames, int max)
{
    const char *at = strstr(html, table), *end = at ? strstr(at, "</table>") : NULL;
    int n = 0;
    while (at && end && n < max && (at = strstr(at, "<tr data-frame=\"")) && at < end) {
        at += strlen("<tr data-frame=\"");
        frames[n++] = atoi(at);
    }
    return n;
}

/* The named lists: the worst by final PSNR (refined, else restored: frame 3 25.0, frame 1 28.25,
 * frame 2 28.5 restored), the biggest changes by |restored - sparse| (frame 2 -1.50, frame 3
 * +0.75, frame 1 +0.38); names from the render's file without "name", the photo's with it,
 * escaped; and a third strip when the worst frame is neither of the two picked. */
static void test_frame_lists(const char *html)
{
    const char *run = strstr(html, "id=\"n6\"");
    REQUIRE(run != NULL);
    int rows[8];
    CHECK(table_rows(run, "<table class=\"worst\">", rows, 8) == 3 && rows[0] == 3 && rows[1] == 1 && rows[2] == 2);
    CHECK(strstr(run, "<tr data-frame=\"3\"><td>r3</td><td>3</td><td>24.00</td><td>24.75</td><td>25.00</td></tr>") != NULL);
    CHECK(strstr(run, "<tr data-frame=\"2\"><td>r2</td><td>2</td><td>30.00</td><td>28.50</td><td>&ndash;</td></tr>") != NULL);
    CHECK(strstr(run, "<figcaption>worst: r2 (frame 2)</figcaption>") != NULL);
    /* the run decided not to restore (its gate closed): no table of the restorer's changes */
    const char *changes = strstr(run, "Biggest changes"), *end = strstr(run, "</section>");
    CHECK(end != NULL && (changes == NULL || changes > end));

    static char text[8192];
    snprintf(text, sizeof text, METRICS, dir, dir, dir, dir);
    REQUIRE(replace_once(text, sizeof text, "\"restoration\": {\"ran\": false, \"why\": \"the gate is <closed> (-0.12 dB)\"}",
                         "\"restoration\": {\"ran\": true, \"why\": null}") == 0);
    write_metrics(text);
    REQUIRE(gv_report_write_html(dir) == 0);
    char *restored = read_report();
    REQUIRE(restored != NULL);
    CHECK(table_rows(restored, "<table class=\"changes\">", rows, 8) == 3 && rows[0] == 2 && rows[1] == 3 && rows[2] == 1);
    CHECK(strstr(restored, "<td>-1.50</td>") != NULL && strstr(restored, "<td>+0.75</td>") != NULL);
    free(restored);

    snprintf(text, sizeof text, METRICS, dir, dir, dir, dir);
    REQUIRE(replace_once(text, sizeof text, "{\"frame\": 2, \"images\"", "{\"frame\": 2, \"name\": \"IMG <2>.jpg\", \"images\"") == 0);
    REQUIRE(replace_once(text, sizeof text, "\"refined\": {\"psnr\": 28.25", "\"refined\": {\"psnr\": 20.5") == 0);
    static char bad[8192];
    snprintf(bad, sizeof bad, "%s", text);
    REQUIRE(replace_once(text, sizeof text, "\"all_held_out\":",
                         "\"consistency\": {\"sparse\": {\"psnr\": 30.25, \"pairs\": 4}, \"restored\": {\"psnr\": null}, "
                         "\"refined\": {\"psnr\": 31.5}},\n   \"all_held_out\":") == 0);
    REQUIRE(replace_once(bad, sizeof bad, "\"all_held_out\":", "\"consistency\": {\"sparse\": {\"psnr\": \"x\"}}, \"all_held_out\":") == 0);
    write_metrics(bad);
    CHECK_FAILS_WITH(gv_report_write_html(dir), "runs[0].consistency.sparse.psnr: expected a number, found a string");
    write_metrics(text);
    REQUIRE(gv_report_write_html(dir) == 0);
    char *named = read_report();
    REQUIRE(named != NULL);
    CHECK(strstr(named, "<figcaption>worst: IMG &lt;2&gt;.jpg (frame 2)</figcaption>") != NULL);
    CHECK(strstr(named, "<td>IMG &lt;2&gt;.jpg</td><td>2</td>") != NULL);
    /* frame 1 now ends worst (20.5 dB) but restoration lost and gained most on 2 and 3 */
    CHECK(table_rows(named, "<table class=\"worst\">", rows, 8) == 3 && rows[0] == 1);
    CHECK(strstr(named, "<figcaption>worst final PSNR: r1 (frame 1)</figcaption>") != NULL);
    CHECK(strstr(named, "; and the worst frame by the PSNR of what the run ends with.") != NULL);
    CHECK(strstr(named, "<p class=\"consistency\" data-key=\"n6.consistency\">3D consistency (each frame warped into its "
                        "neighbours by the model&#39;s depth, masked PSNR): sparse 30.25, restored -, refined 31.50 dB") != NULL);
    free(named);
    write_good_metrics();
    CHECK(gv_report_write_html(dir) == 0); /* the page the tests after this one expect */
}

int main(void)
{
    snprintf(dir, sizeof dir, "%s", check_tmp_dir());
    for (int f = 1; f <= 3; f++) {
        char rel[64];
        snprintf(rel, sizeof rel, "n6/r%d.png", f), write_png(rel, f, 0);
        snprintf(rel, sizeof rel, "n6/s%d.png", f), write_png(rel, f + 10, 0);
        if (f != 2) snprintf(rel, sizeof rel, "n6/f%d.png", f), write_png(rel, f + 20, 0);
        snprintf(rel, sizeof rel, "scene/g%d.png", f), write_png(rel, f, 1);
    }
    write_png("n4/r0.png", 30, 0), write_png("n4/s0.png", 30, 1), write_png("n4/f0.png", 31, 0);
    write_good_metrics();

    if (gv_report_write_html(dir) != 0) {
        fprintf(stderr, "gv_report_write_html: %s\n", gv_last_error());
        return 1;
    }
    char *html = read_report();
    static char text[8192];
    snprintf(text, sizeof text, METRICS, dir, dir, dir, dir);
    cJSON *root = cJSON_Parse(text);
    if (!html || !root) return 1;
    test_table(html, root);
    test_plot(html, root);
    test_error_map(html);
    test_self_contained(html);
    test_frame_lists(html);
    test_bad_input(html);
    test_unchanged_restoration();
    cJSON_Delete(root);
    free(html);
    return check_summary();
}
