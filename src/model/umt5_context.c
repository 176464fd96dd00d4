/* The DiT's text context of a prompt (umt5.h): Wan's T5EncoderModel tokenizes the prompt
 * (padding to text_len, keys of the padding masked), encodes it, and keeps the rows of the
 * real tokens; the DiT then pads them with zero rows to text_len
 * (docs/reference/wan-vace-gaussvid.md 2.4). */
#include <stdlib.h>
#include <string.h>

#include "gaussvid/core/core.h"
#include "gaussvid/model/umt5.h"

int gv_umt5_text_context(const gv_umt5_config *c, const gv_st_file *f, const gv_tokenizer *t, const char *prompt,
                         int text_len, float *out, int32_t *ids)
{
    if (text_len < 1) return gv_fail("umT5: text length %d", text_len);
    if (gv_tokenizer_vocab(t) > c->vocab)
        return gv_fail("%s: the tokenizer has %d pieces, more than the encoder's %d embeddings", f->path,
                       gv_tokenizer_vocab(t), c->vocab);
    int n = gv_tokenizer_encode(t, prompt, ids, text_len);
    if (n < 0) return -1;
    if (gv_umt5_encode(c, f, ids, n, out)) return -1;
    memset(out + (size_t)n * c->dim, 0, (size_t)(text_len - n) * c->dim * sizeof *out);
    return n;
}
