/* The conditioning of a clip (condition.h) on the tiny preset: latent shapes, each latent
 * against its own encoding of the pixels the spec says (ground truth, input, inactive and
 * reactive parts for every anchors variant), the mask channels, the Plücker field against the
 * ray formula, windows of a clip (crops), the per-frame layout; the latent cache (round trip, reuse, selective
 * re-encoding, invalidation by another VAE or a damaged file); any size (padding); and bad inputs. */
#include <sys/stat.h>

#include <omp.h>

#include "check.h"
#include "test_restore_fixtures.h"
#include "gaussvid/model/plucker.h"

#define W 32
#define H 32

/* Our own encoding of frames of the clip, selected per frame: 0 = zeros, 1 = input, 2 = target. */
static float *encode_frames(gv_vae *vae, const gv_clip *clip, const int *pick, int frames, int first)
{
    const int64_t plane = (int64_t)W * H;
    float *video = calloc((size_t)(3 * frames * plane), sizeof(float));
    int lt = 1 + (frames - 1) / vae->cfg.temporal_factor, s = vae->cfg.spatial_factor;
    float *z = malloc((size_t)vae->cfg.z_dim * lt * (H / s) * (W / s) * sizeof(float));
    for (int f = 0; f < frames; f++) {
        if (!pick[f]) continue;
        const uint8_t *src = gv_clip_frame(pick[f] == 1 ? clip->inputs : clip->targets, &clip->info, first + f);
        for (int c = 0; c < 3; c++)
            for (int64_t p = 0; p < plane; p++) video[((int64_t)c * frames + f) * plane + p] = src[p * 3 + c] / 127.5f - 1.0f;
    }
    CHECK(gv_vae_encode(vae, video, frames, H, W, 1, 0, z) == 0);
    free(video);
    return z;
}

static void test_variants(void)
{
    /* inactive / reactive / input picks per anchors variant (condition.h: an end frame that is
     * not an anchor is blanked) */
    struct {
        const char *variant;
        int input[5], inactive[5], reactive[5];
    } cases[] = {
        {"anchors=both", {1, 1, 1, 1, 1}, {1, 0, 0, 0, 1}, {0, 1, 1, 1, 0}},
        {"anchors=first", {1, 1, 1, 1, 0}, {1, 0, 0, 0, 0}, {0, 1, 1, 1, 0}},
        {"anchors=none", {0, 1, 1, 1, 0}, {0, 0, 0, 0, 0}, {0, 1, 1, 1, 0}},
    };
    const int clean[5] = {2, 2, 2, 2, 2};
    for (int k = 0; k < 3; k++) {
        gv_model_config cfg;
        gv_vae vae;
        CHECK(rf_tiny(&cfg, &vae, cases[k].variant, 5) == 0);
        gv_clip clip;
        CHECK(rf_make_clip(&clip, "room", "train", 6, W, H, 40, 3) == 0);
        gv_clip_latents l;
        CHECK(gv_clip_latents_prepare(&vae, &cfg, &clip, &l) == 0);
        CHECK(l.batch == 1 && l.frames == 5 && l.height == H && l.width == W && l.interval == 6);
        CHECK(l.z_dim == 4 && l.latent_frames == 2 && l.lh == 4 && l.lw == 4 && l.vace_dim == 72);
        CHECK(l.plucker && l.plucker_frames == 8 && gv_clip_latents_plucker_count(&l) == 6 * 8 * H * W);
        int64_t nz = gv_clip_latents_z_count(&l), per = nz; /* batch 1: one latent */
        CHECK(nz == 4 * 2 * 4 * 4 && gv_clip_latents_vace_count(&l) == 72 * 2 * 4 * 4);
        float *zc = encode_frames(&vae, &clip, clean, 5, 0), *zi = encode_frames(&vae, &clip, cases[k].input, 5, 0);
        float *za = encode_frames(&vae, &clip, cases[k].inactive, 5, 0);
        float *zr = encode_frames(&vae, &clip, cases[k].reactive, 5, 0);
        /* chunked (prepare) against one-shot (here) encoding: equal up to float rounding (docs/VAE.md) */
        CHECK_NEAR(rf_max_diff(l.z_clean, zc, nz), 0, 1e-4);
        CHECK_NEAR(rf_max_diff(l.z_corrupt, zi, nz), 0, 1e-4);
        CHECK_NEAR(rf_max_diff(l.vace, za, per), 0, 1e-4);
        CHECK_NEAR(rf_max_diff(l.vace + per, zr, per), 0, 1e-4);
        /* docs/reference/wan-vace-gaussvid.md 3.3: for T = 5 the latent mask samples frames 1 and
         * 3, so it is all ones */
        double lo = 1, hi = 1;
        for (int64_t i = 2 * per; i < gv_clip_latents_vace_count(&l); i++) {
            if (l.vace[i] < lo) lo = l.vace[i];
            if (l.vace[i] > hi) hi = l.vace[i];
        }
        CHECK(lo == 1 && hi == 1);
        /* the corruption reaches z_corrupt, not z_clean */
        CHECK(rf_max_diff(l.z_clean, l.z_corrupt, nz) > 1e-3);
        free(zc), free(zi), free(za), free(zr);
        gv_clip_latents_free(&l);
        CHECK(l.z_clean == NULL && l.plucker == NULL);
        gv_clip_free(&clip);
        gv_vae_free(&vae);
    }
}

/* Frame 0 is the reference camera: centre at the origin, so the moment is 0 and the direction
 * is the normalised K^-1 (u, v, 1); frame f sits at packed slot f + 3 (temporal factor 4). */
static void test_plucker(void)
{
    gv_model_config cfg;
    gv_vae vae;
    CHECK(rf_tiny(&cfg, &vae, NULL, 6) == 0);
    gv_clip clip;
    CHECK(rf_make_clip(&clip, "room", "train", 8, W, H, 10, 4) == 0);
    gv_clip_latents l;
    CHECK(gv_clip_latents_prepare(&vae, &cfg, &clip, &l) == 0);
    const int64_t plane = (int64_t)W * H;
    double worst = 0;
    for (int slot = 0; slot < 4; slot++)
        for (int y = 0; y < H; y += 7)
            for (int x = 0; x < W; x += 5) {
                double dx = (x + 0.5 - 0.5 * W) / (0.9 * W), dy = (y + 0.5 - 0.5 * H) / (0.9 * W);
                double n = sqrt(dx * dx + dy * dy + 1), d[3] = {dx / n, dy / n, 1 / n};
                for (int c = 0; c < 6; c++) {
                    double want = c < 3 ? 0.0 : d[c - 3];
                    double got = l.plucker[((int64_t)c * 8 + slot) * plane + (int64_t)y * W + x];
                    if (fabs(got - want) > worst) worst = fabs(got - want);
                }
            }
    CHECK_NEAR(worst, 0, 1e-6);
    gv_camera cams[5];
    gv_clip_cameras(&clip, cams);
    float *rays = malloc((size_t)(6 * plane) * sizeof(float));
    double scale = gv_plucker_scale(cams, 5);
    double far = 0; /* the largest distance of a centre C = -R^T t from frame 0's */
    for (int f = 1; f < 5; f++) {
        double C[2][3];
        for (int k = 0; k < 2; k++)
            for (int i = 0; i < 3; i++) {
                const gv_camera *c = &cams[k ? f : 0];
                C[k][i] = -(c->R[i] * c->t[0] + c->R[3 + i] * c->t[1] + c->R[6 + i] * c->t[2]);
            }
        double d = sqrt(pow(C[1][0] - C[0][0], 2) + pow(C[1][1] - C[0][1], 2) + pow(C[1][2] - C[0][2], 2));
        if (d > far) far = d;
    }
    CHECK_NEAR(scale, far, 1e-9);
    CHECK(far > 0.5);
    for (int f = 1; f < 5; f++) {
        CHECK(gv_plucker_rays(&cams[f], &cams[0], scale, H, W, rays) == 0);
        double diff = 0;
        for (int c = 0; c < 6; c++) diff += rf_max_diff(rays + c * plane, l.plucker + ((int64_t)c * 8 + f + 3) * plane, plane);
        CHECK(diff == 0);
    }
    free(rays);
    gv_clip_latents_free(&l);
    /* the camera variant none has no field */
    gv_model_config none = cfg;
    CHECK(gv_model_config_set_variant(&none, "none", "test") == 0);
    CHECK(gv_clip_latents_prepare(&vae, &none, &clip, &l) == 0 && l.plucker == NULL && l.z_clean);
    gv_clip_latents_free(&l);
    gv_clip_free(&clip);
    gv_vae_free(&vae);
}

/* A window of a prepared clip: every latent and context plane cut exactly, and the Plücker
 * window equal to the field of the same cameras with the principal point moved by the
 * window's corner and the picture made the window's size (what a smaller photo would give). */
static void test_crop(void)
{
    gv_model_config cfg;
    gv_vae vae;
    CHECK(rf_tiny(&cfg, &vae, NULL, 6) == 0);
    gv_clip clip;
    CHECK(rf_make_clip(&clip, "room", "train", 8, W, H, 10, 4) == 0);
    gv_clip_latents l, c;
    memset(&c, 0, sizeof c);
    CHECK(gv_clip_latents_prepare(&vae, &cfg, &clip, &l) == 0);
    const int y = 1, x = l.lw / 2, h = l.lh - 2, w = l.lw - x, sf = H / l.lh;
    CHECK(h >= 1 && w >= 1 && sf == vae.cfg.spatial_factor);
    CHECK(gv_clip_latents_crop(&l, y, x, h, w, &c) == 0);
    CHECK(c.lh == h && c.lw == w && c.height == h * sf && c.width == w * sf && c.interval == l.interval && c.batch == l.batch);
    int z_planes = l.z_dim * l.latent_frames, v_planes = l.vace_dim * l.latent_frames, bad = 0;
    for (int p = 0; p < v_planes; p++)
        for (int r = 0; r < h; r++)
            for (int q = 0; q < w; q++) {
                int64_t in = ((int64_t)p * l.lh + y + r) * l.lw + x + q, out = ((int64_t)p * h + r) * w + q;
                bad += c.vace[out] != l.vace[in];
                if (p < z_planes) bad += c.z_clean[out] != l.z_clean[in] || c.z_corrupt[out] != l.z_corrupt[in];
            }
    CHECK(bad == 0);
    gv_camera cams[5];
    gv_clip_cameras(&clip, cams);
    for (int f = 0; f < 5; f++) {
        cams[f].cx -= x * sf, cams[f].cy -= y * sf;
        cams[f].width = w * sf, cams[f].height = h * sf;
    }
    float *want = malloc((size_t)gv_clip_latents_plucker_count(&c) * sizeof(float));
    CHECK(gv_plucker_field(cams, 5, h * sf, w * sf, vae.cfg.temporal_factor, want, NULL) == 0);
    CHECK_NEAR(rf_max_diff(want, c.plucker, gv_clip_latents_plucker_count(&c)), 0, 1e-6);
    /* a second window of the same shape reuses the arrays; one outside the grid fails */
    float *kept = c.z_clean;
    CHECK(gv_clip_latents_crop(&l, 0, 0, h, w, &c) == 0 && c.z_clean == kept && c.z_clean[0] == l.z_clean[0]);
    CHECK_FAILS_WITH(gv_clip_latents_crop(&l, 3, x, h, w, &c), "outside its");
    free(want);
    gv_clip_latents_free(&c);
    gv_clip_latents_free(&l);
    gv_clip_free(&clip);
    gv_vae_free(&vae);
}

/* The per-frame restorer: the three intermediates as a batch of 1-frame clips. */
static void test_per_frame(void)
{
    gv_model_config cfg;
    gv_vae vae;
    CHECK(rf_tiny(&cfg, &vae, "per-frame", 7) == 0);
    gv_clip clip;
    CHECK(rf_make_clip(&clip, "room", "train", 6, W, H, 30, 5) == 0);
    gv_clip_latents l;
    CHECK(gv_clip_latents_prepare(&vae, &cfg, &clip, &l) == 0);
    CHECK(l.batch == 3 && l.latent_frames == 1 && l.plucker_frames == 4 && l.lh == 4);
    int64_t per = (int64_t)4 * 4 * 4, vper = (int64_t)72 * 4 * 4;
    const int tgt[1] = {2}, inp[1] = {1}, zero[1] = {0};
    float *z0 = encode_frames(&vae, &clip, zero, 1, 0);
    for (int b = 0; b < 3; b++) {
        float *zt = encode_frames(&vae, &clip, tgt, 1, 1 + b), *zi = encode_frames(&vae, &clip, inp, 1, 1 + b);
        CHECK_NEAR(rf_max_diff(l.z_clean + b * per, zt, per), 0, 1e-5);
        CHECK_NEAR(rf_max_diff(l.z_corrupt + b * per, zi, per), 0, 1e-5);
        CHECK_NEAR(rf_max_diff(l.vace + b * vper, z0, per), 0, 1e-5);
        CHECK_NEAR(rf_max_diff(l.vace + b * vper + per, zi, per), 0, 1e-5);
        /* the four packed slots of a frame hold the same rays */
        const int64_t slot = (int64_t)H * W;
        const float *p = l.plucker + (int64_t)b * 6 * 4 * slot;
        CHECK(!memcmp(p, p + slot, (size_t)slot * sizeof(float)) && !memcmp(p, p + 3 * slot, (size_t)slot * sizeof(float)));
        free(zt), free(zi);
    }
    free(z0);
    gv_clip_latents_free(&l);
    gv_clip_free(&clip);
    gv_vae_free(&vae);
}

static int same_set(const gv_latent_set *a, const gv_latent_set *b)
{
    if (a->count != b->count) return 0;
    for (int i = 0; i < a->count; i++) {
        const gv_clip_latents *x = &a->clips[i], *y = &b->clips[i];
        int64_t nz = gv_clip_latents_z_count(x), nv = gv_clip_latents_vace_count(x), np = gv_clip_latents_plucker_count(x);
        if (strcmp(a->names[i], b->names[i]) || nz != gv_clip_latents_z_count(y) || x->interval != y->interval ||
            memcmp(x->z_clean, y->z_clean, (size_t)nz * 4) || memcmp(x->z_corrupt, y->z_corrupt, (size_t)nz * 4) ||
            memcmp(x->vace, y->vace, (size_t)nv * 4) || memcmp(x->plucker, y->plucker, (size_t)np * 4))
            return 0;
    }
    return 1;
}

static void test_cache(const char *tmp)
{
    char dir[4096], path[4200];
    snprintf(dir, sizeof dir, "%s/data", tmp);
    const rf_clip_spec specs[3] = {{"alpha", "train", 6}, {"alpha", "train", 8}, {"beta", "eval", 6}};
    CHECK(rf_make_dataset(dir, specs, 3, W, H, 30) == 0);
    gv_model_config cfg;
    gv_vae vae;
    CHECK(rf_tiny(&cfg, &vae, NULL, 8) == 0);
    gv_latent_set a, b, c;
    CHECK(gv_latent_set_load(dir, "train", "tiny-vae", &vae, &cfg, &a) == 0);
    CHECK(a.count == 2 && a.encoded == 2 && gv_file_exists(a.cache_path));
    CHECK(!strcmp(a.names[0], "clips/alpha_n06_000.safetensors") && a.clips[0].interval == 6 && a.clips[1].interval == 8);
    /* each entry is exactly what prepare gives for that clip */
    gv_clip clip;
    snprintf(path, sizeof path, "%s/%s", dir, a.names[1]);
    CHECK(gv_clip_read(path, &clip) == 0);
    gv_clip_latents direct;
    CHECK(gv_clip_latents_prepare(&vae, &cfg, &clip, &direct) == 0);
    CHECK(!memcmp(direct.z_clean, a.clips[1].z_clean, (size_t)gv_clip_latents_z_count(&direct) * 4) &&
          !memcmp(direct.vace, a.clips[1].vace, (size_t)gv_clip_latents_vace_count(&direct) * 4) &&
          !memcmp(direct.plucker, a.clips[1].plucker, (size_t)gv_clip_latents_plucker_count(&direct) * 4));
    gv_clip_latents_free(&direct);
    gv_clip_free(&clip);
    /* reloaded from the cache: nothing encoded, bit-identical */
    CHECK(gv_latent_set_load(dir, "train", NULL, &vae, &cfg, &b) == 0 && b.encoded == 0 && same_set(&a, &b));
    gv_latent_set_free(&b);
    /* the eval clip is added; afterwards all three come from the cache */
    CHECK(gv_latent_set_load(dir, "eval", NULL, &vae, &cfg, &b) == 0 && b.count == 1 && b.encoded == 1);
    CHECK(gv_latent_set_load(dir, NULL, NULL, &vae, &cfg, &c) == 0 && c.count == 3 && c.encoded == 0);
    CHECK(c.count == 3 && !memcmp(c.clips[2].z_clean, b.clips[0].z_clean, (size_t)gv_clip_latents_z_count(&b.clips[0]) * 4));
    gv_latent_set_free(&b), gv_latent_set_free(&c);
    /* a clip file rewritten with other content is encoded again, alone */
    CHECK(rf_make_clip(&clip, "alpha", "train", 8, W, H, 60, 999) == 0);
    snprintf(path, sizeof path, "%s/clips/alpha_n08_001.safetensors", dir);
    CHECK(gv_clip_write(path, &clip) == 0);
    gv_clip_free(&clip);
    CHECK(gv_latent_set_load(dir, NULL, NULL, &vae, &cfg, &c) == 0 && c.encoded == 1);
    CHECK(c.count == 3 && !memcmp(c.clips[0].z_clean, a.clips[0].z_clean, (size_t)gv_clip_latents_z_count(&a.clips[0]) * 4) &&
          memcmp(c.clips[1].z_corrupt, a.clips[1].z_corrupt, (size_t)gv_clip_latents_z_count(&a.clips[1]) * 4));
    gv_latent_set_free(&c);
    /* another VAE: another cache file, everything encoded */
    gv_model_config cfg2;
    gv_vae vae2;
    CHECK(rf_tiny(&cfg2, &vae2, NULL, 9) == 0);
    CHECK(gv_vae_checksum(&vae2) != gv_vae_checksum(&vae));
    CHECK(gv_latent_set_load(dir, "train", NULL, &vae2, &cfg2, &c) == 0 && c.encoded == 2 && strcmp(c.cache_path, a.cache_path));
    gv_latent_set_free(&c);
    /* the same VAE with other statistics is another VAE too */
    double mean[4] = {0, 0, 0, 0}, std[4] = {1, 1, 1, 1};
    uint64_t before = gv_vae_checksum(&vae2);
    CHECK(gv_vae_set_stats(&vae2, mean, std) == 0 && gv_vae_checksum(&vae2) != before);
    gv_vae_free(&vae2);
    /* another anchors variant: its own file */
    gv_model_config first = cfg;
    CHECK(gv_model_config_set_variant(&first, "anchors=first", "test") == 0);
    CHECK(gv_latent_set_load(dir, "train", NULL, &vae, &first, &c) == 0 && c.encoded == 2 && strstr(c.cache_path, "_first"));
    gv_latent_set_free(&c);
    /* a damaged cache file is rebuilt (with a warning), giving the same latents */
    FILE *f = fopen(a.cache_path, "r+b");
    CHECK(f && fwrite("garbage!", 1, 8, f) == 8);
    if (f) fclose(f);
    CHECK(gv_latent_set_load(dir, "train", NULL, &vae, &cfg, &c) == 0 && c.encoded == 2);
    CHECK(gv_latent_set_load(dir, "train", NULL, &vae, &cfg, &b) == 0 && b.encoded == 0 && same_set(&b, &c));
    gv_latent_set_free(&b), gv_latent_set_free(&c);
    gv_latent_set_free(&a);
    gv_vae_free(&vae);
}

static void test_bad_inputs(const char *tmp)
{
    gv_model_config cfg;
    gv_vae vae;
    CHECK(rf_tiny(&cfg, &vae, NULL, 10) == 0);
    gv_clip clip;
    gv_clip_latents l;
    /* no size but an empty one is refused (gv_clip_alloc refuses those before) */
    int pw, ph;
    CHECK_FAILS_WITH(gv_condition_padded_size(&cfg, 0, 5, &pw, &ph), "at least one pixel");
    CHECK(rf_make_clip(&clip, "room", "train", 6, W, H, 5, 1) == 0);
    gv_model_config small;
    CHECK(gv_model_config_preset(&small, "small") == 0);
    CHECK_FAILS_WITH(gv_clip_latents_prepare(&vae, &small, &clip, &l), "is not the one of config small");
    gv_vae bare;
    CHECK(gv_vae_init(&bare, &cfg, 0, 3) == 0);
    CHECK_FAILS_WITH(gv_clip_latents_prepare(&bare, &cfg, &clip, &l), "latent statistics");
    gv_vae_free(&bare);
    gv_clip_free(&clip);

    char dir[4096], path[4200];
    gv_latent_set s;
    snprintf(dir, sizeof dir, "%s/empty", tmp);
    CHECK(gv_mkdirs(dir) == 0);
    CHECK_FAILS_WITH(gv_latent_set_load(dir, NULL, NULL, &vae, &cfg, &s), "no manifest.json");
    snprintf(dir, sizeof dir, "%s/bad", tmp);
    const rf_clip_spec specs[2] = {{"gamma", "train", 6}, {"gamma", "train", 8}};
    CHECK(rf_make_dataset(dir, specs, 2, W, H, 20) == 0);
    CHECK_FAILS_WITH(gv_latent_set_load(dir, "test", NULL, &vae, &cfg, &s), "expected train or eval");
    CHECK_FAILS_WITH(gv_latent_set_load(dir, "eval", NULL, &vae, &cfg, &s), "lists no eval clips");
    /* a missing clip file and a truncated one are named */
    snprintf(path, sizeof path, "%s/clips/gamma_n08_001.safetensors", dir);
    CHECK(truncate(path, 100) == 0);
    CHECK_FAILS_WITH(gv_latent_set_load(dir, NULL, NULL, &vae, &cfg, &s), "gamma_n08_001.safetensors");
    CHECK(s.count == 0 && s.clips == NULL);
    CHECK(remove(path) == 0);
    CHECK_FAILS_WITH(gv_latent_set_load(dir, NULL, NULL, &vae, &cfg, &s), "gamma_n08_001.safetensors");
    /* clips of a size off the block (which the cache refused before padding) load padded, as
     * gv_clip_latents_prepare makes them */
    snprintf(dir, sizeof dir, "%s/odd", tmp);
    CHECK(rf_make_dataset(dir, specs, 1, 20, 37, 20) == 0);
    CHECK(gv_latent_set_load(dir, NULL, NULL, &vae, &cfg, &s) == 0 && s.count == 1);
    snprintf(path, sizeof path, "%s/%s", dir, s.names[0]);
    CHECK(gv_clip_read(path, &clip) == 0 && gv_clip_latents_prepare(&vae, &cfg, &clip, &l) == 0);
    CHECK(s.clips[0].width == 32 && s.clips[0].height == 48 && l.width == 32 && l.height == 48 &&
          !memcmp(l.z_clean, s.clips[0].z_clean, (size_t)gv_clip_latents_z_count(&l) * 4) &&
          !memcmp(l.plucker, s.clips[0].plucker, (size_t)gv_clip_latents_plucker_count(&l) * 4));
    gv_clip_latents_free(&l), gv_clip_free(&clip), gv_latent_set_free(&s);
    gv_vae_free(&vae);
}

/* Any size (condition.h): a clip off the tiny preset's 16-pixel block gives the latents of the
 * clip padded by reflection (gv_clip_pad), bit for bit, at the next multiple of 16; with the
 * coverage variant its mask comes from the padded plane. Odd sizes and 1-pixel edges. */
static void test_padding(void)
{
    const char *variants[3] = {NULL, "per-frame", "coverage"};
    const int sizes[][2] = {{20, 32}, {40, 32}, {37, 23}, {1, 1}, {1, 17}, {17, 1}, {32, 32}};
    for (int v = 0; v < 3; v++)
        for (int k = 0; k < 7; k++) {
            gv_model_config cfg;
            gv_vae vae;
            CHECK(rf_tiny(&cfg, &vae, variants[v], 40 + v) == 0);
            const int w = sizes[k][0], h = sizes[k][1], pw = (w + 15) / 16 * 16, ph = (h + 15) / 16 * 16;
            int gw = 0, gh = 0;
            CHECK(gv_condition_padded_size(&cfg, w, h, &gw, &gh) == 0 && gw == pw && gh == ph);
            gv_clip clip, padded;
            CHECK(rf_make_clip(&clip, "room", "train", 6, w, h, 30, 7 + k) == 0);
            if (v == 2) { /* a coverage plane that varies along both axes */
                clip.coverage = malloc((size_t)(3 * w * h));
                for (int i = 0; i < 3 * w * h; i++) clip.coverage[i] = (uint8_t)((i * 5 + i / 3) % 4);
            }
            CHECK(gv_clip_pad(&clip, pw, ph, &padded) == 0 && padded.info.width == pw && padded.info.height == ph);
            CHECK(!memcmp(padded.intrinsics, clip.intrinsics, sizeof clip.intrinsics));
            CHECK((v == 2) == (padded.coverage != NULL));
            /* cropping the padded frames gives the clip's frames back */
            uint8_t *back = malloc((size_t)(5 * 3 * w * h));
            CHECK(gv_clip_crop_frames(padded.inputs, pw, ph, &clip.info, back) == 0 &&
                  !memcmp(back, clip.inputs, (size_t)(5 * 3 * w * h)));
            gv_clip_latents a, b;
            CHECK(gv_clip_latents_prepare(&vae, &cfg, &clip, &a) == 0 && gv_clip_latents_prepare(&vae, &cfg, &padded, &b) == 0);
            CHECK(a.width == pw && a.height == ph && a.lw == pw / 8 && a.lh == ph / 8);
            const int64_t nz = gv_clip_latents_z_count(&a), nv = gv_clip_latents_vace_count(&a);
            CHECK(nz == gv_clip_latents_z_count(&b) && !memcmp(a.z_clean, b.z_clean, (size_t)nz * 4) &&
                  !memcmp(a.z_corrupt, b.z_corrupt, (size_t)nz * 4) && !memcmp(a.vace, b.vace, (size_t)nv * 4) &&
                  !memcmp(a.plucker, b.plucker, (size_t)gv_clip_latents_plucker_count(&a) * 4));
            gv_clip_latents_free(&a), gv_clip_latents_free(&b);
            free(back);
            gv_clip_free(&padded), gv_clip_free(&clip);
            gv_vae_free(&vae);
        }
}

int main(void)
{
    const char *tmp = check_tmp_dir();
    gv_log_set_level(GV_LOG_QUIET);
    omp_set_num_threads(1); /* tiny shapes: threads only add synchronisation on a busy machine */
    test_variants();
    test_plucker();
    test_crop();
    test_per_frame();
    test_cache(tmp);
    test_bad_inputs(tmp);
    test_padding();
    return check_summary();
}
