/* The umT5 tokenizer and the prompt's text context (umt5.h) on the committed tiny fixtures:
 * the SentencePiece model tests/fixtures/release/tiny-vace-bf16/google/umt5-xxl/spiece.model
 * gives the ids Debian's spm_encode gave for each case of tokenizer_cases.json (after Wan's
 * whitespace cleaning, then </s>); truncation keeps </s>; the text context is the encoder's
 * rows of those ids followed by zero rows. Skipped, with a message, in a build without
 * libsentencepiece. */
#include <cjson/cJSON.h>
#include <stdint.h>

#include "check.h"
#include "gaussvid/core/core.h"
#include "gaussvid/model/umt5.h"
#include "gaussvid/pth/weight_files.h"

static char fixtures[4096];

static void test_cases(const gv_tokenizer *t)
{
    char path[4200], *text = NULL;
    snprintf(path, sizeof path, "%s/tokenizer_cases.json", fixtures);
    CHECK(gv_read_file(path, &text, NULL) == 0);
    cJSON *cases = cJSON_Parse(text);
    free(text);
    CHECK(cJSON_GetArraySize(cases) == 4);
    const cJSON *c;
    cJSON_ArrayForEach(c, cases) {
        const char *input = cJSON_GetObjectItem(c, "text")->valuestring;
        const cJSON *want = cJSON_GetObjectItem(c, "ids");
        int32_t ids[64];
        int n = gv_tokenizer_encode(t, input, ids, 64), same = n == cJSON_GetArraySize(want);
        for (int i = 0; same && i < n; i++) same = ids[i] == cJSON_GetArrayItem(want, i)->valueint;
        if (!same) fprintf(stderr, "tokens of '%s' differ from spm_encode's (%d tokens)\n", input, n);
        CHECK(same);
    }
    /* truncated to 4: three pieces and </s> */
    int32_t ids[4], all[64];
    const char *prompt = "Remove degradation and restore clean video.";
    int n = gv_tokenizer_encode(t, prompt, all, 64);
    CHECK(gv_tokenizer_encode(t, prompt, ids, 4) == 4 && ids[3] == 1 && !memcmp(ids, all, 3 * sizeof *ids) && n == 13);
    cJSON_Delete(cases);
}

static void test_context(const gv_tokenizer *t)
{
    char path[4200];
    snprintf(path, sizeof path, "%s/tiny-vace-bf16/models_t5_umt5-xxl-enc-bf16.pth", fixtures);
    gv_st_file f;
    gv_umt5_config c;
    CHECK(gv_weights_open(&f, path) == 0 && gv_umt5_config_from_file(&f, &c) == 0);
    CHECK(gv_tokenizer_vocab(t) == c.vocab);
    float context[16 * 16], direct[16 * 16];
    int32_t ids[16];
    int n = gv_umt5_text_context(&c, &f, t, "Remove degradation and restore clean video.", 16, context, ids);
    CHECK(n == 13);
    CHECK(gv_umt5_encode(&c, &f, ids, n, direct) == 0);
    CHECK(memcmp(context, direct, (size_t)n * 16 * sizeof(float)) == 0);
    int zeros = 1;
    for (int i = n * 16; i < 16 * 16; i++) zeros &= context[i] == 0.0f;
    CHECK(zeros);
    /* a prompt longer than the context is cut to text_len tokens, </s> last */
    n = gv_umt5_text_context(&c, &f, t, "Remove degradation and restore clean video. Remove degradation.", 8, context, ids);
    CHECK(n == 8 && ids[7] == 1);
    gv_st_close(&f);
}

int main(void)
{
    snprintf(fixtures, sizeof fixtures, "%s", __FILE__);
    char *slash = strrchr(fixtures, '/');
    if (slash) *slash = '\0';
    else snprintf(fixtures, sizeof fixtures, ".");
    strncat(fixtures, "/fixtures/release", sizeof fixtures - strlen(fixtures) - 1);
    char path[4200];
    snprintf(path, sizeof path, "%s/tiny-vace-bf16/google/umt5-xxl/spiece.model", fixtures);
    gv_tokenizer *t = NULL;
    if (gv_tokenizer_open(&t, path) != 0) {
        if (strstr(gv_last_error(), "built without libsentencepiece")) {
            printf("skipped: %s\n", gv_last_error());
            return check_summary();
        }
        fprintf(stderr, "%s\n", gv_last_error());
        CHECK(0);
        return check_summary();
    }
    CHECK(gv_tokenizer_vocab(t) == 64);
    test_cases(t);
    test_context(t);
    gv_tokenizer_close(t);
    /* not a SentencePiece model: one line naming the file */
    snprintf(path, sizeof path, "%s/tiny-vace-bf16/Wan2.1_VAE.pth", fixtures);
    CHECK_FAILS_WITH(gv_tokenizer_open(&t, path), "Wan2.1_VAE.pth: not a SentencePiece model");
    CHECK_FAILS_WITH(gv_tokenizer_open(&t, "/nonexistent/spiece.model"), "/nonexistent/spiece.model");
    return check_summary();
}
