/* The prompt's text context in restore and training (checkpoint.h, docs/WAN_WEIGHTS.md): a
 * tiny release (the committed fixtures, copied to a scratch folder) is imported with its umT5
 * encoder; loading the base gives the network the cached context, and the velocity restore
 * computes equals the forward pass with that context passed explicitly, and differs from the
 * zero context's; fine-tuning takes the base's context and names it. The cache is reused
 * while its key holds and computed again when the prompt or the encoder changes; a stale
 * cache without its encoder fails in one line. Skipped without libsentencepiece. */
#include <stdint.h>
#include <sys/stat.h>

#include "check.h"
#include "gaussvid/train/checkpoint.h"
#include "gaussvid/core/core.h"
#include "gaussvid/train/model_import.h"
#include "gaussvid/restore/restore.h"
#include "gaussvid/train/train.h"
#include "gaussvid/model/umt5.h"
#include "gaussvid/pth/weight_files.h"

static char fixtures[4096], release[4200], out[4200];

static void copy_release(const char *tmp)
{
    char command[9000];
    snprintf(release, sizeof release, "%s/release", tmp);
    snprintf(command, sizeof command, "cp -r '%s/tiny-vace-bf16' '%s'", fixtures, release);
    CHECK(system(command) == 0);
}

/* The context the encoder gives the prompt, computed here without any cache. */
static int direct_context(const char *encoder, const char *prompt, float *context)
{
    char path[4300];
    gv_st_file f;
    gv_umt5_config c;
    gv_tokenizer *t = NULL;
    int32_t ids[4];
    snprintf(path, sizeof path, "%s/google/umt5-xxl/spiece.model", release);
    int rc = gv_weights_open(&f, encoder) || gv_umt5_config_from_file(&f, &c) || gv_tokenizer_open(&t, path) ? -1 : 0;
    if (rc == 0 && gv_umt5_text_context(&c, &f, t, prompt, 4, context, ids) != 4) rc = -1;
    gv_tokenizer_close(t);
    gv_st_close(&f);
    return rc;
}

/* A clip's latents of the tiny network's sizes with random values. */
static void make_clip(gv_clip_latents *l, const gv_model_config *c)
{
    memset(l, 0, sizeof *l);
    l->frames = 5, l->height = l->width = 32, l->batch = 1;
    l->z_dim = c->dit.in_dim, l->latent_frames = 2, l->lh = l->lw = 4, l->vace_dim = c->dit.vace_in_dim;
    int64_t nz = gv_clip_latents_z_count(l), nv = gv_clip_latents_vace_count(l);
    l->z_clean = malloc((size_t)nz * sizeof(float));
    l->z_corrupt = malloc((size_t)nz * sizeof(float));
    l->vace = malloc((size_t)nv * sizeof(float));
    gv_fill_normal(l->z_clean, nz, 1, 0, 0, 1);
    gv_fill_normal(l->z_corrupt, nz, 2, 0, 0, 1);
    gv_fill_normal(l->vace, nv, 3, 0, 0, 1);
}

/* The velocity restore's network gives the clip at sigma 0.4. */
static void restore_velocity(gv_dit *m, const gv_clip_latents *l, float *v)
{
    gv_restore_net net;
    CHECK(gv_restore_net_init(&net, m, l, 1) == 0);
    CHECK(gv_restore_net_velocity(&net, l->z_corrupt, 0.4, v) == 0);
    gv_restore_net_free(&net);
}

/* The forward pass with the text context given explicitly. */
static void explicit_velocity(gv_dit *m, const gv_clip_latents *l, const float *text, float *v)
{
    gv_graph g;
    gv_graph_init(&g, 0);
    gv_graph_set_grad(&g, 0);
    const gv_dit_config *d = &m->cfg.dit;
    float t = 400.0f;
    gv_dit_inputs in = gv_dit_inputs_default();
    in.latent = gv_tensor_from(&g, 5, (int[]){1, l->z_dim, 2, 4, 4}, l->z_corrupt);
    in.vace = gv_tensor_from(&g, 5, (int[]){1, l->vace_dim, 2, 4, 4}, l->vace);
    in.text = gv_tensor_from(&g, 3, (int[]){1, d->text_len, d->text_dim}, text);
    in.timestep = &t;
    gv_tensor *y = gv_dit_forward(m, &g, &in);
    CHECK(y != NULL);
    if (y) memcpy(v, y->data, (size_t)y->numel * sizeof *v);
    gv_graph_free(&g);
}

static double max_abs_diff(const float *a, const float *b, int64_t n)
{
    double m = 0;
    for (int64_t i = 0; i < n; i++) m = fmax(m, fabs((double)a[i] - b[i]));
    return m;
}

static void test_restore_and_train(void)
{
    gv_model_config cfg;
    gv_release_files files;
    gv_import_summary s;
    CHECK(gv_model_config_preset(&cfg, "tiny") == 0 && gv_model_config_set_variant(&cfg, "camera=none", "test") == 0);
    CHECK(gv_release_find(release, &files) == 0);
    CHECK(gv_model_import(&files, &cfg, GV_GAUSSVID_PROMPT, out, &s) == 0 && s.text_tokens == 4); /* 13 tokens, cut to text_len */
    char base[4300], cache[4300];
    snprintf(base, sizeof base, "%s/base.safetensors", out);
    snprintf(cache, sizeof cache, "%s/text_context.safetensors", out);
    float want[4 * 16];
    CHECK(direct_context(files.t5, GV_GAUSSVID_PROMPT, want) == 0);

    gv_restorer r;
    CHECK(gv_restorer_load(base, &r) == 0);
    CHECK(r.net.text != NULL && !strcmp(r.state.text.prompt, GV_GAUSSVID_PROMPT));
    CHECK(r.net.text && memcmp(r.net.text, want, sizeof want) == 0); /* 13 tokens cut to text_len 4 */
    int nonzero = 0;
    for (int i = 0; i < 4 * 16; i++) nonzero += want[i] != 0.0f;
    CHECK(nonzero == 4 * 16);

    gv_clip_latents l;
    make_clip(&l, &r.cfg);
    int64_t n = gv_clip_latents_z_count(&l);
    float *v = malloc((size_t)n * sizeof *v), *ve = malloc((size_t)n * sizeof *ve), *v0 = malloc((size_t)n * sizeof *v0);
    float zeros[4 * 16] = {0};
    restore_velocity(&r.net, &l, v);
    explicit_velocity(&r.net, &l, want, ve);
    explicit_velocity(&r.net, &l, zeros, v0);
    double same = max_abs_diff(v, ve, n), moved = max_abs_diff(v, v0, n);
    printf("restore's velocity vs the explicit context: %g; vs the zero context: %g\n", same, moved);
    CHECK(same == 0.0 && moved > 1e-3);
    gv_dit_set_text(&r.net, NULL); /* the zero context: what restore gave before */
    restore_velocity(&r.net, &l, v);
    CHECK(max_abs_diff(v, v0, n) == 0.0);
    gv_restorer_free(&r);

    /* fine-tuning takes the base's context, and its checkpoint names it */
    gv_dit m;
    gv_train_state meta;
    memset(&meta, 0, sizeof meta);
    CHECK(gv_train_model(&cfg, GV_OBJECTIVE_FINETUNE, base, 1, 5, &m, &meta) == 0);
    CHECK(m.text && memcmp(m.text, want, sizeof want) == 0 && !strcmp(meta.text.path, cache));
    gv_graph g;
    gv_graph_init(&g, 0);
    gv_sample_draw d;
    memset(&d, 0, sizeof d);
    d.t = 0.5f, d.w_cur = d.w_t = 1.0;
    gv_sample_losses with, without;
    CHECK(gv_train_sample(&m, &g, &l, GV_OBJECTIVE_FINETUNE, &d, l.z_clean, 1.0, 0, &with) == 0);
    gv_dit_set_text(&m, NULL);
    CHECK(gv_train_sample(&m, &g, &l, GV_OBJECTIVE_FINETUNE, &d, l.z_clean, 1.0, 0, &without) == 0);
    printf("fine-tuning loss with the prompt's context %.6f, with zeros %.6f\n", with.fm, without.fm);
    CHECK(with.fm != without.fm);
    gv_graph_free(&g);
    gv_dit_free(&m);
    gv_clip_latents_free(&l);
    free(v), free(ve), free(v0);
}

/* The cache: reused while its key holds; computed again for another prompt or encoder. */
static void test_cache(void)
{
    gv_model_config cfg;
    CHECK(gv_model_config_preset(&cfg, "tiny") == 0);
    gv_text_source src;
    memset(&src, 0, sizeof src);
    snprintf(src.path, sizeof src.path, "%s/text_context.safetensors", out);
    snprintf(src.prompt, sizeof src.prompt, "%s", GV_GAUSSVID_PROMPT);
    float first[64], again[64], other[64], want[64];
    struct stat before, after;
    int computed = -1;
    CHECK(stat(src.path, &before) == 0);
    CHECK(gv_text_context_get(&src, &cfg, first, &computed) == 0 && computed == 0);
    CHECK(stat(src.path, &after) == 0 && after.st_ino == before.st_ino && after.st_mtime == before.st_mtime);

    /* another prompt: computed with the encoder the cache names, and the cache rewritten */
    snprintf(src.prompt, sizeof src.prompt, "a clean video");
    CHECK(gv_text_context_get(&src, &cfg, other, &computed) == 0 && computed == 1);
    char encoder[4300];
    snprintf(encoder, sizeof encoder, "%s/models_t5_umt5-xxl-enc-bf16.pth", release);
    CHECK(direct_context(encoder, "a clean video", want) == 0 && memcmp(other, want, sizeof want) == 0);
    CHECK(memcmp(other, first, sizeof other) != 0);
    CHECK(gv_text_context_get(&src, &cfg, again, &computed) == 0 && computed == 0 && !memcmp(again, other, sizeof again));

    /* other encoder weights (twice the embedding, stored as F32: another size) */
    gv_st_file f;
    gv_st_builder b;
    gv_st_builder_init(&b);
    CHECK(gv_weights_open(&f, encoder) == 0);
    float *values[64] = {NULL}; /* the builder reads them when it writes */
    for (int i = 0; i < f.n_tensors && i < 64; i++) {
        const gv_st_tensor *t = &f.tensors[i];
        float *x = values[i] = malloc((size_t)t->n_elements * sizeof *x);
        CHECK(gv_st_tensor_to_f32(&f, t, x) == 0);
        if (!strcmp(t->name, "token_embedding.weight"))
            for (int64_t k = 0; k < t->n_elements; k++) x[k] *= 2.0f;
        CHECK(gv_st_add_f32(&b, t->name, GV_ST_F32, t->shape, t->rank, x) == 0);
    }
    CHECK(f.n_tensors <= 64);
    gv_st_close(&f);
    CHECK(gv_st_write(&b, encoder) == 0); /* gv_weights_open tells the formats apart by their bytes */
    gv_st_builder_free(&b);
    for (int i = 0; i < 64; i++) free(values[i]);
    if (gv_text_context_get(&src, &cfg, again, &computed)) fprintf(stderr, "%s\n", gv_last_error());
    CHECK(computed == 1);
    CHECK(direct_context(encoder, "a clean video", want) == 0 && memcmp(again, want, sizeof want) == 0);
    CHECK(memcmp(again, other, sizeof again) != 0);

    /* stale, and no encoder to compute it: one line */
    CHECK(unlink(encoder) == 0);
    CHECK(gv_text_context_get(&src, &cfg, again, &computed) == 0 && computed == 0); /* still fresh: kept */
    snprintf(src.prompt, sizeof src.prompt, "another prompt");
    CHECK_FAILS_WITH(gv_text_context_get(&src, &cfg, again, &computed), "no text encoder is there to compute it");
}

/* Without a text context (imported without text), restore keeps the zero context. */
static void test_without_text(void)
{
    gv_model_config cfg;
    gv_release_files files;
    gv_import_summary s;
    char dir[4300], base[4400];
    snprintf(dir, sizeof dir, "%s-notext", out);
    CHECK(gv_model_config_preset(&cfg, "tiny") == 0 && gv_model_config_set_variant(&cfg, "camera=none", "test") == 0);
    CHECK(gv_release_find(release, &files) == 0);
    CHECK(gv_model_import(&files, &cfg, NULL, dir, &s) == 0 && s.text_tokens == 0);
    snprintf(base, sizeof base, "%s/base.safetensors", dir);
    gv_restorer r;
    CHECK(gv_restorer_load(base, &r) == 0 && r.net.text == NULL && !*r.state.text.path);
    gv_restorer_free(&r);
}

int main(void)
{
    snprintf(fixtures, sizeof fixtures, "%s", __FILE__);
    char *slash = strrchr(fixtures, '/');
    if (slash) *slash = '\0';
    strncat(fixtures, "/fixtures/release", sizeof fixtures - strlen(fixtures) - 1);
    char path[4200];
    gv_tokenizer *t = NULL;
    snprintf(path, sizeof path, "%s/tiny-vace-bf16/google/umt5-xxl/spiece.model", fixtures);
    if (gv_tokenizer_open(&t, path) != 0) {
        printf("skipped: %s\n", gv_last_error());
        return strstr(gv_last_error(), "built without libsentencepiece") ? CHECK_SKIP : 1;
    }
    gv_tokenizer_close(t);
    const char *tmp = check_tmp_dir();
    copy_release(tmp);
    snprintf(out, sizeof out, "%s/imported", tmp);
    test_restore_and_train();
    test_cache();
    test_without_text();
    return check_summary();
}
