/* Routing the keys of the published GaussVid checkpoint (include/gaussvid/model/release_lora.h,
 * docs/GAUSSVID_RELEASE.md): which keys are LoRA pairs of which base tensor, which replace
 * VAE decoder tensors, and which are ignored and why. */
#include "gaussvid/model/release_lora.h"

#include <stdlib.h>
#include <string.h>

#include "gaussvid/core/core.h"

enum { MAX_PARTS = 64 };

static const char PREFIX_VACE[] = "pipe.vace.", PREFIX_DIT[] = "pipe.dit.", PREFIX_DECODER[] = "pipe.vae.model.decoder.";

typedef enum { TARGET_NONE, TARGET_VACE, TARGET_DIT, TARGET_DECODER } target;

static int starts(const char *s, const char *prefix)
{
    return strncmp(s, prefix, strlen(prefix)) == 0;
}

/* The release's order of tests; *rest is the key without its prefix (the whole key for a
 * pipe.vae. decoder entry outside pipe.vae.model.decoder.). */
static target route(const char *key, const char **rest)
{
    *rest = key;
    if (starts(key, PREFIX_VACE)) return *rest = key + strlen(PREFIX_VACE), TARGET_VACE;
    if (starts(key, PREFIX_DIT)) return *rest = key + strlen(PREFIX_DIT), TARGET_DIT;
    if (starts(key, PREFIX_DECODER)) return *rest = key + strlen(PREFIX_DECODER), TARGET_DECODER;
    if (starts(key, "pipe.vae.") && strstr(key, "decoder")) return TARGET_DECODER;
    return TARGET_NONE;
}

/* Splits a copy of s at the dots; returns the number of parts (MAX_PARTS + 1 when more). */
static int split(char *copy, char **parts)
{
    int n = 0;
    for (char *p = copy;; p++) {
        if (n == MAX_PARTS) return MAX_PARTS + 1;
        parts[n++] = p;
        p = strchr(p, '.');
        if (!p) return n;
        *p = '\0';
    }
}

/* The index of the first component equal to one of the two names, or -1. */
static int component(char **parts, int n, const char *a, const char *b)
{
    for (int i = 0; i < n; i++)
        if (!strcmp(parts[i], a) || !strcmp(parts[i], b)) return i;
    return -1;
}

/* The LoRA B key's module weight (the fuser's rule) into weight; 0 when it names one. */
static int module_weight(const char *rest, char *weight, size_t size)
{
    char copy[512], *parts[MAX_PARTS];
    if (strlen(rest) >= sizeof copy) return -1;
    strcpy(copy, rest);
    int n = split(copy, parts), i = n <= MAX_PARTS ? component(parts, n, "lora_B", "lora_up") : -1;
    if (i < 0 || strcmp(parts[n - 1], "weight") || i == n - 1) return -1;
    int first = strcmp(parts[0], "diffusion_model") ? 0 : 1, len = 0;
    weight[0] = '\0';
    for (int k = first; k < n - 1; k++) {
        if (k == i || (k == i + 1 && n > i + 2)) continue; /* lora_B and the adapter name */
        len += snprintf(weight + len, size > (size_t)len ? size - (size_t)len : 0, "%s.", parts[k]);
    }
    if (len == 0 || (size_t)len + 7 > size) return -1;
    strcpy(weight + len, "weight");
    return 0;
}

/* The partner of a B key: its lora_B (lora_up) component made lora_A (lora_down). */
static void partner_key(const char *key, char *out, size_t size)
{
    char copy[512], *parts[MAX_PARTS];
    snprintf(copy, sizeof copy, "%s", key);
    int n = split(copy, parts), len = 0;
    for (int k = 0; k < n && k < MAX_PARTS; k++) {
        const char *c = !strcmp(parts[k], "lora_B") ? "lora_A" : !strcmp(parts[k], "lora_up") ? "lora_down" : parts[k];
        len += snprintf(out + len, size > (size_t)len ? size - (size_t)len : 0, "%s%s", k ? "." : "", c);
    }
}

static int is_float(gv_st_dtype d)
{
    return d == GV_ST_F32 || d == GV_ST_F16 || d == GV_ST_BF16 || d == GV_ST_F64;
}

/* The shape without trailing 1s beyond the second dimension (a 1x1 convolution's weight as
 * a matrix); returns the rank. */
static int matrix_shape(const gv_st_tensor *t, int64_t out[2])
{
    int rank = t->rank;
    while (rank > 2 && t->shape[rank - 1] == 1) rank--;
    out[0] = rank > 0 ? t->shape[0] : 1;
    out[1] = rank > 1 ? t->shape[1] : 1;
    return rank;
}

/* Checks a pair against its base tensor; fails naming the B key. */
static int check_pair(const gv_st_file *lora, const gv_st_tensor *a, const gv_st_tensor *b, const gv_st_tensor *w,
                      int *rank)
{
    char sa[64], sb[64], sw[64];
    int64_t ma[2], mb[2], mw[2];
    if (!is_float(a->dtype) || !is_float(b->dtype))
        return gv_fail("%s: %s: dtype %s is not a float type", lora->path, is_float(b->dtype) ? a->name : b->name,
                       gv_st_dtype_name(is_float(b->dtype) ? a->dtype : b->dtype));
    if (matrix_shape(a, ma) != 2 || matrix_shape(b, mb) != 2 || matrix_shape(w, mw) != 2 || mb[1] != ma[0] ||
        mb[0] != mw[0] || ma[1] != mw[1] || ma[0] < 1)
        return gv_fail("%s: %s %s and its lora_A %s do not fit the base tensor %s %s", lora->path, b->name,
                       gv_st_shape_str(sb, sizeof sb, b->shape, b->rank), gv_st_shape_str(sa, sizeof sa, a->shape, a->rank),
                       w->name, gv_st_shape_str(sw, sizeof sw, w->shape, w->rank));
    *rank = (int)ma[0];
    return 0;
}

static int by_weight(const void *x, const void *y)
{
    return strcmp(((const gv_release_module *)x)->weight, ((const gv_release_module *)y)->weight);
}

/* A LoRA B key under pipe.dit./pipe.vace.: its module, checked, appended; its partner's
 * index into *partner. */
static int add_pair(gv_release_plan *p, const gv_st_file *lora, const gv_st_file *base, int k, target t,
                    const char *rest, int *partner)
{
    const gv_st_tensor *b = &lora->tensors[k];
    gv_release_module *m = &p->modules[p->n_modules];
    char a_key[512];
    if (module_weight(rest, m->weight, sizeof m->weight)) return 1; /* not a LoRA weight */
    partner_key(b->name, a_key, sizeof a_key);
    const gv_st_tensor *a = gv_st_find(lora, a_key), *w = gv_st_find(base, m->weight);
    if (!a) return gv_fail("%s: %s has no partner %s", lora->path, b->name, a_key);
    int vace_name = starts(m->weight, "vace");
    if (!w || !is_float(w->dtype) || (t == TARGET_VACE) != vace_name)
        return gv_fail("%s: %s: the %s has no weight %s (in %s)", lora->path, b->name,
                       t == TARGET_VACE ? "VACE branch" : "DiT", m->weight, base->path);
    if (check_pair(lora, a, b, w, &m->rank)) return -1;
    for (int i = 0; i < p->n_modules; i++)
        if (!strcmp(p->modules[i].weight, m->weight))
            return gv_fail("%s: %s and %s both fuse into %s", lora->path, p->modules[i].b->name, b->name, m->weight);
    m->a = a, m->b = b;
    p->n_modules++;
    *partner = (int)(a - lora->tensors);
    snprintf(p->keys[k].target, sizeof p->keys[k].target, "%s", m->weight);
    snprintf(p->keys[*partner].target, sizeof p->keys[*partner].target, "%s", m->weight);
    p->rank_min = p->rank_min && p->rank_min < m->rank ? p->rank_min : m->rank;
    p->rank_max = p->rank_max > m->rank ? p->rank_max : m->rank;
    return 0;
}

/* A decoder entry's fate against the VAE. */
static gv_release_fate decoder_fate(const gv_st_file *vae, const gv_st_tensor *t, const char *rest, char *target,
                                    size_t size)
{
    snprintf(target, size, "decoder.%s", rest);
    if (!vae) return GV_RKEY_DECODER_NO_VAE;
    const gv_st_tensor *v = gv_st_find(vae, target);
    if (!v) return GV_RKEY_DECODER_UNKNOWN;
    if (v->rank != t->rank || memcmp(v->shape, t->shape, sizeof(int64_t) * (size_t)t->rank) || !is_float(v->dtype))
        return GV_RKEY_DECODER_SHAPE;
    return GV_RKEY_DECODER_REPLACED;
}

static int lora_role(const char *rest, int want_b)
{
    char copy[512], *parts[MAX_PARTS];
    snprintf(copy, sizeof copy, "%s", rest);
    int n = split(copy, parts);
    return n <= MAX_PARTS && component(parts, n, want_b ? "lora_B" : "lora_A", want_b ? "lora_up" : "lora_down") >= 0;
}

/* Every B key first (its partner is marked fused), then the rest. */
static int route_all(gv_release_plan *p, const gv_st_file *lora, const gv_st_file *base, const gv_st_file *vae,
                     char *paired)
{
    for (int k = 0; k < lora->n_tensors; k++) {
        const char *rest;
        target t = route(lora->tensors[k].name, &rest);
        p->keys[k].key = lora->tensors[k].name;
        p->keys[k].fate = t == TARGET_NONE ? GV_RKEY_IGNORED_PREFIX : GV_RKEY_IGNORED_NOT_LORA;
        if (t == TARGET_DECODER) {
            p->keys[k].fate = decoder_fate(vae, &lora->tensors[k], rest, p->keys[k].target, sizeof p->keys[k].target);
            if (p->keys[k].fate == GV_RKEY_DECODER_REPLACED && !is_float(lora->tensors[k].dtype))
                return gv_fail("%s: %s: dtype %s is not a float type", lora->path, lora->tensors[k].name,
                               gv_st_dtype_name(lora->tensors[k].dtype));
        }
        if ((t != TARGET_DIT && t != TARGET_VACE) || !lora_role(rest, 1)) continue;
        int partner, rc = add_pair(p, lora, base, k, t, rest, &partner);
        if (rc < 0) return -1;
        if (rc == 0) p->keys[k].fate = GV_RKEY_FUSED, paired[partner] = 1;
    }
    for (int k = 0; k < lora->n_tensors; k++) {
        const char *rest;
        target t = route(lora->tensors[k].name, &rest);
        if (paired[k]) p->keys[k].fate = GV_RKEY_FUSED;
        else if ((t == TARGET_DIT || t == TARGET_VACE) && lora_role(rest, 0)) p->keys[k].fate = GV_RKEY_IGNORED_UNPAIRED;
        p->count[p->keys[k].fate]++;
    }
    return 0;
}

int gv_release_plan_build(gv_release_plan *p, const gv_st_file *lora, const gv_st_file *base, const gv_st_file *vae)
{
    memset(p, 0, sizeof *p);
    int n = lora->n_tensors;
    p->keys = calloc((size_t)n + 1, sizeof *p->keys);
    p->modules = calloc((size_t)n + 1, sizeof *p->modules);
    char *paired = calloc((size_t)n + 1, 1);
    int rc = p->keys && p->modules && paired ? 0 : gv_fail("%s: out of memory", lora->path);
    p->n_keys = n;
    if (rc == 0) rc = route_all(p, lora, base, vae, paired);
    free(paired);
    if (rc) {
        gv_release_plan_free(p);
        return -1;
    }
    qsort(p->modules, (size_t)p->n_modules, sizeof *p->modules, by_weight);
    return 0;
}

void gv_release_plan_free(gv_release_plan *p)
{
    free(p->keys);
    free(p->modules);
    memset(p, 0, sizeof *p);
}

static const char *module_weight_name(const void *modules, int i)
{
    return ((const gv_release_module *)modules)[i].weight;
}

const gv_release_module *gv_release_plan_module(const gv_release_plan *p, const char *weight)
{
    /* the modules are sorted by weight name (gv_release_plan_build) */
    return gv_names_find(p->modules, sizeof *p->modules, NULL, p->n_modules, module_weight_name, weight);
}

const gv_st_tensor *gv_release_plan_decoder(const gv_release_plan *p, const gv_st_file *lora, const char *vae_name)
{
    for (int k = 0; k < p->n_keys; k++)
        if (p->keys[k].fate == GV_RKEY_DECODER_REPLACED && !strcmp(p->keys[k].target, vae_name))
            return &lora->tensors[k];
    return NULL;
}

const char *gv_release_fate_word(gv_release_fate f)
{
    return f == GV_RKEY_FUSED ? "fused" : f == GV_RKEY_DECODER_REPLACED ? "replaced"
           : f <= GV_RKEY_DECODER_NO_VAE ? "skipped" : "ignored";
}

static const char *fate_reason(gv_release_fate f)
{
    static const char *const reasons[GV_RKEY_N_FATES] = {
        "", "", "no such VAE tensor", "another shape than the VAE tensor", "no VAE given",
        "outside pipe.dit., pipe.vace. and pipe.vae.model.decoder.", "not a LoRA weight (no lora_B/lora_up)",
        "lora_A/lora_down without its lora_B/lora_up"};
    return reasons[f];
}

void gv_release_plan_summary(const gv_release_plan *p, char *out, size_t size)
{
    const int *c = p->count;
    int skipped = c[GV_RKEY_DECODER_UNKNOWN] + c[GV_RKEY_DECODER_SHAPE] + c[GV_RKEY_DECODER_NO_VAE];
    int ignored = c[GV_RKEY_IGNORED_PREFIX] + c[GV_RKEY_IGNORED_NOT_LORA] + c[GV_RKEY_IGNORED_UNPAIRED];
    char rank[48] = "";
    if (p->n_modules) {
        if (p->rank_min == p->rank_max) snprintf(rank, sizeof rank, ", rank %d", p->rank_min);
        else snprintf(rank, sizeof rank, ", ranks %d to %d", p->rank_min, p->rank_max);
    }
    snprintf(out, size,
             "%d modules fused (%d keys%s), %d decoder tensors replaced, %d decoder entries skipped (%d unknown name, "
             "%d other shape, %d no VAE), %d keys ignored (%d outside the prefixes, %d not LoRA weights, %d unpaired "
             "lora_A)",
             p->n_modules, c[GV_RKEY_FUSED], rank, c[GV_RKEY_DECODER_REPLACED], skipped, c[GV_RKEY_DECODER_UNKNOWN],
             c[GV_RKEY_DECODER_SHAPE], c[GV_RKEY_DECODER_NO_VAE], ignored, c[GV_RKEY_IGNORED_PREFIX],
             c[GV_RKEY_IGNORED_NOT_LORA], c[GV_RKEY_IGNORED_UNPAIRED]);
}

void gv_release_plan_list(const gv_release_plan *p, FILE *out)
{
    for (int k = 0; k < p->n_keys; k++) {
        const gv_release_key *e = &p->keys[k];
        if (e->fate == GV_RKEY_FUSED || e->fate == GV_RKEY_DECODER_REPLACED)
            fprintf(out, "%-8s %s -> %s\n", gv_release_fate_word(e->fate), e->key, e->target);
        else if (e->fate <= GV_RKEY_DECODER_NO_VAE)
            fprintf(out, "%-8s %s -> %s: %s\n", gv_release_fate_word(e->fate), e->key, e->target, fate_reason(e->fate));
        else
            fprintf(out, "%-8s %s: %s\n", gv_release_fate_word(e->fate), e->key, fate_reason(e->fate));
    }
}

int gv_fuse_precision_from_name(const char *name, gv_fuse_precision *out)
{
    if (name && !strcmp(name, "bf16")) return *out = GV_FUSE_BF16, 0;
    if (name && !strcmp(name, "f32")) return *out = GV_FUSE_F32, 0;
    return gv_fail("--precision: '%s' is not bf16 or f32", name ? name : "");
}
