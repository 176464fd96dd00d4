/* The umT5 tokenizer (umt5.h): SentencePiece through Debian's libsentencepiece
 * (umt5_tokenizer_spm.cpp), as Wan's HuggingfaceTokenizer("google/umt5-xxl") does it with
 * clean="whitespace": runs of whitespace become one space and the ends are trimmed, then
 * the pieces' ids and </s>. Wan's basic_clean also runs ftfy.fix_text and HTML unescaping,
 * which are not reproduced here (no-ops on plain ASCII prompts such as GaussVid's). Without
 * the library every call fails with one line saying so. */
#include "gaussvid/model/umt5.h"

#include <stdlib.h>
#include <string.h>

#include "gaussvid/core/core.h"

#ifdef GV_HAVE_SENTENCEPIECE
void *gv_spm_open(const char *path, char *error, size_t size);
void gv_spm_close(void *handle);
int gv_spm_vocab(const void *handle);
int gv_spm_eos(const void *handle);
long gv_spm_encode(const void *handle, const char *text, int32_t *ids, long max, char *error, size_t size);
#endif

struct gv_tokenizer {
    void *spm;
    char *path;
    int vocab, eos;
};

int gv_tokenizer_open(gv_tokenizer **out, const char *path)
{
    *out = NULL;
#ifdef GV_HAVE_SENTENCEPIECE
    if (!gv_file_exists(path)) return gv_fail("%s: cannot open: not a readable file", path);
    gv_tokenizer *t = calloc(1, sizeof *t);
    if (!t || !(t->path = strdup(path))) {
        free(t);
        return gv_fail("%s: out of memory", path);
    }
    char error[512] = "";
    if (!(t->spm = gv_spm_open(path, error, sizeof error))) {
        for (size_t k = strlen(error); k > 0 && (error[k - 1] == ' ' || error[k - 1] == '\n'); k--) error[k - 1] = '\0';
        free(t->path);
        free(t);
        return gv_fail("%s: not a SentencePiece model: %s", path, error);
    }
    t->vocab = gv_spm_vocab(t->spm), t->eos = gv_spm_eos(t->spm);
    if (t->eos < 0) {
        gv_tokenizer_close(t);
        return gv_fail("%s: the SentencePiece model has no </s> (umT5's is id 1)", path);
    }
    *out = t;
    return 0;
#else
    return gv_fail("%s: gaussvid was built without libsentencepiece (install libsentencepiece-dev and rebuild)", path);
#endif
}

void gv_tokenizer_close(gv_tokenizer *t)
{
    if (!t) return;
#ifdef GV_HAVE_SENTENCEPIECE
    gv_spm_close(t->spm);
#endif
    free(t->path);
    free(t);
}

int gv_tokenizer_vocab(const gv_tokenizer *t)
{
    return t->vocab;
}

#ifdef GV_HAVE_SENTENCEPIECE
/* Wan's whitespace_clean: re.sub(r"\s+", " ", text).strip(), for ASCII whitespace. */
static char *clean_whitespace(const char *text)
{
    size_t n = strlen(text), k = 0;
    char *out = malloc(n + 1);
    if (!out) return NULL;
    int space = 0;
    for (size_t i = 0; i < n; i++) {
        char c = text[i];
        if (c == ' ' || c == '\t' || c == '\n' || c == '\r' || c == '\f' || c == '\v') {
            space = 1;
            continue;
        }
        if (space && k) out[k++] = ' ';
        space = 0;
        out[k++] = c;
    }
    out[k] = '\0';
    return out;
}
#endif

int gv_tokenizer_encode(const gv_tokenizer *t, const char *text, int32_t *ids, int max)
{
    if (max < 1) return gv_fail("%s: no room for any token", t->path);
#ifdef GV_HAVE_SENTENCEPIECE
    char *clean = clean_whitespace(text), error[512] = "";
    if (!clean) return gv_fail("%s: out of memory", t->path);
    long n = gv_spm_encode(t->spm, clean, ids, max - 1, error, sizeof error);
    free(clean);
    if (n < 0) return gv_fail("%s: cannot encode the text: %s", t->path, error);
    if (n > max - 1) n = max - 1; /* truncation keeps room for </s>, as the HF tokenizer does */
    ids[n] = t->eos;
    return (int)n + 1;
#else
    (void)text, (void)ids;
    return gv_fail("%s: gaussvid was built without libsentencepiece", t->path);
#endif
}
