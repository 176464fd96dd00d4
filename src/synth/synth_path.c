/* The translation of the camera path, as a hand-held video walks through a room: a
 * centripetal Catmull-Rom spline through seeded waypoints, either an orbit around the room's
 * middle or a walk along it. The path is planned before the furniture, which keeps clear of
 * it, so the camera is never inside an object; it keeps ROOM_MARGIN from the walls.
 * synth_camera.c adds the view directions, the timing and the shake. */
#include "synth/synth_internal.h"

#include <stdlib.h>
#include <string.h>

#define PLAN_SAMPLES 48          /* dense samples per spline segment */
#define WALL_MARGIN 0.75         /* waypoints keep this far from the walls */
#define ROOM_MARGIN 0.45         /* the whole path keeps this far from the walls */

static double knot_step(sy_vec a, sy_vec b, double alpha)
{
    return fmax(pow(sy_length(sy_sub(b, a)), alpha), 1e-4);
}

/* Point at parameter u in [0, 1] of segment seg (between p[seg] and p[seg + 1]) of a
 * Catmull-Rom spline (alpha 0.5: centripetal, no cusps or loops; 0: uniform), in the
 * Barry-Goldman pyramid form. The ends are extended by reflection. */
static sy_vec catmull_rom(const sy_vec *p, int n, int seg, double u, double alpha)
{
    sy_vec p1 = p[seg], p2 = p[seg + 1];
    sy_vec p0 = seg > 0 ? p[seg - 1] : sy_sub(sy_scale(p1, 2), p2);
    sy_vec p3 = seg + 2 < n ? p[seg + 2] : sy_sub(sy_scale(p2, 2), p1);
    double t0 = 0, t1 = t0 + knot_step(p0, p1, alpha), t2 = t1 + knot_step(p1, p2, alpha);
    double t3 = t2 + knot_step(p2, p3, alpha), t = t1 + u * (t2 - t1);
    sy_vec a1 = sy_add(sy_scale(p0, (t1 - t) / (t1 - t0)), sy_scale(p1, (t - t0) / (t1 - t0)));
    sy_vec a2 = sy_add(sy_scale(p1, (t2 - t) / (t2 - t1)), sy_scale(p2, (t - t1) / (t2 - t1)));
    sy_vec a3 = sy_add(sy_scale(p2, (t3 - t) / (t3 - t2)), sy_scale(p3, (t - t2) / (t3 - t2)));
    sy_vec b1 = sy_add(sy_scale(a1, (t2 - t) / (t2 - t0)), sy_scale(a2, (t - t0) / (t2 - t0)));
    sy_vec b2 = sy_add(sy_scale(a2, (t3 - t) / (t3 - t1)), sy_scale(a3, (t - t1) / (t3 - t1)));
    return sy_add(sy_scale(b1, (t2 - t) / (t2 - t1)), sy_scale(b2, (t - t1) / (t2 - t1)));
}

sy_vec sy_spline_at(const sy_vec *p, int n, double g, double alpha)
{
    int seg = (int)floor(g);
    if (seg > n - 2) seg = n - 2;
    if (seg < 0) seg = 0;
    return catmull_rom(p, n, seg, g - seg, alpha);
}

static void orbit_waypoints(gv_synth_world *w, gv_rng *r, double eye)
{
    double hx = w->room_hi.x - WALL_MARGIN, hy = w->room_hi.y - WALL_MARGIN;
    double ax = hx * sy_uniform(r, 0.45, 0.8), ay = hy * sy_uniform(r, 0.45, 0.8);
    /* not too flat an ellipse: its ends would make the camera pivot on the spot */
    ax = fmin(ax, 1.5 * ay);
    ay = fmin(ay, 1.5 * ax);
    double cx = (hx - ax) * sy_uniform(r, -0.5, 0.5), cy = (hy - ay) * sy_uniform(r, -0.5, 0.5);
    double span = sy_uniform(r, 150, 330) * M_PI / 180;
    if (gv_rng_uniform(r) < 0.5) span = -span;
    int n = (int)ceil(fabs(span) / (45 * M_PI / 180)) + 1 + sy_choice(r, 2);
    if (n > SY_MAX_WAYPOINTS) n = SY_MAX_WAYPOINTS;
    double a0 = sy_uniform(r, 0, 2 * M_PI);
    for (int i = 0; i < n; i++) {
        double a = a0 + span * (i + sy_uniform(r, -0.1, 0.1)) / (n - 1);
        double k = sy_uniform(r, 0.9, 1.08);
        double z = eye + sy_uniform(r, -0.07, 0.07);
        w->waypoints[i] = sy_v(cx + k * ax * cos(a), cy + k * ay * sin(a), z);
    }
    w->n_waypoints = n;
}

static void walk_waypoints(gv_synth_world *w, gv_rng *r, double eye)
{
    int along_x = w->room_hi.x >= w->room_hi.y;
    double h_long = (along_x ? w->room_hi.x : w->room_hi.y) - WALL_MARGIN;
    double h_side = (along_x ? w->room_hi.y : w->room_hi.x) - WALL_MARGIN;
    double from = -h_long * sy_uniform(r, 0.75, 1.0), to = h_long * sy_uniform(r, 0.75, 1.0);
    if (gv_rng_uniform(r) < 0.5) { double t = from; from = -to; to = -t; }
    int n = 5 + sy_choice(r, 3);
    /* a gentle S across the room: a slow sine sideways, no zigzag */
    double side = sy_uniform(r, -0.3, 0.3), swing = sy_uniform(r, 0.1, 0.35);
    double phase = sy_uniform(r, 0, 2 * M_PI), rate = sy_uniform(r, 0.5, 1.1);
    for (int i = 0; i < n; i++) {
        double a = from + (to - from) * i / (n - 1);
        double b = h_side * sy_clamp(side + swing * sin(phase + rate * i), -0.7, 0.7);
        double z = eye + sy_uniform(r, -0.07, 0.07);
        w->waypoints[i] = along_x ? sy_v(a, b, z) : sy_v(b, a, z);
    }
    w->n_waypoints = n;
}

/* Dense samples of the planned path; returns the smallest distance to a wall. */
static double sample_plan(gv_synth_world *w)
{
    double margin = INFINITY;
    for (int i = 0; i < w->n_plan; i++) {
        sy_vec p = sy_spline_at(w->waypoints, w->n_waypoints, (double)i / PLAN_SAMPLES, 0.5);
        w->plan[i] = p;
        margin = fmin(margin, fmin(w->room_hi.x - fabs(p.x), w->room_hi.y - fabs(p.y)));
    }
    return margin;
}

int sy_plan_path(gv_synth_world *w, gv_rng *r)
{
    double eye = sy_uniform(r, 1.35, 1.65);
    w->path_mode = gv_rng_uniform(r) < 0.7 ? 0 : 1;
    if (w->path_mode == 0) orbit_waypoints(w, r, eye);
    else walk_waypoints(w, r, eye);
    w->n_plan = (w->n_waypoints - 1) * PLAN_SAMPLES + 1;
    w->plan = malloc((size_t)w->n_plan * sizeof *w->plan);
    if (!w->plan) return gv_fail("scene synth: out of memory");
    /* the spline can overshoot its waypoints: pull it towards the middle until it fits */
    for (int attempt = 0; sample_plan(w) < ROOM_MARGIN; attempt++) {
        if (attempt == 50) return gv_fail("scene synth: cannot fit the camera path in the room");
        for (int i = 0; i < w->n_waypoints; i++) {
            w->waypoints[i].x *= 0.95;
            w->waypoints[i].y *= 0.95;
        }
    }
    return 0;
}
