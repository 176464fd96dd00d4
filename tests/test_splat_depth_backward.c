/* The accumulated depth sum_i w_i z_i and its backward (src/splat/rasterize_depth.c,
 * rasterize_depth_backward.c): the forward against the double reference rasteriser blending
 * (z, 0, 0) as a colour; every gradient the backward produces (means2d, conics, opacities,
 * view depths) against central finite differences of that reference, on scenes with and
 * without early-stopped pixels; the same numbers as the colour backward run with colour
 * (z, 0, 0), background 0 and dL/dimage (g, 0, 0); thread independence; and the chain to the
 * raw 3D parameters (gv_splat_render_backward_depth, with a loss on the image as well)
 * against finite differences of the reference renderer. */
#include <omp.h>

#include "gaussvid/splat/render.h"
#include "splat_fixtures.h"

enum { MAXN = 160, W = 40, H = 24, NPIX = W * H };

/* A 2D scene: projected Gaussians as the rasteriser takes them. */
typedef struct {
    int n;
    float m2[2 * MAXN], conic[3 * MAXN], color[3 * MAXN], opacity[MAXN], depth[MAXN];
    int radii[MAXN];
} scene2d;

static void add_gaussian(scene2d *s, double mx, double my, double a, double b, double c,
                         double o, double z)
{
    int i = s->n++;
    double det = a * c - b * b, mid = 0.5 * (a + c);
    s->m2[2 * i] = (float)mx, s->m2[2 * i + 1] = (float)my;
    s->conic[3 * i] = (float)(c / det), s->conic[3 * i + 1] = (float)(-b / det);
    s->conic[3 * i + 2] = (float)(a / det);
    s->opacity[i] = (float)o, s->depth[i] = (float)z;
    s->color[3 * i] = (float)z, s->color[3 * i + 1] = s->color[3 * i + 2] = 0;
    s->radii[i] = (int)ceil(3 * sqrt(mid + sqrt(fmax(0.1, mid * mid - det))));
}

/* n Gaussians of 0.5-7 px in any orientation, spread a little beyond the image, opacities
 * o_lo-0.9 (below the 0.99 clamp, which the gradient ignores), depths 1-6. */
static void random_scene(scene2d *s, int n, double o_lo, uint64_t seed)
{
    gv_rng r;
    gv_rng_init(&r, seed);
    s->n = 0;
    for (int i = 0; i < n; i++) {
        double s1 = 0.5 + 6.5 * gv_rng_uniform(&r), s2 = 0.5 + 4 * gv_rng_uniform(&r);
        double th = 3.14159 * gv_rng_uniform(&r), cs = cos(th), sn = sin(th);
        double a = cs * cs * s1 * s1 + sn * sn * s2 * s2 + 0.3, b = cs * sn * (s1 * s1 - s2 * s2);
        double c = sn * sn * s1 * s1 + cs * cs * s2 * s2 + 0.3;
        double mx = -5 + (W + 10) * gv_rng_uniform(&r), my = -5 + (H + 10) * gv_rng_uniform(&r);
        double o = o_lo + (0.9 - o_lo) * gv_rng_uniform(&r), z = 1 + 5 * gv_rng_uniform(&r);
        add_gaussian(s, mx, my, a, b, c, o, z);
    }
}

typedef struct {
    gv_splat_tiles tiles;
    float image[NPIX * 3], final_T[NPIX], depth_sum[NPIX];
    int n_contrib[NPIX];
    float d_m2[2 * MAXN], d_conic[3 * MAXN], d_opacity[MAXN], d_depth[MAXN];
} depth_out;

static const float BLACK[3] = {0, 0, 0};

static void forward(const scene2d *s, depth_out *o)
{
    CHECK(gv_splat_tiles_build(&o->tiles, s->n, W, H, s->m2, s->radii, s->depth) == 0);
    gv_splat_rasterize_forward(&o->tiles, W, H, s->m2, s->conic, s->color, s->opacity, BLACK,
                               o->image, o->final_T, o->n_contrib);
    gv_splat_rasterize_depth(&o->tiles, W, H, s->m2, s->conic, s->opacity, s->depth, NULL, NULL,
                             o->depth_sum);
}

static void backward(const scene2d *s, depth_out *o, const float *g)
{
    gv_splat_rasterize_depth_backward(&o->tiles, W, H, s->m2, s->conic, s->opacity, s->depth,
                                      o->final_T, o->n_contrib, g, o->d_m2, o->d_conic,
                                      o->d_opacity, o->d_depth);
}

/* The reference's sum w z: colour (z, 0, 0) over black, channel 0. The sort uses `order`,
 * the depths as they were, so a change of z alone changes what is blended, not the order. */
typedef struct {
    const scene2d *s;
    const double *g;
    double m2[2 * MAXN], conic[3 * MAXN], opacity[MAXN], z[MAXN], order[MAXN];
} depth_fd;

static double depth_loss(void *ctx, uint64_t *signature)
{
    depth_fd *c = ctx;
    static double img[NPIX * 3], col[3 * MAXN];
    for (int i = 0; i < c->s->n; i++) col[3 * i] = c->z[i], col[3 * i + 1] = col[3 * i + 2] = 0;
    double zero[3] = {0, 0, 0};
    gv_splat_reference_rasterize(c->s->n, W, H, c->m2, c->conic, col, c->opacity, c->order,
                                 c->s->radii, zero, img, signature);
    double loss = 0;
    for (int p = 0; p < NPIX; p++) loss += c->g[p] * img[3 * p];
    return loss;
}

static void fd_setup(depth_fd *c, const scene2d *s, const double *g)
{
    c->s = s, c->g = g;
    for (int i = 0; i < 2 * s->n; i++) c->m2[i] = s->m2[i];
    for (int i = 0; i < 3 * s->n; i++) c->conic[i] = s->conic[i];
    for (int i = 0; i < s->n; i++)
        c->opacity[i] = s->opacity[i], c->z[i] = c->order[i] = s->depth[i];
}

static depth_out out, out2;

/* The forward's sum w z against the reference (the same function the finite differences
 * differentiate). */
static void test_forward(void)
{
    static scene2d s;
    random_scene(&s, 150, 0.05, 11);
    forward(&s, &out);
    static double m2[2 * MAXN], con[3 * MAXN], col[3 * MAXN], op[MAXN], z[MAXN], ref[NPIX * 3];
    for (int i = 0; i < 2 * s.n; i++) m2[i] = s.m2[i];
    for (int i = 0; i < 3 * s.n; i++) con[i] = s.conic[i], col[i] = s.color[i];
    for (int i = 0; i < s.n; i++) op[i] = s.opacity[i], z[i] = s.depth[i];
    double zero[3] = {0, 0, 0};
    uint64_t sig;
    CHECK(gv_splat_reference_rasterize(s.n, W, H, m2, con, col, op, z, s.radii, zero, ref, &sig) == 0);
    double worst = 0, largest = 0;
    for (int p = 0; p < NPIX; p++) {
        double want = ref[3 * p];
        worst = fmax(worst, fabs(out.depth_sum[p] - want) / fmax(want, 1));
        largest = fmax(largest, want);
        /* the colour forward of (z, 0, 0) is the same sum */
        CHECK(fabsf(out.depth_sum[p] - out.image[3 * p]) <= 1e-6f * fmaxf(1, out.image[3 * p]));
    }
    printf("  accumulated depth of %d Gaussians: up to %.2f, max relative |sum w z - reference| "
           "%.2e\n", s.n, largest, worst);
    CHECK(worst < 1e-5);
    gv_splat_tiles_free(&out.tiles);
}

static fix_compare cmp_m2 = {"means2d", 0, 0, {0}, {0}};
static fix_compare cmp_conic = {"conics", 0, 0, {0}, {0}};
static fix_compare cmp_opacity = {"opacities", 0, 0, {0}, {0}};
static fix_compare cmp_z = {"view depths z", 0, 0, {0}, {0}};

/* dL/dD random in [-1, 1] per pixel. With `stack`, six Gaussians of opacity 0.88 piled at
 * (20.3, 11.7): T falls below 1e-4 at their centre, so those pixels stop early. */
static void test_gradients(int n, double o_lo, uint64_t seed, int stack)
{
    static scene2d s;
    cmp_m2.count = cmp_conic.count = cmp_opacity.count = cmp_z.count = 0; /* each scene's own */
    cmp_m2.skipped = cmp_conic.skipped = cmp_opacity.skipped = cmp_z.skipped = 0;
    random_scene(&s, n, o_lo, seed);
    for (int k = 0; stack && k < 6; k++)
        add_gaussian(&s, 20.3 + 0.2 * k, 11.7 - 0.1 * k, 9, 1, 8, 0.88, 1.5 + 0.3 * k);
    static double g[NPIX];
    static float gf[NPIX];
    for (int p = 0; p < NPIX; p++) gf[p] = (float)(g[p] = 2 * gv_uniform_at(seed + 1, (uint64_t)p) - 1);
    forward(&s, &out);
    backward(&s, &out, gf);
    int stopped = 0;
    for (int p = 0; p < NPIX; p++) stopped += out.final_T[p] < 1e-3f;
    printf("  depth gradients, %d Gaussians, %d pixels nearly opaque:\n", s.n, stopped);
    if (stack) CHECK(out.final_T[11 * W + 20] < 1e-3f);
    static depth_fd c;
    fd_setup(&c, &s, g);
    uint64_t s0;
    depth_loss(&c, &s0);
    for (int i = 0; i < s.n; i++) {
        if (s.radii[i] == 0) continue;
        fix_add_params(&cmp_m2, depth_loss, &c, s0, c.m2 + 2 * i, out.d_m2 + 2 * i, 2, 1e-6);
        fix_add_params(&cmp_conic, depth_loss, &c, s0, c.conic + 3 * i, out.d_conic + 3 * i, 3, 1e-6);
        fix_add_params(&cmp_opacity, depth_loss, &c, s0, c.opacity + i, out.d_opacity + i, 1, 1e-6);
        fix_add_params(&cmp_z, depth_loss, &c, s0, c.z + i, out.d_depth + i, 1, 1e-6);
    }
    fix_report(&cmp_m2, 2e-3);
    fix_report(&cmp_conic, 2e-3);
    fix_report(&cmp_opacity, 2e-3);
    fix_report(&cmp_z, 2e-3);
    gv_splat_tiles_free(&out.tiles);
}

/* The depth is the colour's blend with one channel: the colour backward of colour (z, 0, 0),
 * background 0 and dL/dimage (g, 0, 0) gives the same gradients (its d colour[0] is d z);
 * 1 and 3 threads give the same bytes. */
static void test_colour_agreement_and_threads(void)
{
    static scene2d s;
    random_scene(&s, 150, 0.05, 21);
    static float g[NPIX], d_image[NPIX * 3], d_color[3 * MAXN];
    for (int p = 0; p < NPIX; p++) {
        g[p] = (float)(2 * gv_uniform_at(22, (uint64_t)p) - 1);
        d_image[3 * p] = g[p], d_image[3 * p + 1] = d_image[3 * p + 2] = 0;
    }
    omp_set_num_threads(1);
    forward(&s, &out);
    backward(&s, &out, g);
    omp_set_num_threads(3);
    forward(&s, &out2);
    backward(&s, &out2, g);
    omp_set_num_threads(2);
    CHECK(memcmp(out.d_m2, out2.d_m2, sizeof(float) * 2 * s.n) == 0);
    CHECK(memcmp(out.d_conic, out2.d_conic, sizeof(float) * 3 * s.n) == 0);
    CHECK(memcmp(out.d_opacity, out2.d_opacity, sizeof(float) * s.n) == 0);
    CHECK(memcmp(out.d_depth, out2.d_depth, sizeof(float) * s.n) == 0);
    gv_splat_rasterize_backward(&out2.tiles, W, H, BLACK, out2.final_T, out2.n_contrib, d_image,
                                out2.d_m2, out2.d_conic, d_color, out2.d_opacity);
    double worst = 0, scale = 0;
    for (int i = 0; i < s.n; i++) {
        if (s.radii[i] == 0) continue;
        float pairs[7][2] = {{out.d_m2[2 * i], out2.d_m2[2 * i]}, {out.d_m2[2 * i + 1], out2.d_m2[2 * i + 1]},
                             {out.d_conic[3 * i], out2.d_conic[3 * i]}, {out.d_conic[3 * i + 1], out2.d_conic[3 * i + 1]},
                             {out.d_conic[3 * i + 2], out2.d_conic[3 * i + 2]},
                             {out.d_opacity[i], out2.d_opacity[i]}, {out.d_depth[i], d_color[3 * i]}};
        for (int k = 0; k < 7; k++) {
            scale = fmax(scale, fabsf(pairs[k][1]));
            worst = fmax(worst, fabsf(pairs[k][0] - pairs[k][1]));
        }
    }
    printf("  against the colour backward of (z, 0, 0): max |difference| %.2e of gradients up "
           "to %.3g\n", worst, scale);
    CHECK(scale > 0);
    CHECK(worst <= 1e-5 * scale);
    gv_splat_tiles_free(&out.tiles);
    gv_splat_tiles_free(&out2.tiles);
}

/* ---- the chain to the 3D parameters -------------------------------------------------- */

enum { N3 = 40 };

typedef struct {
    const gv_splat_view *view;
    const double *a, *g;    /* dL/dimage, dL/dD */
    double means[3 * N3], sh[3 * N3], opacities[N3], scales[3 * N3], rotations[4 * N3];
    double image[NPIX * 3], depth_sum[NPIX];
} chain_fd;

/* L = sum a . image + sum g D, both from the double reference; the signature covers both
 * renders' discrete decisions. */
static double chain_loss(void *ctx, uint64_t *signature)
{
    chain_fd *c = ctx;
    double bg[3] = {0.25, 0.5, 0.75};
    uint64_t s1, s2;
    gv_splat_reference_render(N3, 0, 0, c->means, c->sh, c->opacities, c->scales, c->rotations,
                              c->view, bg, c->image, &s1);
    double loss = 0;
    for (int p = 0; p < NPIX * 3; p++) loss += c->a[p] * c->image[p];
    fix_reference_depth_sum(N3, c->means, c->scales, c->rotations, c->opacities, c->view,
                            c->depth_sum, &s2);
    for (int p = 0; p < NPIX; p++) loss += c->g[p] * c->depth_sum[p];
    *signature = s1 * 0x9E3779B97F4A7C15ull ^ s2;
    return loss;
}

static void test_chain(void)
{
    gv_splat_view v;
    fix_view(&v, W, H, 31);
    gv_gaussians g, grad;
    fix_gaussians(&g, N3, 0, &v, 32);
    CHECK(gv_gaussians_alloc(&grad, N3, 0) == 0);
    static float image[NPIX * 3], a[NPIX * 3], dD[NPIX], D[NPIX];
    static double ad[NPIX * 3], gd[NPIX];
    for (int p = 0; p < NPIX * 3; p++) a[p] = (float)(ad[p] = 0.5 * gv_uniform_at(33, (uint64_t)p) - 0.25);
    for (int p = 0; p < NPIX; p++) dD[p] = (float)(gd[p] = 2 * gv_uniform_at(34, (uint64_t)p) - 1);
    const float bg[3] = {0.25f, 0.5f, 0.75f};
    gv_splat_renderer r = {0};
    CHECK(gv_splat_render_forward(&r, &g, &v, 0, bg, image) == 0);
    CHECK(gv_splat_render_depth_sum(&r, D) == 0);
    CHECK(gv_splat_render_backward_depth(&r, &g, a, dD, &grad, NULL) == 0);
    static chain_fd c;
    c.view = &v, c.a = ad, c.g = gd;
    for (int i = 0; i < 3 * N3; i++)
        c.means[i] = g.means[i], c.scales[i] = g.scales[i], c.sh[i] = g.sh[i];
    for (int i = 0; i < 4 * N3; i++) c.rotations[i] = g.rotations[i];
    for (int i = 0; i < N3; i++) c.opacities[i] = g.opacities[i];
    uint64_t s0;
    chain_loss(&c, &s0);
    double worst_d = 0; /* c.depth_sum now holds the reference's sum w z */
    for (int p = 0; p < NPIX; p++) worst_d = fmax(worst_d, fabs(D[p] - c.depth_sum[p]) / fmax(1, c.depth_sum[p]));
    static fix_compare means = {"means", 0, 0, {0}, {0}}, scales = {"log-scales", 0, 0, {0}, {0}};
    static fix_compare rots = {"quaternions", 0, 0, {0}, {0}}, ops = {"opacity logits", 0, 0, {0}, {0}};
    int visible = 0;
    for (int i = 0; i < N3; i++) {
        gv_splat_ref_projection p;
        if (r.radii[i] == 0 || !gv_splat_reference_project(c.means + 3 * i, c.scales + 3 * i,
                                                           c.rotations + 4 * i, &v, &p) ||
            p.clamp_x || p.clamp_y) /* the clamped Jacobian's gradient is 3DGS's, not exact */
            continue;
        visible++;
        fix_add_params(&means, chain_loss, &c, s0, c.means + 3 * i, grad.means + 3 * i, 3, 1e-6);
        fix_add_params(&scales, chain_loss, &c, s0, c.scales + 3 * i, grad.scales + 3 * i, 3, 1e-6);
        fix_add_params(&rots, chain_loss, &c, s0, c.rotations + 4 * i, grad.rotations + 4 * i, 4, 1e-6);
        fix_add_params(&ops, chain_loss, &c, s0, c.opacities + i, grad.opacities + i, 1, 1e-6);
    }
    printf("  image and accumulated-depth loss through the projection, %d Gaussians checked "
           "(max relative |D - reference| %.2e):\n", visible, worst_d);
    CHECK(visible > N3 / 3);
    CHECK(worst_d < 1e-5);
    fix_report(&means, 2e-3);
    fix_report(&scales, 2e-3);
    fix_report(&rots, 2e-3);
    fix_report(&ops, 2e-3);

    /* Without a depth loss the result is gv_splat_render_backward's, byte for byte. */
    gv_gaussians g1, g2;
    CHECK(gv_gaussians_alloc(&g1, N3, 0) == 0 && gv_gaussians_alloc(&g2, N3, 0) == 0);
    CHECK(gv_splat_render_forward(&r, &g, &v, 0, bg, image) == 0);
    CHECK(gv_splat_render_backward(&r, &g, a, &g1, NULL) == 0);
    CHECK(gv_splat_render_backward_depth(&r, &g, a, NULL, &g2, NULL) == 0);
    CHECK(memcmp(g1.means, g2.means, sizeof(float) * 3 * N3) == 0);
    CHECK(memcmp(g1.opacities, g2.opacities, sizeof(float) * N3) == 0);
    gv_gaussians_free(&g1), gv_gaussians_free(&g2);
    gv_gaussians_free(&g), gv_gaussians_free(&grad);
    gv_splat_renderer_free(&r);
}

static void test_bad_calls(void)
{
    gv_splat_renderer r = {0};
    float d[4];
    CHECK_FAILS_WITH(gv_splat_render_depth_sum(&r, d), "before any forward");
}

int main(void)
{
    test_forward();
    test_gradients(40, 0.2, 41, 0);
    test_gradients(100, 0.5, 43, 1); /* dense, pixels stop early */
    test_colour_agreement_and_threads();
    test_chain();
    test_bad_calls();
    return check_summary();
}
