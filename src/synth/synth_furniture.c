/* Placing the furniture: seeded kinds and sizes, by rejection sampling. An object stands
 * against a wall (facing the room) or freely (any turn); its footprint must lie in the
 * room, keep clear of the other objects, of the doorways, of the windows (if tall), and
 * keep PATH_CLEARANCE from the planned camera path in plan view. Also rugs on the floor,
 * curtains at windows and framed paintings on the walls, which the path clears by
 * construction (it keeps 0.45 m from the walls). */
#include "synth/synth_objects.h"

#include <stdio.h>
#include <string.h>

#define PATH_CLEARANCE 0.5
#define GAP 0.08
#define MAX_FOOTPRINTS 64

enum { FREE, WALL, EITHER };

typedef struct {
    const char *name;
    sy_object_builder build;
    double w0, w1, d0, d1; /* width and depth ranges (metres) */
    int place, square, tall;
    double weight;
} object_kind;

static const object_kind kinds[] = {
    {"table", sy_build_table, 0.9, 1.6, 0.6, 1.0, FREE, 0, 0, 1.2},
    {"bookshelf", sy_build_bookshelf, 0.8, 1.6, 0.3, 0.36, WALL, 0, 1, 1.0},
    {"cabinet", sy_build_cabinet, 0.6, 1.4, 0.4, 0.55, WALL, 0, 1, 0.8},
    {"sofa", sy_build_sofa, 1.6, 2.2, 0.8, 0.95, EITHER, 0, 0, 0.7},
    {"armchair", sy_build_sofa, 0.75, 0.95, 0.75, 0.9, FREE, 0, 0, 0.6},
    {"chair", sy_build_chair, 0.42, 0.5, 0.42, 0.5, FREE, 0, 0, 0.6},
    {"column", sy_build_column, 0.35, 0.6, 0.35, 0.6, FREE, 1, 1, 0.35},
    {"pedestal", sy_build_pedestal, 0.35, 0.5, 0.35, 0.5, FREE, 1, 0, 0.7},
    {"barrel", sy_build_barrel, 0.45, 0.7, 0.45, 0.7, FREE, 1, 0, 0.5},
    {"crates", sy_build_crates, 0.4, 0.8, 0.4, 0.8, EITHER, 1, 0, 0.6},
    {"plant", sy_build_plant, 0.5, 1.0, 0.5, 1.0, EITHER, 1, 1, 1.0},
    {"floor lamp", sy_build_floor_lamp, 0.3, 0.4, 0.3, 0.4, EITHER, 1, 1, 0.5},
    {"balls", sy_build_balls, 0.3, 0.8, 0.3, 0.8, FREE, 1, 0, 0.4},
};
#define N_KINDS (int)(sizeof kinds / sizeof kinds[0])

typedef struct { double x0, y0, x1, y1; } rect;

typedef struct {
    rect taken[MAX_FOOTPRINTS];
    int n_taken;
} placement;

static int overlaps(rect a, rect b, double gap)
{
    return a.x0 < b.x1 + gap && b.x0 < a.x1 + gap && a.y0 < b.y1 + gap && b.y0 < a.y1 + gap;
}

/* Plan-view zone in front of an opening, depth metres into the room. */
static rect opening_zone(const gv_synth_world *w, const sy_opening *o, double margin, double depth)
{
    sy_vec lo = w->room_lo, hi = w->room_hi;
    double a = o->s0 - margin, b = o->s1 + margin;
    switch (o->wall) {
    case 0: return (rect){lo.x + a, lo.y, lo.x + b, lo.y + depth};
    case 1: return (rect){hi.x - depth, lo.y + a, hi.x, lo.y + b};
    case 2: return (rect){lo.x + a, hi.y - depth, lo.x + b, hi.y};
    default: return (rect){lo.x, lo.y + a, lo.x + depth, lo.y + b};
    }
}

static int footprint_ok(const gv_synth_world *w, const placement *pl, rect f, int tall)
{
    if (f.x0 < w->room_lo.x + 0.01 || f.x1 > w->room_hi.x - 0.01 || f.y0 < w->room_lo.y + 0.01 ||
        f.y1 > w->room_hi.y - 0.01)
        return 0;
    for (int i = 0; i < pl->n_taken; i++)
        if (overlaps(f, pl->taken[i], GAP)) return 0;
    for (int i = 0; i < w->n_openings; i++) {
        const sy_opening *o = &w->openings[i];
        if (o->door && overlaps(f, opening_zone(w, o, 0.2, 1.2), 0)) return 0;
        if (!o->door && tall && overlaps(f, opening_zone(w, o, 0.3, 1.0), 0)) return 0;
    }
    for (int i = 0; i < w->n_plan; i++) {
        sy_vec p = w->plan[i];
        double dx = fmax(fmax(f.x0 - p.x, p.x - f.x1), 0), dy = fmax(fmax(f.y0 - p.y, p.y - f.y1), 0);
        if (dx * dx + dy * dy < PATH_CLEARANCE * PATH_CLEARANCE) return 0;
    }
    return 1;
}

static const object_kind *pick_kind(gv_rng *r)
{
    double total = 0;
    for (int i = 0; i < N_KINDS; i++) total += kinds[i].weight;
    double x = gv_rng_uniform(r) * total;
    for (int i = 0; i < N_KINDS; i++) {
        x -= kinds[i].weight;
        if (x < 0) return &kinds[i];
    }
    return &kinds[N_KINDS - 1];
}

/* A frame and footprint for an object of width x depth, against a wall or free. */
static rect propose(const gv_synth_world *w, gv_rng *r, int on_wall, double width, double depth, sy_frame *f)
{
    sy_vec lo = w->room_lo, hi = w->room_hi;
    double yaw;
    if (on_wall) {
        int k = sy_choice(r, 4);
        double len = k % 2 ? hi.y - lo.y : hi.x - lo.x;
        double s = sy_uniform(r, 0.5 * width + 0.02, fmax(len - 0.5 * width - 0.02, 0.5 * width + 0.02));
        double d = 0.5 * depth + 0.02;
        const double yaws[4] = {0, 0.5 * M_PI, M_PI, -0.5 * M_PI};
        yaw = yaws[k];
        if (k == 0) f->origin = sy_v(lo.x + s, lo.y + d, 0);
        else if (k == 1) f->origin = sy_v(hi.x - d, lo.y + s, 0);
        else if (k == 2) f->origin = sy_v(lo.x + s, hi.y - d, 0);
        else f->origin = sy_v(lo.x + d, lo.y + s, 0);
    } else {
        if (gv_rng_uniform(r) < 0.5) { /* square to the walls, give or take */
            int quarter = sy_choice(r, 4);
            yaw = quarter * 0.5 * M_PI + sy_uniform(r, -0.15, 0.15);
        } else {
            yaw = sy_uniform(r, -M_PI, M_PI);
        }
        double x = sy_uniform(r, lo.x + 0.3, hi.x - 0.3);
        double y = sy_uniform(r, lo.y + 0.3, hi.y - 0.3);
        f->origin = sy_v(x, y, 0);
    }
    f->yaw = yaw;
    double c = fabs(cos(yaw)), s = fabs(sin(yaw));
    double ex = 0.5 * (c * width + s * depth), ey = 0.5 * (s * width + c * depth);
    return (rect){f->origin.x - ex, f->origin.y - ey, f->origin.x + ex, f->origin.y + ey};
}

static void note_object(gv_synth_world *w, const char *name)
{
    size_t used = strlen(w->object_names);
    snprintf(w->object_names + used, sizeof w->object_names - used, "%s%s", used ? ", " : "", name);
    w->n_objects++;
}

static int place_objects(gv_synth_world *w, gv_rng *r, placement *pl)
{
    double area = (w->room_hi.x - w->room_lo.x) * (w->room_hi.y - w->room_lo.y);
    int target = 4 + (int)(area / 5) + sy_choice(r, 3), lamps = 0;
    if (target > 16) target = 16;
    for (int attempt = 0; attempt < 40 * target && w->n_objects < target && pl->n_taken < MAX_FOOTPRINTS; attempt++) {
        const object_kind *k = pick_kind(r);
        if (k->build == sy_build_floor_lamp && lamps >= 2) continue;
        double width = sy_uniform(r, k->w0, k->w1), depth = k->square ? width : sy_uniform(r, k->d0, k->d1);
        int on_wall = k->place == WALL || (k->place == EITHER && gv_rng_uniform(r) < 0.5);
        sy_frame f;
        rect fp = propose(w, r, on_wall, width, depth, &f);
        if (!footprint_ok(w, pl, fp, k->tall)) continue;
        if (sy_begin_group(w, 1) || k->build(w, r, &f, width, depth)) return -1;
        sy_end_group(w);
        pl->taken[pl->n_taken++] = fp;
        lamps += k->build == sy_build_floor_lamp;
        note_object(w, k->name);
    }
    return 0;
}

static int place_rugs(gv_synth_world *w, gv_rng *r)
{
    int n = sy_choice(r, 3);
    rect rugs[2];
    int placed = 0;
    for (int attempt = 0; attempt < 20 && placed < n; attempt++) {
        double hx = 0.5 * sy_uniform(r, 1.2, 3.0), hy = 0.5 * sy_uniform(r, 0.8, 2.0);
        double x = sy_uniform(r, w->room_lo.x + hx + 0.2, w->room_hi.x - hx - 0.2);
        double y = sy_uniform(r, w->room_lo.y + hy + 0.2, w->room_hi.y - hy - 0.2);
        rect fp = {x - hx, y - hy, x + hx, y + hy};
        if (fp.x0 < w->room_lo.x || fp.x1 > w->room_hi.x || fp.y0 < w->room_lo.y || fp.y1 > w->room_hi.y) continue;
        if (placed && overlaps(fp, rugs[0], 0.1)) continue;
        int m = sy_material_for(w, r, "rug");
        if (m < 0 || sy_begin_group(w, 0) || sy_add_box(w, sy_v(x, y, 0.006), sy_v(hx, hy, 0.006), 0, m) < 0) return -1;
        w->groups[w->n_groups - 1].outward = sy_v(0, 0, -1);
        sy_end_group(w);
        rugs[placed++] = fp;
    }
    return 0;
}

/* A frame on wall k at s metres from its start, x along the wall (either way), y into the
 * room, z up. */
static sy_frame wall_frame(const gv_synth_world *w, int k, double s)
{
    sy_vec lo = w->room_lo, hi = w->room_hi;
    const double yaws[4] = {0, 0.5 * M_PI, M_PI, -0.5 * M_PI};
    sy_frame f = {k == 0 ? sy_v(lo.x + s, lo.y, 0) : k == 1 ? sy_v(hi.x, lo.y + s, 0)
                : k == 2 ? sy_v(lo.x + s, hi.y, 0) : sy_v(lo.x, lo.y + s, 0), yaws[k]};
    return f;
}

/* Curtains on some windows: a panel each side on a rod, long or to the sill; their
 * footprints are taken so that furniture does not stand in them. */
static int place_curtains(gv_synth_world *w, gv_rng *r, placement *pl)
{
    double last_end[4] = {-1e9, -1e9, -1e9, -1e9}; /* per wall, where the last rod ends */
    for (int i = 0; i < w->n_openings && pl->n_taken < MAX_FOOTPRINTS; i++) {
        const sy_opening *o = &w->openings[i];
        if (o->door || gv_rng_uniform(r) < 0.5) continue;
        double width = sy_uniform(r, 0.15, 0.28), half = 0.5 * (o->s1 - o->s0);
        if (o->s0 - width - 0.04 < last_end[o->wall] + 0.05) continue; /* the neighbour's curtains */
        last_end[o->wall] = o->s1 + width + 0.04;
        double top = fmin(w->room_hi.z - 0.05, o->z1 + 0.15);
        double bottom = gv_rng_uniform(r) < 0.5 ? 0.02 : o->z0 - 0.1;
        int cloth = sy_material_for(w, r, "curtain"), rod = sy_material_for(w, r, "metal");
        if (cloth < 0 || rod < 0 || sy_begin_group(w, 0)) return -1;
        sy_frame f = wall_frame(w, o->wall, 0.5 * (o->s0 + o->s1));
        sy_vec panel = sy_v(0.5 * width, 0.02, 0.5 * (top - bottom));
        double x = half + 0.5 * width - 0.05;
        if (sy_part_box(w, &f, sy_v(-x, 0.08, 0.5 * (top + bottom)), panel, cloth) < 0 ||
            sy_part_box(w, &f, sy_v(x, 0.08, 0.5 * (top + bottom)), panel, cloth) < 0 ||
            sy_part_box(w, &f, sy_v(0, 0.08, top + 0.012), sy_v(half + width + 0.04, 0.012, 0.012), rod) < 0)
            return -1;
        sy_end_group(w);
        const sy_group *g = &w->groups[w->n_groups - 1];
        pl->taken[pl->n_taken++] = (rect){g->lo.x, g->lo.y, g->hi.x, g->hi.y};
    }
    return 0;
}

/* Framed paintings on free stretches of wall, clear of openings and tall furniture. */
static int place_paintings(gv_synth_world *w, gv_rng *r)
{
    int n = 1 + sy_choice(r, 4), placed = 0;
    for (int attempt = 0; attempt < 30 && placed < n; attempt++) {
        int k = sy_choice(r, 4);
        double len = k % 2 ? w->room_hi.y - w->room_lo.y : w->room_hi.x - w->room_lo.x;
        double pw = sy_uniform(r, 0.4, 1.2), ph = sy_uniform(r, 0.3, 0.9), border = sy_uniform(r, 0.03, 0.08);
        double zc = fmin(sy_uniform(r, 1.3, 1.8), w->room_hi.z - 0.25 - 0.5 * ph);
        double s = sy_uniform(r, 0.5 * pw + 0.3, len - 0.5 * pw - 0.3);
        sy_opening span = {.wall = k, .s0 = s - 0.5 * pw - border, .s1 = s + 0.5 * pw + border};
        int clear = span.s0 > 0.1 && span.s1 < len - 0.1;
        for (int i = 0; i < w->n_openings && clear; i++) {
            const sy_opening *o = &w->openings[i];
            if (o->wall == k && span.s0 < o->s1 + 0.35 && o->s0 < span.s1 + 0.35) clear = 0; /* and curtains */
        }
        sy_frame f = wall_frame(w, k, s);
        /* a square around the painting's middle in plan: a little more than it covers */
        double half = 0.5 * pw + border;
        sy_vec box_lo = sy_v(f.origin.x - half, f.origin.y - half, zc - 0.5 * ph - border);
        sy_vec box_hi = sy_v(f.origin.x + half, f.origin.y + half, zc + 0.5 * ph + border);
        for (int g = 0; g < w->n_groups && clear; g++) {
            const sy_group *o = &w->groups[g];
            int apart = o->lo.x > box_hi.x + 0.05 || box_lo.x > o->hi.x + 0.05 || o->lo.y > box_hi.y + 0.05 ||
                        box_lo.y > o->hi.y + 0.05 || o->lo.z > box_hi.z || box_lo.z > o->hi.z;
            if (o->furniture && !apart) clear = 0;
        }
        if (!clear) continue;
        int frame = sy_material_for(w, r, "frame"), canvas = sy_material_for(w, r, "painting");
        if (frame < 0 || canvas < 0 || sy_begin_group(w, 1)) return -1;
        /* a board for the frame, the canvas standing 1 cm proud of it */
        if (sy_part_box(w, &f, sy_v(0, 0.0125, zc), sy_v(0.5 * pw + border, 0.0125, 0.5 * ph + border), frame) < 0 ||
            sy_part_box(w, &f, sy_v(0, 0.0175, zc), sy_v(0.5 * pw, 0.0175, 0.5 * ph), canvas) < 0)
            return -1;
        sy_end_group(w);
        placed++;
    }
    return 0;
}

int sy_place_furniture(gv_synth_world *w, gv_rng *r)
{
    placement pl;
    memset(&pl, 0, sizeof pl);
    if (place_rugs(w, r) || place_curtains(w, r, &pl) || place_objects(w, r, &pl) || place_paintings(w, r))
        return -1;
    return 0;
}
