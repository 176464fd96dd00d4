/* What `gaussvid reconstruct` leaves in its folder, made readable (docs/REPORT.md): one
 * self-contained report.html (numbers, a per-frame PSNR plot, image strips with error maps,
 * stage timings) and, next to each model, a viewer.html that flies through it in a browser.
 * Both are single files that open from file:// with no network: images, the plot, the
 * JavaScript and the model are inside them. */
#ifndef GAUSSVID_REPORT_H
#define GAUSSVID_REPORT_H

#include <stddef.h>
#include <stdint.h>
#include <stdio.h>

#include "gaussvid/io/image.h"

/* Reads DIR/metrics.json (docs/REPORT.md has its schema) and writes, each atomically, for
 * every run whose model exists DIR/nN/viewer.html, then DIR/report.html. The pipeline's last
 * stage; `gaussvid report DIR` calls it again. Fails with one line naming the file and, for
 * metrics.json, the key that is missing or malformed, before writing anything. Without the
 * viewer's JavaScript in the build it warns and writes the report alone. */
int gv_report_write(const char *dir);
/* Only DIR/report.html (no viewers, no links to them). */
int gv_report_write_html(const char *dir);

/* A viewer page for one model: the .splat file's bytes (base64), the scene's cameras as the
 * fly-through path (JSON, OpenGL camera-to-world as three.js reads it; the frames that are
 * training views at interval n are marked, none when interval is 0) and the vendored renderer
 * (three.js + Spark, third_party/viewer/) in one HTML file, written atomically. title is shown
 * in the page. Fails when the program was built without the vendored renderer
 * (scripts/setup.sh vendors it). */
int gv_viewer_write(const char *splat_path, const char *scene_dir, int interval, const char *title,
                    const char *out_html);
/* Prints to out what a reconstruction folder holds, read from DIR/metrics.json: the scene and
 * restorer; per interval the mean PSNR / SSIM of the sparse, restored and refined frames, in
 * words whether restoration and refinement changed the sparse renders' PSNR, the mean over
 * every held-out view, and the paths of nN/viewer.html and nN/flythrough.mp4; then
 * report.html and metrics.json (a file not written yet is said to be missing).
 * `gaussvid reconstruct` ends with it. */
int gv_report_summary(const char *dir, FILE *out);
/* Whether this build carries the viewer's JavaScript. */
int gv_viewer_available(void);

/* The error maps of the report: per pixel the mean over R, G, B of |a - b| (0..255), shown
 * through the colour map below; a and b must have the same size (3 channels each). */
int gv_error_map(const gv_image *a, const gv_image *b, gv_image *out);
/* The error colour map: black at 0, then blue, red, yellow and white at 1/4, 2/4, 3/4 and 4/4
 * of GV_ERROR_MAP_FULL_SCALE, linear between (rounded to nearest), white above. */
#define GV_ERROR_MAP_FULL_SCALE 64.0 /* |a - b| in 8-bit levels shown white (a quarter of range) */
void gv_error_colour(double error, uint8_t rgb[3]);

/* Standard base64 (RFC 4648, with padding) of n bytes into a malloc'd NUL-terminated text. */
char *gv_base64_encode(const uint8_t *data, size_t n);
/* Decodes standard base64 (padding required, no whitespace); *out is malloc'd. */
int gv_base64_decode(const char *text, size_t length, uint8_t **out, size_t *n);

#endif
