/* Composite check: a two-block transformer in the shape of the restorer (docs/ARCHITECTURE.md 6.3-6.5):
 * adaptive-LayerNorm modulation (shift, scale, gate from a conditioning vector; the camera
 * stream modulated from its own vector), q/k RMSNorm, 3D RoPE shared by the video tokens and
 * the camera tokens aligned with them, joint attention with the asymmetric mask (video
 * queries see every key, camera queries only camera keys), a GELU FFN and an output head. Its
 * full gradient with respect to inputs and parameters is checked against finite differences,
 * and the camera stream is checked to be independent of the video tokens. */
#include <omp.h>

#include "check.h"
#include "nn_testutil.h"

enum { F = 2, ROWS = 2, COLS = 3, NV = F * ROWS * COLS, NC = NV, N = NV + NC };
enum { D = 16, HEADS = 2, HD = D / HEADS, FFN = 24, DC = 8, OUT = 4 };

typedef struct {
    gv_params ps;
    gv_tensor *xv, *xc, *e, *e_cam;
    gv_graph consts; /* the mask and the RoPE table */
    gv_tensor *mask, *table;
    int camera_output;
} model;

static gv_tensor *P(model *m, const char *fmt, int block)
{
    char name[96];
    snprintf(name, sizeof name, fmt, block);
    gv_param *p = gv_params_find(&m->ps, name);
    if (!p) fprintf(stderr, "missing parameter %s\n", name);
    return p ? &p->t : NULL;
}

/* LN(x) (1 + scale) + shift, the modulation of Wan's blocks (docs/reference/wan-vace-gaussvid.md
 * section 2.5). */
static gv_tensor *modulate(gv_graph *g, gv_tensor *x, gv_tensor *mod, int shift_i, int scale_i)
{
    gv_tensor *shift = gv_slice(g, mod, 1, shift_i * D, D), *scale = gv_slice(g, mod, 1, scale_i * D, D);
    return gv_add(g, gv_mul(g, gv_layer_norm(g, x, NULL, NULL, 1e-6f), gv_affine(g, scale, 1, 1)), shift);
}

static gv_tensor *block(gv_graph *g, model *m, int i, gv_tensor **xv, gv_tensor **xc)
{
    gv_tensor *mod_v = gv_linear(g, gv_silu(g, m->e), P(m, "blocks.%d.modulation.weight", i),
                                 P(m, "blocks.%d.modulation.bias", i)); /* [1, 6D] */
    gv_tensor *mod_c = gv_linear(g, gv_silu(g, m->e_cam), P(m, "blocks.%d.modulation.weight", i),
                                 P(m, "blocks.%d.modulation.bias", i));
    gv_tensor *h = gv_concat(g, (gv_tensor *[]){modulate(g, *xv, mod_v, 0, 1), modulate(g, *xc, mod_c, 0, 1)}, 2, 0);
    gv_tensor *q = gv_rms_norm(g, gv_linear(g, h, P(m, "blocks.%d.q.weight", i), P(m, "blocks.%d.q.bias", i)),
                               P(m, "blocks.%d.norm_q.weight", i), 1e-6f);
    gv_tensor *k = gv_rms_norm(g, gv_linear(g, h, P(m, "blocks.%d.k.weight", i), P(m, "blocks.%d.k.bias", i)),
                               P(m, "blocks.%d.norm_k.weight", i), 1e-6f);
    gv_tensor *v = gv_linear(g, h, P(m, "blocks.%d.v.weight", i), P(m, "blocks.%d.v.bias", i));
    q = gv_rope(g, q, m->table, HEADS);
    k = gv_rope(g, k, m->table, HEADS);
    gv_tensor *a = gv_attention(g, q, k, v, m->mask, HEADS, 1.0f / sqrtf((float)HD));
    gv_tensor *o = gv_linear(g, a, P(m, "blocks.%d.o.weight", i), P(m, "blocks.%d.o.bias", i));
    *xv = gv_add(g, *xv, gv_mul(g, gv_slice(g, o, 0, 0, NV), gv_slice(g, mod_v, 1, 2 * D, D)));
    *xc = gv_add(g, *xc, gv_mul(g, gv_slice(g, o, 0, NV, NC), gv_slice(g, mod_c, 1, 2 * D, D)));
    gv_tensor *mods[2] = {mod_v, mod_c}, **xs[2] = {xv, xc};
    for (int s = 0; s < 2; s++) {
        gv_tensor *f = gv_linear(g, modulate(g, *xs[s], mods[s], 3, 4), P(m, "blocks.%d.ffn.0.weight", i),
                                 P(m, "blocks.%d.ffn.0.bias", i));
        f = gv_linear(g, gv_gelu(g, f), P(m, "blocks.%d.ffn.2.weight", i), P(m, "blocks.%d.ffn.2.bias", i));
        *xs[s] = gv_add(g, *xs[s], gv_mul(g, f, gv_slice(g, mods[s], 1, 5 * D, D)));
    }
    return *xv;
}

static gv_tensor *build(gv_graph *g, void *p)
{
    model *m = p;
    gv_tensor *xv = m->xv, *xc = m->xc;
    for (int i = 0; i < 2; i++) block(g, m, i, &xv, &xc);
    if (m->camera_output) return xc;
    return gv_linear(g, gv_layer_norm(g, xv, NULL, NULL, 1e-6f), P(m, "head.weight", 0), P(m, "head.bias", 0));
}

static void add(model *m, const char *fmt, int block, int ndim, const int *shape, float std)
{
    char name[96];
    snprintf(name, sizeof name, fmt, block);
    nt_normal(&m->ps, name, ndim, shape, gv_seed_for_name(9, name), std);
}

static void model_init(model *m)
{
    memset(m, 0, sizeof *m);
    gv_params_init(&m->ps);
    m->xv = nt_normal(&m->ps, "x_video", 2, (int[]){NV, D}, 1, 1.0f);
    m->xc = nt_normal(&m->ps, "x_camera", 2, (int[]){NC, D}, 2, 1.0f);
    m->e = nt_normal(&m->ps, "e_t", 2, (int[]){1, DC}, 3, 1.0f);
    m->e_cam = nt_normal(&m->ps, "e_0", 2, (int[]){1, DC}, 4, 1.0f);
    for (int i = 0; i < 2; i++) {
        add(m, "blocks.%d.modulation.weight", i, 2, (int[]){6 * D, DC}, 0.3f);
        add(m, "blocks.%d.modulation.bias", i, 1, (int[]){6 * D}, 0.3f);
        const char *proj[4] = {"q", "k", "v", "o"};
        for (int j = 0; j < 4; j++) {
            char w[64], b[64];
            snprintf(w, sizeof w, "blocks.%%d.%s.weight", proj[j]);
            snprintf(b, sizeof b, "blocks.%%d.%s.bias", proj[j]);
            add(m, w, i, 2, (int[]){D, D}, 0.3f);
            add(m, b, i, 1, (int[]){D}, 0.1f);
        }
        add(m, "blocks.%d.norm_q.weight", i, 1, (int[]){D}, 0.3f);
        add(m, "blocks.%d.norm_k.weight", i, 1, (int[]){D}, 0.3f);
        add(m, "blocks.%d.ffn.0.weight", i, 2, (int[]){FFN, D}, 0.3f);
        add(m, "blocks.%d.ffn.0.bias", i, 1, (int[]){FFN}, 0.1f);
        add(m, "blocks.%d.ffn.2.weight", i, 2, (int[]){D, FFN}, 0.3f);
        add(m, "blocks.%d.ffn.2.bias", i, 1, (int[]){D}, 0.1f);
    }
    for (int i = 0; i < D; i++) { /* RMSNorm weights around 1 */
        P(m, "blocks.%d.norm_q.weight", 0)->data[i] += 1, P(m, "blocks.%d.norm_k.weight", 0)->data[i] += 1;
        P(m, "blocks.%d.norm_q.weight", 1)->data[i] += 1, P(m, "blocks.%d.norm_k.weight", 1)->data[i] += 1;
    }
    add(m, "head.weight", 0, 2, (int[]){OUT, D}, 0.3f);
    add(m, "head.bias", 0, 1, (int[]){OUT}, 0.1f);
    gv_graph_init(&m->consts, 0);
    /* camera token i shares the RoPE position of video token i */
    gv_tensor *grid = gv_rope3d_table_grid(&m->consts, F, ROWS, COLS, HD);
    m->table = gv_concat(&m->consts, (gv_tensor *[]){grid, grid}, 2, 0);
    m->mask = gv_tensor_new(&m->consts, 2, (int[]){N, N});
    for (int i = NV; i < N; i++) /* camera queries: video keys removed */
        for (int j = 0; j < NV; j++) m->mask->data[i * N + j] = -INFINITY;
}

static void test_gradient(void)
{
    model m;
    model_init(&m);
    gv_gradcheck_opts o = gv_gradcheck_defaults();
    o.max_per_tensor = 12;
    o.h = 5e-3;
    nt_gradcheck("two-block transformer (head)", &m.ps, build, &m, &o);
    m.camera_output = 1;
    nt_gradcheck("two-block transformer (camera)", &m.ps, build, &m, &o);
    gv_graph_free(&m.consts);
    gv_params_free(&m.ps);
}

/* The camera stream never sees the video tokens: its output and the gradient of anything
 * it feeds with respect to x_video are exactly zero. */
static void test_camera_independence(void)
{
    model m;
    model_init(&m);
    m.camera_output = 1;
    gv_graph g;
    gv_graph_init(&g, 0);
    gv_tensor *before = build(&g, &m);
    float *saved = malloc((size_t)before->numel * sizeof *saved);
    memcpy(saved, before->data, (size_t)before->numel * sizeof *saved);
    gv_params_zero_grad(&m.ps);
    CHECK(gv_backward(&g, gv_sum_all(&g, gv_mul(&g, before, before))) == 0);
    double video_grad = 0, camera_grad = 0;
    for (int i = 0; i < NV * D; i++) video_grad += fabs(m.xv->grad[i]), camera_grad += fabs(m.xc->grad[i]);
    CHECK(video_grad == 0.0 && camera_grad > 0.0);
    gv_graph_reset(&g);
    for (int i = 0; i < NV * D; i++) m.xv->data[i] += 0.5f * (float)((i % 7) - 3);
    gv_tensor *after = build(&g, &m);
    CHECK(!memcmp(saved, after->data, (size_t)after->numel * sizeof *saved));
    /* while the video output does depend on the camera tokens */
    m.camera_output = 0;
    gv_graph_reset(&g);
    gv_tensor *y0 = build(&g, &m);
    float first = y0->data[0];
    m.xc->data[0] += 1.0f;
    gv_graph_reset(&g);
    CHECK(build(&g, &m)->data[0] != first);
    free(saved);
    gv_graph_free(&g);
    gv_graph_free(&m.consts);
    gv_params_free(&m.ps);
}

int main(void)
{
    omp_set_num_threads(2);
    test_gradient();
    test_camera_independence();
    return check_summary();
}
