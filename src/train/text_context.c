/* The prompt's text context (checkpoint.h, docs/WAN_WEIGHTS.md "The tokenizer and the cached
 * context"): computed by the umT5 encoder once, cached beside the weights, keyed by the
 * prompt, the encoder (path and size) and the tokenizer's checksum; read back by restore,
 * eval, adapt and train, and computed again when its key no longer holds. */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>

#include "gaussvid/core/core.h"
#include "gaussvid/model/umt5.h"
#include "gaussvid/pth/weight_files.h"
#include "train/train_internal.h"

#define CONTEXT_FORMAT "gaussvid-text-context"

/* FNV-1a 64 of a file's bytes (the tokenizer model: a few MB). */
static int file_checksum(const char *path, char *out, size_t size)
{
    char *data = NULL;
    size_t n = 0;
    if (gv_read_file(path, &data, &n)) return -1;
    uint64_t h = 0xcbf29ce484222325ull;
    for (size_t i = 0; i < n; i++) h = (h ^ (unsigned char)data[i]) * 0x100000001b3ull;
    free(data);
    snprintf(out, size, "fnv1a64:%016llx", (unsigned long long)h);
    return 0;
}

/* "[id, id, ...]" of the prompt's tokens, malloc'ed. */
static char *token_list(const int32_t *ids, int n)
{
    size_t cap = (size_t)n * 12 + 4, len = 0;
    char *text = malloc(cap);
    if (!text) return NULL;
    for (int i = 0; i < n; i++) len += (size_t)snprintf(text + len, cap - len, "%s%d", i ? ", " : "[", ids[i]);
    snprintf(text + len, cap - len, n ? "]" : "[]");
    return text;
}

/* The context of the prompt into out [text_len, text_dim]; the token count, or -1. */
static int compute(const char *encoder, const char *tokenizer, const gv_model_config *cfg, const char *prompt,
                   float *out, int32_t *ids, uint64_t *encoder_bytes)
{
    const gv_dit_config *d = &cfg->dit;
    gv_st_file f;
    gv_umt5_config c;
    gv_tokenizer *t = NULL;
    int rc = gv_weights_open(&f, encoder), opened = rc == 0;
    if (rc == 0) rc = gv_umt5_config_from_file(&f, &c);
    if (rc == 0 && c.dim != d->text_dim)
        rc = gv_fail("%s: the text encoder gives %d values per token, the config %s takes text_dim %d", encoder, c.dim,
                     cfg->name, d->text_dim);
    if (rc == 0) rc = gv_tokenizer_open(&t, tokenizer);
    int n = rc == 0 ? gv_umt5_text_context(&c, &f, t, prompt, d->text_len, out, ids) : -1;
    if (opened) *encoder_bytes = f.file_size;
    gv_tokenizer_close(t);
    if (opened) gv_st_close(&f);
    return rc == 0 ? n : -1;
}

/* Computes, writes the cache, and copies the context to out when out is not NULL. */
static int write_cache(const char *encoder, const char *tokenizer, const gv_model_config *cfg, const char *prompt,
                       const char *path, int *n_tokens, float *out)
{
    const gv_dit_config *d = &cfg->dit;
    size_t count = (size_t)d->text_len * d->text_dim;
    float *context = malloc(count * sizeof *context);
    int32_t *ids = malloc((size_t)d->text_len * sizeof *ids);
    if (!context || !ids) {
        free(context), free(ids);
        return gv_fail("out of memory for the text context");
    }
    uint64_t encoder_bytes = 0;
    int n = compute(encoder, tokenizer, cfg, prompt, context, ids, &encoder_bytes), rc = n < 0 ? -1 : 0;
    char checksum[48], bytes[32], *tokens = NULL;
    if (rc == 0) rc = file_checksum(tokenizer, checksum, sizeof checksum);
    if (rc == 0 && !(tokens = token_list(ids, n))) rc = gv_fail("out of memory");
    snprintf(bytes, sizeof bytes, "%llu", (unsigned long long)encoder_bytes);
    gv_st_builder b;
    gv_st_builder_init(&b);
    if (rc == 0) rc = gv_st_add_f32(&b, "text_context", GV_ST_F32, (int64_t[]){d->text_len, d->text_dim}, 2, context);
    const char *keys[] = {"format", "prompt", "tokens", "text_encoder", "text_encoder_bytes", "tokenizer", "tokenizer_checksum"};
    const char *values[] = {CONTEXT_FORMAT, prompt, tokens, encoder, bytes, tokenizer, checksum};
    for (size_t i = 0; rc == 0 && i < sizeof keys / sizeof *keys; i++) rc = gv_st_add_metadata(&b, keys[i], values[i]);
    if (rc == 0) rc = gv_st_write(&b, path);
    if (rc == 0 && n_tokens) *n_tokens = n;
    if (rc == 0 && out) memcpy(out, context, count * sizeof *out);
    gv_st_builder_free(&b);
    free(context), free(ids), free(tokens);
    return rc;
}

int gv_text_context_write(const char *encoder, const char *tokenizer, const gv_model_config *cfg, const char *prompt,
                          const char *path, int *n_tokens)
{
    return write_cache(encoder, tokenizer, cfg, prompt, path, n_tokens, NULL);
}

static const char *meta_or_empty(const gv_st_file *f, const char *key)
{
    const char *v = gv_st_metadata(f, key);
    return v ? v : "";
}

/* Whether the cache's key still holds: the same prompt, and, when the encoder and tokenizer
 * it names are there, the same encoder size and tokenizer checksum. *why says what changed. */
static int cache_fresh(const gv_st_file *f, const char *prompt, char *why, size_t size)
{
    struct stat st;
    char checksum[48];
    const char *encoder = meta_or_empty(f, "text_encoder"), *tokenizer = meta_or_empty(f, "tokenizer");
    if (strcmp(meta_or_empty(f, "prompt"), prompt)) {
        snprintf(why, size, "it holds the prompt \"%s\", not \"%s\"", meta_or_empty(f, "prompt"), prompt);
        return 0;
    }
    if (*encoder && stat(encoder, &st) == 0 &&
        strtoull(meta_or_empty(f, "text_encoder_bytes"), NULL, 10) != (unsigned long long)st.st_size) {
        snprintf(why, size, "the text encoder %s changed (%lld bytes, it was computed with %s)", encoder,
                 (long long)st.st_size, meta_or_empty(f, "text_encoder_bytes"));
        return 0;
    }
    if (*tokenizer && gv_file_exists(tokenizer) && file_checksum(tokenizer, checksum, sizeof checksum) == 0 &&
        strcmp(checksum, meta_or_empty(f, "tokenizer_checksum"))) {
        snprintf(why, size, "the tokenizer %s changed", tokenizer);
        return 0;
    }
    return 1;
}

int gv_text_context_get(const gv_text_source *src, const gv_model_config *cfg, float *out, int *computed)
{
    const gv_dit_config *d = &cfg->dit;
    char encoder[GV_CHECKPOINT_TEXT], tokenizer[GV_CHECKPOINT_TEXT], why[2 * GV_CHECKPOINT_TEXT] = "it is not there";
    snprintf(encoder, sizeof encoder, "%s", src->encoder);
    snprintf(tokenizer, sizeof tokenizer, "%s", src->tokenizer);
    *computed = 0;
    if (gv_file_exists(src->path)) {
        gv_st_file f;
        if (gv_st_open(&f, src->path)) return -1;
        int rc = 0, fresh = 0;
        if (strcmp(meta_or_empty(&f, "format"), CONTEXT_FORMAT))
            rc = gv_fail("%s: not a text context (metadata format is not %s)", src->path, CONTEXT_FORMAT);
        if (rc == 0) fresh = cache_fresh(&f, src->prompt, why, sizeof why);
        if (rc == 0 && fresh)
            rc = gv_st_read_f32(&f, "text_context", out, (int64_t[]){d->text_len, d->text_dim}, 2);
        if (rc == 0 && !fresh) { /* the cache names the encoder it was computed with */
            if (!*encoder) snprintf(encoder, sizeof encoder, "%s", meta_or_empty(&f, "text_encoder"));
            if (!*tokenizer) snprintf(tokenizer, sizeof tokenizer, "%s", meta_or_empty(&f, "tokenizer"));
        }
        gv_st_close(&f);
        if (rc || fresh) return rc;
    }
    if (!*encoder || !*tokenizer || !gv_file_exists(encoder) || !gv_file_exists(tokenizer))
        return gv_fail("%s: the text context cannot be used (%s) and no text encoder is there to compute it (%s)",
                       src->path, why, *encoder ? encoder : "none named");
    gv_info("text context: computing \"%s\" with %s (%s)", src->prompt, encoder, why);
    if (write_cache(encoder, tokenizer, cfg, src->prompt, src->path, NULL, out)) return -1;
    *computed = 1;
    return 0;
}

int gv_checkpoint_text(const char *ckpt, const gv_train_state *s, gv_dit *m)
{
    if (!m->cfg.dit.cross_attn || !*s->text.path) return gv_dit_set_text(m, NULL); /* the zero context */
    gv_text_source src = s->text;
    char found[GV_CHECKPOINT_TEXT];
    /* the files as written at import, else beside the checkpoint (a moved folder) */
    if (gv_checkpoint_find_beside(ckpt, s->text.path, found, sizeof found)) snprintf(src.path, sizeof src.path, "%s", found);
    if (*s->text.encoder && gv_checkpoint_find_beside(ckpt, s->text.encoder, found, sizeof found))
        snprintf(src.encoder, sizeof src.encoder, "%s", found);
    if (*s->text.tokenizer && gv_checkpoint_find_beside(ckpt, s->text.tokenizer, found, sizeof found))
        snprintf(src.tokenizer, sizeof src.tokenizer, "%s", found);
    size_t n = (size_t)m->cfg.dit.text_len * m->cfg.dit.text_dim;
    float *context = malloc(n * sizeof *context);
    if (!context) return gv_fail("out of memory for the text context");
    int computed = 0, rc = gv_text_context_get(&src, &m->cfg, context, &computed);
    if (rc == 0) rc = gv_dit_set_text(m, context);
    free(context);
    return rc ? gv_fail_context("%s", ckpt) : 0;
}
