/* The umT5 text encoder of Wan2.1 (google/umt5-xxl's encoder, as Wan's wan/modules/t5.py
 * builds it): token embedding, then per layer T5LayerNorm (RMS, no mean, no bias), multi-head
 * self-attention without scaling and with a learned relative-position bias per layer
 * (bidirectional log buckets), T5LayerNorm, gated-GELU(tanh) FFN fc2(fc1(x) * gelu(gate(x))),
 * and a final T5LayerNorm. Inference only (frozen in GaussVid): weights are read from an open
 * weight file (the published models_t5_umt5-xxl-enc-bf16.pth, or any file with its names)
 * one layer at a time and converted to float32 as that layer runs, so the 5.7 B-parameter
 * encoder runs in about 1 GB besides the mapping. docs/WAN_WEIGHTS.md. */
#ifndef GAUSSVID_UMT5_H
#define GAUSSVID_UMT5_H

#include <stdint.h>

#include "gaussvid/io/safetensors.h"

typedef struct {
    int vocab, dim, dim_attn, dim_ffn, num_heads, num_layers;
    int num_buckets;   /* relative-position buckets, half per direction (32) */
    int max_dist;      /* distance where the log buckets end (128; not stored in the weights) */
    double eps;        /* T5LayerNorm epsilon (1e-6) */
} gv_umt5_config;

/* umT5-xxl as Wan2.1 uses it: vocab 256384, dim 4096, 64 heads of 64, FFN 10240, 24 layers,
 * 32 buckets, max distance 128. */
void gv_umt5_config_xxl(gv_umt5_config *c);
/* The config a weight file implies: sizes from token_embedding, blocks.0.attn.q, blocks.0.ffn.fc1
 * and blocks.0.pos_embedding.embedding (buckets x heads), layers by counting blocks; then
 * every tensor checked by name and shape (nothing missing; unexpected names refused). */
int gv_umt5_config_from_file(const gv_st_file *f, gv_umt5_config *c);

/* The bucket of relative position rel = key index - query index: T5's bidirectional
 * buckets (half of them for rel > 0), exact up to num_buckets/4, then logarithmic up to
 * max_dist, then the last bucket. */
int gv_umt5_bucket(int rel, int num_buckets, int max_dist);

/* Encodes the n token ids (0 < n <= 4096, each < vocab) into out [n, dim] (float32). Only
 * the real tokens are given: with the keys of padding masked out, as Wan does, the rows of
 * the real tokens do not depend on the padding. */
int gv_umt5_encode(const gv_umt5_config *c, const gv_st_file *f, const int32_t *ids, int n, float *out);

/* ---- the tokenizer (umt5_tokenizer.c; needs libsentencepiece at build time) ---------------- */
typedef struct gv_tokenizer gv_tokenizer;
/* Opens a SentencePiece model (the release's google/umt5-xxl/spiece.model). */
int gv_tokenizer_open(gv_tokenizer **t, const char *path);
void gv_tokenizer_close(gv_tokenizer *t);
int gv_tokenizer_vocab(const gv_tokenizer *t);
/* The ids of text as Wan tokenizes a prompt: whitespace runs collapsed and the ends trimmed,
 * the SentencePiece ids, then </s>; at most max ids (longer texts are truncated before the
 * </s>). Returns the count, or -1 with a message. */
int gv_tokenizer_encode(const gv_tokenizer *t, const char *text, int32_t *ids, int max);

/* The DiT's text context of a prompt (umt5_context.c): its ids (into ids, at most text_len,
 * </s> included) encoded into the first rows of out [text_len, dim], zero rows after them,
 * as Wan pads the encoder's output. Returns the number of tokens, or -1. */
int gv_umt5_text_context(const gv_umt5_config *c, const gv_st_file *f, const gv_tokenizer *t, const char *prompt,
                         int text_len, float *out, int32_t *ids);

#endif
