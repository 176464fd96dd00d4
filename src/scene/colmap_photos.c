/* The photos of `scene colmap` (colmap_internal.h): listed and put in capture order, decoded
 * once, and the database of an earlier run kept when it was made from the same photos. */
#include <ctype.h>
#include <dirent.h>
#include <stdlib.h>
#include <string.h>
#include <strings.h>
#include <sys/stat.h>

#include "colmap_internal.h"
#include "gaussvid/io/image.h"

static int is_photo(const char *name)
{
    const char *dot = strrchr(name, '.');
    return dot && (!strcasecmp(dot, ".png") || !strcasecmp(dot, ".jpg") || !strcasecmp(dot, ".jpeg"));
}

/* The name's number: the last run of digits before the extension, leading zeros skipped
 * (*digits its start, *len its length); *prefix_len the length of what comes before it.
 * 0 when the name has no number there. */
static int name_number(const char *name, const char **digits, size_t *len, size_t *prefix_len)
{
    const char *dot = strrchr(name, '.'), *end = dot ? dot : name + strlen(name), *start = end;
    while (start > name && isdigit((unsigned char)start[-1])) start--;
    if (start == end) return 0;
    *prefix_len = (size_t)(start - name);
    while (start < end - 1 && *start == '0') start++;
    *digits = start, *len = (size_t)(end - start);
    return 1;
}

static int by_name(const void *a, const void *b)
{
    return strcmp(((const colmap_photo *)a)->name, ((const colmap_photo *)b)->name);
}

/* Ordered names: by number (shorter digit strings are smaller numbers), then by name. */
static int by_number(const void *a, const void *b)
{
    const char *na = ((const colmap_photo *)a)->name, *nb = ((const colmap_photo *)b)->name, *da, *db;
    size_t la, lb, pa, pb;
    name_number(na, &da, &la, &pa);
    name_number(nb, &db, &lb, &pb);
    if (la != lb) return la < lb ? -1 : 1;
    int c = strncmp(da, db, la);
    return c ? c : strcmp(na, nb);
}

/* Ordered: every name is one common prefix and a number (IMG_0001.JPG, DSC04512.JPG,
 * frame_00001.png, PXL_20240101_120000123.jpg): cameras and phones count up as they shoot. */
static int names_ordered(const colmap_photos *p)
{
    const char *d;
    size_t len, prefix, prefix0 = 0;
    for (int i = 0; i < p->n; i++) {
        if (!name_number(p->photo[i].name, &d, &len, &prefix)) return 0;
        if (i == 0) prefix0 = prefix;
        else if (prefix != prefix0 || strncmp(p->photo[i].name, p->photo[0].name, prefix)) return 0;
    }
    return 1;
}

static int add_photo(colmap_photos *p, int *cap, const char *dir, const char *name)
{
    if (strlen(name) >= GV_COLMAP_MAX_NAME)
        return gv_fail("%s/%s: name longer than %d bytes", dir, name, GV_COLMAP_MAX_NAME - 1);
    if (p->n == *cap) {
        *cap = *cap ? 2 * *cap : 64;
        void *grown = realloc(p->photo, (size_t)*cap * sizeof *p->photo);
        if (!grown) return gv_fail("out of memory for %d photo names", *cap);
        p->photo = grown;
    }
    colmap_photo *ph = &p->photo[p->n++];
    memset(ph, 0, sizeof *ph);
    snprintf(ph->name, sizeof ph->name, "%s", name);
    ph->orientation = 1;
    char path[COLMAP_PATH];
    struct stat st;
    snprintf(path, sizeof path, "%s/%s", dir, name);
    if (stat(path, &st) == 0) ph->bytes = (long long)st.st_size, ph->mtime = (long long)st.st_mtime;
    return 0;
}

int colmap_list_photos(const char *dir, colmap_photos *p)
{
    memset(p, 0, sizeof *p);
    DIR *d = opendir(dir);
    if (!d) return gv_fail("%s: no such folder of photos", dir);
    int cap = 0, rc = 0;
    struct dirent *e;
    while (rc == 0 && (e = readdir(d)))
        if (e->d_name[0] != '.' && is_photo(e->d_name)) rc = add_photo(p, &cap, dir, e->d_name);
    closedir(d);
    if (rc) return -1;
    if (p->n < 3) return gv_fail("%s: %d photos (.png, .jpg, .jpeg); COLMAP needs at least 3", dir, p->n);
    p->ordered = names_ordered(p);
    qsort(p->photo, (size_t)p->n, sizeof *p->photo, p->ordered ? by_number : by_name);
    return 0;
}

int colmap_read_photos(const char *dir, int single_camera, colmap_photos *p)
{
    gv_progress bar;
    gv_progress_start(&bar, "read photos", p->n);
    int rc = 0;
    for (int i = 0; i < p->n && rc == 0; i++) {
        char path[COLMAP_PATH];
        gv_image img = {0};
        snprintf(path, sizeof path, "%s/%s", dir, p->photo[i].name);
        /* as stored: COLMAP ignores the EXIF orientation; the scene is turned upright after */
        if (gv_image_read_stored(path, &img, &p->photo[i].orientation)) rc = -1; /* the line names the file */
        else if (i == 0) p->width = img.width, p->height = img.height;
        else if (single_camera && (img.width != p->width || img.height != p->height))
            rc = gv_fail("%s: %dx%d, but %s is %dx%d: photos of one camera share a size", path, img.width, img.height,
                         p->photo[0].name, p->width, p->height);
        gv_image_free(&img);
        gv_progress_update(&bar, i + 1, NULL);
    }
    gv_progress_finish(&bar);
    return rc;
}

void colmap_photos_free(colmap_photos *p)
{
    free(p->photo);
    memset(p, 0, sizeof *p);
}
