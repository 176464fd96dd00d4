/* Seeded materials by role (wall, floor, wood, fabric, ...): each role picks a texture kind
 * and colours from ranges that look like real interiors (pale paints, brown woods, red
 * bricks, saturated accents), so that every seed differs but stays plausible. Colours are
 * chosen in sRGB HSV and stored as linear albedos. */
#include "synth/synth_internal.h"

#include <string.h>

double sy_srgb_to_linear(double c)
{
    return c <= 0.04045 ? c / 12.92 : pow((c + 0.055) / 1.055, 2.4);
}

double sy_linear_to_srgb(double c)
{
    return c <= 0.0031308 ? 12.92 * c : 1.055 * pow(c, 1.0 / 2.4) - 0.055;
}

sy_vec sy_hsv(double h, double s, double v)
{
    h = 6.0 * (h - floor(h));
    int sector = (int)h % 6;
    double f = h - floor(h), p = v * (1 - s), q = v * (1 - s * f), t = v * (1 - s * (1 - f));
    double r, g, b;
    switch (sector) {
    case 0: r = v; g = t; b = p; break;
    case 1: r = q; g = v; b = p; break;
    case 2: r = p; g = v; b = t; break;
    case 3: r = p; g = q; b = v; break;
    case 4: r = t; g = p; b = v; break;
    default: r = v; g = p; b = q; break;
    }
    return sy_v(sy_srgb_to_linear(r), sy_srgb_to_linear(g), sy_srgb_to_linear(b));
}

/* Every random draw is its own statement: C leaves the order of evaluation of function
 * arguments unspecified, and the same seed must give the same scene with any compiler. */
static double U(gv_rng *r, double lo, double hi) { return sy_uniform(r, lo, hi); }

static sy_vec pick(gv_rng *r, double h0, double h1, double s0, double s1, double v0, double v1)
{
    double h = U(r, h0, h1);
    double s = U(r, s0, s1);
    double v = U(r, v0, v1);
    return sy_hsv(h, s, v);
}

static sy_vec wall_paint(gv_rng *r)
{
    if (gv_rng_uniform(r) < 0.6) return pick(r, 0.04, 0.16, 0.03, 0.28, 0.72, 0.93);
    return pick(r, 0, 1, 0.03, 0.2, 0.72, 0.93);
}

static sy_vec wood(gv_rng *r) { return pick(r, 0.05, 0.1, 0.35, 0.7, 0.38, 0.82); }

static sy_vec accent(gv_rng *r) { return pick(r, 0, 1, 0.3, 0.75, 0.45, 0.9); }

static sy_vec neutral(gv_rng *r, double lo, double hi) { return pick(r, 0.05, 0.6, 0, 0.08, lo, hi); }

static sy_vec brick(gv_rng *r)
{
    double kind = gv_rng_uniform(r);
    if (kind < 0.6) return pick(r, 0.0, 0.06, 0.45, 0.75, 0.42, 0.68);
    if (kind < 0.85) return pick(r, 0.08, 0.12, 0.25, 0.45, 0.6, 0.8);
    return pick(r, 0.05, 0.15, 0.02, 0.08, 0.75, 0.9); /* painted */
}

static void base(sy_material *m, gv_rng *r, sy_material_kind kind)
{
    memset(m, 0, sizeof *m);
    m->kind = kind;
    m->seed = gv_rng_u32(r);
    m->variation = U(r, 0.4, 1.0);
}

static void make_wall(sy_material *m, gv_rng *r, int accent_wall)
{
    double k = gv_rng_uniform(r);
    if (accent_wall ? k < 0.35 : k < 0.12) {
        base(m, r, SY_MAT_BRICK);
        m->color[0] = brick(r);
        double f = U(r, 0.7, 1.0);
        m->color[1] = sy_scale(m->color[0], f);
        m->color[2] = neutral(r, 0.55, 0.8);
        m->scale[0] = U(r, 0.19, 0.3);
        m->scale[1] = m->scale[0] * U(r, 0.3, 0.4);
    } else if (accent_wall ? k < 0.6 : k < 0.32) {
        base(m, r, SY_MAT_STRIPES);
        m->color[0] = accent_wall ? accent(r) : wall_paint(r);
        sy_vec other = wall_paint(r);
        m->color[1] = sy_lerp(m->color[0], other, U(r, 0.3, 0.7));
        m->color[2] = gv_rng_uniform(r) < 0.5 ? wall_paint(r) : accent(r);
        m->scale[0] = U(r, 0.06, 0.3);
        m->variant = sy_choice(r, 3);
    } else if (accent_wall ? k < 0.8 : k < 0.4) {
        base(m, r, SY_MAT_PLANKS);
        m->color[0] = wood(r);
        m->color[1] = sy_scale(m->color[0], U(r, 0.45, 0.7));
        m->color[2] = sy_scale(m->color[0], 0.3);
        m->scale[0] = U(r, 0.09, 0.2);
        m->scale[1] = U(r, 1.5, 3.0);
        m->variant = 1; /* vertical boards */
    } else {
        base(m, r, SY_MAT_PLASTER);
        m->color[0] = accent_wall ? accent(r) : wall_paint(r);
        m->color[1] = sy_scale(m->color[0], U(r, 0.8, 0.95));
    }
}

static void make_floor(sy_material *m, gv_rng *r)
{
    double k = gv_rng_uniform(r);
    if (k < 0.45) {
        base(m, r, SY_MAT_PLANKS);
        m->color[0] = wood(r);
        m->color[1] = sy_scale(m->color[0], U(r, 0.4, 0.7));
        m->color[2] = sy_scale(m->color[0], 0.25);
        m->scale[0] = U(r, 0.08, 0.22);
        m->scale[1] = U(r, 0.8, 2.2);
    } else if (k < 0.8) {
        base(m, r, SY_MAT_TILES);
        m->variant = sy_choice(r, 3);
        m->color[0] = gv_rng_uniform(r) < 0.5 ? neutral(r, 0.3, 0.9) : pick(r, 0.02, 0.1, 0.3, 0.6, 0.45, 0.75);
        m->color[1] = m->variant == 1 ? neutral(r, 0.1, 0.4) : sy_scale(m->color[0], U(r, 0.8, 0.95));
        m->color[2] = neutral(r, 0.3, 0.7);
        m->color[3] = neutral(r, 0.2, 0.5);
        m->scale[0] = m->scale[1] = U(r, 0.2, 0.6);
        if (gv_rng_uniform(r) < 0.3) m->scale[1] = m->scale[0] * 0.5;
    } else if (k < 0.9) {
        base(m, r, SY_MAT_MARBLE);
        m->color[0] = neutral(r, 0.65, 0.9);
        m->color[1] = neutral(r, 0.15, 0.5);
        m->scale[0] = U(r, 0.8, 2.5);
    } else {
        base(m, r, SY_MAT_PLASTER); /* polished concrete */
        m->color[0] = neutral(r, 0.4, 0.7);
        m->color[1] = sy_scale(m->color[0], 0.8);
        m->variation = U(r, 0.8, 1.0);
    }
}

static void make_fabric(sy_material *m, gv_rng *r)
{
    base(m, r, SY_MAT_FABRIC);
    m->color[0] = gv_rng_uniform(r) < 0.5 ? accent(r) : neutral(r, 0.2, 0.8);
    m->color[1] = gv_rng_uniform(r) < 0.5 ? accent(r) : sy_scale(m->color[0], 0.6);
    m->color[2] = neutral(r, 0.6, 0.9);
    m->scale[0] = U(r, 0.04, 0.15);
    m->variant = sy_choice(r, 3);
}

static void make_painting(sy_material *m, gv_rng *r)
{
    base(m, r, SY_MAT_PAINTING);
    m->variant = sy_choice(r, 3);
    double h = gv_rng_uniform(r);
    for (int i = 0; i < 4; i++) {
        double hi = h + U(r, -0.15, 0.15) + (i == 3 ? 0.5 : 0);
        m->color[i] = pick(r, hi, hi, 0.3, 0.8, 0.3, 0.95);
    }
    if (m->variant == 0) { /* landscape: sky, far, middle and near hills */
        m->color[0] = pick(r, 0.52, 0.62, 0.2, 0.5, 0.75, 0.95);
        m->color[1] = pick(r, 0.45, 0.6, 0.15, 0.35, 0.5, 0.7);
        m->color[2] = pick(r, 0.2, 0.35, 0.3, 0.6, 0.35, 0.55);
        m->color[3] = pick(r, 0.15, 0.3, 0.4, 0.7, 0.2, 0.35);
    }
}

/* A material of one kind with colours c0, c1 (drawn by the caller beforehand). */
static void make_solid(sy_material *m, gv_rng *r, sy_material_kind kind, sy_vec c0, sy_vec c1)
{
    base(m, r, kind);
    m->color[0] = c0;
    m->color[1] = c1;
}

static void make_other(sy_material *m, gv_rng *r, const char *role)
{
    sy_vec a, b;
    if (!strcmp(role, "ceiling")) {
        a = neutral(r, 0.82, 0.95);
        b = neutral(r, 0.7, 0.8);
        make_solid(m, r, SY_MAT_PLASTER, a, b);
        m->variation = U(r, 0.2, 0.5);
    } else if (!strcmp(role, "wood")) {
        a = wood(r);
        make_solid(m, r, SY_MAT_WOOD, a, sy_scale(a, U(r, 0.45, 0.75)));
        m->scale[0] = U(r, 0.006, 0.02);
        m->axis = sy_choice(r, 2);
    } else if (!strcmp(role, "metal")) {
        a = gv_rng_uniform(r) < 0.5 ? neutral(r, 0.1, 0.5) : pick(r, 0.09, 0.14, 0.4, 0.7, 0.5, 0.8);
        make_solid(m, r, SY_MAT_PAINT, a, a);
    } else if (!strcmp(role, "plastic")) {
        double k = gv_rng_uniform(r);
        a = accent(r);
        b = accent(r);
        make_solid(m, r, k < 0.6 ? SY_MAT_PAINT : k < 0.8 ? SY_MAT_STRIPES : SY_MAT_CHECKS, a, b);
        m->color[2] = neutral(r, 0.7, 0.9);
        m->scale[0] = U(r, 0.05, 0.15);
    } else if (!strcmp(role, "marble")) {
        a = gv_rng_uniform(r) < 0.7 ? neutral(r, 0.7, 0.92) : accent(r);
        b = neutral(r, 0.1, 0.45);
        make_solid(m, r, SY_MAT_MARBLE, a, b);
        m->scale[0] = U(r, 0.5, 2.0);
    } else if (!strcmp(role, "book")) {
        a = pick(r, 0, 1, 0.2, 0.8, 0.2, 0.8);
        b = gv_rng_uniform(r) < 0.5 ? sy_hsv(0.12, 0.6, 0.8) : neutral(r, 0.05, 0.9);
        make_solid(m, r, SY_MAT_BOOK, a, b);
        m->color[2] = sy_hsv(0.11, 0.15, 0.88);
    } else if (!strcmp(role, "foliage")) {
        a = pick(r, 0.2, 0.36, 0.45, 0.8, 0.35, 0.65);
        b = pick(r, 0.25, 0.4, 0.5, 0.9, 0.08, 0.2);
        make_solid(m, r, SY_MAT_FOLIAGE, a, b);
    } else if (!strcmp(role, "pot")) {
        a = gv_rng_uniform(r) < 0.5 ? pick(r, 0.03, 0.07, 0.5, 0.7, 0.55, 0.75) : accent(r);
        make_solid(m, r, SY_MAT_PAINT, a, a);
    } else if (!strcmp(role, "rug")) {
        a = accent(r);
        b = accent(r);
        make_solid(m, r, SY_MAT_RUG, a, b);
        m->color[2] = neutral(r, 0.5, 0.9);
        m->color[3] = sy_scale(a, 0.5);
        m->variant = sy_choice(r, 3);
        m->scale[0] = U(r, 0.1, 0.3);
    } else if (!strcmp(role, "ground")) {
        a = pick(r, 0.2, 0.3, 0.4, 0.7, 0.3, 0.5);
        b = pick(r, 0.08, 0.14, 0.3, 0.5, 0.4, 0.6);
        make_solid(m, r, SY_MAT_GROUND, a, b);
    } else if (!strcmp(role, "curtain")) {
        a = gv_rng_uniform(r) < 0.5 ? accent(r) : neutral(r, 0.5, 0.9);
        make_solid(m, r, SY_MAT_FABRIC, a, a);
        m->variant = 3;
        m->scale[0] = U(r, 0.06, 0.12);
    } else if (!strcmp(role, "dado")) { /* panelling: vertical boards, tiles or paint */
        double k = gv_rng_uniform(r);
        if (k < 0.4) {
            a = wood(r);
            make_solid(m, r, SY_MAT_PLANKS, a, sy_scale(a, 0.6));
            m->color[2] = sy_scale(a, 0.3);
            m->scale[0] = U(r, 0.08, 0.16);
            m->scale[1] = 5;
            m->scale[2] = 0.004;
            m->variant = 1;
        } else if (k < 0.7) {
            a = gv_rng_uniform(r) < 0.5 ? neutral(r, 0.6, 0.9) : accent(r);
            make_solid(m, r, SY_MAT_TILES, a, sy_scale(a, 0.92));
            m->color[2] = neutral(r, 0.5, 0.85);
            m->scale[0] = U(r, 0.1, 0.2);
            m->scale[1] = m->scale[0] * (gv_rng_uniform(r) < 0.5 ? 1 : 0.5);
        } else {
            a = accent(r);
            make_solid(m, r, SY_MAT_PAINT, a, a);
        }
    } else if (!strcmp(role, "frame") || !strcmp(role, "trim")) {
        double k = gv_rng_uniform(r);
        if (role[0] == 't') a = k < 0.7 ? neutral(r, 0.8, 0.95) : wood(r);
        else a = k < 0.4 ? wood(r) : k < 0.7 ? sy_hsv(0.12, 0.6, 0.75) : neutral(r, 0.05, 0.9);
        make_solid(m, r, SY_MAT_PAINT, a, a);
    } else {
        a = accent(r);
        make_solid(m, r, SY_MAT_PAINT, a, a);
    }
}

int sy_material_for(gv_synth_world *w, gv_rng *r, const char *role)
{
    sy_material m;
    if (!strcmp(role, "wall") || !strcmp(role, "accent")) make_wall(&m, r, role[0] == 'a');
    else if (!strcmp(role, "floor")) make_floor(&m, r);
    else if (!strcmp(role, "fabric")) make_fabric(&m, r);
    else if (!strcmp(role, "painting")) make_painting(&m, r);
    else make_other(&m, r, role);
    return sy_add_material(w, &m);
}
