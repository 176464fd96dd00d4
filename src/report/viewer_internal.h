/* The viewer page's parts (viewer.c). */
#ifndef GAUSSVID_VIEWER_INTERNAL_H
#define GAUSSVID_VIEWER_INTERNAL_H

#include <stddef.h>

#include "report_internal.h"

/* The bundled JavaScript (viewer_bundle.c), or NULL when the build has none. */
const char *viewer_bundle(size_t *size);
/* The scene's cameras as the page's path JSON (viewer_path.c). */
int viewer_path_json(report_text *t, const char *scene_dir, int interval, const char *title,
                     long gaussians);

#endif
