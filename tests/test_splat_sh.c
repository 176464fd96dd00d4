/* SH colour: basis values by hand, the +0.5 offset and the clamp at 0, the active degree,
 * agreement with the double reference, and gradients with respect to the coefficients and
 * the means (through the view direction) against central finite differences. */
#include "splat_fixtures.h"

static const double C1 = 0.4886025119029199;
static const double C2_2 = 0.31539156525252005, C2_4 = 0.5462742152960396;
static const double C3_3 = 0.3731763325901154, C3_4 = -0.4570457994644658;
static const double C3_6 = -0.5900435899266435;

static void test_basis_by_hand(void)
{
    float Y[16];
    /* d = +z: only the zonal terms survive: Y0 = C0, Y2 = C1 z = C1,
     * Y6 = C2[2] (2z^2 - x^2 - y^2) = 2 C2[2], Y12 = C3[3] z (2z^2 - 3x^2 - 3y^2) = 2 C3[3]. */
    gv_splat_sh_basis(0, 0, 1, Y);
    double want_z[16] = {FIX_C0, 0, C1, 0, 0, 0, 2 * C2_2, 0, 0, 0, 0, 0, 2 * C3_3, 0, 0, 0};
    for (int k = 0; k < 16; k++) CHECK_NEAR(Y[k], want_z[k], 1e-7);
    /* d = +x: Y3 = -C1 x, Y6 = -C2[2], Y8 = C2[4] x^2, Y13 = C3[4] x (4z^2 - x^2 - y^2) =
     * -C3[4], Y15 = C3[6] x (x^2 - 3y^2) = C3[6]. */
    gv_splat_sh_basis(1, 0, 0, Y);
    double want_x[16] = {FIX_C0, 0, 0, -C1, 0, 0, -C2_2, 0, C2_4, 0, 0, 0, 0, -C3_4, 0, C3_6};
    for (int k = 0; k < 16; k++) CHECK_NEAR(Y[k], want_x[k], 1e-7);
}

static void test_colour_by_hand(void)
{
    /* Degree 0: colour = C0 sh0 + 0.5, clamped at 0: sh0 = (1, -1, -3) gives 0.782, 0.218,
     * and -0.346 -> 0 (bit 2). The degree-1 coefficients are stored but inactive. */
    float sh[4 * 3] = {1, -1, -3, 5, 5, 5, 5, 5, 5, 5, 5, 5};
    float mean[3] = {0.3f, 0.2f, 4}, campos[3] = {0, 0, 0}, rgb[3];
    uint8_t clamped;
    int list[1] = {0};
    gv_splat_sh_forward(1, list, 1, 0, sh, mean, campos, rgb, &clamped);
    CHECK_NEAR(rgb[0], FIX_C0 + 0.5, 1e-6);
    CHECK_NEAR(rgb[1], -FIX_C0 + 0.5, 1e-6);
    CHECK(rgb[2] == 0);
    CHECK(clamped == 4);

    /* Degree 1 at d = (0, 0, 1) seen from campos (0, 0, -4) with mean (0, 0, 1):
     * colour = C0 sh0 + C1 sh2 + 0.5 (Y1 = -C1 y = 0, Y3 = -C1 x = 0). */
    float sh1[4 * 3] = {0.1f, 0.2f, 0.3f, 9, 9, 9, 0.4f, 0.5f, 0.6f, 9, 9, 9};
    float mean1[3] = {0, 0, 1}, cam1[3] = {0, 0, -4};
    gv_splat_sh_forward(1, list, 1, 1, sh1, mean1, cam1, rgb, &clamped);
    for (int c = 0; c < 3; c++) CHECK_NEAR(rgb[c], FIX_C0 * sh1[c] + C1 * sh1[6 + c] + 0.5, 1e-6);
    CHECK(clamped == 0);

    /* Backward of the clamped case: channel 2 passes nothing; d_sh beyond the active
     * degree is zero; d_means is accumulated (+=), here onto 1. */
    float dcol[3] = {1, 1, 1}, dsh[12], dmean[3] = {1, 1, 1};
    gv_splat_sh_forward(1, list, 1, 0, sh, mean, campos, rgb, &clamped);
    gv_splat_sh_backward(1, list, 1, 0, sh, mean, campos, &clamped, dcol, dsh, dmean);
    CHECK_NEAR(dsh[0], FIX_C0, 1e-7);
    CHECK_NEAR(dsh[1], FIX_C0, 1e-7);
    CHECK(dsh[2] == 0);
    for (int k = 3; k < 12; k++) CHECK(dsh[k] == 0);
    /* degree 0 does not depend on the direction */
    for (int j = 0; j < 3; j++) CHECK(dmean[j] == 1);
}

/* L = w . colour of one Gaussian through the reference. */
typedef struct {
    int degree, active;
    double sh[48], mean[3], campos[3], w[3];
} sh_fd;

static double sh_loss(void *ctx, uint64_t *signature)
{
    sh_fd *c = ctx;
    double rgb[3];
    int bits = gv_splat_reference_sh(c->degree, c->active, c->sh, c->mean, c->campos, rgb);
    *signature = (uint64_t)bits;
    return c->w[0] * rgb[0] + c->w[1] * rgb[1] + c->w[2] * rgb[2];
}

static fix_compare cmp_sh = {"SH coefficients", 0, 0, {0}, {0}};
static fix_compare cmp_mean = {"means (view direction)", 0, 0, {0}, {0}};

static void test_reference_and_gradients(void)
{
    gv_splat_view v;
    fix_view(&v, 40, 24, 31);
    enum { N = 40 };
    gv_gaussians g;
    fix_gaussians(&g, N, 3, &v, 32);
    /* Make a few channels negative so that the clamp is exercised. */
    for (int i = 0; i < N; i += 7) g.sh[(size_t)i * 48 + 1] = -4;
    int list[N];
    for (int i = 0; i < N; i++) list[i] = i;
    float colors[3 * N], dcol[3 * N], dsh[48 * N], dmean[3 * N];
    uint8_t clamped[N];
    gv_rng r;
    gv_rng_init(&r, 33);
    for (int i = 0; i < 3 * N; i++) dcol[i] = (float)(2 * gv_rng_uniform(&r) - 1), dmean[i] = 0;
    int n_clamped = 0;
    for (int active = 0; active <= 3; active++) {
        gv_splat_sh_forward(N, list, 3, active, g.sh, g.means, v.campos, colors, clamped);
        gv_splat_sh_backward(N, list, 3, active, g.sh, g.means, v.campos, clamped, dcol, dsh,
                             dmean);
        double worst = 0;
        for (int i = 0; i < N; i++) {
            sh_fd c = {3, active, {0}, {0}, {v.campos[0], v.campos[1], v.campos[2]}, {0}};
            for (int k = 0; k < 48; k++) c.sh[k] = g.sh[(size_t)i * 48 + k];
            for (int j = 0; j < 3; j++) c.mean[j] = g.means[3 * i + j], c.w[j] = dcol[3 * i + j];
            double rgb[3];
            int bits = gv_splat_reference_sh(3, active, c.sh, c.mean, c.campos, rgb);
            CHECK(bits == clamped[i]);
            n_clamped += bits != 0;
            for (int ch = 0; ch < 3; ch++) worst = fmax(worst, fabs(rgb[ch] - colors[3 * i + ch]));
            int used = (active + 1) * (active + 1);
            uint64_t s0;
            sh_loss(&c, &s0);
            for (int k = 0; k < 48; k++) {
                double num;
                if (k >= used * 3) {
                    CHECK(dsh[(size_t)i * 48 + k] == 0);
                    continue;
                }
                if (fix_derivative(sh_loss, &c, s0, c.sh + k, 1e-6, &num)) cmp_sh.skipped++;
                else fix_add(&cmp_sh, dsh[(size_t)i * 48 + k], num);
            }
            if (active == 0) continue; /* colour does not depend on the direction */
            for (int j = 0; j < 3; j++) {
                double num;
                float analytic = dmean[3 * i + j];
                dmean[3 * i + j] = 0;
                if (fix_derivative(sh_loss, &c, s0, c.mean + j, 1e-6, &num)) cmp_mean.skipped++;
                else fix_add(&cmp_mean, analytic, num);
            }
        }
        printf("  degree %d: max |colour - reference| %.2e\n", active, worst);
        CHECK(worst < 2e-6);
    }
    CHECK(n_clamped >= 4);
    fix_report(&cmp_sh, 1e-4);
    fix_report(&cmp_mean, 2e-3);
    gv_gaussians_free(&g);
}

int main(void)
{
    test_basis_by_hand();
    test_colour_by_hand();
    test_reference_and_gradients();
    return check_summary();
}
