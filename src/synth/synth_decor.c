/* Free-standing things of the procedural rooms: columns, pedestals with sculptures,
 * barrels, stacked crates, potted plants, floor lamps (which light the room) and balls. */
#include "synth/synth_objects.h"

static double U(gv_rng *r, double lo, double hi) { return sy_uniform(r, lo, hi); }

int sy_build_column(gv_synth_world *w, gv_rng *r, const sy_frame *f, double width, double depth)
{
    double H = w->room_hi.z, radius = 0.5 * fmin(width, depth) * U(r, 0.55, 0.75);
    int m = sy_material_for(w, r, gv_rng_uniform(r) < 0.5 ? "marble" : "ceiling");
    if (m < 0) return -1;
    double b = 0.5 * fmin(width, depth);
    if (sy_part_box(w, f, sy_v(0, 0, 0.08), sy_v(b, b, 0.08), m) < 0 ||
        sy_part_cylinder(w, f, sy_v(0, 0, 0.16), radius, H - 0.32, m) < 0 ||
        sy_part_box(w, f, sy_v(0, 0, H - 0.08), sy_v(b, b, 0.08), m) < 0)
        return -1;
    return 0;
}

int sy_build_pedestal(gv_synth_world *w, gv_rng *r, const sy_frame *f, double width, double depth)
{
    double h = U(r, 0.8, 1.1), b = 0.5 * fmin(width, depth);
    int stone = sy_material_for(w, r, gv_rng_uniform(r) < 0.6 ? "marble" : "trim");
    int art = sy_material_for(w, r, gv_rng_uniform(r) < 0.5 ? "metal" : gv_rng_uniform(r) < 0.5 ? "marble" : "plastic");
    if (stone < 0 || art < 0) return -1;
    if (sy_part_box(w, f, sy_v(0, 0, 0.5 * h - 0.02), sy_v(b - 0.03, b - 0.03, 0.5 * h - 0.02), stone) < 0 ||
        sy_part_box(w, f, sy_v(0, 0, h - 0.02), sy_v(b, b, 0.02), stone) < 0)
        return -1;
    int kind = sy_choice(r, 3);
    double s = b * U(r, 0.6, 0.9);
    if (kind == 0) return sy_part_sphere(w, f, sy_v(0, 0, h + s), s, art) < 0 ? -1 : 0;
    if (kind == 1) { /* a snowman-like stack */
        double z = h;
        for (int i = 0; i < 3; i++, s *= 0.7) {
            if (sy_part_sphere(w, f, sy_v(0, 0, z + s), s, art) < 0) return -1;
            z += 1.7 * s;
        }
        return 0;
    }
    double ch = U(r, 0.15, 0.45);
    if (sy_part_cylinder(w, f, sy_v(0, 0, h), 0.4 * s, ch, art) < 0) return -1;
    return sy_part_sphere(w, f, sy_v(0, 0, h + ch + 0.7 * s), 0.7 * s, art) < 0 ? -1 : 0;
}

int sy_build_barrel(gv_synth_world *w, gv_rng *r, const sy_frame *f, double width, double depth)
{
    double radius = 0.5 * fmin(width, depth) - 0.01, h = U(r, 0.7, 1.0);
    int staves = sy_material_for(w, r, "accent"), hoop = sy_material_for(w, r, "metal");
    if (staves < 0 || hoop < 0) return -1;
    sy_material *m = &w->materials[staves]; /* vertical boards around the barrel */
    m->kind = SY_MAT_PLANKS;
    m->variant = 1;
    m->scale[0] = U(r, 0.06, 0.1);
    m->scale[1] = 10;
    m->scale[2] = 0.006;
    double hue = U(r, 0.06, 0.09), sat = U(r, 0.4, 0.6), val = U(r, 0.35, 0.6);
    m->color[0] = sy_hsv(hue, sat, val);
    m->color[1] = sy_scale(m->color[0], 0.6);
    m->color[2] = sy_scale(m->color[0], 0.3);
    if (sy_part_cylinder(w, f, sy_v(0, 0, 0), radius - 0.008, h, staves) < 0) return -1;
    double bands[3] = {0.12, 0.5, 0.88};
    for (int i = 0; i < 3; i++)
        if (sy_part_cylinder(w, f, sy_v(0, 0, bands[i] * h - 0.02), radius, 0.04, hoop) < 0) return -1;
    return 0;
}

int sy_build_crates(gv_synth_world *w, gv_rng *r, const sy_frame *f, double width, double depth)
{
    int n = 1 + sy_choice(r, 3);
    double z = 0, s = 0.5 * fmin(width, depth);
    int m = sy_material_for(w, r, "accent");
    if (m < 0) return -1;
    sy_material *mat = &w->materials[m];
    mat->kind = SY_MAT_PLANKS;
    mat->variant = 0;
    mat->scale[0] = U(r, 0.08, 0.14);
    mat->scale[1] = 10;
    mat->scale[2] = U(r, 0.008, 0.02); /* gaps between the slats */
    double hue = U(r, 0.07, 0.11), sat = U(r, 0.3, 0.55), val = U(r, 0.55, 0.8);
    mat->color[0] = sy_hsv(hue, sat, val);
    mat->color[1] = sy_scale(mat->color[0], 0.7);
    mat->color[2] = sy_scale(mat->color[0], 0.35);
    for (int i = 0; i < n; i++) {
        double turn = i ? U(r, -0.4, 0.4) : 0;
        sy_frame g = {f->origin, f->yaw + turn};
        double h = 2 * s * U(r, 0.6, 0.9);
        if (sy_part_box(w, &g, sy_v(0, 0, z + 0.5 * h), sy_v(s, s, 0.5 * h), m) < 0) return -1;
        z += h;
        s *= U(r, 0.6, 0.85);
    }
    return 0;
}

int sy_build_plant(gv_synth_world *w, gv_rng *r, const sy_frame *f, double width, double depth)
{
    double spread = 0.5 * fmin(width, depth), pot_r = spread * U(r, 0.45, 0.6), pot_h = U(r, 0.25, 0.5);
    int pot = sy_material_for(w, r, "pot"), leaves = sy_material_for(w, r, "foliage");
    int bark = sy_material_for(w, r, "wood");
    if (pot < 0 || leaves < 0 || bark < 0) return -1;
    double trunk = U(r, 0.1, 0.8), crown = pot_h + trunk;
    if (sy_part_cylinder(w, f, sy_v(0, 0, 0), pot_r, pot_h, pot) < 0 ||
        sy_part_cylinder(w, f, sy_v(0, 0, pot_h), 0.025, trunk + 0.1, bark) < 0)
        return -1;
    int n = 3 + sy_choice(r, 5);
    for (int i = 0; i < n; i++) {
        double a = 2 * M_PI * i / n + U(r, -0.3, 0.3), rad = spread * U(r, 0.35, 0.6);
        double d = spread - rad;
        double z = crown + rad + U(r, -0.05, 0.35);
        if (sy_part_sphere(w, f, sy_v(d * cos(a), d * sin(a), z), rad, leaves) < 0) return -1;
    }
    return 0;
}

int sy_build_floor_lamp(gv_synth_world *w, gv_rng *r, const sy_frame *f, double width, double depth)
{
    double h = U(r, 1.35, 1.6), globe = U(r, 0.1, 0.15);
    int metal = sy_material_for(w, r, "metal");
    if (metal < 0) return -1;
    if (sy_part_cylinder(w, f, sy_v(0, 0, 0), 0.5 * fmin(width, depth) - 0.02, 0.03, metal) < 0 ||
        sy_part_cylinder(w, f, sy_v(0, 0, 0.03), 0.014, h - 0.03, metal) < 0)
        return -1;
    sy_vec c = sy_v(f->origin.x, f->origin.y, h + globe - 0.01);
    return sy_add_sphere_light(w, c, globe);
}

int sy_build_balls(gv_synth_world *w, gv_rng *r, const sy_frame *f, double width, double depth)
{
    int n = 1 + sy_choice(r, 3);
    double s = 0.5 * fmin(width, depth);
    for (int i = 0; i < n; i++) {
        double radius = s * U(r, 0.25, 0.5), a = 2 * M_PI * i / n + U(r, -0.3, 0.3), d = s - radius;
        int m = sy_material_for(w, r, "plastic");
        if (m < 0 || sy_part_sphere(w, f, sy_v(d * cos(a), d * sin(a), radius), radius, m) < 0) return -1;
    }
    return 0;
}
