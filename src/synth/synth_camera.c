/* The cameras along the planned path: a view direction per waypoint aimed at furniture (as
 * someone filming the room looks at things, with occasional sideways glances), interpolated
 * by a uniform Catmull-Rom spline in yaw and pitch; frames re-timed to near-constant speed
 * (metres and 0.6 m per radian of turn, as the shared scenes, combined as a Euclidean norm
 * so that the speed stays smooth where a pan reverses); then a low-frequency hand
 * shake (about +-12 mm, +-0.6 deg yaw and pitch, +-1.2 deg roll) and a walking bob.
 * Intrinsics: a 28 mm lens on a 36 mm sensor (65.5 deg across), principal point at the
 * image centre, as the shared scenes. */
#include "synth/synth_internal.h"

#include <stdio.h>
#include <stdlib.h>

#define DENSE 64                 /* samples per segment for the re-timing */
#define TURN_METRES 0.6
#define NOMINAL_SECONDS (160.0 / 30.0)
#define MIN_TARGET_DISTANCE 1.2
#define DEG (M_PI / 180.0)

static double wrap_angle(double a)
{
    while (a > M_PI) a -= 2 * M_PI;
    while (a < -M_PI) a += 2 * M_PI;
    return a;
}

/* The direction the camera would look with no furniture in view: towards the middle of
 * the room on an orbit, sideways (alternating) on a walk. */
static double preferred_yaw(const gv_synth_world *w, gv_rng *r, int i)
{
    const sy_vec *p = w->waypoints;
    int n = w->n_waypoints;
    if (w->path_mode == 0) return atan2(-p[i].y, -p[i].x);
    sy_vec ahead = sy_sub(p[i < n - 1 ? i + 1 : i], p[i > 0 ? i - 1 : i]);
    double turn = sy_uniform(r, 20, 75) * DEG * (i % 2 ? 1 : -1);
    return atan2(ahead.y, ahead.x) + turn;
}

static void choose_views(gv_synth_world *w, gv_rng *r, sy_vec *views)
{
    for (int i = 0; i < w->n_waypoints; i++) {
        sy_vec p = w->waypoints[i];
        double pref = preferred_yaw(w, r, i);
        int glance = gv_rng_uniform(r) < 0.25;
        /* the best-scoring object within 75 degrees of the preferred direction (anywhere on
         * a glance); failing that, the best anywhere; failing that, the direction itself */
        sy_vec target = sy_v(p.x + 2 * cos(pref), p.y + 2 * sin(pref), 1.0), fallback = target;
        double best = -INFINITY, best_any = -INFINITY;
        for (int g = 0; g < w->n_groups; g++) {
            const sy_group *group = &w->groups[g];
            if (!group->furniture) continue;
            sy_vec c = sy_scale(sy_add(group->lo, group->hi), 0.5);
            c.z = sy_clamp(c.z, 0.4, 1.6);
            double dist = hypot(c.x - p.x, c.y - p.y);
            double off = fabs(wrap_angle(atan2(c.y - p.y, c.x - p.x) - pref));
            double luck = gv_rng_uniform(r);
            if (dist < MIN_TARGET_DISTANCE) continue;
            double score = luck - 0.3 * off;
            if (score > best_any) { best_any = score; fallback = c; }
            if ((glance || off <= 75 * DEG) && score > best) { best = score; target = c; }
        }
        if (best == -INFINITY) target = fallback;
        double dist = hypot(target.x - p.x, target.y - p.y);
        views[i].x = atan2(target.y - p.y, target.x - p.x);
        views[i].y = sy_clamp(atan2(target.z - p.z, dist), -28 * DEG, 8 * DEG);
        views[i].z = 0;
        if (i > 0) { /* unwrap, and no whip pans between waypoints */
            double step = wrap_angle(views[i].x - views[i - 1].x);
            views[i].x = views[i - 1].x + sy_clamp(step, -80 * DEG, 80 * DEG);
        }
    }
}

static sy_vec view_dir(sy_vec view)
{
    return sy_v(cos(view.y) * cos(view.x), cos(view.y) * sin(view.x), sin(view.y));
}

/* Global spline parameter of each frame, at equal steps of |(travel, 0.6 m x turn)|. */
static int retime(const gv_synth_world *w, const sy_vec *views, int n_frames, double *params)
{
    int n = w->n_waypoints, m = (n - 1) * DENSE + 1;
    double *effort = malloc((size_t)m * sizeof *effort);
    if (!effort) return gv_fail("scene synth: out of memory");
    sy_vec prev_p = sy_spline_at(w->waypoints, n, 0, 0.5), prev_d = view_dir(sy_spline_at(views, n, 0, 0));
    effort[0] = 0;
    for (int i = 1; i < m; i++) {
        double g = (double)i / DENSE;
        sy_vec p = sy_spline_at(w->waypoints, n, g, 0.5), d = view_dir(sy_spline_at(views, n, g, 0));
        double turn = acos(sy_clamp(sy_dot(d, prev_d), -1, 1));
        /* Euclidean, not a sum: the speed then has no kink where the turn changes direction */
        effort[i] = effort[i - 1] + hypot(sy_length(sy_sub(p, prev_p)), TURN_METRES * turn) + 1e-9;
        prev_p = p;
        prev_d = d;
    }
    int i = 0;
    for (int f = 0; f < n_frames; f++) {
        double e = n_frames > 1 ? effort[m - 1] * f / (n_frames - 1) : 0;
        while (i < m - 2 && effort[i + 1] < e) i++;
        double frac = sy_clamp((e - effort[i]) / (effort[i + 1] - effort[i]), 0, 1);
        params[f] = (i + frac) / DENSE;
    }
    free(effort);
    return 0;
}

/* Smooth random wobble: three sines per channel, normalised to amplitude 1. */
typedef struct { double freq[3], phase[3], weight[3]; } wobble;

static void wobble_init(wobble *s, gv_rng *r)
{
    for (int k = 0; k < 3; k++) {
        s->freq[k] = sy_uniform(r, 0.15, 1.1);
        s->phase[k] = sy_uniform(r, 0, 2 * M_PI);
        s->weight[k] = sy_uniform(r, 0.3, 1.0);
    }
}

static double wobble_at(const wobble *s, double seconds)
{
    double sum = 0, norm = 0;
    for (int k = 0; k < 3; k++) {
        sum += s->weight[k] * sin(2 * M_PI * s->freq[k] * seconds + s->phase[k]);
        norm += s->weight[k];
    }
    return sum / norm;
}

/* OpenCV rows: right, down, forward (right = forward x up), rolled about forward. */
static void look_rotation(double yaw, double pitch, double roll, double R[9])
{
    sy_vec f = view_dir(sy_v(yaw, pitch, 0));
    sy_vec right = sy_normalize(sy_cross(f, sy_v(0, 0, 1)));
    sy_vec down = sy_cross(f, right);
    sy_vec r2 = sy_add(sy_scale(right, cos(roll)), sy_scale(down, sin(roll)));
    sy_vec d2 = sy_sub(sy_scale(down, cos(roll)), sy_scale(right, sin(roll)));
    double rows[9] = {r2.x, r2.y, r2.z, d2.x, d2.y, d2.z, f.x, f.y, f.z};
    for (int i = 0; i < 9; i++) R[i] = rows[i];
}

int sy_make_cameras(gv_synth_world *w, gv_rng *r)
{
    int n_frames = w->params.n_frames, n = w->n_waypoints;
    sy_vec views[SY_MAX_WAYPOINTS];
    choose_views(w, r, views);
    double *params = malloc((size_t)n_frames * sizeof *params);
    w->cameras = calloc((size_t)n_frames, sizeof *w->cameras);
    if (!params || !w->cameras) { free(params); return gv_fail("scene synth: out of memory"); }
    if (retime(w, views, n_frames, params)) { free(params); return -1; }
    wobble shake[6];
    for (int c = 0; c < 6; c++) wobble_init(&shake[c], r);
    double bob_phase = sy_uniform(r, 0, 2 * M_PI);
    const double amplitude[6] = {0.012, 0.012, 0.008, 0.6 * DEG, 0.6 * DEG, 1.2 * DEG};

    w->fx = w->params.width * 28.0 / 36.0;
    w->path_length = w->path_turn = 0;
    sy_vec prev_pos = sy_v(0, 0, 0);
    for (int f = 0; f < n_frames; f++) {
        double seconds = n_frames > 1 ? NOMINAL_SECONDS * f / (n_frames - 1) : 0, s[6];
        for (int c = 0; c < 6; c++) s[c] = amplitude[c] * wobble_at(&shake[c], seconds);
        sy_vec pos = sy_spline_at(w->waypoints, n, params[f], 0.5);
        sy_vec view = sy_spline_at(views, n, params[f], 0);
        pos = sy_add(pos, sy_v(s[0], s[1], s[2] + 0.006 * sin(2 * M_PI * 1.8 * seconds + bob_phase)));
        gv_camera *cam = &w->cameras[f];
        look_rotation(view.x + s[3], view.y + s[4], s[5], cam->R);
        const double *R = cam->R;
        for (int i = 0; i < 3; i++)
            cam->t[i] = -(R[3 * i] * pos.x + R[3 * i + 1] * pos.y + R[3 * i + 2] * pos.z);
        cam->width = w->params.width;
        cam->height = w->params.height;
        cam->fx = cam->fy = w->fx;
        cam->cx = 0.5 * cam->width;
        cam->cy = 0.5 * cam->height;
        snprintf(cam->name, sizeof cam->name, "frame_%05d.png", f);
        if (f > 0) {
            const double *P = w->cameras[f - 1].R;
            double trace = R[0] * P[0] + R[1] * P[1] + R[2] * P[2] + R[3] * P[3] + R[4] * P[4] +
                           R[5] * P[5] + R[6] * P[6] + R[7] * P[7] + R[8] * P[8];
            w->path_turn += acos(sy_clamp(0.5 * (trace - 1), -1, 1));
            w->path_length += sy_length(sy_sub(pos, prev_pos));
        }
        prev_pos = pos;
    }
    free(params);
    return 0;
}
