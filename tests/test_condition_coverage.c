/* The coverage plane of a clip and the VACE mask it gives (dataset.h "clip_coverage.c",
 * condition.h, variant coverage): the plane's round trip through a clip file and its absence
 * in older clips; the plane of a hand-built view (a fronto-parallel wall seen by two shifted
 * anchors, one partly occluded) against positions derived by hand, from depth maps and from a
 * wall of Gaussians; the per-pixel VACE context
 * of a clip whose coverage is known halves against our own encoding of V (1 - M) and V M and
 * the exact unshuffled mask; and that without the variant nothing changes. */
#include <omp.h>

#include "check.h"
#include "test_restore_fixtures.h"
#include "gaussvid/splat/coverage.h"

#define W 32
#define H 32
#define PLANE (W * H)

/* Frame 1: the left half covered by the first anchor; frame 2: the right half by the last;
 * frame 3: the top half by both. */
static int covered_by_hand(int frame, int y, int x)
{
    return frame == 1 ? (x < W / 2 ? GV_COVERED_FIRST : 0)
           : frame == 2 ? (x >= W / 2 ? GV_COVERED_LAST : 0)
                        : (y < H / 2 ? GV_COVERED_FIRST | GV_COVERED_LAST : 0);
}

static void wall_cameras(gv_camera cam[5], const gv_camera *cams[5]);

/* An empty W x H clip and the wall's five cameras. */
static void wall_clip(gv_clip *clip, gv_camera cam[5], const gv_camera *cams[5])
{
    gv_clip_info info;
    memset(&info, 0, sizeof info);
    info.width = W, info.height = H;
    CHECK(gv_clip_alloc(clip, &info) == 0);
    wall_cameras(cam, cams);
}

static void add_halves(gv_clip *clip)
{
    clip->coverage = malloc(3 * PLANE);
    for (int f = 1; f <= 3; f++)
        for (int y = 0; y < H; y++)
            for (int x = 0; x < W; x++) clip->coverage[(f - 1) * PLANE + y * W + x] = (uint8_t)covered_by_hand(f, y, x);
}

static void test_clip_file(const char *tmp)
{
    char with[4200], without[4200];
    snprintf(with, sizeof with, "%s/with.safetensors", tmp);
    snprintf(without, sizeof without, "%s/without.safetensors", tmp);
    gv_clip clip, back;
    CHECK(rf_make_clip(&clip, "room", "eval", 6, W, H, 30, 1) == 0);
    CHECK(gv_clip_write(without, &clip) == 0); /* as every clip before the plane */
    add_halves(&clip);
    CHECK(gv_clip_write(with, &clip) == 0);
    CHECK(gv_clip_read(with, &back) == 0);
    CHECK(back.info.has_coverage == 1 && back.coverage && memcmp(back.coverage, clip.coverage, 3 * PLANE) == 0);
    CHECK(memcmp(back.inputs, clip.inputs, 5 * PLANE * 3) == 0);
    gv_clip_free(&back);
    gv_clip_info info;
    CHECK(gv_clip_read_info(with, &info) == 0 && info.has_coverage == 1);
    CHECK(gv_clip_read_info(without, &info) == 0 && info.has_coverage == 0);
    CHECK(gv_clip_read(without, &back) == 0);
    CHECK(back.info.has_coverage == 0 && back.coverage == NULL);
    gv_clip_free(&back);
    /* a value that is not two anchor bits is refused, naming the frame */
    clip.coverage[2 * PLANE + 5] = 4;
    CHECK_FAILS_WITH(gv_clip_write(with, &clip), "coverage value 4 at frame 3");
    gv_clip_free(&clip);
    CHECK(clip.coverage == NULL);
}

/* The target looks down +z at a wall at depth 2 (fx = 16); the anchors sit 1 to either side,
 * so a wall point shifts by fx b / z = 8 pixels: target column i lands at i + 0.5 - 8 in the
 * first anchor (inside from i = 8) and at i + 0.5 + 8 in the last (inside up to i = 23). An
 * occluder at depth 1 over the first anchor's columns 0-3 hides target columns 8-11 from it. */
static void test_plane_by_hand(void)
{
    gv_clip clip;
    gv_camera cam[5];
    const gv_camera *cams[5];
    float *depth[5];
    const float *depths[5];
    wall_clip(&clip, cam, cams);
    for (int f = 0; f < 5; f++) {
        depth[f] = malloc(PLANE * sizeof(float));
        for (int p = 0; p < PLANE; p++) depth[f][p] = 2.0f;
        depths[f] = depth[f];
    }
    for (int y = 0; y < H; y++)
        for (int x = 0; x < 4; x++) depth[0][y * W + x] = 1.0f;
    depth[2][0] = 0; /* no surface at frame 2's pixel (0, 0): nothing to see */
    CHECK(gv_clip_coverage_from_depths(&clip, cams, depths, GV_COVERAGE_TOLERANCE) == 0);
    int wrong = 0;
    for (int f = 1; f <= 3; f++)
        for (int y = 0; y < H; y++)
            for (int x = 0; x < W; x++) {
                int want = (x >= 12 ? GV_COVERED_FIRST : 0) | (x <= 23 ? GV_COVERED_LAST : 0);
                if (f == 2 && x == 0 && y == 0) want = 0;
                wrong += clip.coverage[(f - 1) * PLANE + y * W + x] != want;
            }
    CHECK(wrong == 0);
    cam[3].width = W / 2;
    CHECK_FAILS_WITH(gv_clip_coverage_from_depths(&clip, cams, depths, GV_COVERAGE_TOLERANCE), "frame 3");
    for (int f = 0; f < 5; f++) free(depth[f]);
    gv_clip_free(&clip);
}

/* The 5 cameras of the hand-built views: looking down +z, fx = 16, centres at x = 1 (the first
 * anchor), 0 (the intermediates) and -1 (the last anchor). */
static void wall_cameras(gv_camera cam[5], const gv_camera *cams[5])
{
    const double centre[5] = {1, 0, 0, 0, -1};
    for (int f = 0; f < 5; f++) {
        memset(&cam[f], 0, sizeof cam[f]);
        cam[f].width = W, cam[f].height = H, cam[f].fx = cam[f].fy = 16, cam[f].cx = W / 2.0, cam[f].cy = H / 2.0;
        cam[f].R[0] = cam[f].R[4] = cam[f].R[8] = 1;
        cam[f].t[0] = -centre[f];
        cams[f] = &cam[f];
    }
}

/* The same wall made of Gaussians (flat, opaque, 0.1 apart over x, y in [-3.5, 3.5] at z = 2),
 * through gv_clip_coverage_gaussians (what `reconstruct` calls): its rendered depth is 2
 * wherever a camera looks, so the plane is the hand-derived one without the occluder. */
static void test_plane_of_gaussians(void)
{
    gv_gaussians g;
    const int side = 71;
    CHECK(gv_gaussians_alloc(&g, side * side, 0) == 0);
    for (int i = 0; i < side * side; i++) {
        g.means[3 * i] = -3.5f + 0.1f * (float)(i % side), g.means[3 * i + 1] = -3.5f + 0.1f * (float)(i / side);
        g.means[3 * i + 2] = 2;
        g.scales[3 * i] = g.scales[3 * i + 1] = logf(0.08f), g.scales[3 * i + 2] = logf(0.001f);
        g.rotations[4 * i] = 1, g.rotations[4 * i + 1] = g.rotations[4 * i + 2] = g.rotations[4 * i + 3] = 0;
        g.opacities[i] = 5;
        g.sh[3 * i] = g.sh[3 * i + 1] = g.sh[3 * i + 2] = 0.5f;
    }
    gv_clip clip;
    gv_camera cam[5];
    const gv_camera *cams[5];
    wall_clip(&clip, cam, cams);
    CHECK(gv_clip_coverage_gaussians(&clip, &g, cams, GV_COVERAGE_TOLERANCE, GV_COVERAGE_MIN_OPACITY) == 0);
    int wrong = 0;
    for (int f = 1; clip.coverage && f <= 3; f++)
        for (int y = 0; y < H; y++)
            for (int x = 0; x < W; x++) {
                int want = (x >= 8 ? GV_COVERED_FIRST : 0) | (x <= 23 ? GV_COVERED_LAST : 0);
                wrong += clip.coverage[(f - 1) * PLANE + y * W + x] != want;
            }
    CHECK(clip.coverage && wrong == 0);
    /* nothing seen where the model shows nothing: an empty model covers no pixel */
    g.n = 0;
    CHECK(gv_clip_coverage_gaussians(&clip, &g, cams, GV_COVERAGE_TOLERANCE, GV_COVERAGE_MIN_OPACITY) == 0);
    int seen = 0;
    for (int i = 0; clip.coverage && i < 3 * PLANE; i++) seen += clip.coverage[i] != 0;
    CHECK(seen == 0);
    gv_gaussians_free(&g);
    gv_clip_free(&clip);
}

/* Our own encoding of the blanked input clip weighted per pixel: (1 - M) or M. */
static float *encode_weighted(gv_vae *vae, const gv_clip *clip, const float *mask, int reactive)
{
    float *video = malloc(3 * 5 * PLANE * sizeof(float));
    float *z = malloc((size_t)vae->cfg.z_dim * 2 * (H / 8) * (W / 8) * sizeof(float));
    for (int f = 0; f < 5; f++) {
        const uint8_t *src = gv_clip_frame(clip->inputs, &clip->info, f);
        for (int c = 0; c < 3; c++)
            for (int p = 0; p < PLANE; p++) {
                float m = mask[f * PLANE + p];
                video[(c * 5 + f) * PLANE + p] = (src[p * 3 + c] / 127.5f - 1.0f) * (reactive ? m : 1.0f - m);
            }
    }
    CHECK(gv_vae_encode(vae, video, 5, H, W, 1, 0, z) == 0);
    free(video);
    return z;
}

static void test_vace_context(void)
{
    gv_model_config cfg, plain;
    gv_vae vae;
    CHECK(rf_tiny(&cfg, &vae, "coverage", 5) == 0);
    plain = cfg;
    plain.variant.coverage = 0;
    CHECK(cfg.variant.coverage == 1 && plain.variant.coverage == 0);
    gv_clip clip;
    CHECK(rf_make_clip(&clip, "room", "eval", 6, W, H, 40, 3) == 0);
    gv_clip_latents before, off, on;
    CHECK(gv_clip_latents_prepare(&vae, &cfg, &clip, &before) == 0); /* no plane: the per-frame M */
    add_halves(&clip);
    CHECK(gv_clip_latents_prepare(&vae, &plain, &clip, &off) == 0);
    CHECK(gv_clip_latents_prepare(&vae, &cfg, &clip, &on) == 0);
    int64_t nv = gv_clip_latents_vace_count(&on), nz = gv_clip_latents_z_count(&on);
    /* without the variant, or without a plane, the context is today's, bit for bit */
    CHECK(memcmp(before.vace, off.vace, (size_t)nv * sizeof(float)) == 0);
    CHECK(memcmp(before.z_corrupt, on.z_corrupt, (size_t)nz * sizeof(float)) == 0);
    CHECK(memcmp(before.z_clean, on.z_clean, (size_t)nz * sizeof(float)) == 0);
    /* the pixel mask: 0 on the anchors, per pixel on the intermediates (1 where not covered) */
    float *mask = malloc(5 * PLANE * sizeof(float));
    CHECK(gv_condition_vace_mask(&cfg, &clip, mask) == 0);
    int wrong = 0;
    for (int f = 0; f < 5; f++)
        for (int y = 0; y < H; y++)
            for (int x = 0; x < W; x++) {
                float want = f == 0 || f == 4 ? 0.0f : covered_by_hand(f, y, x) ? 0.0f : 1.0f;
                wrong += mask[f * PLANE + y * W + x] != want;
            }
    CHECK(wrong == 0);
    /* inactive E(V (1 - M)) and reactive E(V M) against our own encodings (chunked against
     * one-shot encoding: equal up to float rounding, as test_condition) */
    int64_t per = nz;
    float *za = encode_weighted(&vae, &clip, mask, 0), *zr = encode_weighted(&vae, &clip, mask, 1);
    CHECK_NEAR(rf_max_diff(on.vace, za, per), 0, 1e-4);
    CHECK_NEAR(rf_max_diff(on.vace + per, zr, per), 0, 1e-4);
    CHECK(rf_max_diff(on.vace, off.vace, per) > 1e-3); /* the covered halves moved to the inactive part */
    /* the mask channels, exactly: the tiny VAE packs 4 frames (latent frames 0, 1 sample pixel
     * frames 1 and 3, docs/reference/wan-vace-gaussvid.md 3.3) and unshuffles 8 x 8 pixels into
     * channel 8 dy + dx */
    const int sf = 8, lh = H / sf, lw = W / sf;
    const float *m = on.vace + 2 * per;
    wrong = 0;
    for (int dy = 0; dy < sf; dy++)
        for (int dx = 0; dx < sf; dx++)
            for (int k = 0; k < 2; k++)
                for (int y = 0; y < lh; y++)
                    for (int x = 0; x < lw; x++) {
                        int frame = k ? 3 : 1, py = y * sf + dy, px = x * sf + dx;
                        float want = covered_by_hand(frame, py, px) ? 0.0f : 1.0f;
                        wrong += m[(((dy * sf + dx) * 2 + k) * lh + y) * lw + x] != want;
                    }
    CHECK(wrong == 0);
    free(mask), free(za), free(zr);
    gv_clip_latents_free(&before), gv_clip_latents_free(&off), gv_clip_latents_free(&on);
    gv_clip_free(&clip);
    gv_vae_free(&vae);
}

static void test_variant_rules(void)
{
    gv_model_config cfg;
    CHECK(gv_model_config_preset(&cfg, "small") == 0 && cfg.variant.coverage == 0);
    CHECK(gv_model_config_set_variant(&cfg, "residual,coverage", "test") == 0 && cfg.variant.coverage == 1);
    char *json = gv_model_config_to_json(&cfg);
    gv_model_config back;
    CHECK(json && gv_model_config_parse(&back, json, "json") == 0 && back.variant.coverage == 1 &&
          gv_model_config_equal(&cfg, &back));
    free(json);
    CHECK(gv_model_config_set_variant(&cfg, "coverage=false", "test") == 0 && !gv_model_config_equal(&cfg, &back));
    json = gv_model_config_to_json(&cfg);
    CHECK(json && strstr(json, "coverage") == NULL); /* off: the config reads and writes as before */
    free(json);
    CHECK_FAILS_WITH(gv_model_config_set_variant(&cfg, "anchors=first,coverage", "test"), "variant.coverage");
    CHECK_FAILS_WITH(gv_model_config_set_variant(&cfg, "coverage=maybe", "test"), "variant.coverage");
}

int main(void)
{
    const char *tmp = check_tmp_dir();
    gv_log_set_level(GV_LOG_QUIET);
    omp_set_num_threads(1);
    test_clip_file(tmp);
    test_plane_by_hand();
    test_plane_of_gaussians();
    test_vace_context();
    test_variant_rules();
    return check_summary();
}
