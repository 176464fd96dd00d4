/* Scene checkpoints (scene_checkpoint.h; docs/ADAPT.md): the adapters of a per-scene
 * fine-tuning with the base they apply to and the gate's measurement, and the bare adapter
 * files a run keeps of its best step. */
#include <errno.h>
#include <inttypes.h>
#include <stddef.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "gaussvid/train/condition.h"
#include "gaussvid/core/core.h"
#include "gaussvid/train/scene_adapt.h"
#include "train/train_internal.h"

double gv_scene_gate_change(const gv_scene_adaptation *a) { return a->gate_psnr_restored - a->gate_psnr_base; }
double gv_scene_harm_change(const gv_scene_adaptation *a) { return a->harm_psnr_restored - a->harm_psnr_base; }

int gv_scene_harm_rules(const gv_scene_adaptation *a)
{
    return a->harm_frames > 0 && strcmp(a->gate_compose, "unseen") != 0;
}

int gv_scene_gate_decide(const gv_scene_adaptation *a)
{
    int gains = gv_scene_gate_change(a) > a->gate_margin_db && a->gate_frames >= a->gate_min_frames;
    int harmless = !gv_scene_harm_rules(a) || gv_scene_harm_change(a) > -a->harm_max_loss_db;
    return gains && harmless;
}

static int hash_piece(void *ctx, const void *bytes, size_t n)
{
    uint64_t *h = ctx;
    *h = gv_fnv1a64(*h, bytes, n);
    return 0;
}

#define CHECKSUM_PIECE (1u << 20) /* bytes read at a time: the memory a checksum takes */

int gv_file_checksum(const char *path, char *out, size_t size)
{
    FILE *f = fopen(path, "rb");
    if (!f) return gv_fail("%s: cannot open: %s", path, strerror(errno));
    unsigned char *piece = malloc(CHECKSUM_PIECE);
    uint64_t h = GV_FNV_OFFSET;
    size_t n = 0;
    while (piece && (n = fread(piece, 1, CHECKSUM_PIECE, f)) > 0) hash_piece(&h, piece, n);
    int rc = !piece ? gv_fail("%s: out of memory", path) : ferror(f) ? gv_fail("%s: read error", path) : 0;
    free(piece);
    fclose(f);
    if (rc == 0) snprintf(out, size, "fnv1a64:%016" PRIx64, h);
    return rc;
}

/* gv_file_checksum of a file already open, streamed through its mapping. */
static int open_file_checksum(const gv_st_file *f, char *out, size_t size)
{
    uint64_t h = GV_FNV_OFFSET;
    if (gv_st_stream(f, hash_piece, &h)) return -1;
    snprintf(out, size, "fnv1a64:%016" PRIx64, h);
    return 0;
}

static int add_adapters(gv_st_builder *b, const gv_dit *m)
{
    int rc = 0;
    for (int i = 0; rc == 0 && i < m->params.n; i++) {
        const gv_tensor *t = &m->params.items[i]->t;
        if (!gv_dit_param_is_adapter(m, t->name)) continue;
        int64_t shape[GV_MAX_DIMS];
        for (int k = 0; k < t->ndim; k++) shape[k] = t->shape[k];
        rc = gv_st_add_f32(b, t->name, GV_ST_F32, shape, t->ndim, t->data);
    }
    return rc;
}

/* Reads every adapter of m from an open file: all must be there, with their shapes. */
static int read_adapters(const gv_st_file *f, gv_dit *m)
{
    for (int i = 0; i < m->params.n; i++) {
        gv_tensor *t = &m->params.items[i]->t;
        if (!gv_dit_param_is_adapter(m, t->name)) continue;
        int64_t shape[GV_MAX_DIMS];
        for (int k = 0; k < t->ndim; k++) shape[k] = t->shape[k];
        if (gv_st_read_f32(f, t->name, t->data, shape, t->ndim)) return -1;
    }
    if (gv_params_check_finite(&m->params, 0)) return gv_fail_context("%s", f->path);
    return 0;
}

int gv_adapters_save(const char *path, const gv_dit *m, const char *const *keys, const char *const *values, int count)
{
    gv_st_builder b;
    gv_st_builder_init(&b);
    int rc = add_adapters(&b, m);
    for (int i = 0; rc == 0 && i < count; i++) rc = gv_st_add_metadata(&b, keys[i], values[i]);
    if (rc == 0) rc = gv_st_write(&b, path);
    gv_st_builder_free(&b);
    return rc ? -1 : 0;
}

int gv_adapters_load(const char *path, gv_dit *m)
{
    gv_st_file f;
    if (gv_st_open(&f, path)) return -1;
    int rc = read_adapters(&f, m);
    gv_st_close(&f);
    return rc;
}

/* ---- the adaptation record -------------------------------------------------------------- */
typedef enum { FIELD_TEXT, FIELD_INT, FIELD_LONG, FIELD_DOUBLE } field_type;
typedef struct {
    const char *key;
    field_type type;
    size_t offset, size;
    int optional; /* absent from checkpoints written before it existed: read as 0 */
} field;

#define TEXT(k, m) {k, FIELD_TEXT, offsetof(gv_scene_adaptation, m), sizeof(((gv_scene_adaptation *)0)->m), 0}
#define NUM(k, t, m) {k, t, offsetof(gv_scene_adaptation, m), 0, 0}
#define LATER(k, t, m) {k, t, offsetof(gv_scene_adaptation, m), 0, 1}
#define LATER_TEXT(k, m) {k, FIELD_TEXT, offsetof(gv_scene_adaptation, m), sizeof(((gv_scene_adaptation *)0)->m), 1}
static const field fields[] = {
    TEXT("scene", scene), NUM("interval", FIELD_INT, interval), NUM("iters", FIELD_INT, iters),
    TEXT("base_checksum", base_checksum), NUM("train_clips", FIELD_INT, train_clips),
    NUM("held_back", FIELD_INT, held_back), NUM("best_step", FIELD_LONG, best_step),
    NUM("val_gain_db", FIELD_DOUBLE, val_gain_db), NUM("val_loss", FIELD_DOUBLE, val_loss),
    NUM("val_identity", FIELD_DOUBLE, val_identity), NUM("gate_margin_db", FIELD_DOUBLE, gate_margin_db),
    NUM("gate_min_frames", FIELD_INT, gate_min_frames),
    NUM("gate_frames", FIELD_INT, gate_frames), NUM("gate_psnr_base", FIELD_DOUBLE, gate_psnr_base),
    NUM("gate_psnr_restored", FIELD_DOUBLE, gate_psnr_restored), NUM("gate_ssim_base", FIELD_DOUBLE, gate_ssim_base),
    NUM("gate_ssim_restored", FIELD_DOUBLE, gate_ssim_restored), TEXT("gate_sampler", gate_sampler),
    NUM("seconds_pairs", FIELD_DOUBLE, seconds_pairs), NUM("seconds_latents", FIELD_DOUBLE, seconds_latents),
    NUM("seconds_train", FIELD_DOUBLE, seconds_train), NUM("seconds_gate", FIELD_DOUBLE, seconds_gate),
    LATER("harm_max_loss_db", FIELD_DOUBLE, harm_max_loss_db), LATER("harm_frames", FIELD_INT, harm_frames),
    LATER("harm_psnr_base", FIELD_DOUBLE, harm_psnr_base), LATER("harm_psnr_restored", FIELD_DOUBLE, harm_psnr_restored),
    LATER("harm_ssim_base", FIELD_DOUBLE, harm_ssim_base), LATER("harm_ssim_restored", FIELD_DOUBLE, harm_ssim_restored),
    LATER_TEXT("gate_compose", gate_compose), LATER_TEXT("best_by", best_by), LATER("subsets", FIELD_INT, subsets),
};
#define N_FIELDS (int)(sizeof fields / sizeof fields[0])

static int add_record(gv_st_builder *b, const gv_scene_adaptation *a)
{
    int rc = gv_st_add_metadata(b, "gate", a->gate_open ? "open" : "closed");
    for (int i = 0; rc == 0 && i < N_FIELDS; i++) {
        const char *p = (const char *)a + fields[i].offset;
        char text[64];
        if (fields[i].type == FIELD_TEXT) {
            rc = gv_st_add_metadata(b, fields[i].key, p);
            continue;
        }
        if (fields[i].type == FIELD_INT) snprintf(text, sizeof text, "%d", *(const int *)p);
        else if (fields[i].type == FIELD_LONG) snprintf(text, sizeof text, "%ld", *(const long *)p);
        else snprintf(text, sizeof text, "%.9g", *(const double *)p);
        rc = gv_st_add_metadata(b, fields[i].key, text);
    }
    return rc;
}

static int read_record(const gv_st_file *f, gv_scene_adaptation *a)
{
    memset(a, 0, sizeof *a);
    const char *gate = gv_st_metadata(f, "gate");
    if (!gate || (strcmp(gate, "open") && strcmp(gate, "closed")))
        return gv_fail("%s: metadata gate is %s, expected open or closed", f->path, gate ? gate : "missing");
    a->gate_open = !strcmp(gate, "open");
    for (int i = 0; i < N_FIELDS; i++) {
        const char *text = gv_st_metadata(f, fields[i].key);
        char *p = (char *)a + fields[i].offset, *end = NULL;
        if (!text && fields[i].optional) continue;
        if (!text) return gv_fail("%s: metadata %s is missing (not a complete scene checkpoint)", f->path, fields[i].key);
        errno = 0;
        if (fields[i].type == FIELD_TEXT) snprintf(p, fields[i].size, "%s", text);
        else if (fields[i].type == FIELD_INT) *(int *)p = (int)strtol(text, &end, 10);
        else if (fields[i].type == FIELD_LONG) *(long *)p = strtol(text, &end, 10);
        else *(double *)p = strtod(text, &end);
        if (fields[i].type != FIELD_TEXT && (!*text || *end || errno))
            return gv_fail("%s: metadata %s '%s' is not a number", f->path, fields[i].key, text);
    }
    return 0;
}

int gv_scene_checkpoint_save(const char *path, const gv_dit *m, const gv_model_config *cfg, const gv_train_state *state,
                             const gv_scene_adaptation *a)
{
    gv_train_state s = *state;
    snprintf(s.kind, sizeof s.kind, GV_SCENE_CHECKPOINT_KIND);
    gv_st_builder b;
    gv_st_builder_init(&b);
    int rc = add_adapters(&b, m);
    if (rc == 0) rc = gv_ckpt_add_state(&b, m, cfg, &s, 1);
    if (rc == 0) rc = add_record(&b, a);
    if (rc == 0) rc = gv_st_write(&b, path);
    gv_st_builder_free(&b);
    return rc ? -1 : 0;
}

/* Opens a checkpoint of kind "scene" and reads its config, state and record. */
static int open_scene(const char *path, gv_st_file *f, gv_model_config *cfg, gv_train_state *s, gv_scene_adaptation *a)
{
    if (gv_ckpt_open(f, path)) return -1;
    int rc = gv_ckpt_read_meta(f, cfg, s);
    if (rc == 0 && strcmp(s->kind, GV_SCENE_CHECKPOINT_KIND))
        rc = gv_fail("%s: a %s checkpoint, not a scene checkpoint (gaussvid adapt)", path, s->kind);
    if (rc == 0) rc = read_record(f, a);
    if (rc) gv_st_close(f);
    return rc;
}

int gv_scene_checkpoint_read(const char *path, gv_scene_adaptation *a)
{
    gv_st_file f;
    gv_model_config cfg;
    gv_train_state s;
    if (open_scene(path, &f, &cfg, &s, a)) return -1;
    gv_st_close(&f);
    return 0;
}

int gv_scene_checkpoint_is(const char *path)
{
    gv_model_config cfg;
    gv_train_state s;
    if (gv_checkpoint_read_info(path, &cfg, &s)) return -1;
    return !strcmp(s.kind, GV_SCENE_CHECKPOINT_KIND);
}

/* The base a scene checkpoint names (metadata "base"): as written, else beside it (1), else in
 * the model folders (2, where another checkpoint may have its name: the caller checks). */
static int find_base(const char *path, const gv_train_state *state, char *out, size_t size)
{
    if (!*state->base) return gv_fail("%s: metadata base is missing: no base checkpoint to apply the adapters to", path);
    int where = gv_checkpoint_find_beside(path, state->base, out, size);
    if (!where)
        return gv_fail("%s: the base checkpoint it adapts, %s, is not found (looked " GV_CHECKPOINT_LOOKED ")", path,
                       state->base);
    return where;
}

/* The base's network and VAE under the scene checkpoint's config cfg (r holds the base's):
 * the same config, or another variant of the same network (adapt --variant), which takes the
 * base's weights as fine-tuning takes a base. Then the adapters from the scene checkpoint f. */
static int load_over_base(const gv_st_file *f, gv_st_file *base, const gv_model_config *cfg, gv_restorer *r)
{
    char *x = gv_model_config_to_json(cfg), *y = gv_model_config_to_json(&r->cfg);
    int same = x && y && !strcmp(x, y);
    free(x), free(y);
    if (!same && !gv_config_same_network(cfg, &r->cfg))
        return gv_fail("%s: written for another model config than its base %s", f->path, base->path);
    if (gv_restorer_read_network(base, r, same ? NULL : cfg)) return -1;
    return read_adapters(f, &r->net);
}

/* Opens the base of scene checkpoint path (r holds its record): found, its checksum the
 * record's, not itself a scene checkpoint; r's config and state become the base's. */
static int open_base(const char *path, const gv_train_state *s, gv_st_file *base, gv_restorer *r)
{
    int where = find_base(path, s, r->base_path, sizeof r->base_path);
    if (where < 0 || gv_ckpt_open(base, r->base_path)) return -1;
    int rc = open_file_checksum(base, r->base_checksum, sizeof r->base_checksum);
    if (rc == 0 && where == 2 && strcmp(r->base_checksum, r->adaptation.base_checksum))
        rc = gv_fail("%s: the base checkpoint it adapts, %s, is not found (looked " GV_CHECKPOINT_LOOKED
                     "; %s there is another checkpoint)", path, s->base, r->base_path);
    else if (rc == 0 && strcmp(r->base_checksum, r->adaptation.base_checksum))
        rc = gv_fail("%s: %s is not the base its adapters were trained on (checksum %s, expected %s)", path,
                     r->base_path, r->base_checksum, r->adaptation.base_checksum);
    if (rc == 0) rc = gv_ckpt_read_meta(base, &r->cfg, &r->state); /* the base's, for its network and VAE */
    if (rc == 0 && !strcmp(r->state.kind, GV_SCENE_CHECKPOINT_KIND))
        rc = gv_fail("%s: its base %s is itself a scene checkpoint", path, r->base_path);
    if (rc) gv_st_close(base);
    return rc;
}

int gv_scene_restorer_open(gv_st_file *f, gv_restorer_part what, gv_restorer *r)
{
    gv_model_config cfg = r->cfg; /* the scene checkpoint's, r's again at the end */
    gv_train_state s = r->state;
    gv_st_file base;
    r->scene = 1;
    if (read_record(f, &r->adaptation)) return -1;
    int network = what == GV_RESTORER_NETWORK || (what == GV_RESTORER_NETWORK_IF_GATE_OPEN && r->adaptation.gate_open);
    int rc = open_base(f->path, &s, &base, r);
    if (rc == 0) {
        /* adapted from its own scene's training views: what it saw beyond them is its base's */
        gv_restorer_read_scenes(r, r->base_path, &r->state);
        if (network) rc = load_over_base(f, &base, &cfg, r);
        gv_st_close(&base);
    } else if (!network) { /* the record alone stands; what the base would tell is unknown */
        r->scenes_known = -1;
        snprintf(r->scenes_error, sizeof r->scenes_error, "%s", gv_last_error());
        rc = 0;
    }
    r->cfg = cfg, r->state = s; /* the scene checkpoint's own record (kind "scene") */
    return rc;
}
