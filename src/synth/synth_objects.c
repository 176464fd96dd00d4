/* Furniture made of boxes, cylinders and spheres, each in its own frame (x across its
 * width, y towards its front, z up, origin at the middle of its footprint on the floor):
 * tables with things on them, bookshelves full of books, cabinets, sofas, chairs. Sizes
 * come from the placement (width x depth); heights and details from the random stream. */
#include "synth/synth_objects.h"

static double U(gv_rng *r, double lo, double hi) { return sy_uniform(r, lo, hi); }

/* A frame for a part placed at (x, y, z) of f and turned by extra yaw. */
static sy_frame sub_frame(const sy_frame *f, double x, double y, double z, double yaw)
{
    double c = cos(f->yaw), s = sin(f->yaw);
    sy_frame g = {sy_v(f->origin.x + c * x - s * y, f->origin.y + s * x + c * y, f->origin.z + z), f->yaw + yaw};
    return g;
}

/* Vases, balls, bowls and book stacks on a surface at height z, within w x d. */
int sy_things_on_top(gv_synth_world *w, gv_rng *r, const sy_frame *f, double width, double depth, double z)
{
    int n = sy_choice(r, 4);
    for (int i = 0; i < n; i++) {
        double slot = width / n, x = -0.5 * width + slot * (i + 0.5) + U(r, -0.2, 0.2) * slot;
        double y = U(r, -0.3, 0.3) * depth, room = fmin(0.5 * slot, 0.5 * depth) - 0.02;
        if (room < 0.05) continue;
        int kind = sy_choice(r, 4);
        if (kind == 0) { /* vase, sometimes with a bunch of leaves */
            double radius = U(r, 0.04, fmin(0.09, room)), height = U(r, 0.12, 0.35);
            int m = sy_material_for(w, r, gv_rng_uniform(r) < 0.5 ? "pot" : "plastic");
            if (m < 0 || sy_part_cylinder(w, f, sy_v(x, y, z), radius, height, m) < 0) return -1;
            if (gv_rng_uniform(r) < 0.4) {
                int leaves = sy_material_for(w, r, "foliage");
                sy_vec bunch = sy_v(x, y, z + height + 0.05);
                if (leaves < 0 || sy_part_sphere(w, f, bunch, 2.2 * radius, leaves) < 0) return -1;
            }
        } else if (kind == 1) { /* ball */
            double radius = U(r, 0.04, fmin(0.1, room));
            int m = sy_material_for(w, r, "plastic");
            if (m < 0 || sy_part_sphere(w, f, sy_v(x, y, z + radius), radius, m) < 0) return -1;
        } else if (kind == 2) { /* bowl: a sphere sunk into the surface */
            double radius = U(r, 0.06, fmin(0.13, room + 0.03));
            int m = sy_material_for(w, r, gv_rng_uniform(r) < 0.5 ? "pot" : "marble");
            if (m < 0 || sy_part_sphere(w, f, sy_v(x, y, z - 0.5 * radius), radius, m) < 0) return -1;
        } else { /* a stack of books, each a little turned */
            int books = 1 + sy_choice(r, 4);
            double zz = z;
            for (int b = 0; b < books; b++) {
                double t = U(r, 0.02, 0.05), turn = U(r, -0.3, 0.3);
                int m = sy_material_for(w, r, "book");
                sy_frame g = sub_frame(f, x, y, zz, turn);
                sy_vec half = sy_v(fmin(0.1, room), fmin(0.14, room), 0.5 * t);
                if (m < 0 || sy_part_box(w, &g, sy_v(0, 0, 0.5 * t), half, m) < 0) return -1;
                zz += t;
            }
        }
    }
    return 0;
}

int sy_build_table(gv_synth_world *w, gv_rng *r, const sy_frame *f, double width, double depth)
{
    double h = U(r, 0.72, 0.78), top = U(r, 0.03, 0.05);
    int board = sy_material_for(w, r, gv_rng_uniform(r) < 0.7 ? "wood" : "marble");
    int legs = gv_rng_uniform(r) < 0.5 ? board : sy_material_for(w, r, "metal");
    int round_legs = gv_rng_uniform(r) < 0.4;
    if (board < 0 || legs < 0) return -1;
    if (sy_part_box(w, f, sy_v(0, 0, h - 0.5 * top), sy_v(0.5 * width, 0.5 * depth, 0.5 * top), board) < 0) return -1;
    for (int i = 0; i < 4; i++) {
        double x = (i & 1 ? 1 : -1) * (0.5 * width - 0.07), y = (i & 2 ? 1 : -1) * (0.5 * depth - 0.07);
        sy_vec leg = sy_v(0.025, 0.025, 0.5 * (h - top));
        int ok = round_legs ? sy_part_cylinder(w, f, sy_v(x, y, 0), 0.022, h - top, legs)
                            : sy_part_box(w, f, sy_v(x, y, 0.5 * (h - top)), leg, legs);
        if (ok < 0) return -1;
    }
    return sy_things_on_top(w, r, f, width - 0.1, depth - 0.1, h);
}

/* Books on one shelf between x0 and x1, standing on z, at most `height` tall. */
static int shelf_books(gv_synth_world *w, gv_rng *r, const sy_frame *f, const int *mats, int n_mats,
                       double x0, double x1, double z, double height, double depth)
{
    double x = x0 + U(r, 0, 0.1);
    while (x < x1 - 0.02) {
        if (gv_rng_uniform(r) < 0.07) { x += U(r, 0.05, 0.25); continue; }
        double t = U(r, 0.018, 0.05), hb = height * U(r, 0.6, 0.92), db = depth * U(r, 0.7, 0.92);
        if (x + t > x1) break;
        int m = mats[sy_choice(r, n_mats)];
        sy_vec center = sy_v(x + 0.5 * t, -0.5 * depth + 0.01 + 0.5 * db, z + 0.5 * hb);
        if (sy_part_box(w, f, center, sy_v(0.5 * t, 0.5 * db, 0.5 * hb), m) < 0) return -1;
        x += t + 0.001;
    }
    return 0;
}

int sy_build_bookshelf(gv_synth_world *w, gv_rng *r, const sy_frame *f, double width, double depth)
{
    double H = U(r, 1.6, fmin(2.1, w->room_hi.z - 0.3)), t = 0.02;
    int wood = sy_material_for(w, r, gv_rng_uniform(r) < 0.6 ? "wood" : "trim");
    int mats[7];
    for (int i = 0; i < 7; i++) mats[i] = sy_material_for(w, r, "book");
    if (wood < 0 || mats[6] < 0) return -1;
    if (sy_part_box(w, f, sy_v(-0.5 * width + 0.5 * t, 0, 0.5 * H), sy_v(0.5 * t, 0.5 * depth, 0.5 * H), wood) < 0 ||
        sy_part_box(w, f, sy_v(0.5 * width - 0.5 * t, 0, 0.5 * H), sy_v(0.5 * t, 0.5 * depth, 0.5 * H), wood) < 0 ||
        sy_part_box(w, f, sy_v(0, -0.5 * depth + 0.005, 0.5 * H), sy_v(0.5 * width, 0.005, 0.5 * H), wood) < 0 ||
        sy_part_box(w, f, sy_v(0, 0, H - 0.5 * t), sy_v(0.5 * width, 0.5 * depth, 0.5 * t), wood) < 0)
        return -1;
    int levels = (int)((H - 0.1) / U(r, 0.3, 0.4));
    if (levels < 2) levels = 2;
    double step = (H - 0.08 - t) / levels;
    for (int k = 0; k < levels; k++) {
        double z = 0.08 + k * step;
        sy_end_group(w); /* one group per level: rays skip the other levels' books */
        if (sy_begin_group(w, 1)) return -1;
        double bottom = k == 0 ? 0 : z - t; /* the lowest board is a plinth down to the floor */
        sy_vec half = sy_v(0.5 * width - t, 0.5 * depth, 0.5 * (z - bottom));
        if (sy_part_box(w, f, sy_v(0, 0, 0.5 * (bottom + z)), half, wood) < 0) return -1;
        if (gv_rng_uniform(r) < 0.85 &&
            shelf_books(w, r, f, mats, 7, -0.5 * width + t, 0.5 * width - t, z, step - t - 0.02, depth - 0.02))
            return -1;
    }
    return 0;
}

int sy_build_cabinet(gv_synth_world *w, gv_rng *r, const sy_frame *f, double width, double depth)
{
    double H = U(r, 0.7, 1.1);
    int body = sy_material_for(w, r, gv_rng_uniform(r) < 0.5 ? "wood" : "trim");
    int front = gv_rng_uniform(r) < 0.5 ? body : sy_material_for(w, r, "frame");
    int knob = sy_material_for(w, r, "metal");
    if (body < 0 || front < 0 || knob < 0) return -1;
    sy_vec half = sy_v(0.5 * width - 0.01, 0.5 * depth - 0.01, 0.5 * (H - 0.03));
    if (sy_part_box(w, f, sy_v(0, 0, 0.5 * (H - 0.03)), half, body) < 0 ||
        sy_part_box(w, f, sy_v(0, 0.01, H - 0.015), sy_v(0.5 * width + 0.01, 0.5 * depth, 0.015), body) < 0)
        return -1;
    int cols = width > 0.9 ? 2 : 1, rows = 1 + sy_choice(r, 3);
    double cw = (width - 0.04) / cols, rh = (H - 0.12) / rows;
    for (int i = 0; i < cols; i++) {
        for (int j = 0; j < rows; j++) {
            double x = -0.5 * width + 0.02 + cw * (i + 0.5), z = 0.06 + rh * (j + 0.5);
            sy_vec door = sy_v(0.5 * cw - 0.006, 0.008, 0.5 * rh - 0.006); /* a drawer or door front */
            sy_vec knob_at = sy_v(x, 0.5 * depth + 0.02, z + (rows == 1 ? 0.3 * rh : 0));
            if (sy_part_box(w, f, sy_v(x, 0.5 * depth - 0.002, z), door, front) < 0 ||
                sy_part_sphere(w, f, knob_at, 0.014, knob) < 0)
                return -1;
        }
    }
    return H < 1.0 ? sy_things_on_top(w, r, f, width - 0.1, depth - 0.1, H) : 0;
}

/* A sofa (or an armchair when narrow): base, back, arms, seat cushions, short feet. */
int sy_build_sofa(gv_synth_world *w, gv_rng *r, const sy_frame *f, double width, double depth)
{
    int cloth = sy_material_for(w, r, "fabric");
    int cushion = gv_rng_uniform(r) < 0.6 ? cloth : sy_material_for(w, r, "fabric");
    int feet = sy_material_for(w, r, "wood");
    if (cloth < 0 || cushion < 0 || feet < 0) return -1;
    double seat = U(r, 0.38, 0.45), back = U(r, 0.75, 0.95), arm = U(r, 0.1, 0.18), arm_h = U(r, 0.55, 0.68);
    double bd = 0.2, hw = 0.5 * width, hd = 0.5 * depth, arm_z = 0.5 * (0.06 + arm_h);
    sy_vec arm_half = sy_v(0.5 * arm, hd, 0.5 * (arm_h - 0.06));
    sy_vec base_half = sy_v(hw - arm, hd, 0.5 * (seat - 0.06)), back_half = sy_v(hw - arm, 0.5 * bd, 0.5 * (back - seat));
    if (sy_part_box(w, f, sy_v(0, 0, 0.5 * (0.06 + seat)), base_half, cloth) < 0 ||
        sy_part_box(w, f, sy_v(0, -hd + 0.5 * bd, 0.5 * (seat + back)), back_half, cloth) < 0 ||
        sy_part_box(w, f, sy_v(-hw + 0.5 * arm, 0, arm_z), arm_half, cloth) < 0 ||
        sy_part_box(w, f, sy_v(hw - 0.5 * arm, 0, arm_z), arm_half, cloth) < 0)
        return -1;
    int n = width > 1.3 ? 2 + sy_choice(r, 2) : 1;
    double cw = (width - 2 * arm) / n;
    for (int i = 0; i < n; i++) {
        double x = -hw + arm + cw * (i + 0.5);
        sy_vec half = sy_v(0.5 * cw - 0.008, hd - 0.5 * bd - 0.01, 0.06);
        if (sy_part_box(w, f, sy_v(x, 0.5 * bd, seat + 0.06), half, cushion) < 0) return -1;
    }
    for (int i = 0; i < 4; i++) {
        double x = (i & 1 ? 1 : -1) * (hw - 0.06), y = (i & 2 ? 1 : -1) * (hd - 0.06);
        if (sy_part_box(w, f, sy_v(x, y, 0.03), sy_v(0.025, 0.025, 0.03), feet) < 0) return -1;
    }
    return 0;
}

int sy_build_chair(gv_synth_world *w, gv_rng *r, const sy_frame *f, double width, double depth)
{
    int m = sy_material_for(w, r, gv_rng_uniform(r) < 0.6 ? "wood" : "plastic");
    if (m < 0) return -1;
    double seat = U(r, 0.43, 0.48), back = U(r, 0.35, 0.5), hw = 0.5 * width, hd = 0.5 * depth;
    if (sy_part_box(w, f, sy_v(0, 0, seat - 0.02), sy_v(hw, hd, 0.02), m) < 0 ||
        sy_part_box(w, f, sy_v(0, -hd + 0.015, seat + 0.5 * back), sy_v(hw, 0.015, 0.5 * back), m) < 0)
        return -1;
    for (int i = 0; i < 4; i++) {
        double x = (i & 1 ? 1 : -1) * (hw - 0.025), y = (i & 2 ? 1 : -1) * (hd - 0.025);
        sy_vec leg = sy_v(0.017, 0.017, 0.5 * (seat - 0.04));
        if (sy_part_box(w, f, sy_v(x, y, 0.5 * (seat - 0.04)), leg, m) < 0) return -1;
    }
    return 0;
}
