/* Images in the report: read from the run's folder (or the scene's, for ground truth) and
 * embedded in the page as PNG data URIs, so the page is one file that needs nothing else. */
#include "report_internal.h"

#include "gaussvid/core/core.h"
#include "gaussvid/report/report.h"

#include <stdlib.h>

int report_read_image(const char *dir, const char *name, gv_image *out)
{
    char path[8192];
    if (name[0] == '/') snprintf(path, sizeof path, "%s", name);
    else if (gv_path_join(path, sizeof path, dir, name) != 0) return -1;
    if (!gv_file_exists(path)) return gv_fail("%s: image named in metrics.json does not exist", path);
    return gv_image_read_rgb(path, out);
}

int report_embed_image(report_text *t, const gv_image *img, const char *alt)
{
    uint8_t *png;
    size_t size;
    if (gv_image_encode_png(img, &png, &size) != 0) return -1;
    char *b64 = gv_base64_encode(png, size);
    free(png);
    if (!b64) return -1;
    text_printf(t, "<img width=\"%d\" height=\"%d\" alt=\"", img->width, img->height);
    text_escaped(t, alt);
    text_append(t, "\" src=\"data:image/png;base64,");
    text_append(t, b64);
    text_append(t, "\">");
    free(b64);
    return 0;
}
