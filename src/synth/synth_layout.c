/* The room: a seeded box-shaped enclosure (floor, ceiling, four thick walls) with windows
 * and a door cut into the walls, window frames, door casings, skirting boards and sometimes
 * ceiling beams; outside, an infinite ground under the sky. Walls are built from boxes
 * around their openings so that the openings are real holes (sun comes in through them). */
#include "synth/synth_internal.h"

#include <stdlib.h>

#define WALL_THICKNESS 0.15
#define SLAB 0.1

/* Wall k runs from its start corner along dir for len metres; inward points into the room. */
typedef struct { sy_vec start, dir, inward; double len; } wall_line;

static wall_line wall_of(const gv_synth_world *w, int k)
{
    sy_vec lo = w->room_lo, hi = w->room_hi;
    wall_line l;
    if (k == 0) { l.start = sy_v(lo.x, lo.y, 0); l.dir = sy_v(1, 0, 0); l.inward = sy_v(0, 1, 0); }
    else if (k == 1) { l.start = sy_v(hi.x, lo.y, 0); l.dir = sy_v(0, 1, 0); l.inward = sy_v(-1, 0, 0); }
    else if (k == 2) { l.start = sy_v(lo.x, hi.y, 0); l.dir = sy_v(1, 0, 0); l.inward = sy_v(0, -1, 0); }
    else { l.start = sy_v(lo.x, lo.y, 0); l.dir = sy_v(0, 1, 0); l.inward = sy_v(1, 0, 0); }
    l.len = k % 2 ? hi.y - lo.y : hi.x - lo.x;
    return l;
}

/* A box spanning [s0, s1] along a wall, [z0, z1] in height and [d0, d1] along the inward
 * normal (negative d is inside the wall). */
static int wall_box(gv_synth_world *w, const wall_line *l, double s0, double s1, double z0,
                    double z1, double d0, double d1, int material)
{
    sy_vec c = sy_add(sy_add(l->start, sy_scale(l->dir, 0.5 * (s0 + s1))), sy_scale(l->inward, 0.5 * (d0 + d1)));
    c.z = 0.5 * (z0 + z1);
    double hs = 0.5 * (s1 - s0), hd = 0.5 * (d1 - d0), hz = 0.5 * (z1 - z0);
    sy_vec half = l->dir.x != 0 ? sy_v(hs, hd, hz) : sy_v(hd, hs, hz);
    return sy_add_box(w, c, half, 0, material) < 0 ? -1 : 0;
}

static int cmp_opening(const void *a, const void *b)
{
    const sy_opening *x = a, *y = b;
    return (x->wall - y->wall) * 1000 + (x->s0 > y->s0) - (x->s0 < y->s0);
}

static int fits(const gv_synth_world *w, const sy_opening *o, double len)
{
    if (o->s0 < 0.35 || o->s1 > len - 0.35) return 0;
    for (int i = 0; i < w->n_openings; i++) {
        const sy_opening *p = &w->openings[i];
        if (p->wall == o->wall && o->s0 < p->s1 + 0.45 && p->s0 < o->s1 + 0.45) return 0;
    }
    return 1;
}

static void choose_openings(gv_synth_world *w, gv_rng *r)
{
    double H = w->room_hi.z;
    int want_door = gv_rng_uniform(r) < 0.6;
    int door_wall = sy_choice(r, 4);
    for (int k = 0; k < 4; k++) {
        double len = wall_of(w, k).len;
        int n = (k == door_wall && want_door);
        double q = gv_rng_uniform(r);
        int windows = q < 0.4 ? 0 : q < 0.8 ? 1 : 2;
        for (int i = 0; i < n + windows && w->n_openings < SY_MAX_OPENINGS; i++) {
            int door = i < n;
            for (int attempt = 0; attempt < 20; attempt++) {
                sy_opening o = {.wall = k, .door = door};
                double width = door ? sy_uniform(r, 0.85, 1.2) : sy_uniform(r, 0.7, 1.8);
                o.s0 = sy_uniform(r, 0.35, len - 0.35 - width);
                o.s1 = o.s0 + width;
                o.z0 = door ? 0 : sy_uniform(r, 0.65, 1.0);
                o.z1 = door ? fmin(H - 0.25, 2.1) : fmin(H - 0.3, o.z0 + sy_uniform(r, 1.0, 1.6));
                if (fits(w, &o, len)) {
                    w->openings[w->n_openings++] = o;
                    break;
                }
            }
        }
    }
    qsort(w->openings, w->n_openings, sizeof *w->openings, cmp_opening);
}

/* Frame of a window (sides, head, sill and a cross of mullions) or casing of a door. */
static int opening_trim(gv_synth_world *w, const wall_line *l, const sy_opening *o, int trim)
{
    double T = WALL_THICKNESS, f = 0.05;
    if (o->door) { /* casing on the inner face around the doorway */
        if (wall_box(w, l, o->s0 - 0.07, o->s0, 0, o->z1 + 0.07, 0, 0.02, trim)) return -1;
        if (wall_box(w, l, o->s1, o->s1 + 0.07, 0, o->z1 + 0.07, 0, 0.02, trim)) return -1;
        return wall_box(w, l, o->s0, o->s1, o->z1, o->z1 + 0.07, 0, 0.02, trim);
    }
    double d0 = -0.65 * T, d1 = -0.35 * T, mid_s = 0.5 * (o->s0 + o->s1), mid_z = o->z0 + 0.6 * (o->z1 - o->z0);
    if (wall_box(w, l, o->s0, o->s0 + f, o->z0, o->z1, d0, d1, trim)) return -1;
    if (wall_box(w, l, o->s1 - f, o->s1, o->z0, o->z1, d0, d1, trim)) return -1;
    if (wall_box(w, l, o->s0, o->s1, o->z1 - f, o->z1, d0, d1, trim)) return -1;
    if (wall_box(w, l, o->s0 - 0.04, o->s1 + 0.04, o->z0 - 0.03, o->z0 + 0.01, -T, 0.05, trim)) return -1; /* sill */
    if (wall_box(w, l, mid_s - 0.02, mid_s + 0.02, o->z0, o->z1, d0, d1, trim)) return -1;
    return wall_box(w, l, o->s0, o->s1, mid_z - 0.02, mid_z + 0.02, d0, d1, trim);
}

/* Lower-wall finish over [s0, s1]: a skirting board, and when the room has one, a dado
 * (panelling up to dado_h, 1 cm proud of the wall) with a rail on top. */
static int wall_base(gv_synth_world *w, const wall_line *l, double s0, double s1, int trim, int dado, double dado_h)
{
    if (s1 <= s0) return 0;
    if (wall_box(w, l, s0, s1, 0, 0.1, 0, 0.015, trim)) return -1;
    if (dado < 0) return 0;
    if (wall_box(w, l, s0, s1, 0.1, dado_h, 0, 0.01, dado)) return -1;
    return wall_box(w, l, s0, s1, dado_h, dado_h + 0.035, 0, 0.02, trim);
}

/* One wall: full-height pieces between openings, pieces above and below each opening,
 * trims, and the lower-wall finish where the wall meets the floor (broken at doors). */
static int build_wall(gv_synth_world *w, int k, int material, int trim, int dado, double dado_h)
{
    wall_line l = wall_of(w, k);
    double H = w->room_hi.z, T = WALL_THICKNESS;
    if (sy_begin_group(w, 0)) return -1;
    w->groups[w->n_groups - 1].outward = sy_scale(l.inward, -1);
    double s = -T, base_from = 0;
    for (int i = 0; i < w->n_openings; i++) {
        const sy_opening *o = &w->openings[i];
        if (o->wall != k) continue;
        if (wall_box(w, &l, s, o->s0, 0, H, -T, 0, material)) return -1;
        if (o->z0 > 0 && wall_box(w, &l, o->s0, o->s1, 0, o->z0, -T, 0, material)) return -1;
        if (wall_box(w, &l, o->s0, o->s1, o->z1, H, -T, 0, material)) return -1;
        if (opening_trim(w, &l, o, trim)) return -1;
        if (o->door) {
            if (wall_base(w, &l, base_from, o->s0 - 0.07, trim, dado, dado_h)) return -1;
            base_from = o->s1 + 0.07;
        }
        s = o->s1;
    }
    if (wall_box(w, &l, s, l.len + T, 0, H, -T, 0, material)) return -1;
    if (wall_base(w, &l, base_from, l.len, trim, dado, dado_h)) return -1;
    sy_end_group(w);
    return 0;
}

static int build_slabs(gv_synth_world *w, gv_rng *r, int floor, int ceiling)
{
    double T = WALL_THICKNESS, H = w->room_hi.z;
    sy_vec half = sy_v(w->room_hi.x + T, w->room_hi.y + T, 0.5 * SLAB);
    if (sy_begin_group(w, 0) || sy_add_box(w, sy_v(0, 0, -0.5 * SLAB), half, 0, floor) < 0) return -1;
    w->groups[w->n_groups - 1].outward = sy_v(0, 0, -1);
    sy_end_group(w);
    if (sy_begin_group(w, 0) || sy_add_box(w, sy_v(0, 0, H + 0.5 * SLAB), half, 0, ceiling) < 0) return -1;
    w->groups[w->n_groups - 1].outward = sy_v(0, 0, 1);
    if (gv_rng_uniform(r) < 0.3) { /* beams across the short side */
        int wood = sy_material_for(w, r, "wood");
        if (wood < 0) return -1;
        int along_x = w->room_hi.x < w->room_hi.y;
        double span = along_x ? 2 * w->room_hi.y : 2 * w->room_hi.x;
        int n = (int)(span / sy_uniform(r, 0.9, 1.6));
        for (int i = 1; i < n; i++) {
            double c = -0.5 * span + span * i / n;
            sy_vec center = along_x ? sy_v(0, c, H - 0.09) : sy_v(c, 0, H - 0.09);
            sy_vec bh = along_x ? sy_v(w->room_hi.x, 0.06, 0.09) : sy_v(0.06, w->room_hi.y, 0.09);
            if (sy_add_box(w, center, bh, 0, wood) < 0) return -1;
        }
    }
    sy_end_group(w);
    return 0;
}

int sy_build_room(gv_synth_world *w, gv_rng *r)
{
    double width = sy_uniform(r, 4.5, 9.0), depth = sy_uniform(r, 4.0, 7.5);
    double height = sy_uniform(r, 2.5, 3.4);
    w->room_lo = sy_v(-0.5 * width, -0.5 * depth, 0);
    w->room_hi = sy_v(0.5 * width, 0.5 * depth, height);
    choose_openings(w, r);

    int wall = sy_material_for(w, r, "wall");
    int accent = gv_rng_uniform(r) < 0.5 ? sy_material_for(w, r, "accent") : wall;
    int accent_wall = sy_choice(r, 4);
    int floor = sy_material_for(w, r, "floor");
    int ceiling = sy_material_for(w, r, "ceiling");
    int trim = sy_material_for(w, r, "trim");
    int ground = sy_material_for(w, r, "ground");
    if (wall < 0 || accent < 0 || floor < 0 || ceiling < 0 || trim < 0 || ground < 0) return -1;
    /* a dado in some rooms, below the lowest window sill */
    double dado_h = sy_uniform(r, 0.8, 1.1);
    for (int i = 0; i < w->n_openings; i++)
        if (!w->openings[i].door) dado_h = fmin(dado_h, w->openings[i].z0 - 0.08);
    int dado = gv_rng_uniform(r) < 0.3 && dado_h > 0.5 ? sy_material_for(w, r, "dado") : -1;
    if (build_slabs(w, r, floor, ceiling)) return -1;
    for (int k = 0; k < 4; k++)
        if (build_wall(w, k, k == accent_wall ? accent : wall, trim, dado, dado_h)) return -1;
    w->wall_material = wall;
    w->floor_material = floor;
    w->sky.ground_z = -0.02;
    w->sky.ground_material = ground;
    w->sky.seed = gv_rng_u32(r);
    return 0;
}
