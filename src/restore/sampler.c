/* Samplers that turn the corrupted latent z-hat into the restored latent with the network's
 * velocity (restore.h; docs/ARCHITECTURE.md 7 "note on inference"). Pure arithmetic on float arrays: the
 * network comes in through a callback, so the tests run the samplers on exact velocities. */
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "gaussvid/core/core.h"
#include "gaussvid/restore/restore.h"
#include "gaussvid/nn/tensor.h"
#include "gaussvid/train/train.h"

gv_sampler gv_sampler_default(void)
{
    gv_sampler s;
    gv_sampler_from_name(GV_SAMPLER_DEFAULT, &s);
    return s;
}

const char *gv_sampler_kind_name(gv_sampler_kind kind)
{
    switch (kind) {
    case GV_SAMPLER_ONESTEP: return "onestep";
    case GV_SAMPLER_ITERATE: return "iterate";
    case GV_SAMPLER_EULER: return "euler";
    case GV_SAMPLER_IDENTITY: return "identity";
    }
    return "?";
}

int gv_sampler_from_name(const char *name, gv_sampler *out)
{
    gv_sampler s = {GV_SAMPLER_ONESTEP, 0.3, 1, 1.0, 1, 1.0, 0, 0};
    if (!strcmp(name, "onestep")) {
        /* the measured best of the released checkpoint on an unseen validation scene
         * (docs/RESTORATION.md "Measured comparison"): a small t0, 8 draws averaged */
        s.t0 = 0.05, s.samples = 8;
    } else if (!strcmp(name, "iterate")) {
        s.kind = GV_SAMPLER_ITERATE, s.steps = 3;
    } else if (!strcmp(name, "euler")) {
        s.kind = GV_SAMPLER_EULER, s.steps = 10;
    } else if (!strcmp(name, "released")) {
        /* docs/reference/wan-vace-gaussvid.md 1.2, 5.4: strength 0.2 shifted by 5 gives the first
         * sigma 5/9 */
        s.kind = GV_SAMPLER_EULER, s.steps = 10, s.shift = 5.0, s.t0 = gv_flow_shift(0.2, 5.0), s.release = 1;
    } else if (!strcmp(name, "identity")) {
        s.kind = GV_SAMPLER_IDENTITY;
    } else {
        return gv_fail("sampler '%s': expected onestep, iterate, euler, released or identity", name);
    }
    *out = s;
    return 0;
}

int gv_sampler_configure(const char *name, double t0, int steps, double shift, int samples, double blend,
                         uint64_t seed, gv_sampler *out)
{
    gv_sampler s;
    if (gv_sampler_from_name(name, &s)) return -1;
    if (t0 > 0) s.t0 = t0;
    if (steps > 0) s.steps = steps;
    if (shift > 0) s.shift = shift;
    if (samples > 0) s.samples = samples;
    if (blend > 0) s.blend = blend;
    s.seed = seed;
    if (gv_sampler_check(&s)) return -1;
    *out = s;
    return 0;
}

int gv_sampler_check(const gv_sampler *s)
{
    const char *name = gv_sampler_kind_name(s->kind);
    if ((unsigned)s->kind > GV_SAMPLER_IDENTITY) return gv_fail("sampler: unknown kind %d", (int)s->kind);
    if (!(s->t0 > 0 && s->t0 < 1)) return gv_fail("sampler %s: t0 %g is not in (0, 1)", name, s->t0);
    if (s->steps < 1 || s->steps > GV_SAMPLER_MAX_STEPS)
        return gv_fail("sampler %s: steps %d is not in 1..%d", name, s->steps, GV_SAMPLER_MAX_STEPS);
    if (s->kind == GV_SAMPLER_ONESTEP && s->steps != 1)
        return gv_fail("sampler onestep: steps %d (it takes one; use iterate or euler for more)", s->steps);
    if (!(s->shift >= 1 && isfinite(s->shift))) return gv_fail("sampler %s: shift %g is below 1", name, s->shift);
    if (s->samples < 1 || s->samples > 1000) return gv_fail("sampler %s: samples %d is not in 1..1000", name, s->samples);
    if (s->kind == GV_SAMPLER_EULER && s->samples != 1)
        return gv_fail("sampler euler: samples %d (an ODE path has one noise draw)", s->samples);
    if (!(s->blend > 0 && s->blend <= 1)) return gv_fail("sampler %s: blend %g is not in (0, 1]", name, s->blend);
    if (s->kind == GV_SAMPLER_EULER && s->blend != 1)
        return gv_fail("sampler euler: blend %g (the ODE path takes whole steps)", s->blend);
    return 0;
}

void gv_release_sigmas(float strength, float shift, int steps, float *sigmas, float *timesteps_bf16)
{
    /* volatile: each product and sum rounded to float32 on its own, never fused */
    const volatile float step = (0.0f - strength) / (float)steps;
    const int n = steps + 1, halfway = n / 2;
    for (int k = 0; k < steps; k++) {
        volatile float prod = step * (float)(k < halfway ? k : n - k - 1);
        volatile float s = k < halfway ? strength + prod : 0.0f - prod;
        volatile float num = shift * s, scaled = (shift - 1.0f) * s, den = 1.0f + scaled;
        sigmas[k] = num / den;
        if (timesteps_bf16) timesteps_bf16[k] = gv_bf16_to_f32(gv_f32_to_bf16(1000.0f * sigmas[k]));
    }
}

int gv_sampler_sigmas(const gv_sampler *s, double *sigmas)
{
    if (gv_sampler_check(s)) return -1;
    if (s->release) {
        float grid[GV_SAMPLER_MAX_STEPS];
        double u = s->t0 / (s->shift - (s->shift - 1.0) * s->t0); /* the strength */
        gv_release_sigmas((float)u, (float)s->shift, s->steps, grid, NULL);
        for (int k = 0; k < s->steps; k++) sigmas[k] = grid[k];
        sigmas[s->steps] = 0.0;
        return 0;
    }
    /* the unshifted start u with shift(u) = t0, then the reference's grid (5.3) */
    double u = s->t0 / (s->shift - (s->shift - 1.0) * s->t0);
    for (int k = 0; k < s->steps; k++) sigmas[k] = gv_flow_shift(u * (1.0 - (double)k / s->steps), s->shift);
    sigmas[0] = s->t0; /* exactly, not through the round trip */
    sigmas[s->steps] = 0.0;
    return 0;
}

void gv_sampler_describe(const gv_sampler *s, char *out, size_t size)
{
    snprintf(out, size, "%s t0=%.4g steps=%d shift=%g samples=%d blend=%g seed=%llu", gv_sampler_kind_name(s->kind),
             s->t0, s->steps, s->shift, s->samples, s->blend, (unsigned long long)s->seed);
}

/* One-step restorations at sigma_0 .. sigma_{steps-1}, each on the previous result, each
 * correction scaled by blend. */
static int sample_restore(const gv_sampler *s, const double *sigmas, gv_velocity_fn velocity, void *ctx, int64_t n,
                          uint64_t seed, float *z, float *x, float *v, float *eps, double *acc)
{
    for (int k = 0; k < s->steps; k++) {
        float t = (float)sigmas[k];
        for (int64_t i = 0; i < n; i++) acc[i] = 0;
        for (int j = 0; j < s->samples; j++) {
            gv_fill_normal(eps, n, seed, (uint64_t)(k * s->samples + j) * (uint64_t)n, 0.0f, 1.0f);
            gv_flow_noisy(z, eps, t, n, x); /* x_t exactly as training builds it (paper eq. 6) */
            if (velocity(ctx, x, sigmas[k], v)) return -1;
            for (int64_t i = 0; i < n; i++) acc[i] += eps[i] - v[i]; /* z0* = eps - v */
        }
        if (s->blend == 1)
            for (int64_t i = 0; i < n; i++) z[i] = (float)(acc[i] / s->samples);
        else /* shrink the correction toward the current latent */
            for (int64_t i = 0; i < n; i++) z[i] += (float)(s->blend * (acc[i] / s->samples - z[i]));
    }
    return 0;
}

/* The reference's Euler ODE steps (5.3) from x = (1 - t0) z-hat + t0 eps. */
static int sample_euler(const gv_sampler *s, const double *sigmas, gv_velocity_fn velocity, void *ctx, int64_t n,
                        uint64_t seed, float *z, float *v, float *eps)
{
    gv_fill_normal(eps, n, seed, 0, 0.0f, 1.0f);
    gv_flow_noisy(z, eps, (float)sigmas[0], n, z);
    for (int k = 0; k < s->steps; k++) {
        if (velocity(ctx, z, sigmas[k], v)) return -1;
        float dt = (float)(sigmas[k + 1] - sigmas[k]);
        for (int64_t i = 0; i < n; i++) z[i] += v[i] * dt;
    }
    return 0;
}

int gv_sample(const gv_sampler *s, gv_velocity_fn velocity, void *ctx, const float *z_hat, int64_t n, uint64_t seed,
              float *z_out)
{
    double sigmas[GV_SAMPLER_MAX_STEPS + 1];
    if (gv_sampler_sigmas(s, sigmas)) return -1;
    if (n < 1) return gv_fail("sampler: %lld latent values", (long long)n);
    memcpy(z_out, z_hat, (size_t)n * sizeof *z_out);
    if (s->kind == GV_SAMPLER_IDENTITY) return 0;
    float *x = malloc((size_t)n * sizeof *x), *v = malloc((size_t)n * sizeof *v), *eps = malloc((size_t)n * sizeof *eps);
    double *acc = malloc((size_t)n * sizeof *acc);
    int rc = -1;
    if (!x || !v || !eps || !acc) gv_fail("sampler: out of memory for %lld latent values", (long long)n);
    else if (s->kind == GV_SAMPLER_EULER) rc = sample_euler(s, sigmas, velocity, ctx, n, seed, z_out, v, eps);
    else rc = sample_restore(s, sigmas, velocity, ctx, n, seed, z_out, x, v, eps, acc);
    free(x), free(v), free(eps), free(acc);
    return rc;
}
