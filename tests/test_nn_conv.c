/* Convolutions against a direct 7-loop convolution in double and finite differences
 * (strides, asymmetric and causal padding, 1x1x1, Conv2D, several column chunks), pixel
 * (un)shuffle, nearest upsampling and the timestep embedding. */
#include <omp.h>

#include "check.h"
#include "nn_testutil.h"

typedef struct {
    gv_tensor *x, *w, *b;
    gv_conv_geom geom;
    int dims, mode, r[3];
} conv_ctx;

static gv_tensor *build_conv(gv_graph *g, void *p)
{
    conv_ctx *c = p;
    return c->dims == 5 ? gv_conv3d(g, c->x, c->w, c->b, &c->geom) : gv_conv2d(g, c->x, c->w, c->b, &c->geom);
}

/* The definition: out[b, co, t, y, x] = bias + sum_{ci, dt, dy, dx} w * x_padded. */
static double *naive_conv(const conv_ctx *c, int shape[5])
{
    const gv_tensor *x = c->x, *w = c->w;
    int xd[5], wd[5];
    for (int i = 0, j = 0; i < 5; i++) { /* 4-D: insert T = 1 / kt = 1 */
        xd[i] = (x->ndim == 4 && i == 2) ? 1 : x->shape[j];
        wd[i] = (w->ndim == 4 && i == 2) ? 1 : w->shape[j];
        if (!(x->ndim == 4 && i == 2)) j++;
    }
    const int *s = c->geom.stride, *p = c->geom.pad;
    int To = (xd[2] + p[0] + p[1] - wd[2]) / s[0] + 1, Ho = (xd[3] + p[2] + p[3] - wd[3]) / s[1] + 1;
    int Wo = (xd[4] + p[4] + p[5] - wd[4]) / s[2] + 1;
    shape[0] = xd[0], shape[1] = wd[0], shape[2] = To, shape[3] = Ho, shape[4] = Wo;
    double *out = calloc((size_t)xd[0] * wd[0] * To * Ho * Wo, sizeof *out);
    for (int b = 0; b < xd[0]; b++)
        for (int co = 0; co < wd[0]; co++)
            for (int t = 0; t < To; t++)
                for (int y = 0; y < Ho; y++)
                    for (int xo = 0; xo < Wo; xo++) {
                        double acc = c->b ? c->b->data[co] : 0;
                        for (int ci = 0; ci < xd[1]; ci++)
                            for (int dt = 0; dt < wd[2]; dt++)
                                for (int dy = 0; dy < wd[3]; dy++)
                                    for (int dx = 0; dx < wd[4]; dx++) {
                                        int ti = t * s[0] - p[0] + dt, yi = y * s[1] - p[2] + dy, xi = xo * s[2] - p[4] + dx;
                                        if (ti < 0 || ti >= xd[2] || yi < 0 || yi >= xd[3] || xi < 0 || xi >= xd[4]) continue;
                                        acc += (double)w->data[(((co * wd[1] + ci) * wd[2] + dt) * wd[3] + dy) * wd[4] + dx] *
                                               x->data[(((int64_t)(b * xd[1] + ci) * xd[2] + ti) * xd[3] + yi) * xd[4] + xi];
                                    }
                        out[(((int64_t)(b * wd[0] + co) * To + t) * Ho + y) * Wo + xo] = acc;
                    }
    return out;
}

static void conv_case(const char *label, int dims, const int *xs, const int *ws, int bias,
                      gv_conv_geom geom, int gradcheck)
{
    gv_params ps;
    gv_params_init(&ps);
    conv_ctx c = {.geom = geom, .dims = dims};
    c.x = nt_uniform(&ps, "x", dims, xs, 201, -1, 1);
    c.w = nt_uniform(&ps, "w", dims, ws, 202, -0.5f, 0.5f);
    if (bias) c.b = nt_uniform(&ps, "bias", 1, (int[]){ws[0]}, 203, -1, 1);
    gv_graph g;
    gv_graph_init(&g, 0);
    gv_tensor *y = build_conv(&g, &c);
    int shape[5];
    double *ref = naive_conv(&c, shape);
    int shape_ok = y && y->shape[0] == shape[0] && y->shape[1] == shape[1] &&
                   gv_dim(y, -1) == shape[4] && gv_dim(y, -2) == shape[3] && (dims == 4 || y->shape[2] == shape[2]);
    double err = shape_ok ? nt_max_diff(y->data, ref, y->numel) : 1;
    printf("conv %-36s -> [%d, %d, %d, %d, %d] forward max |err| %.2e\n", label, shape[0], shape[1],
           shape[2], shape[3], shape[4], err);
    CHECK(shape_ok && err < 1e-5);
    free(ref);
    /* Adjoint identities (conv is bilinear): <dy, y(x, w)> = <dx, x> = <dw, w> without bias. */
    if (!bias && y) {
        int64_t n = y->numel;
        float *dy = malloc((size_t)n * sizeof *dy);
        gv_fill_normal(dy, n, 204, 0, 0, 1);
        double lhs = 0, dxx = 0, dww = 0;
        for (int64_t i = 0; i < n; i++) lhs += (double)dy[i] * y->data[i];
        gv_params_zero_grad(&ps);
        CHECK(gv_backward_seed(&g, y, dy) == 0);
        for (int64_t i = 0; i < c.x->numel; i++) dxx += (double)c.x->grad[i] * c.x->data[i];
        for (int64_t i = 0; i < c.w->numel; i++) dww += (double)c.w->grad[i] * c.w->data[i];
        CHECK(fabs(lhs - dxx) < 1e-4 * (1 + fabs(lhs)) && fabs(lhs - dww) < 1e-4 * (1 + fabs(lhs)));
        free(dy);
    }
    gv_graph_free(&g);
    if (gradcheck) nt_gradcheck(label, &ps, build_conv, &c, NULL);
    gv_params_free(&ps);
}

static void test_conv(void)
{
    /* Wan CausalConv3d(3, padding 1): 2 frames of zeros in front, none behind. */
    conv_case("3x3x3 causal", 5, (int[]){2, 3, 5, 6, 7}, (int[]){4, 3, 3, 3, 3}, 1,
              gv_conv_geom_causal(1, 1, 1, 1, 1), 1);
    conv_case("3x3x3 causal (no bias)", 5, (int[]){1, 2, 4, 5, 3}, (int[]){3, 2, 3, 3, 3}, 0,
              gv_conv_geom_causal(1, 1, 1, 1, 1), 1);
    /* strides 2 with asymmetric padding and an uneven kernel */
    gv_conv_geom odd = {{2, 2, 2}, {1, 0, 0, 1, 1, 0}};
    conv_case("2x3x2 stride 2 asymmetric pad", 5, (int[]){2, 3, 5, 7, 6}, (int[]){5, 3, 2, 3, 2}, 1, odd, 1);
    /* 1x1x1 (no column buffer) */
    conv_case("1x1x1 pointwise", 5, (int[]){2, 5, 3, 4, 3}, (int[]){3, 5, 1, 1, 1}, 1,
              gv_conv_geom_same(1, 0, 0, 0), 1);
    conv_case("1x1x1 pointwise (no bias)", 5, (int[]){2, 5, 3, 4, 3}, (int[]){3, 5, 1, 1, 1}, 0,
              gv_conv_geom_same(1, 0, 0, 0), 0);
    /* VAE downsample3d time_conv: (3,1,1), stride (2,1,1), no padding */
    gv_conv_geom time = {{2, 1, 1}, {0, 0, 0, 0, 0, 0}};
    conv_case("3x1x1 temporal stride 2", 5, (int[]){1, 4, 7, 3, 2}, (int[]){4, 4, 3, 1, 1}, 1, time, 1);
    /* VAE downsample2d: zero pad right 1 / bottom 1, 3x3 stride 2 */
    gv_conv_geom down = {{1, 2, 2}, {0, 0, 0, 1, 0, 1}};
    conv_case("conv2d 3x3 stride 2 pad r/b", 4, (int[]){2, 3, 9, 8}, (int[]){4, 3, 3, 3}, 1, down, 1);
    conv_case("conv2d 3x3 same", 4, (int[]){1, 2, 5, 7}, (int[]){3, 2, 3, 3}, 0, gv_conv_geom_same(1, 0, 1, 1), 1);
    /* K*P above the 4M-float column chunk: two chunks, the boundary inside a row */
    conv_case("3x3x3 two column chunks", 5, (int[]){1, 8, 3, 20, 340}, (int[]){2, 8, 3, 3, 3}, 0,
              gv_conv_geom_same(1, 1, 1, 1), 0);

    gv_graph g;
    gv_graph_init(&g, 0);
    gv_tensor *x = gv_tensor_new(&g, 5, (int[]){1, 3, 2, 4, 4}), *w = gv_tensor_new(&g, 5, (int[]){2, 4, 3, 3, 3});
    gv_conv_geom same = gv_conv_geom_same(1, 1, 1, 1);
    CHECK_FAILS_WITH(gv_conv3d(&g, x, w, NULL, &same) ? 0 : -1, "do not match");
    gv_tensor *w3 = gv_tensor_new(&g, 5, (int[]){2, 3, 5, 1, 1});
    gv_conv_geom none = gv_conv_geom_same(1, 0, 0, 0);
    CHECK_FAILS_WITH(gv_conv3d(&g, x, w3, NULL, &none) ? 0 : -1, "smaller than the kernel");
    CHECK_FAILS_WITH(gv_conv2d(&g, x, w3, NULL, &none) ? 0 : -1, "do not match");
    gv_graph_free(&g);
}

/* ---- resampling ----------------------------------------------------------------------- */
static gv_tensor *build_resample(gv_graph *g, void *p)
{
    conv_ctx *c = p;
    switch (c->mode) {
    case 0: return gv_pixel_unshuffle(g, c->x, c->r[0], c->r[1], c->r[2]);
    case 1: return gv_pixel_shuffle(g, c->x, c->r[0], c->r[1], c->r[2]);
    default: return gv_upsample_nearest(g, c->x, c->r[0], c->r[1], c->r[2]);
    }
}

static void test_resample(void)
{
    gv_graph g;
    gv_graph_init(&g, 0);
    /* 2x2 unshuffle of one 2x2 image: channel dy*2 + dx */
    gv_tensor *img = gv_tensor_from(&g, 4, (int[]){1, 1, 2, 2}, (float[]){0, 1, 2, 3});
    gv_tensor *u = gv_pixel_unshuffle(&g, img, 1, 2, 2);
    CHECK(u && u->shape[1] == 4 && u->shape[2] == 1 && u->data[0] == 0 && u->data[1] == 1 &&
          u->data[2] == 2 && u->data[3] == 3);
    /* Plücker packing: 6 channels x 4 frames -> 24 channels, channel c*4 + k = frame k of c */
    gv_tensor *rays = gv_tensor_new(&g, 5, (int[]){1, 6, 4, 1, 1});
    for (int i = 0; i < 24; i++) rays->data[i] = (float)i; /* value c*4 + k */
    gv_tensor *packed = gv_pixel_unshuffle(&g, rays, 4, 1, 1);
    int ok = packed && packed->shape[1] == 24 && packed->shape[2] == 1;
    for (int ch = 0; ok && ch < 24; ch++) ok = packed->data[ch] == (float)ch;
    CHECK(ok);
    /* round trip on an awkward shape */
    gv_tensor *v = gv_tensor_new(&g, 5, (int[]){2, 3, 4, 6, 10});
    gv_fill_uniform(v->data, v->numel, 5, 0, -1, 1);
    gv_tensor *back = gv_pixel_shuffle(&g, gv_pixel_unshuffle(&g, v, 2, 3, 5), 2, 3, 5);
    CHECK(back && gv_same_shape(back, v) && !memcmp(back->data, v->data, (size_t)v->numel * sizeof(float)));
    /* nearest upsampling by hand */
    gv_tensor *up = gv_upsample_nearest(&g, img, 1, 2, 3);
    float expect[24] = {0, 0, 0, 1, 1, 1, 0, 0, 0, 1, 1, 1, 2, 2, 2, 3, 3, 3, 2, 2, 2, 3, 3, 3};
    ok = up && up->shape[2] == 4 && up->shape[3] == 6;
    for (int i = 0; ok && i < 24; i++) ok = up->data[i] == expect[i];
    CHECK(ok);
    CHECK_FAILS_WITH(gv_pixel_unshuffle(&g, v, 3, 1, 1) ? 0 : -1, "does not divide");
    CHECK_FAILS_WITH(gv_upsample_nearest(&g, img, 2, 1, 1) ? 0 : -1, "temporal factor of 1");
    gv_graph_free(&g);

    static const char *names[] = {"pixel_unshuffle (2,3,1)", "pixel_shuffle (1,2,2)", "upsample (2,1,3)"};
    int shapes[3][5] = {{2, 3, 4, 6, 5}, {1, 8, 3, 2, 3}, {2, 2, 2, 3, 2}};
    int factors[3][3] = {{2, 3, 1}, {1, 2, 2}, {2, 1, 3}};
    for (int mode = 0; mode < 3; mode++) {
        gv_params ps;
        gv_params_init(&ps);
        conv_ctx c = {.mode = mode};
        memcpy(c.r, factors[mode], sizeof c.r);
        c.x = nt_uniform(&ps, "x", 5, shapes[mode], 211, -1, 1);
        nt_gradcheck(names[mode], &ps, build_resample, &c, NULL);
        gv_params_free(&ps);
    }
}

static void test_timestep_embedding(void)
{
    gv_graph g;
    gv_graph_init(&g, 0);
    float t[2] = {0.0f, 555.5f};
    gv_tensor *e = gv_timestep_embedding(&g, t, 2, 256);
    CHECK(e && e->shape[0] == 2 && e->shape[1] == 256);
    double worst = 0;
    for (int i = 0; i < 128; i++) { /* cos first, then sin; w_i = 10000^(-i/128) */
        double w = pow(10000.0, -i / 128.0);
        worst = fmax(worst, fabs(e->data[i] - 1.0));
        worst = fmax(worst, fabs(e->data[128 + i] - 0.0));
        worst = fmax(worst, fabs(e->data[256 + i] - cos(555.5 * w)));
        worst = fmax(worst, fabs(e->data[256 + 128 + i] - sin(555.5 * w)));
    }
    CHECK(worst < 1e-7);
    CHECK_NEAR(e->data[256], cos(555.5), 1e-7); /* i = 0: frequency 1 */
    CHECK_FAILS_WITH(gv_timestep_embedding(&g, t, 2, 7) ? 0 : -1, "even dimension");
    gv_graph_free(&g);
}

int main(void)
{
    omp_set_num_threads(2);
    test_conv();
    test_resample();
    test_timestep_embedding();
    return check_summary();
}
