/* The published GaussVid checkpoint applied to a Wan2.1-VACE release (release_lora.h,
 * docs/GAUSSVID_RELEASE.md), on a checkpoint in the release's naming written here: rank-4
 * LoRA pairs with PEFT (lora_A/lora_B, with and without ".default") and kohya
 * (lora_down/lora_up) keys in BF16, F16 and F32, an alpha tensor the release ignores,
 * distractor keys, decoder entries that replace, one of another shape and unknown names;
 * and the tiny release of tests/fixtures/release as the base. Checked: every key's fate; the
 * fused weights against the rule computed here independently (to the bit in bf16, to float32
 * rounding in f32), through gv_release_fuse, `model merge` (gv_release_merge) and `model
 * import --lora` (gv_model_import); the replaced decoder tensors; bad checkpoints fail naming
 * the key or file.
 *
 *   test_release_lora                       runs the checks
 *   test_release_lora --write-fixtures DIR  writes the checkpoints (tests/cli/gaussvid_release.sh) */
#include <stdint.h>

#include "check.h"
#include "gaussvid/core/core.h"
#include "gaussvid/train/model_import.h"
#include "gaussvid/model/release_lora.h"
#include "gaussvid/io/safetensors.h"
#include "gaussvid/pth/weight_files.h"

enum { RANK = 4 };

static char fixtures[4096];

/* ---- the checkpoint ------------------------------------------------------------------------ */

/* Values of a tensor: a fixed function of its name and index (a 64-bit LCG), in [-s, s]. */
static void fill(float *x, int64_t n, const char *name, float s)
{
    uint64_t state = 1469598103934665603ull;
    for (const char *p = name; *p; p++) state = (state ^ (unsigned char)*p) * 1099511628211ull;
    for (int64_t i = 0; i < n; i++) {
        state = state * 6364136223846793005ull + 1442695040888963407ull;
        x[i] = s * (float)((double)(state >> 11) / 9007199254740992.0 * 2.0 - 1.0);
    }
}

typedef struct {
    const char *name;
    gv_st_dtype dtype;
    int rank;
    int64_t shape[5];
} entry;

/* The good checkpoint: 7 pairs (5 DiT, 2 VACE), 2 replaced decoder tensors, 3 skipped decoder
 * entries, 6 ignored keys. */
static const entry GOOD[] = {
    {"pipe.dit.blocks.0.self_attn.q.lora_A.default.weight", GV_ST_BF16, 2, {RANK, 32}},
    {"pipe.dit.blocks.0.self_attn.q.lora_B.default.weight", GV_ST_BF16, 2, {32, RANK}},
    {"pipe.dit.blocks.0.ffn.0.lora_A.default.weight", GV_ST_BF16, 2, {RANK, 32}},
    {"pipe.dit.blocks.0.ffn.0.lora_B.default.weight", GV_ST_BF16, 2, {64, RANK}},
    {"pipe.dit.blocks.1.ffn.2.lora_A.default.weight", GV_ST_BF16, 2, {RANK, 64}},
    {"pipe.dit.blocks.1.ffn.2.lora_B.default.weight", GV_ST_BF16, 2, {32, RANK}},
    {"pipe.dit.blocks.1.cross_attn.o.lora_A.weight", GV_ST_F32, 2, {RANK, 32}},
    {"pipe.dit.blocks.1.cross_attn.o.lora_B.weight", GV_ST_F32, 2, {32, RANK}},
    {"pipe.vace.vace_blocks.0.self_attn.k.lora_A.default.weight", GV_ST_F16, 2, {RANK, 32}},
    {"pipe.vace.vace_blocks.0.self_attn.k.lora_B.default.weight", GV_ST_F16, 2, {32, RANK}},
    {"pipe.dit.blocks.1.self_attn.v.lora_down.weight", GV_ST_BF16, 2, {RANK, 32}},
    {"pipe.dit.blocks.1.self_attn.v.lora_up.weight", GV_ST_BF16, 2, {32, RANK}},
    {"pipe.vace.vace_blocks.1.ffn.0.lora_down.weight", GV_ST_BF16, 2, {RANK, 32}},
    {"pipe.vace.vace_blocks.1.ffn.0.lora_up.weight", GV_ST_BF16, 2, {64, RANK}},
    {"pipe.dit.blocks.1.self_attn.v.alpha", GV_ST_F32, 0, {0}},
    {"pipe.dit.camera_encoder.scale", GV_ST_F32, 1, {1}},
    {"pipe.dit.blocks.0.self_attn.k.lora_A.default.weight", GV_ST_BF16, 2, {RANK, 32}},
    {"pipe.text_encoder.blocks.0.weight", GV_ST_BF16, 2, {2, 2}},
    {"pipe.vae.model.encoder.conv1.weight", GV_ST_BF16, 1, {4}},
    {"lr_scheduler.last_epoch", GV_ST_F32, 1, {1}},
    {"pipe.vae.model.decoder.head.2.bias", GV_ST_F32, 1, {3}},
    {"pipe.vae.model.decoder.conv1.weight", GV_ST_BF16, 5, {16, 4, 3, 3, 3}},
    {"pipe.vae.model.decoder.head.2.weight", GV_ST_BF16, 5, {3, 8, 3, 3, 1}},
    {"pipe.vae.model.decoder.no_such.weight", GV_ST_F32, 1, {2}},
    {"pipe.vae.decoder.head.2.bias", GV_ST_F32, 1, {3}},
};
#define N_GOOD ((int)(sizeof GOOD / sizeof *GOOD))

/* The good checkpoint with `extra` added and the key `drop` left out (NULL: none). */
static int write_checkpoint(const char *path, const entry *extra, int n_extra, const char *drop)
{
    gv_st_builder b;
    gv_st_builder_init(&b);
    float *values[N_GOOD + 4] = {0};
    int rc = 0;
    for (int i = 0; rc == 0 && i < N_GOOD + n_extra; i++) {
        const entry *e = i < N_GOOD ? &GOOD[i] : &extra[i - N_GOOD];
        if (drop && !strcmp(drop, e->name)) continue;
        int64_t n = 1;
        for (int k = 0; k < e->rank; k++) n *= e->shape[k];
        values[i] = malloc((size_t)n * sizeof(float));
        fill(values[i], n, e->name, strstr(e->name, "alpha") ? 0.0f : 0.5f);
        if (strstr(e->name, "alpha")) values[i][0] = 8.0f; /* alpha/rank = 2 if it were applied */
        rc = gv_st_add_f32(&b, e->name, e->dtype, e->shape, e->rank, values[i]);
    }
    if (rc == 0) rc = gv_st_write(&b, path);
    gv_st_builder_free(&b);
    for (int i = 0; i < N_GOOD + 4; i++) free(values[i]);
    return rc;
}

static const char *in_dir(char *out, const char *dir, const char *name)
{
    snprintf(out, 4300, "%s/%s", dir, name);
    return out;
}

/* good.safetensors and the bad ones, named by what is wrong. */
static int write_fixtures(const char *dir)
{
    char path[4300];
    const entry missing_block[] = {{"pipe.dit.blocks.5.self_attn.q.lora_A.default.weight", GV_ST_BF16, 2, {RANK, 32}},
                                   {"pipe.dit.blocks.5.self_attn.q.lora_B.default.weight", GV_ST_BF16, 2, {32, RANK}}};
    const entry vace_under_dit[] = {{"pipe.dit.vace_blocks.0.ffn.2.lora_A.default.weight", GV_ST_BF16, 2, {RANK, 64}},
                                    {"pipe.dit.vace_blocks.0.ffn.2.lora_B.default.weight", GV_ST_BF16, 2, {32, RANK}}};
    const entry wrong_shape[] = {{"pipe.dit.blocks.1.self_attn.o.lora_A.default.weight", GV_ST_BF16, 2, {RANK, 31}},
                                 {"pipe.dit.blocks.1.self_attn.o.lora_B.default.weight", GV_ST_BF16, 2, {32, RANK}}};
    int rc = write_checkpoint(in_dir(path, dir, "good.safetensors"), NULL, 0, NULL);
    if (rc == 0) rc = write_checkpoint(in_dir(path, dir, "missing_block.safetensors"), missing_block, 2, NULL);
    if (rc == 0) rc = write_checkpoint(in_dir(path, dir, "vace_under_dit.safetensors"), vace_under_dit, 2, NULL);
    if (rc == 0) rc = write_checkpoint(in_dir(path, dir, "wrong_shape.safetensors"), wrong_shape, 2, NULL);
    if (rc == 0)
        rc = write_checkpoint(in_dir(path, dir, "b_without_a.safetensors"), NULL, 0,
                              "pipe.dit.blocks.0.ffn.0.lora_A.default.weight");
    FILE *f = rc == 0 ? fopen(in_dir(path, dir, "not_safetensors.safetensors"), "w") : NULL;
    if (f) fputs("{\"this is\": \"JSON, not a safetensors file\"}\n", f), fclose(f);
    char *bytes = NULL;
    size_t size = 0;
    if (rc == 0) rc = gv_read_file(in_dir(path, dir, "good.safetensors"), &bytes, &size);
    f = rc == 0 ? fopen(in_dir(path, dir, "truncated.safetensors"), "wb") : NULL;
    if (f) fwrite(bytes, 1, size - 100, f), fclose(f);
    free(bytes);
    if (rc) fprintf(stderr, "%s\n", gv_last_error());
    return rc;
}

/* ---- the rule, computed independently ------------------------------------------------------ */

static float bf16(float x)
{
    return gv_bf16_to_f32(gv_f32_to_bf16(x));
}

static uint32_t bits(float x)
{
    uint32_t u;
    memcpy(&u, &x, 4);
    return u;
}

static float *read_all(const gv_st_file *f, const char *name, int64_t *n)
{
    const gv_st_tensor *t = gv_st_find(f, name);
    if (!t) return NULL;
    float *x = malloc((size_t)t->n_elements * sizeof *x);
    gv_st_tensor_to_f32(f, t, x);
    *n = t->n_elements;
    return x;
}

/* Compares the fused weight `got` with the rule: bf16 (bit for bit):
 * bf16(bf16(W) + bf16(float(sum_r bf16(B) bf16(A)))); f32: W + sum_r B A within float32
 * rounding. Returns the number of elements the LoRA changed. */
static int check_rule(const gv_st_file *base, const gv_st_file *lora, const char *weight, const char *a_key,
                      const char *b_key, int is_bf16, const float *got)
{
    int64_t nw = 0, na = 0, nb = 0;
    float *w = read_all(base, weight, &nw), *a = read_all(lora, a_key, &na), *b = read_all(lora, b_key, &nb);
    if (!w || !a || !b) {
        CHECK(!"tensor found");
        free(w), free(a), free(b);
        return 0;
    }
    int64_t n_in = na / RANK, n_out = nb / RANK;
    CHECK(n_in * n_out == nw);
    int changed = 0, wrong = 0;
    for (int64_t o = 0; o < n_out; o++)
        for (int64_t i = 0; i < n_in; i++) {
            double sum = 0, magnitude = fabs(w[o * n_in + i]);
            for (int r = 0; r < RANK; r++) {
                double p = is_bf16 ? (double)bf16(b[o * RANK + r]) * bf16(a[r * n_in + i])
                                   : (double)b[o * RANK + r] * a[r * n_in + i];
                sum += p, magnitude += fabs(p);
            }
            float g = got[o * n_in + i];
            if (is_bf16) {
                float want = bf16(bf16(w[o * n_in + i]) + bf16((float)sum));
                wrong += bits(g) != bits(want);
                changed += bits(want) != bits(bf16(w[o * n_in + i]));
            } else {
                double want = w[o * n_in + i] + sum;
                wrong += fabs(g - want) > 4 * 1.2e-7 * magnitude;
                changed += g != w[o * n_in + i];
            }
        }
    CHECK(wrong == 0);
    free(w), free(a), free(b);
    return changed;
}

/* The seven pairs of GOOD: base weight, A key, B key. */
static const char *const PAIRS[7][3] = {
    {"blocks.0.self_attn.q.weight", "pipe.dit.blocks.0.self_attn.q.lora_A.default.weight",
     "pipe.dit.blocks.0.self_attn.q.lora_B.default.weight"},
    {"blocks.0.ffn.0.weight", "pipe.dit.blocks.0.ffn.0.lora_A.default.weight", "pipe.dit.blocks.0.ffn.0.lora_B.default.weight"},
    {"blocks.1.ffn.2.weight", "pipe.dit.blocks.1.ffn.2.lora_A.default.weight", "pipe.dit.blocks.1.ffn.2.lora_B.default.weight"},
    {"blocks.1.cross_attn.o.weight", "pipe.dit.blocks.1.cross_attn.o.lora_A.weight",
     "pipe.dit.blocks.1.cross_attn.o.lora_B.weight"},
    {"vace_blocks.0.self_attn.k.weight", "pipe.vace.vace_blocks.0.self_attn.k.lora_A.default.weight",
     "pipe.vace.vace_blocks.0.self_attn.k.lora_B.default.weight"},
    {"blocks.1.self_attn.v.weight", "pipe.dit.blocks.1.self_attn.v.lora_down.weight",
     "pipe.dit.blocks.1.self_attn.v.lora_up.weight"},
    {"vace_blocks.1.ffn.0.weight", "pipe.vace.vace_blocks.1.ffn.0.lora_down.weight",
     "pipe.vace.vace_blocks.1.ffn.0.lora_up.weight"},
};

/* ---- the checks ------------------------------------------------------------------------------ */

typedef struct {
    gv_st_file lora, base, base_bf16, vae;
} opened;

static int open_all(opened *o, const char *dir)
{
    char path[4300];
    memset(o, 0, sizeof *o);
    int rc = gv_st_open(&o->lora, in_dir(path, dir, "good.safetensors"));
    if (rc == 0) rc = gv_st_open(&o->base, in_dir(path, fixtures, "tiny_dit_f32.safetensors"));
    if (rc == 0)
        rc = gv_weights_open(&o->base_bf16, in_dir(path, fixtures, "tiny-vace-bf16/diffusion_pytorch_model.safetensors.index.json"));
    if (rc == 0) rc = gv_weights_open(&o->vae, in_dir(path, fixtures, "tiny-vace-bf16/Wan2.1_VAE.pth"));
    if (rc) fprintf(stderr, "%s\n", gv_last_error());
    return rc;
}

static void close_all(opened *o)
{
    gv_st_close(&o->lora), gv_st_close(&o->base), gv_st_close(&o->base_bf16), gv_st_close(&o->vae);
}

static gv_release_fate fate_of(const gv_release_plan *p, const char *key)
{
    for (int k = 0; k < p->n_keys; k++)
        if (!strcmp(p->keys[k].key, key)) return p->keys[k].fate;
    return GV_RKEY_N_FATES;
}

static void test_plan(opened *o)
{
    gv_release_plan p;
    REQUIRE(gv_release_plan_build(&p, &o->lora, &o->base, &o->vae) == 0);
    CHECK(p.n_keys == N_GOOD);
    CHECK(p.n_modules == 7 && p.rank_min == RANK && p.rank_max == RANK);
    CHECK(p.count[GV_RKEY_FUSED] == 14);
    CHECK(p.count[GV_RKEY_DECODER_REPLACED] == 2);
    CHECK(p.count[GV_RKEY_DECODER_UNKNOWN] == 2 && p.count[GV_RKEY_DECODER_SHAPE] == 1);
    CHECK(p.count[GV_RKEY_DECODER_NO_VAE] == 0);
    CHECK(p.count[GV_RKEY_IGNORED_PREFIX] == 3 && p.count[GV_RKEY_IGNORED_NOT_LORA] == 2);
    CHECK(p.count[GV_RKEY_IGNORED_UNPAIRED] == 1);
    CHECK(fate_of(&p, "pipe.dit.blocks.1.self_attn.v.alpha") == GV_RKEY_IGNORED_NOT_LORA);
    CHECK(fate_of(&p, "pipe.dit.camera_encoder.scale") == GV_RKEY_IGNORED_NOT_LORA);
    CHECK(fate_of(&p, "pipe.dit.blocks.0.self_attn.k.lora_A.default.weight") == GV_RKEY_IGNORED_UNPAIRED);
    CHECK(fate_of(&p, "pipe.vae.model.encoder.conv1.weight") == GV_RKEY_IGNORED_PREFIX);
    CHECK(fate_of(&p, "pipe.vae.decoder.head.2.bias") == GV_RKEY_DECODER_UNKNOWN);
    CHECK(fate_of(&p, "pipe.vae.model.decoder.head.2.weight") == GV_RKEY_DECODER_SHAPE);
    CHECK(fate_of(&p, "pipe.vae.model.decoder.conv1.weight") == GV_RKEY_DECODER_REPLACED);
    for (int i = 0; i < 7; i++) {
        const gv_release_module *m = gv_release_plan_module(&p, PAIRS[i][0]);
        CHECK(m && !strcmp(m->a->name, PAIRS[i][1]) && !strcmp(m->b->name, PAIRS[i][2]) && m->rank == RANK);
        CHECK(fate_of(&p, PAIRS[i][1]) == GV_RKEY_FUSED && fate_of(&p, PAIRS[i][2]) == GV_RKEY_FUSED);
    }
    CHECK(gv_release_plan_module(&p, "blocks.0.self_attn.k.weight") == NULL);
    const gv_st_tensor *d = gv_release_plan_decoder(&p, &o->lora, "decoder.head.2.bias");
    CHECK(d && !strcmp(d->name, "pipe.vae.model.decoder.head.2.bias"));
    char summary[512];
    gv_release_plan_summary(&p, summary, sizeof summary);
    CHECK(strstr(summary, "7 modules fused (14 keys, rank 4), 2 decoder tensors replaced, 3 decoder entries skipped") != NULL);
    gv_release_plan_free(&p);
    /* without a VAE every decoder entry is skipped, named so */
    REQUIRE(gv_release_plan_build(&p, &o->lora, &o->base, NULL) == 0);
    CHECK(p.count[GV_RKEY_DECODER_NO_VAE] == 5 && p.count[GV_RKEY_DECODER_REPLACED] == 0);
    gv_release_plan_free(&p);
}

/* gv_release_fuse on both bases and both precisions against the rule. */
static void test_fuse(opened *o)
{
    const gv_st_file *bases[2] = {&o->base, &o->base_bf16};
    for (int f = 0; f < 2; f++) {
        gv_release_plan p;
        REQUIRE(gv_release_plan_build(&p, &o->lora, bases[f], &o->vae) == 0);
        for (int i = 0; i < 7; i++)
            for (int prec = 0; prec < 2; prec++) {
                const gv_st_tensor *w = gv_st_find(bases[f], PAIRS[i][0]);
                float *out = malloc((size_t)w->n_elements * sizeof *out);
                CHECK(gv_release_fuse(bases[f], w, &o->lora, gv_release_plan_module(&p, PAIRS[i][0]),
                                      prec == 0 ? GV_FUSE_BF16 : GV_FUSE_F32, out) == 0);
                int changed = check_rule(bases[f], &o->lora, PAIRS[i][0], PAIRS[i][1], PAIRS[i][2], prec == 0, out);
                CHECK(changed > w->n_elements / 2); /* the LoRA does change the weight */
                free(out);
            }
        gv_release_plan_free(&p);
    }
}

static void check_same_bits(const gv_st_file *f, const char *name, const float *want, int64_t n)
{
    int64_t got_n;
    float *got = read_all(f, name, &got_n);
    int same = got && got_n == n;
    for (int64_t k = 0; same && k < n; k++) same = bits(got[k]) == bits(want[k]);
    CHECK(same);
    free(got);
}

/* One merged file pair: fused pairs by the rule, the rest converted, the decoder replaced. */
static void check_merged(opened *o, const char *out, const char *vae_out, int is_bf16)
{
    gv_st_file m, v;
    REQUIRE(gv_st_open(&m, out) == 0);
    REQUIRE(gv_st_open(&v, vae_out) == 0);
    CHECK(m.n_tensors == o->base.n_tensors && v.n_tensors == o->vae.n_tensors);
    for (int i = 0; i < 7; i++) {
        const gv_st_tensor *t = gv_st_find(&m, PAIRS[i][0]);
        CHECK(t && t->dtype == (is_bf16 ? GV_ST_BF16 : GV_ST_F32));
        float *got = t ? read_all(&m, PAIRS[i][0], &(int64_t){0}) : NULL;
        if (got) check_rule(&o->base, &o->lora, PAIRS[i][0], PAIRS[i][1], PAIRS[i][2], is_bf16, got);
        free(got);
    }
    const char *untouched[] = {"blocks.0.self_attn.k.weight", "head.head.weight", "vace_blocks.0.before_proj.bias"};
    for (int i = 0; i < 3; i++) {
        int64_t n;
        float *w = read_all(&o->base, untouched[i], &n);
        for (int64_t k = 0; is_bf16 && w && k < n; k++) w[k] = bf16(w[k]);
        if (w) check_same_bits(&m, untouched[i], w, n);
        free(w);
    }
    const char *vae_names[][2] = {{"decoder.head.2.bias", "pipe.vae.model.decoder.head.2.bias"},
                                  {"decoder.conv1.weight", "pipe.vae.model.decoder.conv1.weight"},
                                  {"decoder.head.2.weight", NULL}, {"encoder.conv1.weight", NULL}};
    for (int i = 0; i < 4; i++) {
        int64_t n;
        float *w = read_all(vae_names[i][1] ? &o->lora : &o->vae, vae_names[i][1] ? vae_names[i][1] : vae_names[i][0], &n);
        for (int64_t k = 0; is_bf16 && w && k < n; k++) w[k] = bf16(w[k]);
        if (w) check_same_bits(&v, vae_names[i][0], w, n);
        free(w);
    }
    CHECK(gv_st_metadata(&m, "merge_precision") && !strcmp(gv_st_metadata(&m, "merge_precision"), is_bf16 ? "bf16" : "f32"));
    gv_st_close(&m), gv_st_close(&v);
}

static void test_merge(opened *o, const char *dir)
{
    gv_release_plan p;
    char out[4300], vae_out[4300];
    REQUIRE(gv_release_plan_build(&p, &o->lora, &o->base, &o->vae) == 0);
    for (int prec = 0; prec < 2; prec++) {
        in_dir(out, dir, prec == 0 ? "merged_bf16.safetensors" : "merged_f32.safetensors");
        in_dir(vae_out, dir, prec == 0 ? "vae_bf16.safetensors" : "vae_f32.safetensors");
        CHECK(gv_release_merge(&p, &o->lora, &o->base, out, &o->vae, vae_out, prec == 0 ? GV_FUSE_BF16 : GV_FUSE_F32) == 0);
        check_merged(o, out, vae_out, prec == 0);
    }
    gv_release_plan_free(&p);
}

/* `model import --lora`: the fused tensors BF16 by the rule, the rest as published, the VAE's
 * decoder entries replaced (bf16 values). */
static void test_import(opened *o, const char *dir)
{
    gv_release_files files;
    char path[4300], out_dir[4300];
    REQUIRE(gv_release_find(in_dir(path, fixtures, "tiny-vace-bf16"), &files) == 0);
    in_dir(files.lora, dir, "good.safetensors");
    gv_model_config c;
    REQUIRE(gv_model_config_preset(&c, "tiny") == 0);
    gv_import_summary s;
    REQUIRE(gv_model_import(&files, &c, NULL, in_dir(out_dir, dir, "imported"), &s) == 0);
    CHECK(strstr(s.lora_summary, "7 modules fused") != NULL);
    gv_st_file b, v;
    REQUIRE(gv_st_open(&b, in_dir(path, out_dir, "base.safetensors")) == 0);
    for (int i = 0; i < 7; i++) {
        int64_t n;
        float *got = read_all(&b, PAIRS[i][0], &n);
        CHECK(gv_st_find(&b, PAIRS[i][0])->dtype == GV_ST_BF16);
        if (got) check_rule(&o->base_bf16, &o->lora, PAIRS[i][0], PAIRS[i][1], PAIRS[i][2], 1, got);
        free(got);
    }
    int64_t n;
    float *w = read_all(&o->base_bf16, "blocks.0.self_attn.k.weight", &n);
    if (w) check_same_bits(&b, "blocks.0.self_attn.k.weight", w, n);
    free(w);
    CHECK(gv_st_metadata(&b, "merged_lora") != NULL);
    gv_st_close(&b);
    REQUIRE(gv_st_open(&v, in_dir(path, out_dir, "vae.safetensors")) == 0);
    w = read_all(&o->lora, "pipe.vae.model.decoder.head.2.bias", &n);
    for (int64_t k = 0; w && k < n; k++) w[k] = bf16(w[k]);
    if (w) check_same_bits(&v, "decoder.head.2.bias", w, n);
    free(w);
    w = read_all(&o->vae, "decoder.head.2.weight", &n); /* the entry of another shape left it */
    if (w) check_same_bits(&v, "decoder.head.2.weight", w, n);
    free(w);
    gv_st_close(&v);
}

static int plan_of(const char *dir, const char *name, const opened *o)
{
    char path[4300];
    gv_st_file f;
    gv_release_plan p;
    int rc = gv_st_open(&f, in_dir(path, dir, name));
    if (rc == 0) rc = gv_release_plan_build(&p, &f, &o->base, &o->vae);
    if (rc == 0) gv_release_plan_free(&p);
    gv_st_close(&f);
    return rc;
}

static void test_bad(const opened *o, const char *dir)
{
    CHECK_FAILS_WITH(plan_of(dir, "missing_block.safetensors", o),
                     "pipe.dit.blocks.5.self_attn.q.lora_B.default.weight: the DiT has no weight blocks.5.self_attn.q.weight");
    CHECK_FAILS_WITH(plan_of(dir, "vace_under_dit.safetensors", o),
                     "pipe.dit.vace_blocks.0.ffn.2.lora_B.default.weight: the DiT has no weight");
    CHECK_FAILS_WITH(plan_of(dir, "wrong_shape.safetensors", o), "pipe.dit.blocks.1.self_attn.o.lora_B.default.weight [32, 4] "
                                                                 "and its lora_A [4, 31] do not fit");
    CHECK_FAILS_WITH(plan_of(dir, "b_without_a.safetensors", o),
                     "pipe.dit.blocks.0.ffn.0.lora_B.default.weight has no partner pipe.dit.blocks.0.ffn.0.lora_A.default.weight");
    CHECK_FAILS_WITH(plan_of(dir, "not_safetensors.safetensors", o), "not_safetensors.safetensors");
    CHECK_FAILS_WITH(plan_of(dir, "truncated.safetensors", o), "truncated.safetensors");
}

int main(int argc, char **argv)
{
    if (argc == 3 && !strcmp(argv[1], "--write-fixtures")) return write_fixtures(argv[2]) ? 1 : 0;
    snprintf(fixtures, sizeof fixtures, "%s", __FILE__);
    char *slash = strrchr(fixtures, '/');
    if (slash) *slash = '\0';
    else snprintf(fixtures, sizeof fixtures, ".");
    strncat(fixtures, "/fixtures/release", sizeof fixtures - strlen(fixtures) - 1);
    const char *dir = check_tmp_dir();
    if (write_fixtures(dir)) return 1;
    opened o;
    if (open_all(&o, dir)) return 1;
    test_plan(&o);
    test_fuse(&o);
    test_merge(&o, dir);
    test_import(&o, dir);
    test_bad(&o, dir);
    close_all(&o);
    return check_summary();
}
