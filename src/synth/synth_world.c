/* Growing the world: materials, and primitives collected in groups whose bounding boxes let
 * a ray skip whole pieces of furniture at once. */
#include "synth/synth_internal.h"

#include <stdlib.h>
#include <string.h>

static int grow(void **array, int *cap, int need, size_t item)
{
    if (need <= *cap) return 0;
    int cap2 = *cap ? 2 * *cap : 64;
    while (cap2 < need) cap2 *= 2;
    void *bigger = realloc(*array, (size_t)cap2 * item);
    if (!bigger) return gv_fail("scene synth: out of memory (%d items)", cap2);
    *array = bigger;
    *cap = cap2;
    return 0;
}

int sy_add_material(gv_synth_world *w, const sy_material *m)
{
    if (grow((void **)&w->materials, &w->cap_materials, w->n_materials + 1, sizeof *m)) return -1;
    w->materials[w->n_materials] = *m;
    return w->n_materials++;
}

int sy_begin_group(gv_synth_world *w, int furniture)
{
    if (grow((void **)&w->groups, &w->cap_groups, w->n_groups + 1, sizeof *w->groups)) return -1;
    sy_group *g = &w->groups[w->n_groups];
    memset(g, 0, sizeof *g);
    g->first = w->n_prims;
    g->furniture = furniture;
    g->lo = sy_v(INFINITY, INFINITY, INFINITY);
    g->hi = sy_v(-INFINITY, -INFINITY, -INFINITY);
    w->open_group = w->n_groups++;
    return 0;
}

void sy_end_group(gv_synth_world *w)
{
    if (w->open_group < 0) return;
    sy_group *g = &w->groups[w->open_group];
    g->count = w->n_prims - g->first;
    for (int i = g->first; i < w->n_prims; i++) {
        sy_vec lo, hi;
        sy_prim_bounds(&w->prims[i], &lo, &hi);
        g->lo = sy_v(fmin(g->lo.x, lo.x), fmin(g->lo.y, lo.y), fmin(g->lo.z, lo.z));
        g->hi = sy_v(fmax(g->hi.x, hi.x), fmax(g->hi.y, hi.y), fmax(g->hi.z, hi.z));
    }
    w->open_group = -1;
}

static int add_prim(gv_synth_world *w, sy_shape shape, sy_vec center, sy_vec half, double yaw, int material)
{
    if (w->open_group < 0) return gv_fail("scene synth: primitive added outside a group");
    if (grow((void **)&w->prims, &w->cap_prims, w->n_prims + 1, sizeof *w->prims)) return -1;
    sy_prim *p = &w->prims[w->n_prims];
    memset(p, 0, sizeof *p);
    p->shape = shape;
    p->center = center;
    p->half = half;
    sy_prim_set_yaw(p, yaw);
    p->material = material;
    p->light = -1;
    return w->n_prims++;
}

int sy_add_box(gv_synth_world *w, sy_vec center, sy_vec half, double yaw, int material)
{
    return add_prim(w, SY_BOX, center, half, yaw, material);
}

int sy_add_sphere(gv_synth_world *w, sy_vec center, double radius, int material)
{
    return add_prim(w, SY_SPHERE, center, sy_v(radius, radius, radius), 0, material);
}

int sy_add_cylinder(gv_synth_world *w, sy_vec base, double radius, double height, double yaw, int material)
{
    return add_prim(w, SY_CYLINDER, base, sy_v(radius, radius, height), yaw, material);
}

/* Parts of an object are given in its frame (x across, y towards its front, z up). */
static sy_vec frame_point(const sy_frame *f, sy_vec c)
{
    double cy = cos(f->yaw), sn = sin(f->yaw);
    return sy_v(f->origin.x + cy * c.x - sn * c.y, f->origin.y + sn * c.x + cy * c.y, f->origin.z + c.z);
}

int sy_part_box(gv_synth_world *w, const sy_frame *f, sy_vec center, sy_vec half, int material)
{
    return sy_add_box(w, frame_point(f, center), half, f->yaw, material);
}

int sy_part_cylinder(gv_synth_world *w, const sy_frame *f, sy_vec base, double r, double h, int material)
{
    return sy_add_cylinder(w, frame_point(f, base), r, h, f->yaw, material);
}

int sy_part_sphere(gv_synth_world *w, const sy_frame *f, sy_vec center, double r, int material)
{
    int i = sy_add_sphere(w, frame_point(f, center), r, material);
    if (i >= 0) sy_prim_set_yaw(&w->prims[i], f->yaw);
    return i;
}
