/* The tensors a config implies: the Wan presets' parameter counts against sums over the
 * reference's shape tables (written out here independently of the library), key names and
 * shapes spot-checked against the reference's lists, this project's camera and LoRA tensors,
 * and the check of safetensors files (missing, unexpected, mis-shaped, duplicated). */
#include "check.h"
#include "gaussvid/core/core.h"
#include "gaussvid/model/model_config.h"
#include "gaussvid/io/safetensors.h"
#include "gaussvid/model/weight_names.h"

static const char *tmp;

/* ---- the reference's tables, summed by hand ------------------------------------------- */

/* Reference 2.8, one block: modulation [1,6,D]; self_attn q,k,v,o [D,D]+[D]; norm_q, norm_k
 * [D]; norm3 weight and bias [D]; cross_attn like self_attn; ffn.0 [F,D]+[F]; ffn.2 [D,F]+[D]. */
static int64_t ref_block(int64_t D, int64_t F)
{
    int64_t attention = 4 * (D * D + D) + D + D;
    return 6 * D + attention + 2 * D + attention + (F * D + F) + (D * F + D);
}

/* Reference 2.8 outside the blocks: patch_embedding [D,16,1,2,2]+[D], text_embedding.0
 * [D,4096]+[D], .2 [D,D]+[D], time_embedding.0 [D,256]+[D], .2 [D,D]+[D], time_projection.1
 * [6D,D]+[6D], head.modulation [1,2,D], head.head [64,D]+[64]. */
static int64_t ref_dit(int64_t D, int64_t F, int64_t L)
{
    return (D * 16 * 4 + D) + (D * 4096 + D) + (D * D + D) + (D * 256 + D) + (D * D + D) + (6 * D * D + 6 * D) +
           L * ref_block(D, F) + 2 * D + (64 * D + 64);
}

/* Reference 3.1: vace_patch_embedding [D,96,1,2,2]+[D], V blocks, each with after_proj
 * [D,D]+[D], and before_proj [D,D]+[D] on block 0. */
static int64_t ref_vace(int64_t D, int64_t F, int64_t V)
{
    return (D * 96 * 4 + D) + V * (ref_block(D, F) + D * D + D) + (D * D + D);
}

/* Reference 4.2: ResidualBlock(i, o) = 2 gammas, two 3x3x3 convs with bias, a 1x1x1
 * shortcut with bias when i != o; AttentionBlock(c) = gamma, to_qkv 3c x c + 3c, proj c x c + c;
 * downsample: 3x3 conv c -> c (+ time_conv c -> c, 3x1x1); upsample: 3x3 conv c -> c/2
 * (+ time_conv c -> 2c, 3x1x1). */
static int64_t res(int64_t i, int64_t o)
{
    return i + o + (o * i * 27 + o) + (o * o * 27 + o) + (i != o ? o * i + o : 0);
}
static int64_t attn(int64_t c) { return c + 3 * c * c + 3 * c + c * c + c; }
static int64_t down(int64_t c, int t) { return c * c * 9 + c + (t ? c * c * 3 + c : 0); }
static int64_t up(int64_t c, int t) { return (c / 2) * c * 9 + c / 2 + (t ? 2 * c * c * 3 + 2 * c : 0); }
static int64_t conv(int64_t o, int64_t i, int64_t k) { return o * i * k + o; }

/* Reference 4.3's layout of the Wan2.1 VAE, stage by stage. */
static int64_t ref_vae_encoder(void)
{
    return conv(96, 3, 27) + 2 * res(96, 96) + down(96, 0) + res(96, 192) + res(192, 192) + down(192, 1) +
           res(192, 384) + res(384, 384) + down(384, 1) + 2 * res(384, 384) +
           2 * res(384, 384) + attn(384) + 384 + conv(32, 384, 27) + conv(32, 32, 1);
}

static int64_t ref_vae_decoder(void)
{
    return conv(16, 16, 1) + conv(384, 16, 27) + 2 * res(384, 384) + attn(384) + 3 * res(384, 384) + up(384, 1) +
           res(192, 384) + 2 * res(384, 384) + up(384, 1) + 3 * res(192, 192) + up(192, 0) + 3 * res(96, 96) + 96 +
           conv(3, 96, 27);
}

static int build(gv_weight_list *l, gv_weight_counts *n, const char *preset, const char *variant)
{
    gv_model_config c;
    if (gv_model_config_preset(&c, preset) || (variant && gv_model_config_set_variant(&c, variant, NULL))) return -1;
    if (gv_weight_list_build(l, &c)) return -1;
    gv_weight_list_count(l, n);
    return 0;
}

static void test_wan_counts(void)
{
    gv_weight_list l;
    gv_weight_counts n;
    struct { const char *preset; int64_t D, F, L, V; double ref_main, ref_vace; } cases[] = {
        /* docs/reference/wan-vace-gaussvid.md 2.1: main 1.42 B + VACE 0.74 B */
        {"wan2.1-vace-1.3b", 1536, 8960, 30, 15, 1.42e9, 0.74e9},
        {"wan2.1-vace-14b", 5120, 13824, 40, 8, 14.29e9, 3.05e9}, /* main 14.29 B + VACE 3.05 B */
    };
    for (int i = 0; i < 2; i++) {
        CHECK(build(&l, &n, cases[i].preset, "camera=none,lora=0") == 0);
        int64_t D = cases[i].D, F = cases[i].F, L = cases[i].L, V = cases[i].V;
        int64_t main = n.params[GV_MODULE_PATCH_EMBEDDING] + n.params[GV_MODULE_TIME_EMBEDDING] +
                       n.params[GV_MODULE_TEXT_EMBEDDING] + n.params[GV_MODULE_BLOCKS] + n.params[GV_MODULE_HEAD];
        CHECK(n.params[GV_MODULE_BLOCKS] == L * ref_block(D, F));
        CHECK(main == ref_dit(D, F, L));
        CHECK(n.params[GV_MODULE_VACE] == ref_vace(D, F, V));
        CHECK(fabs((double)main - cases[i].ref_main) < 0.006e9);
        CHECK(fabs((double)n.params[GV_MODULE_VACE] - cases[i].ref_vace) < 0.006e9);
        CHECK(n.params[GV_MODULE_VAE_ENCODER] == ref_vae_encoder());
        CHECK(n.params[GV_MODULE_VAE_DECODER] == ref_vae_decoder());
        CHECK(n.params[GV_MODULE_CAMERA] == 0 && n.params[GV_MODULE_LORA] == 0 && n.trainable == 0);
        CHECK(n.total == main + n.params[GV_MODULE_VACE] + ref_vae_encoder() + ref_vae_decoder());
        gv_weight_list_free(&l);
    }
    /* Reference 4.1: about 126.9 M (encoder 53.6 M, decoder 73.3 M). */
    CHECK(fabs((double)ref_vae_encoder() - 53.6e6) < 0.05e6 && fabs((double)ref_vae_decoder() - 73.3e6) < 0.05e6);
    printf("1.3B: DiT %lld + VACE %lld; VAE %lld + %lld\n", (long long)ref_dit(1536, 8960, 30),
           (long long)ref_vace(1536, 8960, 15), (long long)ref_vae_encoder(), (long long)ref_vae_decoder());
}

/* Name and shape of one tensor, or absence when rank < 0. */
static void expect(const gv_weight_list *l, const char *name, int rank, int64_t a, int64_t b, int64_t c, int64_t d, int64_t e)
{
    const gv_weight_spec *w = gv_weight_list_find(l, name);
    int64_t want[5] = {a, b, c, d, e};
    int ok = rank < 0 ? w == NULL : w != NULL && w->rank == rank;
    for (int k = 0; ok && rank > 0 && k < rank; k++) ok = w->shape[k] == want[k];
    CHECK(ok);
    if (!ok) fprintf(stderr, "  %s: %s\n", name, w ? "wrong shape or present" : "absent");
}

static void test_wan_names(void)
{
    gv_weight_list l;
    gv_weight_counts n;
    CHECK(build(&l, &n, "wan2.1-vace-1.3b", "camera=none,lora=0") == 0);
    /* Reference 2.8. */
    expect(&l, "patch_embedding.weight", 5, 1536, 16, 1, 2, 2);
    expect(&l, "patch_embedding.bias", 1, 1536, 0, 0, 0, 0);
    expect(&l, "text_embedding.0.weight", 2, 1536, 4096, 0, 0, 0);
    expect(&l, "text_embedding.2.bias", 1, 1536, 0, 0, 0, 0);
    expect(&l, "time_embedding.0.weight", 2, 1536, 256, 0, 0, 0);
    expect(&l, "time_embedding.2.weight", 2, 1536, 1536, 0, 0, 0);
    expect(&l, "time_projection.1.weight", 2, 9216, 1536, 0, 0, 0);
    expect(&l, "time_projection.1.bias", 1, 9216, 0, 0, 0, 0);
    expect(&l, "blocks.0.modulation", 3, 1, 6, 1536, 0, 0);
    expect(&l, "blocks.29.self_attn.q.weight", 2, 1536, 1536, 0, 0, 0);
    expect(&l, "blocks.29.self_attn.o.bias", 1, 1536, 0, 0, 0, 0);
    expect(&l, "blocks.7.self_attn.norm_q.weight", 1, 1536, 0, 0, 0, 0);
    expect(&l, "blocks.7.cross_attn.norm_k.weight", 1, 1536, 0, 0, 0, 0);
    expect(&l, "blocks.7.cross_attn.v.weight", 2, 1536, 1536, 0, 0, 0);
    expect(&l, "blocks.3.norm3.weight", 1, 1536, 0, 0, 0, 0);
    expect(&l, "blocks.3.norm3.bias", 1, 1536, 0, 0, 0, 0);
    expect(&l, "blocks.12.ffn.0.weight", 2, 8960, 1536, 0, 0, 0);
    expect(&l, "blocks.12.ffn.0.bias", 1, 8960, 0, 0, 0, 0);
    expect(&l, "blocks.12.ffn.2.weight", 2, 1536, 8960, 0, 0, 0);
    expect(&l, "head.modulation", 3, 1, 2, 1536, 0, 0);
    expect(&l, "head.head.weight", 2, 64, 1536, 0, 0, 0);
    expect(&l, "head.head.bias", 1, 64, 0, 0, 0, 0);
    expect(&l, "blocks.30.modulation", -1, 0, 0, 0, 0, 0);
    expect(&l, "blocks.0.norm1.weight", -1, 0, 0, 0, 0, 0); /* norm1, norm2, head.norm: no parameters */
    expect(&l, "head.norm.weight", -1, 0, 0, 0, 0, 0);
    /* Reference 3.1. */
    expect(&l, "vace_patch_embedding.weight", 5, 1536, 96, 1, 2, 2);
    expect(&l, "vace_blocks.0.before_proj.weight", 2, 1536, 1536, 0, 0, 0);
    expect(&l, "vace_blocks.0.before_proj.bias", 1, 1536, 0, 0, 0, 0);
    expect(&l, "vace_blocks.1.before_proj.weight", -1, 0, 0, 0, 0, 0);
    expect(&l, "vace_blocks.14.after_proj.weight", 2, 1536, 1536, 0, 0, 0);
    expect(&l, "vace_blocks.14.cross_attn.k.weight", 2, 1536, 1536, 0, 0, 0);
    expect(&l, "vace_blocks.14.modulation", 3, 1, 6, 1536, 0, 0);
    expect(&l, "vace_blocks.15.after_proj.weight", -1, 0, 0, 0, 0, 0);
    /* Reference 4.3's key examples. */
    expect(&l, "encoder.conv1.weight", 5, 96, 3, 3, 3, 3);
    expect(&l, "encoder.downsamples.0.residual.0.gamma", 4, 96, 1, 1, 1, 0);
    expect(&l, "encoder.downsamples.0.residual.2.weight", 5, 96, 96, 3, 3, 3);
    expect(&l, "encoder.downsamples.0.shortcut.weight", -1, 0, 0, 0, 0, 0);
    expect(&l, "encoder.downsamples.3.shortcut.weight", 5, 192, 96, 1, 1, 1);
    expect(&l, "encoder.downsamples.2.resample.1.weight", 4, 96, 96, 3, 3, 0);
    expect(&l, "encoder.downsamples.2.time_conv.weight", -1, 0, 0, 0, 0, 0);
    expect(&l, "encoder.downsamples.5.time_conv.weight", 5, 192, 192, 3, 1, 1);
    expect(&l, "encoder.downsamples.8.time_conv.weight", 5, 384, 384, 3, 1, 1);
    expect(&l, "encoder.downsamples.10.residual.6.weight", 5, 384, 384, 3, 3, 3);
    expect(&l, "encoder.downsamples.11.residual.0.gamma", -1, 0, 0, 0, 0, 0);
    expect(&l, "encoder.middle.1.norm.gamma", 3, 384, 1, 1, 0, 0);
    expect(&l, "encoder.middle.1.to_qkv.weight", 4, 1152, 384, 1, 1, 0);
    expect(&l, "encoder.middle.1.proj.weight", 4, 384, 384, 1, 1, 0);
    expect(&l, "encoder.head.0.gamma", 4, 384, 1, 1, 1, 0);
    expect(&l, "encoder.head.2.weight", 5, 32, 384, 3, 3, 3);
    expect(&l, "conv1.weight", 5, 32, 32, 1, 1, 1);
    expect(&l, "conv2.weight", 5, 16, 16, 1, 1, 1);
    expect(&l, "decoder.conv1.weight", 5, 384, 16, 3, 3, 3);
    expect(&l, "decoder.upsamples.3.time_conv.weight", 5, 768, 384, 3, 1, 1);
    expect(&l, "decoder.upsamples.3.resample.1.weight", 4, 192, 384, 3, 3, 0);
    expect(&l, "decoder.upsamples.4.shortcut.weight", 5, 384, 192, 1, 1, 1);
    expect(&l, "decoder.upsamples.7.time_conv.weight", 5, 768, 384, 3, 1, 1);
    expect(&l, "decoder.upsamples.8.shortcut.weight", -1, 0, 0, 0, 0, 0); /* Res(192, 192) */
    expect(&l, "decoder.upsamples.11.resample.1.weight", 4, 96, 192, 3, 3, 0);
    expect(&l, "decoder.upsamples.11.time_conv.weight", -1, 0, 0, 0, 0, 0);
    expect(&l, "decoder.upsamples.14.residual.6.weight", 5, 96, 96, 3, 3, 3);
    expect(&l, "decoder.upsamples.15.residual.0.gamma", -1, 0, 0, 0, 0, 0);
    expect(&l, "decoder.head.2.weight", 5, 3, 96, 3, 3, 3);
    /* Every listed tensor is found by name; module order starts with the patch embedding. */
    int found = 0;
    for (int i = 0; i < l.n; i++) found += gv_weight_list_find(&l, l.items[i].name) == &l.items[i];
    CHECK(found == l.n && !strcmp(l.items[0].name, "patch_embedding.weight"));
    gv_weight_list_free(&l);

    CHECK(build(&l, &n, "wan2.1-vace-14b", "camera=none,lora=0") == 0);
    expect(&l, "blocks.39.ffn.0.weight", 2, 13824, 5120, 0, 0, 0);
    expect(&l, "blocks.40.ffn.0.weight", -1, 0, 0, 0, 0, 0);
    expect(&l, "vace_blocks.7.after_proj.weight", 2, 5120, 5120, 0, 0, 0);
    expect(&l, "vace_blocks.8.after_proj.weight", -1, 0, 0, 0, 0, 0);
    expect(&l, "head.head.weight", 2, 64, 5120, 0, 0, 0);
    gv_weight_list_free(&l);
}

/* ---- this project's tensors ----------------------------------------------------------- */

static void test_camera_and_lora(void)
{
    gv_weight_list l;
    gv_weight_counts n;
    /* tiny: D 32, F 64, 2 blocks + 2 VACE blocks with cross-attention; rank 2 on
     * q, k, v, o (self and cross, PEFT's suffix rule) and ffn.0, ffn.2. */
    CHECK(build(&l, &n, "tiny", NULL) == 0);
    int64_t D = 32, F = 64, r = 2;
    int64_t lora_block = 8 * r * (D + D) + r * (D + F) + r * (F + D);
    CHECK(n.params[GV_MODULE_LORA] == 4 * lora_block);
    CHECK(n.tensors[GV_MODULE_LORA] == 4 * 10 * 2);
    expect(&l, "blocks.0.self_attn.q.lora_A.weight", 2, 2, 32, 0, 0, 0);
    expect(&l, "blocks.1.cross_attn.o.lora_B.weight", 2, 32, 2, 0, 0, 0);
    expect(&l, "blocks.0.ffn.2.lora_A.weight", 2, 2, 64, 0, 0, 0);
    expect(&l, "vace_blocks.1.ffn.0.lora_B.weight", 2, 64, 2, 0, 0, 0);
    expect(&l, "vace_blocks.0.after_proj.lora_A.weight", -1, 0, 0, 0, 0, 0);
    expect(&l, "blocks.0.self_attn.norm_q.lora_A.weight", -1, 0, 0, 0, 0, 0);
    /* Decomposed encoder: C 4, G 8, P 32, kernel (4, 16, 16) on 3 channels per stream. */
    int64_t C = 4, G = 8, P = 32, kvol = 4 * 16 * 16;
    int64_t camera = 2 * (C * 3 * kvol + C) + 2 * ((G * C + G) + (C * G + C)) + (P * 2 * C + P) + (D * P + D) + 2 * D + 1 +
                     2 * 6 * D;
    CHECK(n.params[GV_MODULE_CAMERA] == camera);
    CHECK(n.trainable == camera + 4 * lora_block);
    expect(&l, "camera_encoder.conv_m.weight", 5, 4, 3, 4, 16, 16);
    expect(&l, "camera_encoder.conv_d.bias", 1, 4, 0, 0, 0, 0);
    expect(&l, "camera_encoder.gate_d2m.0.weight", 2, 8, 4, 0, 0, 0);
    expect(&l, "camera_encoder.gate_m2d.2.weight", 2, 4, 8, 0, 0, 0);
    expect(&l, "camera_encoder.proj.0.weight", 2, 32, 8, 0, 0, 0);
    expect(&l, "camera_encoder.proj.2.weight", 2, 32, 32, 0, 0, 0);
    expect(&l, "camera_encoder.norm.weight", 1, 32, 0, 0, 0, 0);
    expect(&l, "camera_encoder.gamma", 1, 1, 0, 0, 0, 0);
    expect(&l, "blocks.1.camera_modulation", 3, 1, 6, 32, 0, 0);
    expect(&l, "vace_blocks.0.camera_modulation", -1, 0, 0, 0, 0, 0);
    /* Specified initial values: zero last projection, lora_B and VACE projections; gamma. */
    const gv_weight_spec *w;
    CHECK((w = gv_weight_list_find(&l, "camera_encoder.proj.2.weight")) && w->init == GV_INIT_ZEROS && w->trainable);
    CHECK((w = gv_weight_list_find(&l, "camera_encoder.gamma")) && w->init == GV_INIT_CONSTANT && w->init_value == 0.1);
    CHECK((w = gv_weight_list_find(&l, "blocks.0.ffn.0.lora_B.weight")) && w->init == GV_INIT_ZEROS && w->trainable);
    CHECK((w = gv_weight_list_find(&l, "vace_blocks.0.before_proj.weight")) && w->init == GV_INIT_ZEROS && !w->trainable);
    CHECK((w = gv_weight_list_find(&l, "encoder.middle.1.proj.weight")) && w->init == GV_INIT_ZEROS);
    CHECK((w = gv_weight_list_find(&l, "blocks.0.self_attn.norm_k.weight")) && w->init == GV_INIT_ONES && !w->trainable);
    gv_weight_list_free(&l);

    /* Monolithic: one conv over 6 channels to 2C, residual MLP 2C -> 2G -> 2C. */
    CHECK(build(&l, &n, "tiny", "monolithic,lora=0") == 0);
    expect(&l, "camera_encoder.conv.weight", 5, 8, 6, 4, 16, 16);
    expect(&l, "camera_encoder.mlp.0.weight", 2, 16, 8, 0, 0, 0);
    expect(&l, "camera_encoder.mlp.2.weight", 2, 8, 16, 0, 0, 0);
    expect(&l, "camera_encoder.conv_m.weight", -1, 0, 0, 0, 0, 0);
    expect(&l, "blocks.0.camera_modulation", 3, 1, 6, 32, 0, 0);
    CHECK(n.params[GV_MODULE_LORA] == 0 && n.trainable == n.params[GV_MODULE_CAMERA]);
    gv_weight_list_free(&l);
    /* Early fusion: the same encoder, no camera stream in the blocks. */
    CHECK(build(&l, &n, "tiny", "early") == 0);
    expect(&l, "camera_encoder.conv.weight", 5, 8, 6, 4, 16, 16);
    expect(&l, "blocks.0.camera_modulation", -1, 0, 0, 0, 0, 0);
    gv_weight_list_free(&l);
    /* small: no text, so no cross-attention or norm3; patch 1x4x4 and kernel (1, 16, 16). */
    CHECK(build(&l, &n, "small", NULL) == 0);
    expect(&l, "blocks.0.cross_attn.q.weight", -1, 0, 0, 0, 0, 0);
    expect(&l, "blocks.0.norm3.weight", -1, 0, 0, 0, 0, 0);
    expect(&l, "text_embedding.0.weight", -1, 0, 0, 0, 0, 0);
    expect(&l, "patch_embedding.weight", 5, 192, 16, 1, 4, 4);
    expect(&l, "head.head.weight", 2, 256, 192, 0, 0, 0);
    expect(&l, "vace_patch_embedding.weight", 5, 192, 48, 1, 4, 4);
    expect(&l, "camera_encoder.conv_m.weight", 5, 64, 3, 1, 16, 16);
    expect(&l, "blocks.4.self_attn.k.lora_A.weight", 2, 16, 192, 0, 0, 0);
    expect(&l, "blocks.5.self_attn.k.weight", -1, 0, 0, 0, 0, 0); /* 5 blocks */
    /* small's VAE: [1, 2, 4], time down [F, F]: both resamples 2D, no time_conv. */
    expect(&l, "encoder.downsamples.1.time_conv.weight", -1, 0, 0, 0, 0, 0);
    expect(&l, "encoder.downsamples.3.time_conv.weight", -1, 0, 0, 0, 0, 0);
    expect(&l, "encoder.downsamples.4.shortcut.weight", 5, 128, 64, 1, 1, 1);
    expect(&l, "decoder.upsamples.2.time_conv.weight", -1, 0, 0, 0, 0, 0);
    expect(&l, "decoder.upsamples.5.resample.1.weight", 4, 32, 64, 3, 3, 0);
    expect(&l, "decoder.upsamples.5.time_conv.weight", -1, 0, 0, 0, 0, 0);
    gv_weight_list_free(&l);
}

/* attn_scales inserts attention blocks and shifts the state-dict indices as the official
 * nn.Sequential does: encoder stage scales 1, 1/2, 1/4, 1/8; decoder 1/4, 1/2, 1, 2. */
static void test_attention_scales(void)
{
    gv_model_config c;
    gv_model_config_preset(&c, "tiny");
    c.vae.n_attn_scales = 1;
    c.vae.attn_scales[0] = 1.0;
    gv_weight_list l;
    CHECK(gv_weight_list_build(&l, &c) == 0);
    /* tiny: dim 8, [1, 2, 2, 2], one res block per encoder stage, two per decoder stage. */
    expect(&l, "encoder.downsamples.0.residual.2.weight", 5, 8, 8, 3, 3, 3);
    expect(&l, "encoder.downsamples.1.to_qkv.weight", 4, 24, 8, 1, 1, 0);
    expect(&l, "encoder.downsamples.2.resample.1.weight", 4, 8, 8, 3, 3, 0);
    expect(&l, "encoder.downsamples.3.to_qkv.weight", -1, 0, 0, 0, 0, 0);
    expect(&l, "decoder.upsamples.6.residual.2.weight", 5, 16, 8, 3, 3, 3);
    expect(&l, "decoder.upsamples.7.to_qkv.weight", 4, 48, 16, 1, 1, 0);
    expect(&l, "decoder.upsamples.9.proj.weight", 4, 16, 16, 1, 1, 0);
    expect(&l, "decoder.upsamples.10.resample.1.weight", 4, 8, 16, 3, 3, 0);
    expect(&l, "decoder.upsamples.10.time_conv.weight", -1, 0, 0, 0, 0, 0);
    expect(&l, "decoder.upsamples.12.residual.6.weight", 5, 8, 8, 3, 3, 3);
    expect(&l, "decoder.upsamples.13.residual.0.gamma", -1, 0, 0, 0, 0, 0);
    gv_weight_list_free(&l);
}

/* ---- checking files ------------------------------------------------------------------- */

/* Writes the tensors of `l` in `parts` (all zeros), skipping `skip`, reshaping `reshape`,
 * adding `extra`. */
static void write_weights(const char *path, const gv_weight_list *l, unsigned parts, const char *skip,
                          const char *reshape, const char *extra, gv_st_dtype dtype)
{
    int64_t largest = 1;
    for (int i = 0; i < l->n; i++) largest = l->items[i].numel > largest ? l->items[i].numel : largest;
    float *zeros = calloc((size_t)largest + 1, sizeof *zeros);
    gv_st_builder b;
    gv_st_builder_init(&b);
    for (int i = 0; i < l->n; i++) {
        const gv_weight_spec *w = &l->items[i];
        if (!(gv_module_part(w->module) & parts) || (skip && !strcmp(w->name, skip))) continue;
        int64_t shape[5];
        memcpy(shape, w->shape, sizeof shape);
        if (reshape && !strcmp(w->name, reshape)) shape[0] += 1;
        if (dtype == GV_ST_I32) {
            CHECK(gv_st_add_raw(&b, w->name, GV_ST_I32, shape, w->rank, zeros) == 0);
        } else {
            CHECK(gv_st_add_f32(&b, w->name, dtype, shape, w->rank, zeros) == 0);
        }
    }
    if (extra) CHECK(gv_st_add_f32(&b, extra, GV_ST_F32, (int64_t[]){2}, 1, zeros) == 0);
    CHECK(gv_st_write(&b, path) == 0);
    gv_st_builder_free(&b);
    free(zeros);
}

static int open_and_check(const gv_weight_list *l, unsigned parts, const char **paths, int n, gv_weight_report *r)
{
    gv_st_file files[4];
    memset(files, 0, sizeof files);
    for (int i = 0; i < n; i++)
        if (gv_st_open(&files[i], paths[i])) return -1;
    int rc = gv_weights_check(l, parts, files, n, r);
    /* The report points into the files' names: copy what the caller reads before closing. */
    for (int i = 0; i < r->n_unexpected; i++) r->unexpected[i].name = strdup(r->unexpected[i].name);
    for (int i = 0; i < r->n_duplicate; i++) r->duplicate[i].name = strdup(r->duplicate[i].name);
    for (int i = 0; i < n; i++) gv_st_close(&files[i]);
    return rc;
}

static void free_report(gv_weight_report *r)
{
    for (int i = 0; i < r->n_unexpected; i++) free((char *)r->unexpected[i].name);
    for (int i = 0; i < r->n_duplicate; i++) free((char *)r->duplicate[i].name);
    gv_weight_report_free(r);
}

static void test_check_files(void)
{
    gv_weight_list l;
    gv_weight_counts n;
    CHECK(build(&l, &n, "tiny", NULL) == 0);
    char full[4200], base[4200], adapters[4200], bad[4200], ints[4200];
    snprintf(full, sizeof full, "%s/full.safetensors", tmp);
    snprintf(base, sizeof base, "%s/base.safetensors", tmp);
    snprintf(adapters, sizeof adapters, "%s/adapters.safetensors", tmp);
    snprintf(bad, sizeof bad, "%s/bad.safetensors", tmp);
    snprintf(ints, sizeof ints, "%s/ints.safetensors", tmp);
    write_weights(full, &l, GV_PART_ALL, NULL, NULL, NULL, GV_ST_BF16);
    write_weights(base, &l, GV_PART_BASE, NULL, NULL, NULL, GV_ST_F32);
    write_weights(adapters, &l, GV_PART_ADAPTERS, NULL, NULL, NULL, GV_ST_F16);
    write_weights(bad, &l, GV_PART_ALL, "blocks.1.ffn.2.bias", "camera_encoder.gamma", "blocks.0.extra.weight", GV_ST_F32);
    write_weights(ints, &l, GV_PART_CAMERA, NULL, NULL, NULL, GV_ST_I32);
    gv_weight_report r;

    const char *one[1] = {full};
    CHECK(open_and_check(&l, GV_PART_ALL, one, 1, &r) == 0);
    CHECK(gv_weight_report_ok(&r) && r.n_expected == l.n && r.n_found == l.n);
    CHECK(gv_weight_report_fail(&r, "x") == 0);
    free_report(&r);

    /* The published base alone: loads as "base", misses exactly the adapters as "all". */
    one[0] = base;
    CHECK(open_and_check(&l, GV_PART_BASE, one, 1, &r) == 0 && gv_weight_report_ok(&r));
    free_report(&r);
    CHECK(open_and_check(&l, GV_PART_ALL, one, 1, &r) == 0);
    CHECK(r.n_missing == n.tensors[GV_MODULE_CAMERA] + n.tensors[GV_MODULE_LORA] && r.n_unexpected == 0);
    free_report(&r);

    /* Two files together. */
    const char *two[2] = {base, adapters};
    CHECK(open_and_check(&l, GV_PART_ALL, two, 2, &r) == 0 && gv_weight_report_ok(&r));
    free_report(&r);
    const char *dup[2] = {full, adapters};
    CHECK(open_and_check(&l, GV_PART_ALL, dup, 2, &r) == 0);
    CHECK(r.n_duplicate == n.tensors[GV_MODULE_CAMERA] + n.tensors[GV_MODULE_LORA] && !gv_weight_report_ok(&r));
    CHECK(r.n_missing == 0 && r.n_unexpected == 0 && r.n_mismatched == 0);
    free_report(&r);

    /* One missing, one mis-shaped, one unexpected. */
    one[0] = bad;
    CHECK(open_and_check(&l, GV_PART_ALL, one, 1, &r) == 0);
    CHECK(r.n_missing == 1 && !strcmp(r.missing[0].name, "blocks.1.ffn.2.bias") && !strcmp(r.missing[0].detail, "[32]"));
    CHECK(r.n_mismatched == 1 && !strcmp(r.mismatched[0].name, "camera_encoder.gamma"));
    CHECK(r.n_mismatched == 1 && strstr(r.mismatched[0].detail, "expected [1], found [2]"));
    CHECK(r.n_unexpected == 1 && !strcmp(r.unexpected[0].name, "blocks.0.extra.weight"));
    CHECK(r.n_duplicate == 0 && !gv_weight_report_ok(&r));
    CHECK_FAILS_WITH(gv_weight_report_fail(&r, "bad.safetensors"),
                     "bad.safetensors: the weights do not load: 1 missing (blocks.1.ffn.2.bias); 1 unexpected "
                     "(blocks.0.extra.weight); 1 mis-shaped (camera_encoder.gamma expected [1], found [2])");
    free_report(&r);

    /* Integer tensors do not load as weights. */
    one[0] = ints;
    CHECK(open_and_check(&l, GV_PART_CAMERA, one, 1, &r) == 0);
    CHECK(r.n_mismatched == n.tensors[GV_MODULE_CAMERA] && strstr(r.mismatched[0].detail, "dtype I32"));
    free_report(&r);
    gv_weight_list_free(&l);

    unsigned mask;
    CHECK(gv_parts_parse("dit,vae", &mask, "--parts") == 0 && mask == (GV_PART_DIT | GV_PART_VAE));
    CHECK(gv_parts_parse("base,lora", &mask, "--parts") == 0 && mask == (GV_PART_BASE | GV_PART_LORA));
    CHECK(gv_parts_parse("all", &mask, "--parts") == 0 && mask == GV_PART_ALL);
    CHECK_FAILS_WITH(gv_parts_parse("dit,text", &mask, "--parts"), "--parts: \"text\" is not a part");
    CHECK_FAILS_WITH(gv_parts_parse("dit,", &mask, "--parts"), "\"\" is not a part");
}

int main(void)
{
    tmp = check_tmp_dir();
    test_wan_counts();
    test_wan_names();
    test_camera_and_lora();
    test_attention_scales();
    test_check_files();
    return check_summary();
}
