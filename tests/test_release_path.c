/* The released GaussVid restore path (sampler "released", docs/GAUSSVID_RELEASE.md) against
 * the numbers the specification computed with the official code: the float32 sigma table
 * linspace(0.2, 0, 11)[:-1] shifted by 5 (bit patterns), the bf16 timesteps the DiT sees, the
 * time embedding of those timesteps (the sinusoid, and the DiT's bf16 rounding of the
 * timestep and of the sinusoid), the VACE mask (0 on the first and last frame) and the
 * latent frames its nearest-exact resize picks for T = 5, 9, 13, 17, 21, 81, and the
 * truncating uint8 conversion; the release's SSIM (scikit-image's) against a window-by-window
 * computation and a hand-derived case. */
#include <stdint.h>

#include "check.h"
#include "model_testutil.h"
#include "gaussvid/io/metrics.h"
#include "gaussvid/restore/restore.h"
#include "gaussvid/model/vae.h"

static uint32_t bits(float x)
{
    uint32_t u;
    memcpy(&u, &x, 4);
    return u;
}

/* Specification section 4.4: sigma_k as float32 bits, and bf16(1000 sigma_k). */
static const uint32_t SIGMA_BITS[10] = {0x3f0e38e4, 0x3f05f418, 0x3ef9c18f, 0x3ee5be5c, 0x3ecf914c,
                                        0x3eb6db6d, 0x3e9b26ca, 0x3e77bdee, 0x3e308d3d, 0x3dbda12e};
static const float TIMESTEPS_BF16[10] = {556.0f, 524.0f, 488.0f, 448.0f, 406.0f, 358.0f, 304.0f, 242.0f, 172.0f, 92.5f};

static void test_sigmas(void)
{
    float sigma[10], t[10];
    gv_release_sigmas(0.2f, 5.0f, 10, sigma, t);
    for (int k = 0; k < 10; k++) {
        CHECK(bits(sigma[k]) == SIGMA_BITS[k]);
        CHECK(t[k] == TIMESTEPS_BF16[k]);
    }
    /* the named sampler runs on that table, down to 0, starting at 5/9 */
    gv_sampler s;
    REQUIRE(gv_sampler_from_name("released", &s) == 0);
    CHECK(s.release == 1 && s.steps == 10 && s.kind == GV_SAMPLER_EULER);
    double grid[11];
    REQUIRE(gv_sampler_sigmas(&s, grid) == 0);
    for (int k = 0; k < 10; k++) CHECK(bits((float)grid[k]) == SIGMA_BITS[k] && grid[k] == (double)(float)grid[k]);
    CHECK(grid[10] == 0.0);
    CHECK_NEAR(grid[0], 0.5556, 5e-5);
    /* the DiT's timestep 1000 sigma_k (float32, as restore computes it) rounds to the table */
    for (int k = 0; k < 10; k++) CHECK(gv_bf16_to_f32(gv_f32_to_bf16(1000.0f * (float)grid[k])) == TIMESTEPS_BF16[k]);
    /* the other samplers keep their double grid */
    REQUIRE(gv_sampler_from_name("euler", &s) == 0);
    CHECK(s.release == 0);
}

/* Wan's sinusoid of the bf16 timesteps: cos(t w_i) then sin(t w_i), w_i = 10000^(-i/128),
 * 256 values, computed in double here. */
static void test_sinusoid(void)
{
    gv_graph g;
    gv_graph_init(&g, 0);
    gv_tensor *e = gv_timestep_embedding(&g, TIMESTEPS_BF16, 10, 256);
    REQUIRE(e != NULL);
    int wrong = 0;
    for (int k = 0; k < 10; k++)
        for (int i = 0; i < 128; i++) {
            double w = exp(-log(10000.0) * i / 128.0), a = (double)TIMESTEPS_BF16[k] * w;
            wrong += fabs(e->data[k * 256 + i] - cos(a)) > 1e-6 || fabs(e->data[k * 256 + 128 + i] - sin(a)) > 1e-6;
        }
    CHECK(wrong == 0);
    CHECK(e->data[0] == (float)cos(556.0) && e->data[128] == (float)sin(556.0)); /* i = 0: w = 1 */
    gv_graph_free(&g);
}

static void test_dit_time(void)
{
    gv_dit m;
    REQUIRE(mt_model(&m, "camera=none,lora=0", 5) == 0);
    mt_randomize(&m, MT_BASE, 7);
    enum { CAP = 1 << 16 };
    float *a = malloc(CAP * sizeof *a), *b = malloc(CAP * sizeof *b), *c = malloc(CAP * sizeof *c);
    int64_t n = mt_forward_clip(&m, 555.5556f, 1, a, CAP);
    REQUIRE(n > 0);
    CHECK(mt_forward_clip(&m, 556.0f, 1, b, CAP) == n);
    CHECK(mt_forward_clip(&m, 556.0f, 0, c, CAP) == n);
    int same = 1, all_same = 1;
    for (int64_t k = 0; k < n; k++) same &= bits(a[k]) == bits(b[k]), all_same &= bits(b[k]) == bits(c[k]);
    CHECK(same);      /* 555.5556 is fed as bf16: 556 */
    CHECK(!all_same); /* the sinusoid is rounded to bf16 */
    CHECK(mt_max_abs_diff(b, c, n) < 2e-2 * mt_max_abs(c, n)); /* by bf16's precision, not more */
    free(a), free(b), free(c);
    gv_dit_free(&m);
}

/* The frames the latent mask is taken from: PyTorch's nearest-exact from T frames to
 * (T + 3) / 4, floor((k + 0.5) T / T_lat), derived by hand for each T. */
static void test_vace_mask(void)
{
    static const int T[6] = {5, 9, 13, 17, 21, 81};
    static const int picks[6][21] = {
        {1, 3},
        {1, 4, 7},
        {1, 4, 8, 11},
        {1, 5, 8, 11, 15},
        {1, 5, 8, 12, 15, 19},
        {1, 5, 9, 13, 17, 21, 25, 28, 32, 36, 40, 44, 48, 52, 55, 59, 63, 67, 71, 75, 79},
    };
    for (int c = 0; c < 6; c++) {
        int frames = T[c], tl = (frames + 3) / 4, sf = 2, plane = 4; /* 2x2 pixels, one latent cell */
        float frame_mask[81], probe[81 * 4], release[81 * 4], out[4 * 21];
        REQUIRE(gv_vace_frame_mask(GV_ANCHORS_BOTH, frames, frame_mask) == 0);
        int anchors_ok = frame_mask[0] == 0 && frame_mask[frames - 1] == 0;
        for (int f = 1; f < frames - 1; f++) anchors_ok &= frame_mask[f] == 1;
        CHECK(anchors_ok);
        for (int f = 0; f < frames; f++)
            for (int p = 0; p < plane; p++) probe[f * plane + p] = (float)f, release[f * plane + p] = frame_mask[f];
        REQUIRE(gv_vace_mask_latent(probe, frames, 2, 2, tl, sf, out) == 0);
        int picked = 1;
        for (int ch = 0; ch < sf * sf; ch++)
            for (int k = 0; k < tl; k++) picked &= out[ch * tl + k] == (float)picks[c][k];
        CHECK(picked);
        /* neither anchor is picked: the release's latent mask is all ones */
        REQUIRE(gv_vace_mask_latent(release, frames, 2, 2, tl, sf, out) == 0);
        int ones = 1;
        for (int k = 0; k < sf * sf * tl; k++) ones &= out[k] == 1.0f;
        CHECK(ones);
    }
}

/* uint8(clip((x + 1) 127.5, 0, 255)) on bf16 values, truncating (hand-derived). */
static void test_to_u8(void)
{
    CHECK(gv_release_to_u8(0.0f) == 127);  /* 127.5 truncates (rounding would give 128) */
    CHECK(gv_release_to_u8(0.5f) == 191);  /* 191.25 */
    CHECK(gv_release_to_u8(0.9f) == 242);  /* bf16 0.8984375, 1.8984375, 242.05 -> bf16 242 */
    CHECK(gv_release_to_u8(0.999f) == 255); /* bf16(0.999) = 1 */
    CHECK(gv_release_to_u8(-1.0f) == 0 && gv_release_to_u8(-3.0f) == 0 && gv_release_to_u8(3.0f) == 255);
    CHECK(gv_release_to_u8(NAN) == 0);
    CHECK(gv_release_to_u8(-0.99f) == 1); /* bf16(-0.99) = -0.98828125: 0.01171875 127.5 = 1.494 -> bf16 1.4921875 */
}

/* skimage's SSIM, computed here window by window with two-pass sample (co)variances. */
static double naive_ssim(const gv_image *a, const gv_image *b)
{
    const double c1 = 6.5025, c2 = 58.5225; /* (0.01 255)^2, (0.03 255)^2 */
    double total = 0;
    for (int c = 0; c < a->channels; c++) {
        double sum = 0;
        int count = 0;
        for (int y = 3; y < a->height - 3; y++)
            for (int x = 3; x < a->width - 3; x++, count++) {
                double ma = 0, mb = 0, va = 0, vb = 0, cab = 0;
                for (int pass = 0; pass < 2; pass++)
                    for (int dy = -3; dy <= 3; dy++)
                        for (int dx = -3; dx <= 3; dx++) {
                            size_t i = ((size_t)(y + dy) * a->width + x + dx) * a->channels + c;
                            double p = a->pixels[i], q = b->pixels[i];
                            if (pass == 0) ma += p / 49, mb += q / 49;
                            else va += (p - ma) * (p - ma) / 48, vb += (q - mb) * (q - mb) / 48, cab += (p - ma) * (q - mb) / 48;
                        }
                sum += (2 * ma * mb + c1) * (2 * cab + c2) / ((ma * ma + mb * mb + c1) * (va + vb + c2));
            }
        total += sum / count;
    }
    return total / a->channels;
}

static void test_ssim_skimage(void)
{
    enum { W = 20, H = 16 };
    uint8_t pa[W * H * 3], pb[W * H * 3];
    gv_image a = {W, H, 3, pa}, b = {W, H, 3, pb};
    double s;
    /* constant images p and q: no variance, S = (2pq + C1) / (p^2 + q^2 + C1) */
    memset(pa, 100, sizeof pa), memset(pb, 110, sizeof pb);
    REQUIRE(gv_image_ssim_skimage(&a, &b, &s) == 0);
    CHECK_NEAR(s, (2.0 * 100 * 110 + 6.5025) / (100.0 * 100 + 110.0 * 110 + 6.5025), 1e-13);
    REQUIRE(gv_image_ssim_skimage(&a, &a, &s) == 0);
    CHECK(s == 1.0);
    /* a random pair against the window-by-window computation */
    uint64_t state = 12345;
    for (int i = 0; i < W * H * 3; i++) {
        state = state * 6364136223846793005ull + 1442695040888963407ull;
        pa[i] = (uint8_t)(state >> 56);
        pb[i] = (uint8_t)(pa[i] / 2 + (state >> 33) % 100);
    }
    REQUIRE(gv_image_ssim_skimage(&a, &b, &s) == 0);
    double want = naive_ssim(&a, &b);
    CHECK_NEAR(s, want, 1e-12);
    CHECK(s > 0.05 && s < 0.95);
    gv_image small = {6, 16, 3, pa};
    CHECK_FAILS_WITH(gv_image_ssim_skimage(&small, &small, &s), "smaller than its 7x7 window");
}

/* ---- the tiled VAE ------------------------------------------------------------------------- */

static void test_tile_origins(void)
{
    int o[8];
    /* 560x1024 (latent 70x128): decode tiles 30x52 at strides 15x26, encode 240x416 px at 120x208 */
    CHECK(gv_vae_tile_origins(70, 30, 15, o, 8) == 4 && o[0] == 0 && o[1] == 15 && o[2] == 30 && o[3] == 45);
    CHECK(gv_vae_tile_origins(128, 52, 26, o, 8) == 4 && o[0] == 0 && o[1] == 26 && o[2] == 52 && o[3] == 78);
    CHECK(gv_vae_tile_origins(560, 240, 120, o, 8) == 4 && o[0] == 0 && o[1] == 120 && o[2] == 240 && o[3] == 360);
    CHECK(gv_vae_tile_origins(1024, 416, 208, o, 8) == 4 && o[3] == 624);
    CHECK(gv_vae_tile_origins(18, 30, 15, o, 8) == 1 && o[0] == 0); /* a 144-pixel frame: one tile */
}

/* The blend written from the definition: weights min(row ramp, column ramp), ramps
 * (k + 1) / border on inner sides; tiles decoded whole by gv_vae_decode (no tiling). */
static void test_tiled_decode(void)
{
    gv_model_config c;
    REQUIRE(gv_model_config_preset(&c, "tiny") == 0);
    gv_vae v;
    REQUIRE(gv_vae_init(&v, &c, 0, 3) == 0);
    enum { Z = 4, TL = 2, LH = 6, LW = 6, S = 8, T = 5, HH = LH * S, WW = LW * S };
    float *z = malloc(sizeof(float) * Z * TL * LH * LW), *whole = malloc(sizeof(float) * 3 * T * HH * WW);
    float *tiled = malloc(sizeof(float) * 3 * T * HH * WW), *tile = malloc(sizeof(float) * 3 * T * 32 * 32);
    float *crop = malloc(sizeof(float) * Z * TL * 4 * 4);
    double *sum = calloc((size_t)3 * T * HH * WW, sizeof *sum), *wsum = calloc((size_t)HH * WW, sizeof *wsum);
    uint64_t st = 5;
    for (int k = 0; k < Z * TL * LH * LW; k++) {
        st = st * 6364136223846793005ull + 1442695040888963407ull;
        z[k] = (float)((double)(st >> 11) / 9007199254740992.0 * 2 - 1);
    }
    /* tiles 4x4 cells at strides 2x2 over 6x6: origins 0 and 2 on each axis, ramps of 16 px */
    const gv_vae_tiling t = {4, 4, 2, 2, 0};
    REQUIRE(gv_vae_decode_tiled(&v, &t, z, TL, LH, LW, 0, 1, tiled) == 0);
    for (int oy = 0; oy <= 2; oy += 2)
        for (int ox = 0; ox <= 2; ox += 2) {
            for (int ct = 0; ct < Z * TL; ct++)
                for (int y = 0; y < 4; y++)
                    for (int x = 0; x < 4; x++) crop[(ct * 4 + y) * 4 + x] = z[(ct * LH + oy + y) * LW + ox + x];
            REQUIRE(gv_vae_decode(&v, crop, TL, 4, 4, 0, 1, tile) == 0);
            for (int y = 0; y < 32; y++)
                for (int x = 0; x < 32; x++) {
                    /* row ramp: up from the top unless the tile starts at 0, down to the bottom
                     * unless it ends at the image's bottom (48 px) */
                    double ry = 1, rx = 1;
                    if (oy > 0 && y < 16) ry = fmin(ry, (y + 1) / 16.0);
                    if (oy * 8 + 32 < HH && y >= 16) ry = fmin(ry, (32 - y) / 16.0);
                    if (ox > 0 && x < 16) rx = fmin(rx, (x + 1) / 16.0);
                    if (ox * 8 + 32 < WW && x >= 16) rx = fmin(rx, (32 - x) / 16.0);
                    double m = fmin(ry, rx);
                    int at = (oy * 8 + y) * WW + ox * 8 + x;
                    wsum[at] += m;
                    for (int ct = 0; ct < 3 * T; ct++) sum[ct * HH * WW + at] += m * tile[(ct * 32 + y) * 32 + x];
                }
        }
    double worst = 0;
    for (int ct = 0; ct < 3 * T; ct++)
        for (int p = 0; p < HH * WW; p++) worst = fmax(worst, fabs(tiled[ct * HH * WW + p] - sum[ct * HH * WW + p] / wsum[p]));
    CHECK(worst < 1e-5);
    /* one tile over the whole latent: the whole decode, bit for bit; with bf16 sums, its bf16 rounding */
    REQUIRE(gv_vae_decode(&v, z, TL, LH, LW, 0, 1, whole) == 0);
    const gv_vae_tiling one = {6, 6, 3, 3, 0}, one_bf16 = {6, 6, 3, 3, 1};
    REQUIRE(gv_vae_decode_tiled(&v, &one, z, TL, LH, LW, 0, 1, tiled) == 0);
    int same = 1, rounded = 1, differs = 0;
    for (int k = 0; k < 3 * T * HH * WW; k++) same &= bits(tiled[k]) == bits(whole[k]);
    REQUIRE(gv_vae_decode_tiled(&v, &one_bf16, z, TL, LH, LW, 0, 1, tiled) == 0);
    for (int k = 0; k < 3 * T * HH * WW; k++)
        rounded &= bits(tiled[k]) == bits(gv_bf16_to_f32(gv_f32_to_bf16(whole[k]))), differs += tiled[k] != whole[k];
    CHECK(same && rounded && differs > 0);
    /* the VAE's tiling field routes gv_vae_decode through the tiles */
    v.tiling = &t;
    REQUIRE(gv_vae_decode(&v, z, TL, LH, LW, 0, 1, whole) == 0);
    REQUIRE(gv_vae_decode_tiled(&v, &t, z, TL, LH, LW, 0, 1, tiled) == 0);
    same = 1;
    for (int k = 0; k < 3 * T * HH * WW; k++) same &= bits(tiled[k]) == bits(whole[k]);
    CHECK(same);
    /* encoding in tiles: one tile is the whole encode */
    v.tiling = NULL;
    float *lat_whole = malloc(sizeof(float) * Z * TL * LH * LW), *lat_tiled = malloc(sizeof(float) * Z * TL * LH * LW);
    REQUIRE(gv_vae_encode(&v, whole, T, HH, WW, 0, 4, lat_whole) == 0);
    REQUIRE(gv_vae_encode_tiled(&v, &one, whole, T, HH, WW, 0, 4, lat_tiled) == 0);
    same = 1;
    for (int k = 0; k < Z * TL * LH * LW; k++) same &= bits(lat_tiled[k]) == bits(lat_whole[k]);
    CHECK(same);
    REQUIRE(gv_vae_encode_tiled(&v, &t, whole, T, HH, WW, 0, 4, lat_tiled) == 0);
    worst = 0;
    for (int k = 0; k < Z * TL * LH * LW; k++) worst = fmax(worst, fabs(lat_tiled[k] - lat_whole[k]));
    CHECK(worst > 0 && worst < 10); /* tiles see less context: close, not equal */
    free(lat_whole), free(lat_tiled);
    free(z), free(whole), free(tiled), free(tile), free(crop), free(sum), free(wsum);
    gv_vae_free(&v);
}

int main(void)
{
    test_tile_origins();
    test_tiled_decode();
    test_ssim_skimage();
    test_sigmas();
    test_sinusoid();
    test_dit_time();
    test_vace_mask();
    test_to_u8();
    return check_summary();
}
