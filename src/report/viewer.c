/* viewer.html: one model, the scene's cameras and the renderer in a single page that opens
 * from file:// (docs/REPORT.md). The model's bytes are the .splat file's, in base64, inside a
 * <script type="application/octet-stream"> element that the page decodes; the path is JSON in
 * another; the JavaScript is the bundle built into the program (viewer_bundle.c). */
#include "viewer_internal.h"

#include "gaussvid/core/core.h"
#include "gaussvid/report/report.h"

#include <stdlib.h>
#include <string.h>
#include <strings.h>

static const char STYLE[] =
    "html,body{margin:0;height:100%;background:#111;color:#ddd;font:13px system-ui,sans-serif;overflow:hidden}\n"
    "#view{display:block;margin:0 auto;cursor:grab;touch-action:none}\n"
    "#controls{display:flex;gap:10px;align-items:center;padding:6px 10px;background:#222}\n"
    "#position{flex:1}.hint{color:#888}\n";

static const char CONTROLS[] =
    "<canvas id=\"view\"></canvas>\n"
    "<div id=\"controls\"><button id=\"play\">Pause</button>"
    "<input id=\"position\" type=\"range\" min=\"0\" max=\"0\" step=\"0.01\" value=\"0\" aria-label=\"position along the path\">"
    "<select id=\"speed\" aria-label=\"speed\"><option value=\"0.5\">0.5&times;</option><option value=\"1\" selected>1&times;</option>"
    "<option value=\"2\">2&times;</option><option value=\"4\">4&times;</option></select>"
    "<span id=\"status\">loading the model&hellip;</span>"
    "<span class=\"hint\">drag to look, double-click to reset, space to play or pause</span></div>\n";

int gv_viewer_available(void)
{
    size_t size;
    return viewer_bundle(&size) != NULL;
}

/* The bundle goes inside <script>: the HTML parser would end the element at "</script". */
static int bundle_is_embeddable(const char *js, size_t size)
{
    for (size_t i = 0; i + 8 <= size; i++)
        if (js[i] == '<' && js[i + 1] == '/' && !strncasecmp(js + i + 2, "script", 6)) return 0;
    return 1;
}

static int build_page(report_text *t, const char *splat_path, const char *scene_dir, int interval, const char *title)
{
    size_t js_size;
    const char *js = viewer_bundle(&js_size);
    if (!js)
        return gv_fail("viewer: this gaussvid was built without the viewer's JavaScript (run scripts/setup.sh, "
                       "which vendors it from npm, then rebuild)");
    if (!bundle_is_embeddable(js, js_size)) return gv_fail("viewer: the bundled JavaScript contains </script");
    char *bytes;
    size_t size;
    if (gv_read_file(splat_path, &bytes, &size) != 0) return -1;
    if (size == 0 || size % 32 != 0) {
        free(bytes);
        return gv_fail("%s: %zu bytes, not a .splat file (32 bytes per Gaussian)", splat_path, size);
    }
    char *b64 = gv_base64_encode((const uint8_t *)bytes, size);
    free(bytes);
    if (!b64) return -1;

    text_append(t, "<!DOCTYPE html>\n<html lang=\"en\">\n<head>\n<meta charset=\"utf-8\">\n<title>");
    text_escaped(t, title);
    text_printf(t, "</title>\n<style>\n%s</style>\n</head>\n<body data-state=\"loading\">\n%s", STYLE, CONTROLS);
    text_append(t, "<script id=\"gv-path\" type=\"application/json\">");
    int rc = viewer_path_json(t, scene_dir, interval, title, (long)(size / 32));
    if (rc == 0) {
        text_printf(t, "</script>\n<script id=\"gv-model\" type=\"application/octet-stream\" data-format=\"splat\" "
                       "data-bytes=\"%zu\">", size);
        text_append(t, b64);
        text_append(t, "</script>\n<script>\n");
        text_append_n(t, js, js_size);
        text_append(t, "\n</script>\n</body>\n</html>\n");
    }
    free(b64);
    return rc;
}

int gv_viewer_write(const char *splat_path, const char *scene_dir, int interval, const char *title, const char *out_html)
{
    report_text t = {0};
    int rc = build_page(&t, splat_path, scene_dir, interval, title);
    if (rc == 0) rc = text_write_atomic(&t, out_html);
    text_free(&t);
    return rc;
}
