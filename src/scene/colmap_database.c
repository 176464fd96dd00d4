/* The COLMAP database of `scene colmap` kept between runs (colmap_internal.h): OUT/colmap/
 * photos.txt records the camera options and each photo's size and time; a rerun whose photos
 * include all of those, unchanged, with the same options keeps database.db, and COLMAP skips
 * what it holds (features of a photo already extracted, pairs already matched). Anything else
 * starts a new database, with one line saying why. */
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "colmap_internal.h"

static void header(const gv_colmap_run_options *o, char *out, size_t size)
{
    snprintf(out, size, "gaussvid scene colmap database of: camera_model=%s single_camera=%d", o->camera_model,
             o->single_camera);
}

/* NULL when the manifest's photos are all among p, unchanged, else the reason. */
static const char *changed(const char *text, const char *want_header, const colmap_photos *p, char *why, size_t size)
{
    size_t hl = strlen(want_header);
    if (strncmp(text, want_header, hl) || text[hl] != '\n') return "COLMAP's camera options changed";
    for (const char *line = text + hl + 1; *line;) {
        const char *end = strchr(line, '\n');
        size_t len = end ? (size_t)(end - line) : strlen(line);
        long long bytes, mtime;
        int name_at = 0;
        char name[GV_COLMAP_MAX_NAME + 64];
        snprintf(name, sizeof name, "%.*s", (int)(len < sizeof name - 1 ? len : sizeof name - 1), line);
        if (sscanf(name, "%lld %lld %n", &bytes, &mtime, &name_at) != 2 || !name_at) return "photos.txt is damaged";
        int i = 0;
        while (i < p->n && strcmp(p->photo[i].name, name + name_at)) i++;
        if (i == p->n) return snprintf(why, size, "%s is no longer among the photos", name + name_at), why;
        if (p->photo[i].bytes != bytes || p->photo[i].mtime != mtime)
            return snprintf(why, size, "%s changed", name + name_at), why;
        line += len + (end != NULL);
    }
    return NULL;
}

static int write_lines(const char *path, const char *first, const colmap_photos *p, int with_stat)
{
    size_t size = (size_t)p->n * (GV_COLMAP_MAX_NAME + 48) + strlen(first) + 2, len = 0;
    char *text = malloc(size);
    if (!text) return gv_fail("out of memory");
    len += (size_t)snprintf(text, size, "%s", first);
    for (int i = 0; i < p->n; i++) {
        const colmap_photo *ph = &p->photo[i];
        if (with_stat) len += (size_t)snprintf(text + len, size - len, "%s%lld %lld %s", len ? "\n" : "", ph->bytes, ph->mtime, ph->name);
        else len += (size_t)snprintf(text + len, size - len, "%s%s", len ? "\n" : "", ph->name);
    }
    int rc = gv_write_text_atomic(path, text); /* it adds the last newline */
    free(text);
    return rc;
}

static void remove_database(const char *db)
{
    static const char *const sidecars[] = {"", "-journal", "-wal", "-shm"};
    for (int i = 0; i < 4; i++) {
        char path[COLMAP_PATH + 16];
        snprintf(path, sizeof path, "%s%s", db, sidecars[i]);
        remove(path);
    }
}

int colmap_prepare_database(const colmap_paths *paths, const gv_colmap_run_options *o, const colmap_photos *p,
                            int *resumed)
{
    char head[512], why[GV_COLMAP_MAX_NAME + 64];
    header(o, head, sizeof head);
    *resumed = 0;
    if (gv_file_exists(paths->db)) {
        char *text = NULL;
        size_t size;
        const char *reason = "no photos.txt beside it";
        if (gv_file_exists(paths->manifest)) {
            if (gv_read_file(paths->manifest, &text, &size)) return -1;
            reason = changed(text, head, p, why, sizeof why);
            free(text);
        }
        if (reason) {
            gv_info("a new COLMAP database: %s (%s)", reason, paths->db);
            remove_database(paths->db);
        } else {
            *resumed = 1;
            gv_info("resuming with %s: COLMAP skips the photos whose features it holds and the pairs it has matched",
                    paths->db);
        }
    }
    if (write_lines(paths->manifest, head, p, 1)) return -1;
    return write_lines(paths->list, "", p, 0);
}
