/* Model configs: the presets' published numbers, the shipped configs/<name>.json, JSON round
 * trips, strict rejection of malformed files (each naming the file and the key), variant
 * overrides and the clip cost arithmetic. */
#include <cjson/cJSON.h>

#include "check.h"
#include "gaussvid/core/core.h"
#include "gaussvid/model/model_config.h"

static const char *tmp;

/* The source tree's configs/ folder, from this file's path. */
static const char *configs_dir(void)
{
    static char dir[4096];
    snprintf(dir, sizeof dir, "%s", __FILE__);
    char *slash = strrchr(dir, '/');
    if (slash) *slash = '\0';
    else snprintf(dir, sizeof dir, ".");
    strncat(dir, "/../configs", sizeof dir - strlen(dir) - 1);
    return dir;
}

static void test_wan_presets(void)
{
    gv_model_config c;
    /* Reference 2.1 and 3.1: 1.3B. */
    CHECK(gv_model_config_preset(&c, "wan2.1-vace-1.3b") == 0);
    CHECK(c.dit.dim == 1536 && c.dit.ffn_dim == 8960 && c.dit.num_heads == 12 && c.dit.num_layers == 30);
    CHECK(c.dit.freq_dim == 256 && c.dit.text_dim == 4096 && c.dit.text_len == 512);
    CHECK(c.dit.in_dim == 16 && c.dit.out_dim == 16 && c.dit.vace_in_dim == 96);
    CHECK(c.dit.patch_size[0] == 1 && c.dit.patch_size[1] == 2 && c.dit.patch_size[2] == 2);
    CHECK(c.dit.eps == 1e-6 && c.dit.qk_norm && c.dit.cross_attn_norm && c.dit.cross_attn);
    CHECK(c.dit.n_vace_layers == 15);
    for (int j = 0; j < 15; j++) CHECK(c.dit.vace_layers[j] == 2 * j);
    /* 14B. */
    CHECK(gv_model_config_preset(&c, "wan2.1-vace-14b") == 0);
    CHECK(c.dit.dim == 5120 && c.dit.ffn_dim == 13824 && c.dit.num_heads == 40 && c.dit.num_layers == 40);
    CHECK(c.dit.dim / c.dit.num_heads == 128);
    CHECK(c.dit.n_vace_layers == 8);
    for (int j = 0; j < 8; j++) CHECK(c.dit.vace_layers[j] == 5 * j);
    /* Reference 4.1 and 4.5: the VAE. */
    const gv_vae_config *v = &c.vae;
    CHECK(v->dim == 96 && v->z_dim == 16 && v->num_res_blocks == 2 && v->n_attn_scales == 0);
    CHECK(v->n_levels == 4 && v->dim_mult[0] == 1 && v->dim_mult[1] == 2 && v->dim_mult[2] == 4 && v->dim_mult[3] == 4);
    CHECK(!v->temperal_downsample[0] && v->temperal_downsample[1] && v->temperal_downsample[2]);
    CHECK(v->temporal_factor == 4 && v->spatial_factor == 8 && v->has_latent_stats);
    CHECK(v->latent_mean[0] == -0.7571 && v->latent_mean[7] == 1.5508 && v->latent_mean[15] == -0.2921);
    CHECK(v->latent_std[0] == 2.8184 && v->latent_std[8] == 3.2687 && v->latent_std[15] == 1.9160);
    /* The authors' camera encoder sizes (docs/reference/wan-vace-gaussvid.md 1.4) and LoRA rank 32
     * (paper 4). */
    CHECK(c.camera.channels == 128 && c.camera.gate_hidden == 256 && c.camera.proj_hidden == 5120);
    CHECK(c.camera.gamma_init == 0.1 && c.lora.rank == 32 && c.lora.alpha == 32);
    int k[3];
    gv_model_camera_kernel(&c, k);
    CHECK(k[0] == 4 && k[1] == 16 && k[2] == 16); /* the authors' Conv3d kernel (4, 16, 16) */
}

static void test_presets_and_round_trip(void)
{
    const char *const *names = gv_model_preset_names();
    int n = 0;
    for (; names[n]; n++) {
        gv_model_config c, back, file;
        CHECK(gv_model_config_preset(&c, names[n]) == 0);
        CHECK(!strcmp(c.name, names[n]));
        char *text = gv_model_config_to_json(&c);
        CHECK(text != NULL);
        if (!text) continue;
        CHECK(gv_model_config_parse(&back, text, names[n]) == 0);
        CHECK(gv_model_config_equal(&c, &back));
        char *again = gv_model_config_to_json(&back);
        CHECK(again && !strcmp(text, again));
        free(again);
        free(text);
        /* The shipped file describes the same model. */
        char path[4200];
        snprintf(path, sizeof path, "%s/%s.json", configs_dir(), names[n]);
        CHECK(gv_model_config_load(&file, path) == 0);
        CHECK(gv_model_config_equal(&c, &file));
        /* Written and read back through a file. */
        snprintf(path, sizeof path, "%s/%s.json", tmp, names[n]);
        CHECK(gv_model_config_write(&c, path) == 0);
        CHECK(gv_model_config_load(&file, path) == 0 && gv_model_config_equal(&c, &file));
    }
    CHECK(n == 4);
    gv_model_config c;
    CHECK_FAILS_WITH(gv_model_config_preset(&c, "huge"), "huge: unknown model preset");
    CHECK_FAILS_WITH(gv_model_config_load(&c, "no-such-preset"), "no-such-preset: neither a model preset");
    CHECK_FAILS_WITH(gv_model_config_load(&c, "/no/such/file.json"), "/no/such/file.json");
}

/* Equality must notice a change in any part (else the round trip above proves nothing). */
static void test_equal_notices_changes(void)
{
    gv_model_config a, b;
    gv_model_config_preset(&a, "wan2.1-vace-1.3b");
    b = a, b.dit.vace_layers[14]++;
    CHECK(!gv_model_config_equal(&a, &b));
    b = a, b.vae.latent_std[3] += 1e-9;
    CHECK(!gv_model_config_equal(&a, &b));
    b = a, b.vae.temperal_downsample[0] = 1;
    CHECK(!gv_model_config_equal(&a, &b));
    b = a, b.camera.gamma_init = 0.2;
    CHECK(!gv_model_config_equal(&a, &b));
    b = a, b.lora.targets[5][4] = '0';
    CHECK(!gv_model_config_equal(&a, &b));
    b = a, b.variant.anchors = GV_ANCHORS_FIRST;
    CHECK(!gv_model_config_equal(&a, &b));
    b = a, b.variant.skip = 1;
    CHECK(!gv_model_config_equal(&a, &b));
    b = a;
    CHECK(gv_model_config_equal(&a, &b));
}

/* Optional fields take their documented defaults; the name comes from the file. */
static void test_minimal_file(void)
{
    char path[4200];
    snprintf(path, sizeof path, "%s/minimal.json", tmp);
    FILE *f = fopen(path, "w");
    fprintf(f, "{\"dit\": {\"dim\": 64, \"ffn_dim\": 128, \"freq_dim\": 32, \"num_heads\": 4, \"num_layers\": 3,\n"
               " \"vace_layers\": [0, 2], \"vace_in_dim\": 32, \"patch_size\": [1, 2, 2], \"in_dim\": 8,\n"
               " \"out_dim\": 8, \"eps\": 1e-6, \"cross_attn\": false},\n"
               " \"vae\": {\"dim\": 16, \"z_dim\": 8, \"dim_mult\": [1, 2, 4], \"num_res_blocks\": 1,\n"
               " \"attn_scales\": [], \"temperal_downsample\": [true, true]}}\n");
    fclose(f);
    gv_model_config c;
    CHECK(gv_model_config_load(&c, path) == 0);
    CHECK(!strcmp(c.name, "minimal"));
    CHECK(c.vae.spatial_factor == 4 && c.vae.temporal_factor == 4 && !c.vae.has_latent_stats);
    CHECK(c.dit.qk_norm && c.dit.cross_attn_norm && !c.dit.cross_attn && c.dit.text_dim == 0);
    CHECK(c.camera.channels == 128 && c.camera.gate_hidden == 256 && c.camera.proj_hidden == 64);
    CHECK(c.camera.gamma_init == 0.1);
    CHECK(c.lora.rank == 32 && c.lora.alpha == 32 && c.lora.n_targets == 6 && c.lora.blocks && c.lora.vace_blocks);
    CHECK(!strcmp(c.lora.targets[4], "ffn.0"));
    CHECK(c.variant.camera == GV_CAMERA_DECOMPOSED && c.variant.anchors == GV_ANCHORS_BOTH && !c.variant.per_frame);
    CHECK(!c.variant.skip);
}

/* ---- malformed files ------------------------------------------------------------------ */

/* The tiny preset as a cJSON tree, to be damaged. */
static cJSON *tiny_json(void)
{
    gv_model_config c;
    gv_model_config_preset(&c, "tiny");
    char *text = gv_model_config_to_json(&c);
    cJSON *root = cJSON_Parse(text);
    free(text);
    return root;
}

static void write_text(const char *path, const char *text)
{
    FILE *f = fopen(path, "w");
    if (f) {
        fputs(text, f);
        fclose(f);
    }
}

/* Writes the text as NAME.json; loading must fail with one line naming the file and
 * containing `needle`. */
static void expect_bad_text(const char *name, const char *text, const char *needle)
{
    char path[4200];
    snprintf(path, sizeof path, "%s/%s.json", tmp, name);
    write_text(path, text);
    gv_model_config c;
    gv_clear_error();
    int rc = gv_model_config_load(&c, path);
    const char *msg = gv_last_error();
    int ok = rc != 0 && strstr(msg, path) && strstr(msg, needle) && !strchr(msg, '\n');
    CHECK(ok);
    if (!ok) fprintf(stderr, "  %s: rc %d, message '%s', wanted '%s'\n", name, rc, msg, needle);
}

static void expect_bad(const char *name, cJSON *root, const char *needle)
{
    char *text = cJSON_Print(root);
    expect_bad_text(name, text, needle);
    free(text);
    cJSON_Delete(root);
}

static cJSON *sec(cJSON *root, const char *name)
{
    return cJSON_GetObjectItemCaseSensitive(root, name);
}

static void set(cJSON *obj, const char *key, cJSON *value)
{
    if (cJSON_GetObjectItemCaseSensitive(obj, key)) cJSON_ReplaceItemInObjectCaseSensitive(obj, key, value);
    else cJSON_AddItemToObject(obj, key, value);
}

static void test_malformed(void)
{
    cJSON *r;
    r = tiny_json(), cJSON_AddNumberToObject(r, "extra", 1);
    expect_bad("unknown_top", r, "extra: unknown key");
    r = tiny_json(), cJSON_AddNumberToObject(sec(r, "dit"), "dims", 32);
    expect_bad("unknown_dit", r, "dit.dims: unknown key");
    r = tiny_json(), cJSON_AddNumberToObject(sec(r, "lora"), "dropout", 0.1);
    expect_bad("unknown_lora", r, "lora.dropout: unknown key");
    r = tiny_json(), set(sec(r, "dit"), "dim", cJSON_CreateString("32"));
    expect_bad("string_dim", r, "dit.dim: expected an integer, got a string");
    r = tiny_json(), set(sec(r, "dit"), "num_layers", cJSON_CreateNumber(2.5));
    expect_bad("fractional_layers", r, "dit.num_layers: expected an integer, got 2.5");
    r = tiny_json(), set(sec(r, "dit"), "qk_norm", cJSON_CreateNumber(1));
    expect_bad("number_bool", r, "dit.qk_norm: expected true or false, got a number");
    r = tiny_json(), set(sec(r, "vae"), "dim_mult", cJSON_CreateString("1,2"));
    expect_bad("string_list", r, "vae.dim_mult: expected an array, got a string");
    r = tiny_json(), set(r, "vae", cJSON_CreateArray());
    expect_bad("array_section", r, "vae: expected an object, got an array");
    r = tiny_json(), set(sec(r, "dit"), "dim", cJSON_CreateNumber(-32));
    expect_bad("negative_dim", r, "dit.dim: must be in [1, 65536] (got -32)");
    r = tiny_json(), set(sec(r, "vae"), "z_dim", cJSON_CreateNumber(-4));
    expect_bad("negative_z", r, "vae.z_dim: must be in [1, 64] (got -4)");
    r = tiny_json(), set(sec(r, "dit"), "dim", cJSON_CreateNumber(33));
    expect_bad("dim_heads", r, "dit.dim: 33 is not divisible by dit.num_heads (2)");
    r = tiny_json(), set(sec(r, "dit"), "dim", cJSON_CreateNumber(30));
    expect_bad("odd_head_dim", r, "dit.num_heads: head dimension dim/num_heads = 15");
    r = tiny_json(), cJSON_DeleteItemFromObjectCaseSensitive(sec(r, "dit"), "ffn_dim");
    expect_bad("missing_ffn", r, "dit.ffn_dim: missing");
    r = tiny_json(), cJSON_DeleteItemFromObjectCaseSensitive(r, "vae");
    expect_bad("missing_vae", r, "vae: missing");
    r = tiny_json(), set(sec(r, "dit"), "vace_layers", cJSON_CreateIntArray((int[]){1}, 1));
    expect_bad("vace_start", r, "dit.vace_layers: must start with layer 0");
    r = tiny_json(), set(sec(r, "dit"), "vace_layers", cJSON_CreateIntArray((int[]){0, 5}, 2));
    expect_bad("vace_range", r, "dit.vace_layers: layer 5 is not a block index");
    r = tiny_json(), set(sec(r, "dit"), "vace_layers", cJSON_CreateIntArray((int[]){0, 0}, 2));
    expect_bad("vace_order", r, "dit.vace_layers: must be strictly increasing");
    r = tiny_json(), set(sec(r, "dit"), "vace_in_dim", cJSON_CreateNumber(96));
    expect_bad("vace_in_dim", r, "dit.vace_in_dim: 96 should be");
    r = tiny_json(), set(sec(r, "dit"), "in_dim", cJSON_CreateNumber(16));
    expect_bad("in_dim", r, "dit.in_dim: 16 differs from vae.z_dim (4)");
    r = tiny_json(), set(sec(r, "dit"), "patch_size", cJSON_CreateIntArray((int[]){1, 2}, 2));
    expect_bad("patch", r, "dit.patch_size: needs 3 entries");
    r = tiny_json(), set(sec(r, "dit"), "eps", cJSON_CreateNumber(0));
    expect_bad("eps", r, "dit.eps: must be in (0, 0.1]");
    r = tiny_json(), set(sec(r, "dit"), "freq_dim", cJSON_CreateNumber(15));
    expect_bad("freq_dim", r, "dit.freq_dim: must be even");
    r = tiny_json(), cJSON_DeleteItemFromObjectCaseSensitive(sec(r, "dit"), "text_len");
    expect_bad("text_len", r, "dit.text_len: missing");
    int flags2[2] = {1, 1};
    r = tiny_json(), set(sec(r, "vae"), "temperal_downsample", cJSON_CreateArray());
    cJSON_AddItemToArray(sec(sec(r, "vae"), "temperal_downsample"), cJSON_CreateBool(flags2[0]));
    expect_bad("temperal_length", r, "vae.temperal_downsample: has 1 flags; vae.dim_mult has 4 levels, so 3");
    r = tiny_json(), cJSON_ReplaceItemInArray(sec(sec(r, "vae"), "temperal_downsample"), 2, cJSON_CreateFalse());
    expect_bad("temporal_two", r, "vae.temperal_downsample: needs 0 or 2 true flags");
    r = tiny_json(), set(sec(r, "vae"), "spatial_factor", cJSON_CreateNumber(16));
    expect_bad("spatial_factor", r, "vae.spatial_factor: 16 disagrees with vae.dim_mult");
    r = tiny_json(), set(sec(r, "vae"), "dim_mult", cJSON_CreateIntArray((int[]){1, 2, 2, 2, 2}, 5));
    expect_bad("five_levels", r, "vae.dim_mult: has 5 entries, at most 4");
    r = tiny_json(), set(sec(r, "vae"), "attn_scales", cJSON_CreateDoubleArray((double[]){0.3}, 1));
    expect_bad("attn_scale", r, "vae.attn_scales: 0.3 is not a power of two");
    r = tiny_json(), set(sec(r, "vae"), "latent_mean", cJSON_CreateDoubleArray((double[]){0, 0, 0, 0}, 4));
    expect_bad("mean_alone", r, "vae.latent_std: missing");
    r = tiny_json(), set(sec(r, "vae"), "latent_mean", cJSON_CreateDoubleArray((double[]){0, 0, 0}, 3));
    set(sec(r, "vae"), "latent_std", cJSON_CreateDoubleArray((double[]){1, 1, 1}, 3));
    expect_bad("mean_length", r, "vae.latent_mean: has 3 entries, vae.z_dim is 4");
    r = tiny_json(), set(sec(r, "vae"), "latent_mean", cJSON_CreateDoubleArray((double[]){0, 0, 0, 0}, 4));
    set(sec(r, "vae"), "latent_std", cJSON_CreateDoubleArray((double[]){1, 1, -1, 1}, 4));
    expect_bad("negative_std", r, "vae.latent_std: entry 2 must be positive");
    r = tiny_json(), set(sec(r, "camera"), "channels", cJSON_CreateNumber(0));
    expect_bad("camera_channels", r, "camera.channels: must be in [1, 65536] (got 0)");
    r = tiny_json(), set(sec(r, "variant"), "camera", cJSON_CreateString("side"));
    expect_bad("camera_variant", r, "variant.camera: \"side\" is not none, early, monolithic or decomposed");
    r = tiny_json(), set(sec(r, "variant"), "per_frame", cJSON_CreateTrue());
    expect_bad("per_frame_anchors", r, "variant.anchors: a per-frame restorer has no anchors");
    cJSON *targets = cJSON_CreateArray();
    cJSON_AddItemToArray(targets, cJSON_CreateString("qq"));
    r = tiny_json(), set(sec(r, "lora"), "targets", targets);
    expect_bad("lora_target", r, "lora.targets: \"qq\" is not a linear layer");
    targets = cJSON_CreateArray();
    cJSON_AddItemToArray(targets, cJSON_CreateString("cross_attn.q"));
    r = tiny_json(), set(sec(r, "lora"), "targets", targets), set(sec(r, "dit"), "cross_attn", cJSON_CreateFalse());
    expect_bad("lora_cross", r, "lora.targets: \"cross_attn.q\" matches no layer");
    r = tiny_json(), set(sec(r, "lora"), "alpha", cJSON_CreateNumber(-1));
    expect_bad("lora_alpha", r, "lora.alpha: must be positive");
    /* 1e999 reads as infinity, which could not be written back (a fuzz finding): refused even
     * where it would be unused (rank 0) */
    r = tiny_json(), set(sec(r, "lora"), "rank", cJSON_CreateNumber(0)), set(sec(r, "lora"), "alpha", cJSON_CreateNumber(12345));
    {
        char *text = cJSON_Print(r), *at = strstr(text, "12345");
        CHECK(at != NULL);
        if (at) memcpy(at, "1e999", 5);
        expect_bad_text("infinite_alpha", text, "lora.alpha: inf is not a finite number");
        free(text);
        cJSON_Delete(r);
    }
    /* Text-level damage. */
    expect_bad_text("not_json", "{\n\"dit\": {\"dim\": 32,,\n}}\n", "line 2: not valid JSON");
    expect_bad_text("array_root", "[1, 2]", "a model config must be a JSON object, got an array");
    cJSON *root = tiny_json();
    char *text = cJSON_Print(root);
    cJSON_Delete(root);
    char *at = strstr(text, "\"ffn_dim\"");
    char dup[8192];
    snprintf(dup, sizeof dup, "%.*s\"dim\": 32, %s", (int)(at - text), text, at);
    free(text);
    expect_bad_text("duplicate", dup, "dit.dim: duplicate key");
}

/* ---- variants ------------------------------------------------------------------------- */

static void test_variants(void)
{
    gv_model_config c;
    gv_model_config_preset(&c, "small");
    CHECK(gv_model_config_set_variant(&c, "camera=none,anchors=first", NULL) == 0);
    CHECK(c.variant.camera == GV_CAMERA_NONE && c.variant.anchors == GV_ANCHORS_FIRST);
    CHECK(gv_model_config_set_variant(&c, "monolithic", NULL) == 0 && c.variant.camera == GV_CAMERA_MONOLITHIC);
    CHECK(gv_model_config_set_variant(&c, "per-frame", NULL) == 0);
    CHECK(c.variant.per_frame && c.variant.anchors == GV_ANCHORS_NONE);
    CHECK(gv_model_config_set_variant(&c, "lora=8", NULL) == 0 && c.lora.rank == 8 && c.lora.alpha == 8);
    CHECK(gv_model_config_set_variant(&c, "lora=0", NULL) == 0 && c.lora.rank == 0);
    CHECK(gv_model_config_set_variant(&c, "lora=4", NULL) == 0 && c.lora.rank == 4 && c.lora.alpha == 4);
    CHECK(gv_model_config_set_variant(&c, "skip", NULL) == 0 && c.variant.skip);
    char *text = gv_model_config_to_json(&c); /* the flag survives the JSON round trip */
    gv_model_config back;
    CHECK(text && gv_model_config_parse(&back, text, "skip.json") == 0 && back.variant.skip && gv_model_config_equal(&c, &back));
    free(text);
    /* the output forms exclude each other: naming one replaces the other */
    CHECK(gv_model_config_set_variant(&c, "residual", NULL) == 0 && c.variant.residual && !c.variant.skip);
    CHECK(gv_model_config_set_variant(&c, "skip", NULL) == 0 && c.variant.skip && !c.variant.residual);
    CHECK(gv_model_config_set_variant(&c, "skip=false", NULL) == 0 && !c.variant.skip);
    gv_model_config_preset(&c, "small");
    CHECK_FAILS_WITH(gv_model_config_set_variant(&c, "skip=yes", "--variant"), "variant.skip: \"yes\" is not true or false");
    CHECK_FAILS_WITH(gv_model_config_set_variant(&c, "camera=side", "--variant"), "--variant: variant.camera: \"side\"");
    CHECK_FAILS_WITH(gv_model_config_set_variant(&c, "per_frame=true", "--variant"), "variant.anchors: a per-frame restorer");
    CHECK_FAILS_WITH(gv_model_config_set_variant(&c, "speed=2", "--variant"), "speed: unknown variant key");
    CHECK_FAILS_WITH(gv_model_config_set_variant(&c, "lora=-1", "--variant"), "lora.rank");
    CHECK_FAILS_WITH(gv_model_config_set_variant(&c, "fast", "--variant"), "\"fast\" is not a variant");
    CHECK(!strcmp(gv_camera_variant_name(GV_CAMERA_EARLY), "early") && !strcmp(gv_anchors_name(GV_ANCHORS_BOTH), "both"));
}

/* ---- clip cost ------------------------------------------------------------------------ */

static void test_cost(void)
{
    gv_model_config c;
    gv_model_cost k;
    gv_model_config_preset(&c, "small");
    CHECK(gv_model_cost_estimate(&c, 5, 144, 256, &k) == 0);
    /* 5 frames, temporal factor 1 -> 5 latent frames; 144x256 / 4 -> 36x64; patch 4x4 -> 9x16. */
    CHECK(k.latent_frames == 5 && k.latent_height == 36 && k.latent_width == 64);
    CHECK(k.video_tokens == 720 && k.camera_tokens == 720 && k.evaluations == 1);
    /* Hand arithmetic: 5 blocks x 1440 tokens x 2 (4 D^2 + 2 D F), D 192, F 768;
     * attention 5 x 4 x 1440^2 x 192. */
    CHECK_NEAR(k.flops_blocks_linear, 5.0 * 1440 * 2 * (4.0 * 192 * 192 + 2.0 * 192 * 768), 0.5);
    CHECK_NEAR(k.flops_blocks_attention, 5.0 * 4 * 1440 * 1440 * 192, 0.5);
    CHECK(k.flops_cross_attention == 0);
    double sum = k.flops_blocks_linear + k.flops_blocks_attention + k.flops_vace + k.flops_camera + k.flops_lora + k.flops_embed_head;
    CHECK_NEAR(k.flops_total, sum, 1);
    /* docs/MODEL.md: the forward pass of the temporal-factor-1 layout, about 18 GFLOP. */
    CHECK(k.flops_total > 16e9 && k.flops_total < 20e9);
    /* Without the camera stream the blocks see half the tokens. */
    CHECK(gv_model_config_set_variant(&c, "camera=early", NULL) == 0);
    CHECK(gv_model_cost_estimate(&c, 5, 144, 256, &k) == 0 && k.camera_tokens == 0 && k.flops_camera > 0);
    CHECK_NEAR(k.flops_blocks_attention, 5.0 * 4 * 720 * 720 * 192, 0.5);
    CHECK(gv_model_config_set_variant(&c, "camera=none,per-frame", NULL) == 0);
    CHECK(gv_model_cost_estimate(&c, 5, 144, 256, &k) == 0 && k.evaluations == 5 && k.video_tokens == 144);
    CHECK(k.flops_camera == 0);
    /* Reference 2.9's estimate for one evaluation at 560x1024x5 (4480 tokens, no camera):
     * about 153 TFLOP (14B) and 23 TFLOP (1.3B); it leaves out the VACE projections and
     * counts one of the two cross-attention K/V products, so agree within 3%. */
    gv_model_config_preset(&c, "wan2.1-vace-14b");
    CHECK(gv_model_config_set_variant(&c, "camera=none,lora=0", NULL) == 0);
    CHECK(gv_model_cost_estimate(&c, 5, 560, 1024, &k) == 0 && k.video_tokens == 4480);
    CHECK(fabs(k.flops_total / 153e12 - 1) < 0.03);
    gv_model_config_preset(&c, "wan2.1-vace-1.3b");
    CHECK(gv_model_config_set_variant(&c, "camera=none,lora=0", NULL) == 0);
    CHECK(gv_model_cost_estimate(&c, 5, 560, 1024, &k) == 0 && fabs(k.flops_total / 23e12 - 1) < 0.03);
    CHECK_FAILS_WITH(gv_model_cost_estimate(&c, 4, 144, 256, &k), "1 + k x 4 frames"); /* 1.3B packs 4 */
    gv_model_config_preset(&c, "small");
    CHECK_FAILS_WITH(gv_model_cost_estimate(&c, 5, 100, 256, &k), "multiples of 16x16");
}

/* Random byte damage to a valid config: every result either parses into a config that
 * validates and round-trips, or fails with one line starting with the source name. */
static void test_mutations(void)
{
    gv_model_config c, back;
    gv_model_config_preset(&c, "wan2.1-vace-1.3b");
    char *text = gv_model_config_to_json(&c);
    size_t len = strlen(text);
    char *damaged = malloc(len + 1);
    gv_rng rng;
    gv_rng_init(&rng, 5);
    static const char alphabet[] = "{}[]:,\"0123456789-.eEtrufalsn x";
    int parsed = 0, rejected = 0, bad = 0;
    for (int trial = 0; trial < 3000; trial++) {
        memcpy(damaged, text, len + 1);
        int edits = 1 + (int)(gv_rng_u32(&rng) % 3);
        for (int e = 0; e < edits; e++) {
            size_t at = gv_rng_u32(&rng) % len;
            if (gv_rng_u32(&rng) % 4 == 0) memmove(damaged + at, damaged + at + 1, strlen(damaged + at)); /* delete */
            else damaged[at] = alphabet[gv_rng_u32(&rng) % (sizeof alphabet - 1)];
        }
        gv_clear_error();
        if (gv_model_config_parse(&c, damaged, "fuzz.json") == 0) {
            char *again = gv_model_config_to_json(&c);
            parsed++;
            bad += gv_model_config_validate(&c, "fuzz.json") != 0 || !again ||
                   gv_model_config_parse(&back, again, "again") != 0 || !gv_model_config_equal(&c, &back);
            free(again);
        } else {
            rejected++;
            const char *msg = gv_last_error();
            bad += strncmp(msg, "fuzz.json: ", 11) != 0 || strchr(msg, '\n') != NULL;
        }
    }
    printf("mutations: %d parsed, %d rejected, %d bad\n", parsed, rejected, bad);
    CHECK(bad == 0 && rejected > 1000);
    free(damaged);
    free(text);
}

int main(void)
{
    tmp = check_tmp_dir();
    test_wan_presets();
    test_presets_and_round_trip();
    test_equal_notices_changes();
    test_minimal_file();
    test_malformed();
    test_variants();
    test_cost();
    test_mutations();
    return check_summary();
}
