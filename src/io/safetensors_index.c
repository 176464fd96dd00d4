/* Sharded safetensors checkpoints: "<name>.safetensors.index.json" is
 *   {"metadata": {"total_size": ...}, "weight_map": {"<tensor>": "<shard file>", ...}}
 * (the huggingface convention, e.g. Wan2.1-VACE-14B's seven shards). The shards are opened
 * and presented as one gv_st_file whose tensors point into the shards' mappings, so a
 * loader that reads one file by name reads a sharded checkpoint unchanged. The index and
 * the shards must agree exactly: a tensor the map names must be in its shard, and a tensor
 * of a shard must be mapped to that shard (anything else means mixed-up files). */
#include <cjson/cJSON.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>

#include "gaussvid/core/core.h"
#include "gaussvid/io/safetensors.h"
#include "io/safetensors_internal.h"

/* An index lists names and file names only: 14B's is about 100 KB. */
enum { INDEX_MAX_BYTES = 64 << 20, INDEX_MAX_SHARDS = 100000 };

typedef struct {
    int n;
    gv_st_file *shards;
} shard_set;

static void release_shards(void *owner)
{
    shard_set *s = owner;
    for (int i = 0; i < s->n; i++) gv_st_close(&s->shards[i]);
    free(s->shards);
    free(s);
}

/* One weight-map entry: tensor name -> shard file and its number. */
typedef struct {
    const char *name, *file;
    int shard;
} map_entry;

static int by_entry_name(const void *a, const void *b)
{
    return strcmp(((const map_entry *)a)->name, ((const map_entry *)b)->name);
}

static const map_entry *map_find(const map_entry *map, int n, const char *name)
{
    map_entry key = {name, NULL, 0};
    return bsearch(&key, map, (size_t)n, sizeof *map, by_entry_name);
}

/* A shard is named relative to the index's folder: no absolute path, no "..", so an index
 * cannot point a loader at files outside its release folder. */
static int check_shard_name(const char *index, const char *tensor, const char *shard)
{
    if (!*shard) return gv_fail("%s: tensor '%s' is mapped to an empty file name", index, tensor);
    if (shard[0] == '/') return gv_fail("%s: tensor '%s': shard '%s' is an absolute path", index, tensor, shard);
    for (const char *p = shard; *p; p++)
        if ((p == shard || p[-1] == '/') && p[0] == '.' && p[1] == '.' && (p[2] == '/' || p[2] == '\0'))
            return gv_fail("%s: tensor '%s': shard '%s' leaves the index's folder", index, tensor, shard);
    return 0;
}

static int by_string(const void *a, const void *b)
{
    return strcmp(*(const char *const *)a, *(const char *const *)b);
}

/* Reads the weight map: names sorted with their shard numbers, and the distinct shard names
 * sorted (so "-00001-of-" is the first shard whatever the map's order). */
static int read_weight_map(const char *path, const cJSON *root, map_entry **map_out, int *n_map,
                           const char ***shard_names, int *n_shards)
{
    const cJSON *wm = cJSON_GetObjectItemCaseSensitive(root, "weight_map");
    if (!cJSON_IsObject(wm)) return gv_fail("%s: no \"weight_map\" object (not a safetensors index?)", path);
    int n = cJSON_GetArraySize(wm);
    if (n == 0) return gv_fail("%s: the weight_map is empty", path);
    map_entry *map = malloc((size_t)n * sizeof *map);
    const char **names = malloc((size_t)n * sizeof *names);
    if (!map || !names) {
        free(map);
        free(names);
        return gv_fail("%s: out of memory for %d entries", path, n);
    }
    int k = 0, shards = 0, rc = 0;
    const cJSON *e;
    cJSON_ArrayForEach(e, wm) {
        if (!cJSON_IsString(e)) { rc = gv_fail("%s: weight_map entry '%s' is not a file name", path, e->string); break; }
        if ((rc = check_shard_name(path, e->string, e->valuestring))) break;
        map[k++] = (map_entry){e->string, e->valuestring, 0};
        names[shards++] = e->valuestring;
    }
    if (rc == 0) { /* distinct shard names, sorted; then each entry's shard number */
        qsort(names, (size_t)shards, sizeof *names, by_string);
        int distinct = 0;
        for (int i = 0; i < shards; i++)
            if (i == 0 || strcmp(names[i], names[distinct - 1])) names[distinct++] = names[i];
        shards = distinct;
        if (shards > INDEX_MAX_SHARDS) rc = gv_fail("%s: %d shards, more than %d", path, shards, INDEX_MAX_SHARDS);
        for (int i = 0; i < n && rc == 0; i++) {
            const char **found = bsearch(&map[i].file, names, (size_t)shards, sizeof *names, by_string);
            map[i].shard = (int)(found - names);
        }
    }
    if (rc == 0) {
        qsort(map, (size_t)n, sizeof *map, by_entry_name);
        for (int i = 1; i < n && rc == 0; i++) /* cJSON keeps both of a repeated key */
            if (!strcmp(map[i].name, map[i - 1].name)) rc = gv_fail("%s: tensor '%s' is listed twice", path, map[i].name);
    }
    if (rc) {
        free(map);
        free(names);
        return -1;
    }
    *map_out = map, *n_map = n, *shard_names = names, *n_shards = shards;
    return 0;
}

static int open_shards(const char *path, const char **names, int n, shard_set *set)
{
    char dir[4096], shard_path[8192];
    snprintf(dir, sizeof dir, "%s", path);
    char *slash = strrchr(dir, '/');
    if (slash) *slash = '\0';
    else snprintf(dir, sizeof dir, ".");
    if (!(set->shards = calloc((size_t)n, sizeof *set->shards))) return gv_fail("%s: out of memory", path);
    for (set->n = 0; set->n < n; set->n++) {
        if (gv_path_join(shard_path, sizeof shard_path, dir, names[set->n])) return -1;
        if (gv_st_open(&set->shards[set->n], shard_path)) return gv_fail_context("%s", path);
    }
    return 0;
}

/* Every tensor of every shard must be mapped to that shard, and every mapped tensor found. */
static int check_agreement(const char *path, const map_entry *map, int n_map, const char **names, const shard_set *set)
{
    long total = 0;
    for (int s = 0; s < set->n; s++) {
        const gv_st_file *sh = &set->shards[s];
        total += sh->n_tensors;
        for (int i = 0; i < sh->n_tensors; i++) {
            const map_entry *e = map_find(map, n_map, sh->tensors[i].name);
            if (!e) return gv_fail("%s: shard %s holds tensor '%s', which the index does not list", path, names[s],
                                   sh->tensors[i].name);
            if (e->shard != s)
                return gv_fail("%s: shard %s holds tensor '%s', which the index maps to %s", path, names[s],
                               sh->tensors[i].name, names[e->shard]);
        }
    }
    for (int i = 0; i < n_map; i++)
        if (!gv_st_find(&set->shards[map[i].shard], map[i].name))
            return gv_fail("%s: tensor '%s' is mapped to shard %s, which does not hold it", path, map[i].name,
                           names[map[i].shard]);
    /* each shard tensor was found in the map under its shard, and names are unique per shard
     * and in the map, so the counts agree; kept as a cheap guard */
    if (total != n_map) return gv_fail("%s: the shards hold %ld tensors, the index lists %d", path, total, n_map);
    return 0;
}

/* The merged view: tensors of all shards, metadata of all shards (the first value wins). */
static int merge(gv_st_file *f, const shard_set *set)
{
    int n = 0, n_meta = 0;
    for (int s = 0; s < set->n; s++) n += set->shards[s].n_tensors, n_meta += set->shards[s].n_metadata;
    f->tensors = malloc(((size_t)n + 1) * sizeof *f->tensors);
    f->metadata_keys = malloc(((size_t)n_meta + 1) * sizeof *f->metadata_keys);
    f->metadata_values = malloc(((size_t)n_meta + 1) * sizeof *f->metadata_values);
    if (!f->tensors || !f->metadata_keys || !f->metadata_values) return gv_fail("%s: out of memory", f->path);
    for (int s = 0; s < set->n; s++) {
        const gv_st_file *sh = &set->shards[s];
        memcpy(f->tensors + f->n_tensors, sh->tensors, (size_t)sh->n_tensors * sizeof *sh->tensors);
        f->n_tensors += sh->n_tensors;
        f->file_size += sh->file_size, f->header_size += sh->header_size, f->data_size += sh->data_size;
        for (int k = 0; k < sh->n_metadata; k++) {
            if (gv_st_metadata(f, sh->metadata_keys[k])) continue;
            f->metadata_keys[f->n_metadata] = sh->metadata_keys[k];
            f->metadata_values[f->n_metadata++] = sh->metadata_values[k];
        }
    }
    return gv_st_build_name_index(f);
}

int gv_st_index_open(gv_st_file *f, const char *path)
{
    memset(f, 0, sizeof *f);
    struct stat st;
    if (stat(path, &st) != 0 || !S_ISREG(st.st_mode)) return gv_fail("%s: cannot open: not a readable file", path);
    if (st.st_size > INDEX_MAX_BYTES)
        return gv_fail("%s: %lld bytes is too large for a safetensors index (limit %d)", path, (long long)st.st_size,
                       INDEX_MAX_BYTES);
    char *text = NULL;
    if (gv_read_file(path, &text, NULL)) return -1;
    cJSON *root = cJSON_ParseWithOpts(text, NULL, 1); /* nothing but whitespace after it */
    free(text);
    if (!cJSON_IsObject(root)) {
        cJSON_Delete(root);
        return gv_fail("%s: not a JSON object (a safetensors index is {\"weight_map\": {...}})", path);
    }
    map_entry *map = NULL;
    const char **names = NULL;
    int n_map = 0, n_shards = 0;
    shard_set *set = calloc(1, sizeof *set);
    int rc = set ? 0 : gv_fail("%s: out of memory", path);
    if (rc == 0) rc = read_weight_map(path, root, &map, &n_map, &names, &n_shards);
    if (rc == 0) rc = open_shards(path, names, n_shards, set);
    if (rc == 0) rc = check_agreement(path, map, n_map, names, set);
    free(map);
    free(names);
    cJSON_Delete(root); /* the shard names lived in it; the shards keep their own copies */
    if (set) { /* from here on gv_st_close releases the shards, also on failure */
        f->owner = set;
        f->release = release_shards;
    }
    if (rc == 0 && !(f->path = strdup(path))) rc = gv_fail("%s: out of memory", path);
    if (rc == 0) rc = merge(f, set);
    if (rc) {
        gv_st_close(f);
        return -1;
    }
    return 0;
}
