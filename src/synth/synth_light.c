/* The lights: ceiling panels (rectangles facing down), pendant bulbs and floor-lamp globes
 * (glowing spheres), and sun and sky through the openings; by day, at dusk or by night.
 * Intensities are set so that each source gives a chosen irradiance on the floor beneath
 * it; the camera's exposure (synth_render.c) then brings the whole to a photographic level,
 * so only ratios matter: sun patches are several times brighter than lamplight. */
#include "synth/synth_internal.h"

static int emitter_material(gv_synth_world *w)
{
    for (int i = 0; i < w->n_materials; i++)
        if (w->materials[i].kind == SY_MAT_EMITTER) return i;
    sy_material m = {.kind = SY_MAT_EMITTER};
    return sy_add_material(w, &m);
}

int sy_add_sphere_light(gv_synth_world *w, sy_vec center, double radius)
{
    int m = emitter_material(w);
    if (m < 0) return -1;
    int p = sy_add_sphere(w, center, radius, m);
    if (p < 0) return -1;
    if (w->n_lights >= SY_MAX_LIGHTS - 1) return 0; /* keep a slot for the sun: this one stays dark */
    sy_light l = {.kind = SY_LIGHT_SPHERE, .pos = center, .size = {radius, 0}};
    w->prims[p].light = w->n_lights;
    w->lights[w->n_lights++] = l;
    return 0;
}

static int add_panel(gv_synth_world *w, gv_rng *r, double x, double y)
{
    double H = w->room_hi.z, sx = sy_uniform(r, 0.15, 0.3), sy = sy_uniform(r, 0.15, 0.6);
    if (gv_rng_uniform(r) < 0.5) { double t = sx; sx = sy; sy = t; }
    int m = emitter_material(w);
    if (m < 0 || sy_begin_group(w, 0)) return -1;
    int p = sy_add_box(w, sy_v(x, y, H - 0.015), sy_v(sx, sy, 0.015), 0, m);
    if (p < 0) return -1;
    sy_end_group(w);
    sy_light l = {.kind = SY_LIGHT_RECT, .pos = sy_v(x, y, H - 0.03), .size = {sx, sy}};
    w->prims[p].light = w->n_lights;
    w->lights[w->n_lights++] = l;
    return 0;
}

static int add_pendant(gv_synth_world *w, gv_rng *r, double x, double y)
{
    double H = w->room_hi.z, radius = sy_uniform(r, 0.06, 0.1), drop = sy_uniform(r, 0.45, 0.75);
    int cord = sy_material_for(w, r, "metal");
    if (cord < 0 || sy_begin_group(w, 0)) return -1;
    if (sy_add_cylinder(w, sy_v(x, y, H - drop + radius), 0.006, drop - radius, 0, cord) < 0) return -1;
    if (sy_add_sphere_light(w, sy_v(x, y, H - drop), radius)) return -1;
    sy_end_group(w);
    return 0;
}

/* Colour of a lamp: warm (2700 K-like) to cool white. */
static sy_vec lamp_color(double warmth)
{
    return sy_lerp(sy_v(0.9, 0.95, 1.0), sy_v(1.0, 0.72, 0.45), warmth);
}

static void add_sun_and_sky(gv_synth_world *w, gv_rng *r, double floor_irradiance)
{
    sy_sky *sky = &w->sky;
    double mood = gv_rng_uniform(r); /* day with sun, overcast day, dusk, night */
    int windows = w->n_openings > 0;
    sky->sun_irradiance = sy_v(0, 0, 0);
    if (windows && mood < 0.55 && w->n_lights < SY_MAX_LIGHTS) {
        const sy_opening *o = &w->openings[sy_choice(r, w->n_openings)];
        const double outward[4] = {-0.5 * M_PI, 0, 0.5 * M_PI, M_PI};
        double azimuth = outward[o->wall] + sy_uniform(r, -50, 50) * M_PI / 180;
        double elevation = sy_uniform(r, 20, 50) * M_PI / 180;
        sky->sun_dir = sy_v(cos(elevation) * cos(azimuth), cos(elevation) * sin(azimuth), sin(elevation));
        double strength = sy_uniform(r, 3, 8) * floor_irradiance;
        sky->sun_irradiance = sy_scale(sy_v(1.0, 0.93, 0.82), strength);
        sy_light sun = {.kind = SY_LIGHT_SUN, .dir = sky->sun_dir, .angle = sy_uniform(r, 0.5, 1.5) * M_PI / 180,
                        .radiance = sky->sun_irradiance};
        w->lights[w->n_lights++] = sun;
    }
    double level = floor_irradiance * sy_uniform(r, 0.4, 0.9);
    if (mood < 0.75) { /* daylight blue, or overcast grey */
        double blue = mood < 0.55 ? 1.0 : 0.3;
        sky->zenith = sy_scale(sy_lerp(sy_v(0.8, 0.82, 0.85), sy_v(0.25, 0.45, 0.95), blue), level);
        sky->horizon = sy_scale(sy_v(0.9, 0.92, 0.95), 1.3 * level);
    } else if (mood < 0.9) { /* dusk */
        sky->zenith = sy_scale(sy_v(0.25, 0.3, 0.6), 0.5 * level);
        sky->horizon = sy_scale(sy_v(1.0, 0.55, 0.3), 0.9 * level);
    } else { /* night */
        sky->zenith = sy_scale(sy_v(0.02, 0.03, 0.08), level);
        sky->horizon = sy_scale(sy_v(0.05, 0.06, 0.12), level);
    }
    sky->hills = sy_scale(sy_lerp(sky->horizon, sy_v(0.2, 0.3, 0.25), 0.5), 0.7);
}

int sy_build_lights(gv_synth_world *w, gv_rng *r)
{
    double W = w->room_hi.x - w->room_lo.x, D = w->room_hi.y - w->room_lo.y, H = w->room_hi.z;
    int mode = sy_choice(r, 3); /* panels, pendants, or both */
    int n = 1 + sy_choice(r, 3);
    int along_x = W >= D;
    double side = sy_uniform(r, -0.2, 0.2);
    for (int i = 0; i < n && w->n_lights < SY_MAX_LIGHTS - 1; i++) {
        double a = ((i + 0.5) / n - 0.5) * 0.8 + sy_uniform(r, -0.05, 0.05);
        double x = along_x ? a * W : side * W, y = along_x ? side * D : a * D;
        int pendant = mode == 1 || (mode == 2 && i % 2);
        if ((pendant ? add_pendant(w, r, x, y) : add_panel(w, r, x, y))) return -1;
    }
    double warmth = gv_rng_uniform(r);
    double floor_irradiance = 1.0;
    int interior = w->n_lights;
    for (int i = 0; i < interior; i++) {
        sy_light *l = &w->lights[i];
        double jitter = sy_uniform(r, -0.15, 0.15);
        double share = floor_irradiance * sy_uniform(r, 0.7, 1.3) / pow(interior, 0.6);
        sy_vec color = lamp_color(sy_clamp(warmth + jitter, 0, 1));
        double h = l->kind == SY_LIGHT_RECT ? H - 0.03 : l->pos.z;
        double area = l->kind == SY_LIGHT_RECT ? 4 * l->size[0] * l->size[1] : M_PI * l->size[0] * l->size[0];
        /* E = L A / h^2 on the floor under a small source facing it */
        l->radiance = sy_scale(color, share * h * h / area);
    }
    add_sun_and_sky(w, r, floor_irradiance);
    return 0;
}
