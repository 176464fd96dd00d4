/* Helpers shared by the tests of the DiT (include after check.h): a tiny model of any variant,
 * "pretrained" random base weights, and random inputs of a clip (latent, timestep, text,
 * VACE context, the Plücker field of a real camera path). */
#ifndef GAUSSVID_TESTS_MODEL_TESTUTIL_H
#define GAUSSVID_TESTS_MODEL_TESTUTIL_H

#include "gaussvid/core/core.h"
#include "gaussvid/model/dit.h"
#include "gaussvid/model/plucker.h"

/* The tiny preset with variant overrides (NULL: the preset's), initialised. */
static inline int mt_model(gv_dit *m, const char *variant, uint64_t seed)
{
    gv_model_config c;
    if (gv_model_config_preset(&c, "tiny") != 0) return -1;
    if (variant && gv_model_config_set_variant(&c, variant, "test") != 0) return -1;
    return gv_dit_init(m, &c, seed);
}

/* Fills every tensor of the modules in `mask` (1 << gv_module) with random values of a trained
 * network's scale: weights U(+-sqrt(3 / fan_in)), vectors N(0, 0.1^2) (norm gains 1 + that).
 * Zero-initialised projections become non-zero: a stand-in for pretrained weights. */
static inline void mt_randomize(gv_dit *m, unsigned mask, uint64_t seed)
{
    for (int i = 0; i < m->params.n; i++) {
        gv_tensor *t = &m->params.items[i]->t;
        const gv_weight_spec *s = gv_weight_list_find(&m->weights, t->name);
        if (!s || !(mask & (1u << s->module))) continue;
        uint64_t k = gv_seed_for_name(seed, t->name);
        if (t->ndim >= 2 && !strstr(t->name, "modulation")) {
            float b = sqrtf(3.0f / (float)(t->numel / t->shape[0]));
            gv_fill_uniform(t->data, t->numel, k, 0, -b, b);
        } else {
            gv_fill_normal(t->data, t->numel, k, 0, s->init == GV_INIT_ONES ? 1.0f : 0.0f, 0.1f);
        }
        if (!strcmp(t->name, "camera_encoder.gamma")) t->data[0] = 0.7f;
    }
}

#define MT_BASE ((1u << GV_MODULE_PATCH_EMBEDDING) | (1u << GV_MODULE_TIME_EMBEDDING) | (1u << GV_MODULE_TEXT_EMBEDDING) | \
                 (1u << GV_MODULE_BLOCKS) | (1u << GV_MODULE_HEAD) | (1u << GV_MODULE_VACE))
#define MT_ALL (MT_BASE | (1u << GV_MODULE_CAMERA) | (1u << GV_MODULE_LORA))

/* A camera path: cameras looking roughly along +z, moving sideways and turning a little. */
static inline void mt_cameras(gv_camera *cams, int n, int height, int width, double shift)
{
    for (int f = 0; f < n; f++) {
        double a = 0.05 * f + shift, ca = cos(a), sa = sin(a);
        gv_camera *c = &cams[f];
        memset(c, 0, sizeof *c);
        c->width = width, c->height = height;
        c->fx = c->fy = 0.9 * width;
        c->cx = 0.5 * width + 0.3, c->cy = 0.5 * height - 0.2;
        double R[9] = {ca, 0, -sa, 0, 1, 0, sa, 0, ca};
        memcpy(c->R, R, sizeof R);
        c->t[0] = -0.3 * f - shift, c->t[1] = 0.05 * f, c->t[2] = 2.0 + 0.1 * f;
    }
}

typedef struct {
    int B, frames, height, width; /* clip size in pixels */
    int T, H, W;                  /* latent grid */
    gv_tensor *latent, *text, *vace, *plucker;
    float t[8];
} mt_inputs;

/* Random inputs for a clip of `frames` frames of height x width pixels, batch B, as leaves of
 * graph g (or parameters "input.*" of ps when ps is given, for gradient checks). */
static inline int mt_make_inputs(const gv_dit *m, gv_graph *g, gv_params *ps, int B, int frames, int height, int width,
                                 uint64_t seed, mt_inputs *in)
{
    const gv_model_config *c = &m->cfg;
    memset(in, 0, sizeof *in);
    in->B = B, in->frames = frames, in->height = height, in->width = width;
    int tf = c->vae.temporal_factor, sf = c->vae.spatial_factor;
    in->T = 1 + (frames - 1) / tf, in->H = height / sf, in->W = width / sf;
    int packed = gv_plucker_packed_frames(frames, tf);
    if (packed < 0) return -1;
    int ls[5] = {B, c->dit.in_dim, in->T, in->H, in->W};
    int vs[5] = {B, c->dit.vace_in_dim, in->T, in->H, in->W};
    int ts[3] = {B, c->dit.text_len, c->dit.text_dim};
    int ps5[5] = {B, 6, packed, height, width};
    gv_tensor *made[4] = {NULL, NULL, NULL, NULL};
    const char *names[4] = {"input.latent", "input.text", "input.vace", "input.plucker"};
    const int *shapes[4] = {ls, ts, vs, ps5};
    int ndims[4] = {5, 3, 5, 5};
    int want[4] = {1, c->dit.cross_attn, c->dit.n_vace_layers > 0, c->variant.camera != GV_CAMERA_NONE};
    for (int i = 0; i < 4; i++) {
        if (!want[i]) continue;
        made[i] = ps ? gv_params_add(ps, names[i], ndims[i], shapes[i], 1) : gv_tensor_new(g, ndims[i], shapes[i]);
        if (!made[i]) return -1;
        if (i < 3) gv_fill_normal(made[i]->data, made[i]->numel, seed + i, 0, 0.0f, 1.0f);
    }
    if (made[3]) {
        gv_camera cams[64];
        int64_t per = (int64_t)6 * packed * height * width;
        for (int b = 0; b < B; b++) {
            mt_cameras(cams, frames, height, width, 0.2 * b + 0.01 * (double)(seed % 7));
            if (gv_plucker_field(cams, frames, height, width, tf, made[3]->data + b * per, NULL) != 0) return -1;
        }
    }
    in->latent = made[0], in->text = made[1], in->vace = made[2], in->plucker = made[3];
    for (int b = 0; b < B; b++) in->t[b] = 100.0f + 237.0f * b + (float)(seed % 5);
    return 0;
}

/* gv_dit_inputs of mt_inputs. */
static inline gv_dit_inputs mt_dit_inputs(const mt_inputs *in)
{
    gv_dit_inputs d = gv_dit_inputs_default();
    d.latent = in->latent, d.timestep = in->t, d.text = in->text, d.vace = in->vace, d.plucker = in->plucker;
    return d;
}

/* One evaluation of m on the fixed 5-frame 32x32 clip of seed 11, at timestep t (t < 0: the
 * clip's own) with or without the release's BF16 time embedding; copies the output into out
 * and returns its element count, or -1 (failure, or more than cap elements). */
static inline int64_t mt_forward_clip(gv_dit *m, float t, int bf16_time, float *out, int64_t cap)
{
    gv_graph g;
    gv_graph_init(&g, 0);
    gv_graph_set_grad(&g, 0);
    mt_inputs in;
    int64_t n = -1;
    if (mt_make_inputs(m, &g, NULL, 1, 5, 32, 32, 11, &in) == 0) {
        if (t >= 0) in.t[0] = t;
        gv_dit_inputs d = mt_dit_inputs(&in);
        d.bf16_time = bf16_time;
        gv_tensor *y = gv_dit_forward(m, &g, &d);
        if (y && y->numel <= cap) memcpy(out, y->data, (size_t)(n = y->numel) * sizeof *out);
    }
    gv_graph_free(&g);
    return n;
}

/* Largest |a - b| over n floats. */
static inline double mt_max_abs_diff(const float *a, const float *b, int64_t n)
{
    double worst = 0;
    for (int64_t i = 0; i < n; i++) {
        double d = fabs((double)a[i] - b[i]);
        if (!(d <= worst)) worst = d;
    }
    return worst;
}

static inline double mt_max_abs(const float *a, int64_t n)
{
    double worst = 0;
    for (int64_t i = 0; i < n; i++)
        if (!(fabs(a[i]) <= worst)) worst = fabs(a[i]);
    return worst;
}

#endif
