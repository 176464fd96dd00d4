/* Shading: what a ray sees. Surfaces are Lambertian, radiance = albedo / pi x irradiance,
 * the irradiance coming from the baked lightmap (or, for the ground outside, from the sun
 * and sky directly); emitters show their light's radiance; rays that leave through an
 * opening see a sky with distant hills. No view-dependent term anywhere, so a point looks
 * the same from every camera. The tone curve maps radiance to 8-bit sRGB. */
#include "synth/synth_internal.h"

sy_vec sy_sky_radiance(const gv_synth_world *w, sy_vec d)
{
    const sy_sky *sky = &w->sky;
    double elevation = asin(sy_clamp(d.z, -1, 1));
    sy_vec c = sy_lerp(sky->horizon, sky->zenith, sy_smoothstep(0.0, 0.7, elevation));
    /* clouds: noise on the plane of the sky, fading towards the horizon where it would alias */
    if (elevation > 0.02) {
        double k = 1.0 / fmax(d.z, 0.05);
        double cloud = sy_fbm2(d.x * k, d.y * k, 0.6, 4, 0.05 * k, sky->seed);
        double amount = sy_smoothstep(0.0, 0.4, cloud) * sy_smoothstep(0.02, 0.25, elevation);
        c = sy_lerp(c, sy_scale(sky->horizon, 1.15), 0.7 * amount);
    }
    if (sky->sun_irradiance.x > 0) { /* a soft glow around the sun */
        double g = pow(fmax(sy_dot(d, sky->sun_dir), 0), 40);
        c = sy_add(c, sy_scale(sky->horizon, 1.5 * g));
    }
    /* hills on the horizon: a height per azimuth, from noise on the circle (cos, sin) */
    double across = fmax(hypot(d.x, d.y), 1e-9);
    double hill = 0.02 + 0.05 * (0.5 + 0.5 * sy_fbm2(2 * d.x / across, 2 * d.y / across, 1.0, 4, 0.01, sky->seed + 1));
    double below = sy_smoothstep(hill + 0.002, hill - 0.002, elevation);
    return sy_lerp(c, sky->hills, below);
}

static sy_vec lightmap_texel(const gv_synth_world *w, const sy_patch *pa, int i, int j)
{
    const float *t = w->lightmap + 3 * (pa->offset + (long)j * pa->nu + i);
    return sy_v(t[0], t[1], t[2]);
}

sy_vec sy_irradiance(const gv_synth_world *w, const sy_surface *s)
{
    if (s->patch < 0) { /* the ground outside: sun (with the house's shadow) and sky */
        const sy_sky *sky = &w->sky;
        sy_vec e = sy_scale(sy_add(sky->zenith, sky->horizon), 0.5 * M_PI);
        double cosine = sy_dot(s->n, sky->sun_dir);
        if (sky->sun_irradiance.x > 0 && cosine > 0 &&
            !sy_occluded(w, sy_add(s->p, sy_scale(s->n, 1e-4)), sky->sun_dir, 1e4))
            e = sy_add(e, sy_scale(sky->sun_irradiance, cosine));
        return e;
    }
    const sy_patch *pa = &w->patches[s->patch];
    double x = s->s * pa->nu - 0.5, y = s->t * pa->nv - 0.5;
    int i0 = (int)floor(x), j0 = (int)floor(y), i1 = i0 + 1, j1 = j0 + 1;
    double fx = x - i0, fy = y - j0;
    if (pa->wraps) {
        i0 = (i0 + pa->nu) % pa->nu;
        i1 = i1 % pa->nu;
    } else {
        i0 = i0 < 0 ? 0 : i0;
        i1 = i1 >= pa->nu ? pa->nu - 1 : i1;
    }
    j0 = j0 < 0 ? 0 : j0;
    j1 = j1 >= pa->nv ? pa->nv - 1 : j1;
    sy_vec a = sy_lerp(lightmap_texel(w, pa, i0, j0), lightmap_texel(w, pa, i1, j0), fx);
    sy_vec b = sy_lerp(lightmap_texel(w, pa, i0, j1), lightmap_texel(w, pa, i1, j1), fx);
    return sy_lerp(a, b, fy);
}

sy_vec sy_radiance(const gv_synth_world *w, sy_vec o, sy_vec d, double pixel_angle, int *id, sy_vec *hit_point)
{
    sy_hit hit;
    if (!sy_trace(w, o, d, 1e30, &hit)) {
        *id = -1;
        return sy_sky_radiance(w, d);
    }
    sy_surface s;
    sy_surface_at(w, o, d, &hit, &s);
    if (hit_point) *hit_point = s.p;
    const sy_material *m;
    if (hit.prim >= 0) {
        const sy_prim *p = &w->prims[hit.prim];
        *id = hit.prim * 8 + hit.face;
        if (p->light >= 0) return w->lights[p->light].radiance;
        m = &w->materials[p->material];
    } else {
        *id = -2;
        m = &w->materials[w->sky.ground_material];
    }
    /* the pixel's footprint on the surface, widened at grazing angles */
    double footprint = hit.t * pixel_angle / fmax(fabs(sy_dot(s.n, d)), 0.2);
    sy_vec albedo = sy_material_albedo(m, &s, footprint);
    if (w->params.texture_detail > 0) albedo = sy_albedo_detail(albedo, s.p, footprint, w->params.texture_detail, m->seed);
    return sy_scale(sy_mul(albedo, sy_irradiance(w, &s)), 1.0 / M_PI);
}

/* Narkowicz's fit of the ACES filmic curve, then the sRGB transfer function. */
static double filmic(double x)
{
    if (!(x > 0)) return 0;
    double y = (x * (2.51 * x + 0.03)) / (x * (2.43 * x + 0.59) + 0.14);
    return sy_linear_to_srgb(sy_clamp(y, 0, 1));
}

void sy_tone_map(const gv_synth_world *w, sy_vec radiance, uint8_t rgb[3])
{
    double c[3] = {radiance.x, radiance.y, radiance.z};
    for (int k = 0; k < 3; k++) rgb[k] = (uint8_t)(255.0 * filmic(w->exposure * c[k]) + 0.5);
}
