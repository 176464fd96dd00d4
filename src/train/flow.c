/* Flow matching as the reference scheduler defines it
 * (docs/reference/wan-vace-gaussvid.md section 5): x_sigma = (1 - sigma) x0 + sigma eps,
 * velocity target eps - x0, the shift, and the training grid with its timestep weights used
 * for base pretraining. GaussVid fine-tuning starts the path at the corrupted latent instead
 * of x0 (paper eq. 6) with the same target (eq. 7). */
#include <math.h>

#include "gaussvid/train/train.h"

double gv_flow_shift(double sigma, double shift)
{
    return shift * sigma / (1.0 + (shift - 1.0) * sigma);
}

void gv_flow_noisy(const float *start, const float *eps, float t, int64_t n, float *x_t)
{
    for (int64_t i = 0; i < n; i++) x_t[i] = (1.0f - t) * start[i] + t * eps[i];
}

void gv_flow_target(const float *z0, const float *eps, int64_t n, float *v)
{
    for (int64_t i = 0; i < n; i++) v[i] = eps[i] - z0[i];
}

void gv_flow_skip_from_noise(const float *z_hat, const float *eps, float t, int64_t n, float *s)
{
    for (int64_t i = 0; i < n; i++) s[i] = (1.0f - t) * (eps[i] - z_hat[i]);
}

void gv_flow_skip_from_x(const float *z_hat, const float *x, double t, int64_t n, float *s)
{
    float c = (float)((1.0 - t) / t);
    for (int64_t i = 0; i < n; i++) s[i] = c * (x[i] - z_hat[i]);
}

void gv_flow_residual_from_noise(const float *z_hat, const float *eps, int64_t n, float *r)
{
    for (int64_t i = 0; i < n; i++) r[i] = eps[i] - z_hat[i];
}

void gv_flow_residual_from_x(const float *z_hat, const float *x, double t, int64_t n, float *r)
{
    float c = (float)(1.0 / t);
    for (int64_t i = 0; i < n; i++) r[i] = c * (x[i] - z_hat[i]);
}

/* Reference 5.5: sigma from linspace(1, 0, 1001)[:-1], shifted; the weight is a bell around
 * timestep 500, shifted down to 0 at its minimum and normalised to mean 1 over the grid. */
void gv_pretrain_schedule_init(gv_pretrain_schedule *s, double shift)
{
    double y[GV_FLOW_GRID], y_min = INFINITY, sum = 0;
    s->shift = shift;
    for (int k = 0; k < GV_FLOW_GRID; k++) {
        s->sigma[k] = gv_flow_shift(1.0 - (double)k / GV_FLOW_GRID, shift);
        double t = 1000.0 * s->sigma[k];
        y[k] = exp(-2.0 * ((t - 500.0) / 1000.0) * ((t - 500.0) / 1000.0));
        if (y[k] < y_min) y_min = y[k];
    }
    for (int k = 0; k < GV_FLOW_GRID; k++) sum += y[k] - y_min;
    for (int k = 0; k < GV_FLOW_GRID; k++) s->weight[k] = sum > 0 ? (y[k] - y_min) * GV_FLOW_GRID / sum : 1.0;
}

int gv_pretrain_index(double u)
{
    int k = (int)(u * GV_FLOW_GRID);
    return k < 0 ? 0 : k >= GV_FLOW_GRID ? GV_FLOW_GRID - 1 : k;
}
