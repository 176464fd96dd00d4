/* The pairs `scene colmap` matches (colmap_internal.h, docs/SCENES.md "Matching"):
 * - sequential (ordered names, video frames): each photo with its next WINDOW photos, with
 *   those 16, 32, 64 ... ahead (COLMAP's quadratic overlap), and loop closure: the capture is
 *   taken as a ring, its last WINDOW photos matched with its first ones (a walk around an
 *   object ends where it began); with a vocabulary tree, COLMAP's retrieval adds the WINDOW
 *   most similar photos of each (loops anywhere);
 * - exhaustive (unordered names, no tree): every pair;
 * - vocab_tree (unordered names, a tree given): COLMAP's vocab_tree_matcher.
 * Listed pairs go to COLMAP's matches_importer in chunks, so progress counts pairs; COLMAP
 * skips a pair its database already holds, so a rerun after a kill continues. */
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "colmap_internal.h"

#define WINDOW 10 /* COLMAP's default SequentialMatching.overlap */

typedef struct {
    int a, b;
} photo_pair;

/* The pairs of a matcher over n photos in capture order; *count of them (NULL list: count only). */
static long list_pairs(const char *matcher, int n, photo_pair *list)
{
    long count = 0;
    int sequential = !strcmp(matcher, "sequential");
    for (int a = 0; a < n; a++)
        for (int b = a + 1; b < n; b++) {
            int d = b - a; /* n - d: the distance the other way round the ring; d a power of 2 */
            if (sequential && d > WINDOW && n - d > WINDOW && (d & (d - 1))) continue;
            if (list) list[count] = (photo_pair){a, b};
            count++;
        }
    return count;
}

int colmap_choose_matcher(const gv_colmap_run_options *o, const colmap_photos *p, char *matcher, size_t size,
                          char *why, size_t why_size, long *pairs)
{
    const char *m = o->matcher;
    const char *kind = o->video ? "video frames" : p->ordered ? "ordered names" : "unordered names";
    if (!m) m = p->ordered ? "sequential" : o->vocab_tree ? "vocab_tree" : "exhaustive";
    if (strcmp(m, "exhaustive") && strcmp(m, "sequential") && strcmp(m, "vocab_tree"))
        return gv_fail("matcher %s: expected exhaustive, sequential or vocab_tree", m);
    if (!strcmp(m, "vocab_tree") && !o->vocab_tree) return gv_fail("matcher vocab_tree needs --vocab-tree FILE");
    snprintf(matcher, size, "%s", m);
    *pairs = strcmp(m, "vocab_tree") ? list_pairs(m, p->n, NULL) : 0;
    long all = (long)p->n * (p->n - 1) / 2;
    const char *chosen = o->matcher ? "as asked" : "chosen";
    if (!strcmp(m, "sequential"))
        snprintf(why, why_size, "matcher: sequential with loop closure (%s, %s): %ld of the %ld pairs, each photo with "
                 "its %d next, 16, 32, ... ahead, the last with the first%s", kind, chosen, *pairs, all, WINDOW,
                 o->vocab_tree ? ", and the vocabulary tree's closest" : "");
    else if (!strcmp(m, "exhaustive"))
        snprintf(why, why_size, "matcher: exhaustive (%s, %s): all %ld pairs%s", kind, chosen, all,
                 p->ordered || o->matcher ? "" : "; names like IMG_0001.JPG would match in sequence, and --vocab-tree "
                 "FILE scales to large sets");
    else
        snprintf(why, why_size, "matcher: vocab_tree (%s, %s): each photo with its closest in %s", kind, chosen,
                 o->vocab_tree);
    return 0;
}

/* One chunk of pairs through matches_importer. */
static int match_chunk(const colmap_paths *paths, const colmap_photos *p, const photo_pair *pairs, long n)
{
    size_t size = (size_t)n * (2 * GV_COLMAP_MAX_NAME + 2) + 1, len = 0;
    char *text = malloc(size), file[COLMAP_PATH + 16];
    if (!text) return gv_fail("out of memory for %ld pairs", n);
    for (long i = 0; i < n; i++)
        len += (size_t)snprintf(text + len, size - len, "%s%s %s", i ? "\n" : "", p->photo[pairs[i].a].name,
                                p->photo[pairs[i].b].name);
    snprintf(file, sizeof file, "%s/pairs.txt", paths->work);
    int rc = gv_write_text_atomic(file, text);
    free(text);
    const char *argv[] = {paths->colmap, "matches_importer", "--database_path", paths->db, "--match_list_path", file,
                          "--match_type", "pairs", "--SiftMatching.use_gpu", "0", "--SiftMatching.num_threads",
                          paths->threads, NULL};
    return rc ? rc : colmap_step(argv, paths->log, NULL, NULL);
}

/* "Matching image [i/N]" of COLMAP's vocab_tree_matcher moves the bar. */
static void on_matching_line(const char *line, void *ctx)
{
    int i, n;
    if (sscanf(line, "Matching image [%d/%d]", &i, &n) == 2) gv_progress_update(ctx, i, NULL);
}

static int match_tree(const colmap_paths *paths, const gv_colmap_run_options *o, const colmap_photos *p,
                      int loops_only)
{
    char k[16];
    snprintf(k, sizeof k, "%d", loops_only ? WINDOW : 100); /* 100: COLMAP's default */
    const char *argv[] = {paths->colmap, "vocab_tree_matcher", "--database_path", paths->db,
                          "--VocabTreeMatching.vocab_tree_path", o->vocab_tree, "--VocabTreeMatching.num_images", k,
                          "--SiftMatching.use_gpu", "0", "--SiftMatching.num_threads", paths->threads, NULL};
    gv_progress bar;
    gv_progress_start(&bar, loops_only ? "loops (tree)" : "match (tree)", p->n);
    int rc = colmap_step(argv, paths->log, on_matching_line, &bar);
    gv_progress_finish(&bar);
    return rc;
}

int colmap_match(const colmap_paths *paths, const gv_colmap_run_options *o, const colmap_photos *p,
                 const char *matcher)
{
    if (!strcmp(matcher, "vocab_tree")) return match_tree(paths, o, p, 0);
    long total = list_pairs(matcher, p->n, NULL);
    photo_pair *pairs = malloc((size_t)total * sizeof *pairs);
    if (!pairs) return gv_fail("out of memory for %ld pairs", total);
    list_pairs(matcher, p->n, pairs);
    long chunk = (total + 19) / 20; /* about twenty updates of the bar */
    if (chunk < 25) chunk = 25;
    if (chunk > 400) chunk = 400;
    gv_progress bar;
    gv_progress_start(&bar, "match pairs", total);
    int rc = 0;
    for (long done = 0; done < total && rc == 0;) {
        long n = total - done < chunk ? total - done : chunk;
        rc = match_chunk(paths, p, pairs + done, n);
        done += n;
        gv_progress_update(&bar, done, "pairs matched of %ld", total);
    }
    gv_progress_finish(&bar);
    free(pairs);
    if (rc == 0 && o->vocab_tree && !strcmp(matcher, "sequential")) rc = match_tree(paths, o, p, 1);
    return rc;
}
