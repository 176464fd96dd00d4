/* The committed fixtures in every layout Wan2.1-VACE is published in (tests/fixtures/release,
 * written by scripts/make_release_fixtures.py): the tiny DiT + VACE as one F32 safetensors
 * file and as BF16 shards with an index, the tiny VAE as F32 safetensors and as a PyTorch
 * zip checkpoint. Each loads to the same tensors (the BF16 ones exactly the BF16 rounding of
 * the F32 ones, rounded by the script independently of this code), and a forward pass gives
 * the same output: bit for bit against F32 weights rounded to BF16, and within BF16's
 * precision against the F32 weights. */
#include <stdint.h>

#include "check.h"
#include "model_testutil.h"
#include "gaussvid/io/safetensors.h"
#include "gaussvid/model/vae.h"
#include "gaussvid/pth/weight_files.h"
#include "gaussvid/model/weight_names.h"

static char fixtures[4096];

static const char *fixture(char *out, const char *name)
{
    snprintf(out, 4200, "%s/%s", fixtures, name);
    return out;
}

static uint32_t bits_of_float(float x)
{
    uint32_t u;
    memcpy(&u, &x, 4);
    return u;
}

static float bf16_round(float x)
{
    return gv_bf16_to_f32(gv_f32_to_bf16(x));
}

/* The published network at tiny size: no camera encoder, no LoRA. */
static int release_model(gv_dit *m)
{
    gv_model_config c;
    if (gv_model_config_preset(&c, "tiny") || gv_model_config_set_variant(&c, "camera=none,lora=0", "test")) return -1;
    return gv_dit_init(m, &c, 1);
}

static int load(gv_dit *m, const char *file)
{
    char path[4200];
    const char *paths[1] = {fixture(path, file)};
    if (release_model(m)) return -1;
    int rc = gv_dit_load(m, paths, 1, GV_PART_DIT | GV_PART_VACE);
    if (rc) fprintf(stderr, "%s\n", gv_last_error());
    return rc;
}

static double rel_l2(const float *a, const float *b, int64_t n)
{
    double num = 0, den = 0;
    for (int64_t i = 0; i < n; i++) num += (double)(a[i] - b[i]) * (a[i] - b[i]), den += (double)b[i] * b[i];
    return sqrt(num / (den > 0 ? den : 1));
}

static void test_dit(void)
{
    gv_dit f32, bf16;
    CHECK(load(&f32, "tiny_dit_f32.safetensors") == 0);
    CHECK(load(&bf16, "tiny-vace-bf16/diffusion_pytorch_model.safetensors.index.json") == 0);
    CHECK(f32.params.n == bf16.params.n && f32.params.n == 131);
    /* the same tensors, BF16 rounding aside */
    int64_t elements = 0, differ = 0, rounded = 0;
    for (int i = 0; i < f32.params.n && i < bf16.params.n; i++) {
        const gv_tensor *a = &f32.params.items[i]->t, *b = gv_params_find(&bf16.params, a->name) ? &gv_params_find(&bf16.params, a->name)->t : NULL;
        if (!b || b->numel != a->numel) { differ++; continue; }
        float *scratch; /* the linear weights stay BF16 in the mapped shards */
        const float *bv = gv_tensor_values(b, &scratch);
        if (!bv) { differ++; continue; }
        for (int64_t k = 0; k < a->numel; k++) {
            differ += bits_of_float(bv[k]) != bits_of_float(bf16_round(a->data[k]));
            rounded += a->data[k] != bv[k];
        }
        free(scratch);
        elements += a->numel;
    }
    int kept = 0;
    int64_t kept_bytes = gv_dit_bf16_bytes(&bf16, &kept);
    printf("kept in BF16 (mapped): %d linear weights, %lld bytes\n", kept, (long long)kept_bytes);
    CHECK(kept > 0 && kept_bytes > 0 && gv_dit_bf16_bytes(&f32, NULL) == 0);
    printf("DiT + VACE: %lld elements; BF16 = round(F32) for all but %lld; %lld changed by the rounding\n",
           (long long)elements, (long long)differ, (long long)rounded);
    CHECK(elements == 75184 && differ == 0 && rounded > elements / 2);

    /* forward: BF16 files == F32 weights rounded to BF16, bit for bit; close to F32 */
    static float y32[4096], ybf[4096], yround[4096];
    int64_t n32 = mt_forward_clip(&f32, -1, 0, y32, 4096), nbf = mt_forward_clip(&bf16, -1, 0, ybf, 4096);
    for (int i = 0; i < f32.params.n; i++) {
        gv_tensor *t = &f32.params.items[i]->t;
        for (int64_t k = 0; k < t->numel; k++) t->data[k] = bf16_round(t->data[k]);
    }
    int64_t nround = mt_forward_clip(&f32, -1, 0, yround, 4096);
    CHECK(n32 > 0 && n32 == nbf && nbf == nround);
    int same = n32 > 0;
    for (int64_t k = 0; k < n32 && same; k++) same = bits_of_float(ybf[k]) == bits_of_float(yround[k]);
    CHECK(same);
    double rel = n32 > 0 ? rel_l2(ybf, y32, n32) : 1;
    printf("forward from BF16 shards vs F32: relative L2 %.3g, max |diff| %.3g (output max %.3g)\n", rel,
           mt_max_abs_diff(ybf, y32, n32 > 0 ? n32 : 0), mt_max_abs(y32, n32 > 0 ? n32 : 0));
    CHECK(rel < 2e-2); /* BF16 keeps 8 bits: about 0.4 % per weight */
    gv_dit_free(&f32);
    gv_dit_free(&bf16);
}

static int vae_of(gv_vae *v, const char *file)
{
    gv_model_config c;
    char path[4200];
    if (gv_model_config_preset(&c, "tiny") || gv_vae_init(v, &c, 0, 1)) return -1;
    int rc = gv_vae_load(v, fixture(path, file), 0);
    if (rc) fprintf(stderr, "%s\n", gv_last_error());
    return rc;
}

static void test_vae(void)
{
    char path[4200];
    /* the checkpoint's tensors point into the mapped storages: nothing copied, 64-byte aligned */
    gv_st_file f;
    CHECK(gv_weights_open(&f, fixture(path, "tiny-vace-bf16/Wan2.1_VAE.pth")) == 0);
    int in_place = f.n_tensors == 146;
    for (int i = 0; i < f.n_tensors; i++) {
        const gv_st_tensor *t = &f.tensors[i];
        in_place &= t->dtype == GV_ST_F32 && (const uint8_t *)t->data == f.map + t->begin && t->begin % 64 == 0;
    }
    CHECK(in_place);
    gv_st_close(&f);

    gv_vae a, b;
    CHECK(vae_of(&a, "tiny_vae_f32.safetensors") == 0);
    CHECK(vae_of(&b, "tiny-vace-bf16/Wan2.1_VAE.pth") == 0);
    int64_t elements = 0, differ = 0;
    for (int i = 0; i < a.params.n; i++) {
        const gv_tensor *x = &a.params.items[i]->t;
        const gv_param *y = gv_params_find(&b.params, x->name);
        if (!y || y->t.numel != x->numel) { differ++; continue; }
        differ += memcmp(x->data, y->t.data, (size_t)x->numel * sizeof *x->data) != 0;
        elements += x->numel;
    }
    printf("VAE: %lld elements, %lld tensors differ between the .pth and the safetensors file\n", (long long)elements,
           (long long)differ);
    CHECK(elements == 203295 && differ == 0);
    /* encode and decode a 5-frame 32x32 clip with each: the same numbers */
    static float video[3 * 5 * 32 * 32], za[4 * 2 * 4 * 4], zb[4 * 2 * 4 * 4], va[3 * 5 * 32 * 32], vb[3 * 5 * 32 * 32];
    gv_fill_uniform(video, 3 * 5 * 32 * 32, 5, 0, -1, 1);
    CHECK(gv_vae_encode(&a, video, 5, 32, 32, 0, 0, za) == 0 && gv_vae_encode(&b, video, 5, 32, 32, 0, 0, zb) == 0);
    CHECK(memcmp(za, zb, sizeof za) == 0 && mt_max_abs(za, 4 * 2 * 4 * 4) > 0);
    CHECK(gv_vae_decode(&a, za, 2, 4, 4, 0, 1, va) == 0 && gv_vae_decode(&b, zb, 2, 4, 4, 0, 1, vb) == 0);
    CHECK(memcmp(va, vb, sizeof va) == 0);
    gv_vae_free(&a);
    gv_vae_free(&b);
}

int main(void)
{
    snprintf(fixtures, sizeof fixtures, "%s", __FILE__);
    char *slash = strrchr(fixtures, '/');
    if (slash) *slash = '\0';
    else snprintf(fixtures, sizeof fixtures, ".");
    strncat(fixtures, "/fixtures/release", sizeof fixtures - strlen(fixtures) - 1);
    test_dit();
    test_vae();
    return check_summary();
}
