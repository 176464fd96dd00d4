/* The latent cache of a dataset (docs/ARCHITECTURE.md 6.2: clip latents are computed once): one safetensors
 * file in the dataset folder per (VAE weights, anchors variant, per-frame, coverage), holding for every
 * clip its z_clean, z_corrupt and VACE context, and in "__metadata__" the checksum of each
 * clip file it was computed from. condition.h gives the rules. */
#include <inttypes.h>
#include <stdlib.h>
#include <string.h>

#include <cjson/cJSON.h>

#include "gaussvid/train/condition.h"
#include "gaussvid/core/core.h"
#include "gaussvid/core/dist.h"
#include "gaussvid/io/safetensors.h"

#define CACHE_FORMAT "gaussvid.latents"
#define CACHE_FORMAT_VERSION "1" /* bump when the conditioning of a clip changes */

static const char *const part_names[3] = {"z_clean", "z_corrupt", "vace"};

uint64_t gv_fnv1a64(uint64_t h, const void *data, size_t size)
{
    const unsigned char *p = data;
    for (size_t i = 0; i < size; i++) h = (h ^ p[i]) * 0x100000001b3ull;
    return h;
}

uint64_t gv_vae_checksum(const gv_vae *vae)
{
    uint64_t h = GV_FNV_OFFSET;
    for (int i = 0; i < vae->params.n; i++) {
        const gv_tensor *t = &vae->params.items[i]->t;
        h = gv_fnv1a64(h, t->name, strlen(t->name) + 1);
        h = gv_fnv1a64(h, t->shape, sizeof(int) * (size_t)t->ndim);
        h = gv_fnv1a64(h, t->data, (size_t)t->numel * sizeof(float));
    }
    int z = vae->cfg.z_dim;
    h = gv_fnv1a64(h, &vae->has_stats, sizeof vae->has_stats);
    h = gv_fnv1a64(h, vae->mean, (size_t)z * sizeof(float));
    return gv_fnv1a64(h, vae->std, (size_t)z * sizeof(float));
}

int gv_latent_cache_path(char *out, size_t size, const char *dataset_dir, uint64_t vae_key, const gv_model_config *cfg)
{
    char name[128];
    snprintf(name, sizeof name, "latents_%016" PRIx64 "_%s%s%s.safetensors", vae_key, gv_anchors_name(cfg->variant.anchors),
             cfg->variant.per_frame ? "_per-frame" : "", cfg->variant.coverage ? "_coverage" : "");
    return gv_path_join(out, size, dataset_dir, name);
}

int64_t gv_latent_set_max_z_count(const gv_latent_set *s)
{
    int64_t most = 0;
    for (int i = 0; i < s->count; i++)
        if (gv_clip_latents_z_count(&s->clips[i]) > most) most = gv_clip_latents_z_count(&s->clips[i]);
    return most;
}

void gv_latent_set_free(gv_latent_set *s)
{
    if (!s) return;
    for (int i = 0; i < s->count; i++) {
        if (s->clips) gv_clip_latents_free(&s->clips[i]);
        if (s->names) free(s->names[i]);
    }
    free(s->clips), free(s->names);
    memset(s, 0, sizeof *s);
}

/* ---- the cache file ------------------------------------------------------------------------ */
typedef struct {
    gv_st_file f;
    int open;
    cJSON *clips; /* name -> checksum (hex string) */
} cache_file;

static void cache_close(cache_file *c)
{
    if (c->open) gv_st_close(&c->f);
    cJSON_Delete(c->clips);
    memset(c, 0, sizeof *c);
}

/* Opens the cache when it exists and is ours for this key and config; otherwise leaves it
 * closed (a file that cannot be used is reported and will be replaced). */
static void cache_open(const char *path, uint64_t key, const gv_model_config *cfg, cache_file *c)
{
    memset(c, 0, sizeof *c);
    if (!gv_file_exists(path)) return;
    char want[32];
    snprintf(want, sizeof want, "%016" PRIx64, key);
    const char *why = NULL;
    if (gv_st_open(&c->f, path) != 0) {
        gv_warn("%s; rebuilding the latent cache", gv_last_error());
        return;
    }
    c->open = 1;
    const char *format = gv_st_metadata(&c->f, "format"), *version = gv_st_metadata(&c->f, "format_version");
    const char *vae = gv_st_metadata(&c->f, "vae"), *anchors = gv_st_metadata(&c->f, "anchors");
    const char *per_frame = gv_st_metadata(&c->f, "per_frame"), *clips = gv_st_metadata(&c->f, "clips");
    if (!format || strcmp(format, CACHE_FORMAT)) why = "not a gaussvid latent cache";
    else if (!version || strcmp(version, CACHE_FORMAT_VERSION)) why = "another cache format version";
    else if (!vae || strcmp(vae, want)) why = "computed with another VAE";
    else if (!anchors || strcmp(anchors, gv_anchors_name(cfg->variant.anchors)) || !per_frame ||
             strcmp(per_frame, cfg->variant.per_frame ? "true" : "false"))
        why = "computed for another anchors variant";
    else if (!gv_st_metadata(&c->f, "coverage") != !cfg->variant.coverage) /* written only when on */
        why = "computed for another VACE mask (coverage)";
    else if (!clips || !cJSON_IsObject(c->clips = cJSON_Parse(clips)))
        why = "\"clips\" metadata is not a JSON object";
    if (why) {
        gv_warn("%s: %s; rebuilding the latent cache", path, why);
        cache_close(c);
    }
}

/* 1 and l filled (arrays allocated) when the cache holds the clip computed from the same file
 * content with the sizes l already has; 0 otherwise. */
static int cache_take(cache_file *c, const char *name, const char *hash, gv_clip_latents *l)
{
    if (!c->open) return 0;
    const cJSON *h = cJSON_GetObjectItemCaseSensitive(c->clips, name);
    if (!cJSON_IsString(h) || strcmp(h->valuestring, hash)) return 0;
    gv_clip_latents sized = *l;
    if (gv_clip_latents_alloc(l, 0)) return -1;
    float *dst[3] = {l->z_clean, l->z_corrupt, l->vace};
    int channels[3] = {l->z_dim, l->z_dim, l->vace_dim};
    for (int k = 0; k < 3; k++) {
        char tensor[512];
        snprintf(tensor, sizeof tensor, "%s/%s", name, part_names[k]);
        int64_t shape[5] = {l->batch, channels[k], l->latent_frames, l->lh, l->lw};
        if (gv_st_read_f32(&c->f, tensor, dst[k], shape, 5) != 0) {
            gv_debug("latent cache: %s; encoding again", gv_last_error());
            gv_clip_latents_free(l);
            *l = sized;
            return 0;
        }
    }
    return 1;
}

/* Writes every clip of the set plus the old file's entries for other clips of the manifest. */
static int cache_write(const char *path, uint64_t key, const gv_model_config *cfg, const char *vae_path,
                       const gv_latent_set *s, char (*hashes)[20], cache_file *old, const gv_manifest *m)
{
    gv_st_builder b;
    gv_st_builder_init(&b);
    cJSON *clips = cJSON_CreateObject();
    int rc = clips ? 0 : gv_fail("%s: out of memory", path);
    for (int i = 0; rc == 0 && i < s->count; i++) {
        const gv_clip_latents *l = &s->clips[i];
        const float *src[3] = {l->z_clean, l->z_corrupt, l->vace};
        int channels[3] = {l->z_dim, l->z_dim, l->vace_dim};
        for (int k = 0; rc == 0 && k < 3; k++) {
            char tensor[512];
            snprintf(tensor, sizeof tensor, "%s/%s", s->names[i], part_names[k]);
            int64_t shape[5] = {l->batch, channels[k], l->latent_frames, l->lh, l->lw};
            rc = gv_st_add_f32(&b, tensor, GV_ST_F32, shape, 5, src[k]);
        }
        if (rc == 0 && !cJSON_AddStringToObject(clips, s->names[i], hashes[i])) rc = gv_fail("%s: out of memory", path);
    }
    /* entries of clips outside this selection stay, while the manifest lists them */
    for (int j = 0; rc == 0 && old->open && j < m->n_clips; j++) {
        const char *name = m->clips[j].file;
        const cJSON *h = cJSON_GetObjectItemCaseSensitive(old->clips, name);
        if (!cJSON_IsString(h) || cJSON_GetObjectItemCaseSensitive(clips, name)) continue;
        int present = 1;
        const gv_st_tensor *t[3];
        for (int k = 0; k < 3 && present; k++) {
            char tensor[512];
            snprintf(tensor, sizeof tensor, "%s/%s", name, part_names[k]);
            t[k] = gv_st_find(&old->f, tensor);
            present = t[k] && t[k]->dtype == GV_ST_F32;
        }
        for (int k = 0; k < 3 && present && rc == 0; k++)
            rc = gv_st_add_raw(&b, t[k]->name, GV_ST_F32, t[k]->shape, t[k]->rank, t[k]->data);
        if (present && rc == 0 && !cJSON_AddStringToObject(clips, name, h->valuestring))
            rc = gv_fail("%s: out of memory", path);
    }
    char key_hex[32];
    snprintf(key_hex, sizeof key_hex, "%016" PRIx64, key);
    char *clips_json = rc == 0 ? cJSON_PrintUnformatted(clips) : NULL;
    if (rc == 0 && !clips_json) rc = gv_fail("%s: out of memory", path);
    if (rc == 0)
        rc = gv_st_add_metadata(&b, "format", CACHE_FORMAT) || gv_st_add_metadata(&b, "format_version", CACHE_FORMAT_VERSION) ||
                     gv_st_add_metadata(&b, "vae", key_hex) ||
                     gv_st_add_metadata(&b, "vae_path", vae_path ? vae_path : "") ||
                     gv_st_add_metadata(&b, "anchors", gv_anchors_name(cfg->variant.anchors)) ||
                     gv_st_add_metadata(&b, "per_frame", cfg->variant.per_frame ? "true" : "false") ||
                     (cfg->variant.coverage && gv_st_add_metadata(&b, "coverage", "true")) ||
                     gv_st_add_metadata(&b, "clips", clips_json) || gv_st_write(&b, path)
                 ? -1
                 : 0;
    free(clips_json);
    cJSON_Delete(clips);
    gv_st_builder_free(&b);
    return rc;
}

/* ---- loading a set ------------------------------------------------------------------------- */
/* The manifest's clips of the split, names copied into s (count set, clips zeroed). */
static int select_clips(const char *dir, const char *split, const gv_manifest *m, gv_latent_set *s)
{
    if (split && strcmp(split, "train") && strcmp(split, "eval"))
        return gv_fail("split '%s': expected train or eval", split);
    int n = 0;
    for (int i = 0; i < m->n_clips; i++) n += !split || !strcmp(m->clips[i].id.split, split);
    if (n == 0) return gv_fail("%s: the manifest lists no %s clips", dir, split ? split : "");
    s->clips = calloc((size_t)n, sizeof *s->clips);
    s->names = calloc((size_t)n, sizeof *s->names);
    if (!s->clips || !s->names) return gv_fail("%s: out of memory for %d clips", dir, n);
    for (int i = 0; i < m->n_clips; i++) {
        if (split && strcmp(m->clips[i].id.split, split)) continue;
        if (!(s->names[s->count] = strdup(m->clips[i].file))) return gv_fail("%s: out of memory", dir);
        s->count++;
    }
    return 0;
}

/* Clip i: read it, checksum its file, take its latents from the cache or encode them. */
static int load_one(const char *dir, gv_latent_set *s, int i, char hash[20], cache_file *cache, gv_vae *vae,
                    const gv_model_config *cfg, int encode)
{
    char path[4096];
    if (gv_path_join(path, sizeof path, dir, s->names[i])) return -1;
    char *bytes;
    size_t size;
    if (gv_read_file(path, &bytes, &size)) return -1;
    snprintf(hash, 20, "%016" PRIx64, gv_fnv1a64(GV_FNV_OFFSET, bytes, size));
    free(bytes);
    gv_clip clip;
    if (gv_clip_read(path, &clip)) return -1;
    gv_clip_latents *l = &s->clips[i];
    int rc = gv_clip_latents_shape(vae, cfg, &clip.info, l);
    int taken = rc == 0 ? cache_take(cache, s->names[i], hash, l) : -1;
    if (taken < 0) rc = -1;
    else if (taken == 0 && encode) {
        rc = gv_clip_latents_prepare(vae, cfg, &clip, l);
        s->encoded += rc == 0;
    } else if (taken == 0) {
        rc = 1; /* to be encoded in the second pass */
    } else if (cfg->variant.camera != GV_CAMERA_NONE) {
        l->plucker = malloc((size_t)gv_clip_latents_plucker_count(l) * sizeof(float));
        rc = l->plucker ? gv_clip_latents_plucker(&clip, vae->cfg.temporal_factor, l)
                        : gv_fail("out of memory for a Plücker field");
    }
    gv_clip_free(&clip);
    if (rc < 0) return gv_fail_context("%s", path);
    return rc;
}

static int load_set(const char *dataset_dir, const char *split, const char *vae_path, gv_vae *vae,
                    const gv_model_config *cfg, gv_latent_set *out);

/* Under mpirun rank 0 loads first, encoding what the cache lacks and writing it; the other
 * ranks then read the cache it wrote instead of encoding the same clips again. */
int gv_latent_set_load(const char *dataset_dir, const char *split, const char *vae_path, gv_vae *vae,
                       const gv_model_config *cfg, gv_latent_set *out)
{
    memset(out, 0, sizeof *out);
    if (!gv_dist_is_root() && gv_dist_after_root(0, dataset_dir)) return -1;
    int rc = load_set(dataset_dir, split, vae_path, vae, cfg, out);
    if (gv_dist_is_root() && gv_dist_after_root(rc, dataset_dir)) return -1;
    return rc;
}

static int load_set(const char *dataset_dir, const char *split, const char *vae_path, gv_vae *vae,
                    const gv_model_config *cfg, gv_latent_set *out)
{
    gv_manifest m;
    if (gv_manifest_read_dataset(dataset_dir, &m)) return -1;
    uint64_t key = gv_vae_checksum(vae);
    char (*hashes)[20] = NULL;
    int *pending = NULL, n_pending = 0;
    cache_file cache = {0};
    int rc = select_clips(dataset_dir, split, &m, out);
    if (rc == 0) rc = gv_latent_cache_path(out->cache_path, sizeof out->cache_path, dataset_dir, key, cfg);
    if (rc == 0) {
        hashes = calloc((size_t)out->count, sizeof *hashes);
        pending = calloc((size_t)out->count, sizeof *pending);
        if (!hashes || !pending) rc = gv_fail("%s: out of memory", dataset_dir);
    }
    if (rc == 0) cache_open(out->cache_path, key, cfg, &cache);
    /* first pass: everything the cache holds; second: encode the rest, with progress */
    for (int i = 0; rc == 0 && i < out->count; i++) {
        int r = load_one(dataset_dir, out, i, hashes[i], &cache, vae, cfg, 0);
        if (r < 0) rc = -1;
        else if (r > 0) pending[n_pending++] = i;
    }
    if (rc == 0 && n_pending > 0) {
        gv_progress bar;
        gv_progress_start(&bar, "encode latents", n_pending);
        for (int k = 0; rc == 0 && k < n_pending; k++) {
            rc = load_one(dataset_dir, out, pending[k], hashes[pending[k]], &cache, vae, cfg, 1);
            gv_progress_update(&bar, k + 1, NULL);
        }
        gv_progress_finish(&bar);
        if (rc == 0) gv_atomic_sweep_beside(out->cache_path); /* a killed writer's temporary */
        if (rc == 0) rc = cache_write(out->cache_path, key, cfg, vae_path, out, hashes, &cache, &m);
        if (rc == 0) gv_info("%s: %d clips encoded, %d from the cache", out->cache_path, n_pending, out->count - n_pending);
    }
    cache_close(&cache);
    free(hashes), free(pending);
    gv_manifest_free(&m);
    if (rc) gv_latent_set_free(out);
    return rc;
}
