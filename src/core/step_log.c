/* Step-numbered logs (train, pretrain and vae train's --log, train's --val-log) after a kill:
 * the run resumes from its last checkpoint, so the rows written after that checkpoint will
 * be written again, and the last row may have been cut mid-line. Rewinding the log to the
 * checkpoint's step before appending keeps every step once (issue 25). */
#include "gaussvid/core/core.h"

#include <stdlib.h>
#include <string.h>

int gv_step_log_rewind(const char *path, long last_step)
{
    if (!gv_file_exists(path)) return 0;
    char *text;
    size_t size;
    if (gv_read_file(path, &text, &size)) return -1;
    size_t keep = 0;
    for (size_t at = 0; at < size;) {
        char *newline = memchr(text + at, '\n', size - at);
        if (!newline) break; /* a row cut short by the kill */
        char *end;
        long step = strtol(text + at, &end, 10);
        int is_row = end != text + at;
        if (is_row && step > last_step) break; /* rows are in step order */
        at = (size_t)(newline - text) + 1;
        keep = at; /* the header, or a row of a step the checkpoint holds */
    }
    int rc = 0;
    if (keep < size) {
        gv_atomic_file af;
        rc = gv_atomic_open(&af, path);
        if (rc == 0) {
            fwrite(text, 1, keep, af.f);
            rc = gv_atomic_commit(&af);
        }
    }
    free(text);
    return rc;
}
