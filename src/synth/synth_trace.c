/* Ray queries against the whole world: closest hit (camera rays) and any hit (shadow and
 * occlusion rays) through the bounding volume hierarchy, plus the outside ground, an infinite
 * plane under the room seen through doors and windows. */
#include "synth/synth_internal.h"

#define RAY_EPSILON 1e-7

int sy_trace(const gv_synth_world *w, sy_vec o, sy_vec d, double tmax, sy_hit *hit)
{
    hit->t = tmax;
    hit->prim = SY_HIT_NONE;
    hit->face = 0;
    sy_bvh_traverse(w, o, d, RAY_EPSILON, hit, 0);
    if (d.z < -1e-12) {
        double t = (w->sky.ground_z - o.z) / d.z;
        if (t > RAY_EPSILON && t < hit->t) {
            hit->t = t;
            hit->prim = SY_HIT_GROUND;
            hit->face = 0;
        }
    }
    return hit->prim != SY_HIT_NONE;
}

int sy_occluded(const gv_synth_world *w, sy_vec o, sy_vec d, double tmax)
{
    if (d.z < -1e-12 && (w->sky.ground_z - o.z) / d.z < tmax) return 1;
    sy_hit hit = {tmax, SY_HIT_NONE, 0};
    return sy_bvh_traverse(w, o, d, RAY_EPSILON, &hit, 1);
}

void sy_surface_at(const gv_synth_world *w, sy_vec o, sy_vec d, const sy_hit *hit, sy_surface *s)
{
    if (hit->prim >= 0) {
        sy_prim_surface(&w->prims[hit->prim], hit->face, o, d, hit->t, s);
        return;
    }
    s->p = sy_add(o, sy_scale(d, hit->t));
    s->n = sy_v(0, 0, 1);
    s->local = s->p;
    s->u = s->p.x;
    s->v = s->p.y;
    s->size_u = s->size_v = 1e9;
    s->face = 0;
    s->patch = -1;
    s->s = s->t = 0;
}

double sy_furniture_clearance(const gv_synth_world *w, sy_vec p)
{
    double best = INFINITY;
    for (int g = 0; g < w->n_groups; g++) {
        const sy_group *group = &w->groups[g];
        if (!group->furniture) continue;
        double dx = fmax(fmax(group->lo.x - p.x, p.x - group->hi.x), 0);
        double dy = fmax(fmax(group->lo.y - p.y, p.y - group->hi.y), 0);
        double dz = fmax(fmax(group->lo.z - p.z, p.z - group->hi.z), 0);
        best = fmin(best, sqrt(dx * dx + dy * dy + dz * dz));
    }
    return best;
}
