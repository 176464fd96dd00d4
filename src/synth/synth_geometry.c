/* Ray intersection and surface parameterisation of the three primitives of the procedural
 * scenes: boxes (rotated about +z), spheres and capped vertical cylinders. Each works in
 * its own frame (translated to the centre, rotated by -yaw), where the tests are the
 * textbook ones: slabs for the box, the quadratic for the sphere and the cylinder's side. */
#include "synth/synth_internal.h"

void sy_prim_set_yaw(sy_prim *p, double yaw)
{
    p->yaw = yaw;
    p->cos_yaw = cos(yaw);
    p->sin_yaw = sin(yaw);
}

int sy_prim_n_faces(const sy_prim *p)
{
    return p->shape == SY_BOX ? 6 : p->shape == SY_SPHERE ? 1 : 3;
}

static sy_vec to_local_dir(const sy_prim *p, sy_vec d)
{
    return sy_v(p->cos_yaw * d.x + p->sin_yaw * d.y, -p->sin_yaw * d.x + p->cos_yaw * d.y, d.z);
}

static sy_vec to_local(const sy_prim *p, sy_vec x) { return to_local_dir(p, sy_sub(x, p->center)); }

static sy_vec to_world_dir(const sy_prim *p, sy_vec d)
{
    return sy_v(p->cos_yaw * d.x - p->sin_yaw * d.y, p->sin_yaw * d.x + p->cos_yaw * d.y, d.z);
}

static double comp(sy_vec v, int axis) { return axis == 0 ? v.x : axis == 1 ? v.y : v.z; }

static void set_comp(sy_vec *v, int axis, double value)
{
    if (axis == 0) v->x = value;
    else if (axis == 1) v->y = value;
    else v->z = value;
}

/* Slab test. Face 2a is +axis a, 2a + 1 is -axis a. From inside, the exit face is hit. */
static int box_intersect(sy_vec o, sy_vec d, sy_vec h, double tmin, double tmax, double *t, int *face)
{
    double t_near = -INFINITY, t_far = INFINITY;
    int f_near = 0, f_far = 0;
    for (int a = 0; a < 3; a++) {
        double oa = comp(o, a), da = comp(d, a), ha = comp(h, a);
        if (fabs(da) < 1e-15) {
            if (oa < -ha || oa > ha) return 0;
            continue;
        }
        double t0 = (-ha - oa) / da, t1 = (ha - oa) / da;
        int enter = 2 * a + (da > 0), leave = 2 * a + (da < 0);
        if (t0 > t1) { double s = t0; t0 = t1; t1 = s; }
        if (t0 > t_near) { t_near = t0; f_near = enter; }
        if (t1 < t_far) { t_far = t1; f_far = leave; }
    }
    if (t_near > t_far) return 0;
    if (t_near > tmin && t_near < tmax) { *t = t_near; *face = f_near; return 1; }
    if (t_far > tmin && t_far < tmax) { *t = t_far; *face = f_far; return 1; }
    return 0;
}

static int sphere_intersect(sy_vec o, sy_vec d, double r, double tmin, double tmax, double *t)
{
    double b = sy_dot(o, d), c = sy_dot(o, o) - r * r;
    double disc = b * b - c;
    if (disc < 0) return 0;
    double root = sqrt(disc);
    double t0 = -b - root, t1 = -b + root;
    if (t0 > tmin && t0 < tmax) { *t = t0; return 1; }
    if (t1 > tmin && t1 < tmax) { *t = t1; return 1; }
    return 0;
}

static int cylinder_intersect(sy_vec o, sy_vec d, double r, double h, double tmin, double tmax,
                              double *t, int *face)
{
    int found = 0;
    double a = d.x * d.x + d.y * d.y;
    if (a > 1e-15) {
        double b = o.x * d.x + o.y * d.y, c = o.x * o.x + o.y * o.y - r * r;
        double disc = b * b - a * c;
        if (disc >= 0) {
            double root = sqrt(disc);
            double roots[2] = {(-b - root) / a, (-b + root) / a};
            for (int i = 0; i < 2 && !found; i++) {
                double z = o.z + roots[i] * d.z;
                if (roots[i] > tmin && roots[i] < tmax && z >= 0 && z <= h) {
                    *t = tmax = roots[i];
                    *face = 0;
                    found = 1;
                }
            }
        }
    }
    if (fabs(d.z) > 1e-15) {
        double cap_z[2] = {h, 0};
        for (int i = 0; i < 2; i++) {
            double tc = (cap_z[i] - o.z) / d.z;
            double x = o.x + tc * d.x, y = o.y + tc * d.y;
            if (tc > tmin && tc < tmax && x * x + y * y <= r * r) {
                *t = tmax = tc;
                *face = 1 + i;
                found = 1;
            }
        }
    }
    return found;
}

int sy_prim_intersect(const sy_prim *p, sy_vec o, sy_vec d, double tmin, double tmax,
                      double *t, int *face)
{
    sy_vec lo = to_local(p, o), ld = to_local_dir(p, d);
    switch (p->shape) {
    case SY_BOX: return box_intersect(lo, ld, p->half, tmin, tmax, t, face);
    case SY_SPHERE: *face = 0; return sphere_intersect(lo, ld, p->half.x, tmin, tmax, t);
    default: return cylinder_intersect(lo, ld, p->half.x, p->half.z, tmin, tmax, t, face);
    }
}

/* The two in-face axes of box face axis a: u horizontal, v up on vertical faces. */
static void box_face_axes(int a, int *ua, int *va)
{
    *ua = a == 0 ? 1 : 0;
    *va = a == 2 ? 1 : 2;
}

/* Fills normal, face coordinates and patch coordinates from a local point on a face. */
static void local_surface(const sy_prim *p, int face, sy_vec l, sy_vec *n, sy_surface *s)
{
    const double two_pi = 2.0 * M_PI;
    if (p->shape == SY_BOX) {
        int a = face / 2, ua, va;
        box_face_axes(a, &ua, &va);
        *n = sy_v(0, 0, 0);
        set_comp(n, a, face % 2 ? -1.0 : 1.0);
        double hu = comp(p->half, ua), hv = comp(p->half, va);
        s->u = comp(l, ua) + hu;
        s->v = comp(l, va) + hv;
        s->size_u = 2 * hu;
        s->size_v = 2 * hv;
    } else if (p->shape == SY_SPHERE) {
        double r = p->half.x;
        *n = sy_scale(l, 1.0 / r);
        double phi = atan2(l.y, l.x) + M_PI, theta = acos(sy_clamp(l.z / r, -1, 1));
        s->u = phi * r;
        s->v = (M_PI - theta) * r;
        s->size_u = two_pi * r;
        s->size_v = M_PI * r;
    } else {
        double r = p->half.x, h = p->half.z;
        if (face == 0) {
            *n = sy_v(l.x / r, l.y / r, 0);
            s->u = (atan2(l.y, l.x) + M_PI) * r;
            s->v = l.z;
            s->size_u = two_pi * r;
            s->size_v = h;
        } else {
            *n = sy_v(0, 0, face == 1 ? 1 : -1);
            s->u = l.x + r;
            s->v = l.y + r;
            s->size_u = s->size_v = 2 * r;
        }
    }
    s->s = sy_clamp(s->u / s->size_u, 0, 1);
    s->t = sy_clamp(s->v / s->size_v, 0, 1);
}

void sy_prim_surface(const sy_prim *p, int face, sy_vec o, sy_vec d, double t, sy_surface *s)
{
    s->p = sy_add(o, sy_scale(d, t));
    s->local = to_local(p, s->p);
    sy_vec n;
    local_surface(p, face, s->local, &n, s);
    n = to_world_dir(p, n);
    s->n = sy_dot(n, d) > 0 ? sy_scale(n, -1) : n;
    s->face = face;
    s->patch = p->first_patch + face;
}

void sy_prim_face_point(const sy_prim *p, int face, double s, double t, sy_vec *point, sy_vec *normal)
{
    sy_vec l, n;
    if (p->shape == SY_BOX) {
        int a = face / 2, ua, va;
        box_face_axes(a, &ua, &va);
        l = n = sy_v(0, 0, 0);
        double sign = face % 2 ? -1.0 : 1.0;
        set_comp(&l, a, sign * comp(p->half, a));
        set_comp(&n, a, sign);
        set_comp(&l, ua, (2 * s - 1) * comp(p->half, ua));
        set_comp(&l, va, (2 * t - 1) * comp(p->half, va));
    } else if (p->shape == SY_SPHERE) {
        double phi = 2 * M_PI * s - M_PI, theta = M_PI * (1 - t);
        n = sy_v(sin(theta) * cos(phi), sin(theta) * sin(phi), cos(theta));
        l = sy_scale(n, p->half.x);
    } else {
        double r = p->half.x, h = p->half.z;
        if (face == 0) {
            double phi = 2 * M_PI * s - M_PI;
            n = sy_v(cos(phi), sin(phi), 0);
            l = sy_v(r * n.x, r * n.y, t * h);
        } else {
            n = sy_v(0, 0, face == 1 ? 1 : -1);
            l = sy_v((2 * s - 1) * r, (2 * t - 1) * r, face == 1 ? h : 0);
        }
    }
    *point = sy_add(p->center, to_world_dir(p, l));
    *normal = to_world_dir(p, n);
}

void sy_prim_face_size(const sy_prim *p, int face, double *size_s, double *size_t, int *wraps)
{
    sy_surface s;
    sy_vec n, l = sy_v(0, 0, 0);
    if (p->shape == SY_BOX) set_comp(&l, face / 2, (face % 2 ? -1 : 1) * comp(p->half, face / 2));
    else if (p->shape == SY_SPHERE) l = sy_v(p->half.x, 0, 0);
    else l = face == 0 ? sy_v(p->half.x, 0, 0) : sy_v(0, 0, face == 1 ? p->half.z : 0);
    local_surface(p, face, l, &n, &s);
    *size_s = s.size_u;
    *size_t = s.size_v;
    *wraps = p->shape == SY_SPHERE || (p->shape == SY_CYLINDER && face == 0);
}

void sy_prim_bounds(const sy_prim *p, sy_vec *lo, sy_vec *hi)
{
    double ex, ey, z0, z1;
    if (p->shape == SY_BOX) {
        ex = fabs(p->cos_yaw) * p->half.x + fabs(p->sin_yaw) * p->half.y;
        ey = fabs(p->sin_yaw) * p->half.x + fabs(p->cos_yaw) * p->half.y;
        z0 = -p->half.z;
        z1 = p->half.z;
    } else if (p->shape == SY_SPHERE) {
        ex = ey = p->half.x;
        z0 = -p->half.x;
        z1 = p->half.x;
    } else {
        ex = ey = p->half.x;
        z0 = 0;
        z1 = p->half.z;
    }
    *lo = sy_v(p->center.x - ex, p->center.y - ey, p->center.z + z0);
    *hi = sy_v(p->center.x + ex, p->center.y + ey, p->center.z + z1);
}

int sy_prim_contains(const sy_prim *p, sy_vec point)
{
    sy_vec l = to_local(p, point);
    switch (p->shape) {
    case SY_BOX:
        return fabs(l.x) <= p->half.x && fabs(l.y) <= p->half.y && fabs(l.z) <= p->half.z;
    case SY_SPHERE: return sy_dot(l, l) <= p->half.x * p->half.x;
    default:
        return l.x * l.x + l.y * l.y <= p->half.x * p->half.x && l.z >= 0 && l.z <= p->half.z;
    }
}
