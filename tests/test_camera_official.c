/* The official GaussVid camera code (plucker_official.h, docs/GAUSSVID_RELEASE.md): the
 * Plücker map on a hand-derived case (two cameras, 2x2 pixels: exact rays and moments), the
 * packing, and the PluckerTokenEncoder with the official parameter names on random cameras
 * and weights against an independent computation written here (rigid inverses, loops in
 * double).
 *
 *   test_camera_official                       runs the checks
 *   test_camera_official --write-fixtures DIR  writes camera_weights.safetensors and
 *                                              camera_inputs.safetensors (tests/cli/gaussvid_release.sh) */
#include <stdint.h>

#include "check.h"
#include "gaussvid/core/core.h"
#include "gaussvid/model/plucker_official.h"
#include "gaussvid/io/safetensors.h"

/* Frame 0 at (0, 0, 5) looking down +z; frame 1 turned 90 degrees about z and moved to
 * (1, 0, 5); fx = fy = 2, cx = cy = 1. */
static const float KS[2][9] = {{2, 0, 1, 0, 2, 1, 0, 0, 1}, {2, 0, 1, 0, 2, 1, 0, 0, 1}};
static const float C2WS[2][16] = {{1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 5, 0, 0, 0, 1},
                                  {0, -1, 0, 1, 1, 0, 0, 0, 0, 0, 1, 5, 0, 0, 0, 1}};

static void test_hand_derived(void)
{
    float out[2 * 2 * 2 * 6];
    REQUIRE(gv_official_plucker(&KS[0][0], &C2WS[0][0], 2, 2, 2, out) == 0);
    const double a = 0.25 / sqrt(1.125), c = 1.0 / sqrt(1.125); /* 0.2357022604, 0.9428090416 */
    /* pixel (i, j) of frame f: out[((f 2 + j) 2 + i) 6 + channel] */
    const double want[4][2][6] = {
        /* frame 0 is the identity: no moment; d = the normalised camera ray */
        {{0, 0, 0, -a, -a, c}, {0, 0, 0, a, -a, c}},  /* j = 0: i = 0, 1 */
        {{0, 0, 0, -a, a, c}, {0, 0, 0, a, a, c}},    /* j = 1 */
        /* frame 1: d = R_z(90) d_cam = (-y, x, z); o = (1, 0, 0); m = o x d = (0, -d_z, d_y) */
        {{0, -c, -a, a, -a, c}, {0, -c, a, a, a, c}},  /* j = 0: d_cam (-a, -a, c) and (a, -a, c) */
        {{0, -c, -a, -a, -a, c}, {0, -c, a, -a, a, c}}, /* j = 1: d_cam (-a, a, c) and (a, a, c) */
    };
    int wrong = 0;
    for (int f = 0; f < 2; f++)
        for (int j = 0; j < 2; j++)
            for (int i = 0; i < 2; i++)
                for (int ch = 0; ch < 6; ch++)
                    wrong += fabs(out[((f * 2 + j) * 2 + i) * 6 + ch] - want[f * 2 + j][i][ch]) > 1e-7;
    CHECK(wrong == 0);
    /* packing: three copies of frame 0, then the frames; channels first */
    float packed[6 * 5 * 4];
    gv_official_pack(out, 2, 2, 2, packed);
    int packed_ok = 1;
    for (int ch = 0; ch < 6; ch++)
        for (int t = 0; t < 5; t++)
            for (int p = 0; p < 4; p++) packed_ok &= packed[(ch * 5 + t) * 4 + p] == out[((t < 3 ? 0 : t - 3) * 4 + p) * 6 + ch];
    CHECK(packed_ok);
    float singular[2][16] = {{0}};
    CHECK_FAILS_WITH(gv_official_plucker(&KS[0][0], &singular[0][0], 2, 2, 2, out), "c2ws[0] is singular");
}

/* ---- random cameras and weights ------------------------------------------------------------ */

enum { F = 5, H = 32, W = 32, TP = F + 3, HID = 4, BOT = 8, D = 32, NTOK = 2 * 2 * 2 };

static uint64_t state = 99;
static float uniform(float lo, float hi)
{
    state = state * 6364136223846793005ull + 1442695040888963407ull;
    return lo + (hi - lo) * (float)((double)(state >> 11) / 9007199254740992.0);
}

/* Random rigid camera-to-world poses (rotation from a random unit quaternion) and intrinsics. */
static void random_cameras(float *Ks, float *c2ws)
{
    for (int f = 0; f < F; f++) {
        double q[4], n = 0;
        for (int k = 0; k < 4; k++) q[k] = uniform(-1, 1), n += q[k] * q[k];
        for (int k = 0; k < 4; k++) q[k] /= sqrt(n);
        double w = q[0], x = q[1], y = q[2], z = q[3];
        double R[9] = {1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y),
                       2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x),
                       2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)};
        float *P = c2ws + 16 * f, *K = Ks + 9 * f;
        memset(P, 0, 16 * sizeof *P), memset(K, 0, 9 * sizeof *K);
        for (int r = 0; r < 3; r++) {
            for (int c = 0; c < 3; c++) P[r * 4 + c] = (float)R[r * 3 + c];
            P[r * 4 + 3] = uniform(-2, 2);
        }
        P[15] = 1;
        K[0] = uniform(20, 40), K[4] = uniform(20, 40), K[2] = uniform(12, 20), K[5] = uniform(12, 20), K[8] = 1;
    }
}

typedef struct {
    const char *name;
    int rank;
    int64_t shape[5];
    float *v;
} wt;

static wt WEIGHTS[] = {
    {"dxo_patch_embed.weight", 5, {HID, 3, 4, 16, 16}, 0}, {"dxo_patch_embed.bias", 1, {HID}, 0},
    {"d_patch_embed.weight", 5, {HID, 3, 4, 16, 16}, 0},   {"d_patch_embed.bias", 1, {HID}, 0},
    {"gate_dxo_from_d.0.weight", 2, {BOT, HID}, 0},        {"gate_dxo_from_d.0.bias", 1, {BOT}, 0},
    {"gate_dxo_from_d.2.weight", 2, {HID, BOT}, 0},        {"gate_dxo_from_d.2.bias", 1, {HID}, 0},
    {"gate_d_from_dxo.0.weight", 2, {BOT, HID}, 0},        {"gate_d_from_dxo.0.bias", 1, {BOT}, 0},
    {"gate_d_from_dxo.2.weight", 2, {HID, BOT}, 0},        {"gate_d_from_dxo.2.bias", 1, {HID}, 0},
    {"out_proj.0.weight", 2, {D, 2 * HID}, 0},             {"out_proj.0.bias", 1, {D}, 0},
    {"out_proj.2.weight", 2, {D, D}, 0},                   {"out_proj.2.bias", 1, {D}, 0},
    {"out_norm.weight", 1, {D}, 0},                        {"out_norm.bias", 1, {D}, 0},
    {"scale", 1, {1}, 0},
};
enum { N_WEIGHTS = (int)(sizeof WEIGHTS / sizeof *WEIGHTS) };

static int write_weights(const char *path)
{
    gv_st_builder b;
    gv_st_builder_init(&b);
    int rc = 0;
    for (int i = 0; rc == 0 && i < N_WEIGHTS; i++) {
        int64_t n = 1;
        for (int k = 0; k < WEIGHTS[i].rank; k++) n *= WEIGHTS[i].shape[k];
        WEIGHTS[i].v = malloc((size_t)n * sizeof(float));
        float s = WEIGHTS[i].rank == 5 ? 0.05f : 0.5f;
        for (int64_t k = 0; k < n; k++) WEIGHTS[i].v[k] = uniform(-s, s);
        if (!strcmp(WEIGHTS[i].name, "scale")) WEIGHTS[i].v[0] = 0.7f;
        rc = gv_st_add_f32(&b, WEIGHTS[i].name, GV_ST_F32, WEIGHTS[i].shape, WEIGHTS[i].rank, WEIGHTS[i].v);
    }
    if (rc == 0) rc = gv_st_write(&b, path);
    gv_st_builder_free(&b);
    return rc;
}

static const float *W_(const char *name)
{
    for (int i = 0; i < N_WEIGHTS; i++)
        if (!strcmp(WEIGHTS[i].name, name)) return WEIGHTS[i].v;
    return NULL;
}

/* The map, written from the definition: rel = c2w_0^-1 c2w_f with the rigid inverse
 * [R^T | -R^T t]. out [F, H, W, 6] in double. */
static void reference_plucker(const float *Ks, const float *c2ws, double *out)
{
    const float *P0 = c2ws;
    for (int f = 0; f < F; f++) {
        const float *P = c2ws + 16 * f, *K = Ks + 9 * f;
        double R[9], o[3];
        for (int r = 0; r < 3; r++) {
            for (int c = 0; c < 3; c++) {
                R[r * 3 + c] = 0;
                for (int k = 0; k < 3; k++) R[r * 3 + c] += (double)P0[k * 4 + r] * P[k * 4 + c];
            }
            o[r] = 0;
            for (int k = 0; k < 3; k++) o[r] += (double)P0[k * 4 + r] * (P[k * 4 + 3] - P0[k * 4 + 3]);
        }
        if (f == 0) memset(o, 0, sizeof o), memset(R, 0, sizeof R), R[0] = R[4] = R[8] = 1;
        for (int j = 0; j < H; j++)
            for (int i = 0; i < W; i++) {
                double v[3] = {(i + 0.5 - K[2]) / K[0], (j + 0.5 - K[5]) / K[4], 1}, d[3];
                double n = sqrt(v[0] * v[0] + v[1] * v[1] + 1);
                for (int r = 0; r < 3; r++) d[r] = (R[r * 3] * v[0] + R[r * 3 + 1] * v[1] + R[r * 3 + 2] * v[2]) / n;
                double *px = out + (((size_t)f * H + j) * W + i) * 6;
                px[0] = o[1] * d[2] - o[2] * d[1], px[1] = o[2] * d[0] - o[0] * d[2], px[2] = o[0] * d[1] - o[1] * d[0];
                px[3] = d[0], px[4] = d[1], px[5] = d[2];
            }
    }
}

static double sigm(double x) { return 1 / (1 + exp(-x)); }
static double silu(double x) { return x * sigm(x); }

/* y[out] = W x + b for one token. */
static void lin(const char *name, const double *x, int in, int out, double *y)
{
    char wn[64], bn[64];
    snprintf(wn, sizeof wn, "%s.weight", name), snprintf(bn, sizeof bn, "%s.bias", name);
    for (int o = 0; o < out; o++) {
        y[o] = W_(bn)[o];
        for (int i = 0; i < in; i++) y[o] += (double)W_(wn)[o * in + i] * x[i];
    }
}

/* The encoder, token by token, from the packed field built here. */
static void reference_tokens(const double *plk, double *tokens)
{
    for (int tok = 0; tok < NTOK; tok++) {
        int t = tok / 4, y = tok / 2 % 2, x = tok % 2;
        double fm[HID], fd[HID];
        for (int s = 0; s < 2; s++)
            for (int o = 0; o < HID; o++) {
                const char *name = s ? "d_patch_embed" : "dxo_patch_embed";
                char wn[64], bn[64];
                snprintf(wn, sizeof wn, "%s.weight", name), snprintf(bn, sizeof bn, "%s.bias", name);
                double acc = W_(bn)[o];
                for (int ic = 0; ic < 3; ic++)
                    for (int dt = 0; dt < 4; dt++)
                        for (int dy = 0; dy < 16; dy++)
                            for (int dx = 0; dx < 16; dx++) {
                                int pt = t * 4 + dt, frame = pt < 3 ? 0 : pt - 3;
                                double p = plk[(((size_t)frame * H + y * 16 + dy) * W + x * 16 + dx) * 6 + 3 * s + ic];
                                acc += W_(wn)[(((o * 3 + ic) * 4 + dt) * 16 + dy) * 16 + dx] * p;
                            }
                (s ? fd : fm)[o] = acc;
            }
        double h1[BOT], gm[HID], gd[HID], fu[2 * HID], p1[D], y2[D];
        lin("gate_dxo_from_d.0", fd, HID, BOT, h1);
        for (int k = 0; k < BOT; k++) h1[k] = silu(h1[k]);
        lin("gate_dxo_from_d.2", h1, BOT, HID, gm);
        lin("gate_d_from_dxo.0", fm, HID, BOT, h1);
        for (int k = 0; k < BOT; k++) h1[k] = silu(h1[k]);
        lin("gate_d_from_dxo.2", h1, BOT, HID, gd);
        for (int k = 0; k < HID; k++) fu[k] = fm[k] * sigm(gm[k]), fu[HID + k] = fd[k] * sigm(gd[k]);
        lin("out_proj.0", fu, 2 * HID, D, p1);
        for (int k = 0; k < D; k++) p1[k] = silu(p1[k]);
        lin("out_proj.2", p1, D, D, y2);
        double mean = 0, var = 0;
        for (int k = 0; k < D; k++) mean += y2[k] / D;
        for (int k = 0; k < D; k++) var += (y2[k] - mean) * (y2[k] - mean) / D;
        for (int k = 0; k < D; k++)
            tokens[tok * D + k] = ((y2[k] - mean) / sqrt(var + 1e-5) * W_("out_norm.weight")[k] + W_("out_norm.bias")[k]) * 0.7;
    }
}

static int tiny_config(gv_model_config *c)
{
    return gv_model_config_preset(c, "tiny");
}

static void test_random(const char *dir)
{
    char path[4300];
    snprintf(path, sizeof path, "%s/camera_weights.safetensors", dir);
    REQUIRE(write_weights(path) == 0);
    float Ks[F * 9], c2ws[F * 16];
    random_cameras(Ks, c2ws);
    float *plk = malloc(sizeof(float) * F * H * W * 6), *packed = malloc(sizeof(float) * 6 * TP * H * W);
    double *want = malloc(sizeof(double) * F * H * W * 6), tokens_want[NTOK * D];
    float tokens[NTOK * D];
    REQUIRE(gv_official_plucker(Ks, c2ws, F, H, W, plk) == 0);
    reference_plucker(Ks, c2ws, want);
    double worst = 0;
    for (int k = 0; k < F * H * W * 6; k++) worst = fmax(worst, fabs(plk[k] - want[k]));
    CHECK(worst < 1e-5);
    gv_official_pack(plk, F, H, W, packed);
    gv_model_config c;
    REQUIRE(tiny_config(&c) == 0);
    gv_st_file w;
    REQUIRE(gv_st_open(&w, path) == 0);
    REQUIRE(gv_official_camera_encode(&c, &w, packed, TP, H, W, tokens) == 0);
    reference_tokens(want, tokens_want);
    worst = 0;
    double largest = 0;
    for (int k = 0; k < NTOK * D; k++) worst = fmax(worst, fabs(tokens[k] - tokens_want[k])), largest = fmax(largest, fabs(tokens_want[k]));
    CHECK(worst < 1e-4 && largest > 0.1);
    /* wrong sizes and a config the official class cannot have, named */
    CHECK_FAILS_WITH(gv_official_camera_encode(&c, &w, packed, TP - 1, H, W, tokens), "not a whole number");
    c.camera.gate_hidden = BOT + 1;
    CHECK_FAILS_WITH(gv_official_camera_encode(&c, &w, packed, TP, H, W, tokens), "gate_dxo_from_d.0.weight");
    c.camera.gate_hidden = BOT, c.camera.proj_hidden = D + 1;
    CHECK_FAILS_WITH(gv_official_camera_encode(&c, &w, packed, TP, H, W, tokens), "camera.proj_hidden must be dit.dim");
    gv_st_close(&w);
    free(plk), free(packed), free(want);
}

/* The CLI test's files: the weights and the cameras (Ks, c2ws, size) of test_random. */
static int write_fixtures(const char *dir)
{
    char path[4300];
    snprintf(path, sizeof path, "%s/camera_weights.safetensors", dir);
    float Ks[F * 9], c2ws[F * 16], size[2] = {H, W};
    if (write_weights(path)) return -1;
    random_cameras(Ks, c2ws);
    gv_st_builder b;
    gv_st_builder_init(&b);
    int rc = gv_st_add_f32(&b, "Ks", GV_ST_F32, (int64_t[]){F, 3, 3}, 3, Ks);
    if (rc == 0) rc = gv_st_add_f32(&b, "c2ws", GV_ST_F32, (int64_t[]){F, 4, 4}, 3, c2ws);
    if (rc == 0) rc = gv_st_add_f32(&b, "size", GV_ST_F32, (int64_t[]){2}, 1, size);
    snprintf(path, sizeof path, "%s/camera_inputs.safetensors", dir);
    if (rc == 0) rc = gv_st_write(&b, path);
    gv_st_builder_free(&b);
    return rc;
}

int main(int argc, char **argv)
{
    if (argc == 3 && !strcmp(argv[1], "--write-fixtures")) return write_fixtures(argv[2]) ? 1 : 0;
    test_hand_derived();
    test_random(check_tmp_dir());
    for (int i = 0; i < N_WEIGHTS; i++) free(WEIGHTS[i].v);
    return check_summary();
}
