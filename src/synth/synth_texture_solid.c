/* Solid textures (functions of the position in the primitive's frame, so they wrap around
 * corners and curved surfaces: plaster, wood rings, marble, foliage, ground) and pictures on
 * faces (paintings, book spines). All are band-limited by the footprint w (metres). */
#include "synth/synth_internal.h"

static double component(sy_vec v, int axis) { return axis == 0 ? v.x : axis == 1 ? v.y : v.z; }

static sy_vec plaster(const sy_material *m, const sy_surface *s, double w)
{
    double blotch = sy_fbm3(s->local, 1.5, 4, w, m->seed);
    double grain = sy_fbm3(s->local, 90, 2, w, m->seed + 1);
    sy_vec c = sy_lerp(m->color[0], m->color[1], sy_clamp(0.5 + 0.9 * m->variation * blotch, 0, 1));
    return sy_scale(c, 1.0 + 0.07 * grain);
}

/* Growth rings around an axis of the primitive's frame (off-centre, so faces show arcs and
 * streaks), with fibres along the axis. */
static sy_vec wood(const sy_material *m, const sy_surface *s, double w)
{
    sy_vec p = s->local;
    int a = m->axis;
    double along = component(p, a);
    double x = component(p, (a + 1) % 3) + 0.37, y = component(p, (a + 2) % 3) - 0.23;
    double spacing = m->scale[0];
    double warp = 0.6 * sy_fbm3(sy_v(along * 0.7, x * 2, y * 2), 1.0, 3, w * 2, m->seed);
    double ring = sqrt(x * x + y * y) / spacing + 3.0 * warp;
    double f = ring - floor(ring);
    double profile = sy_smoothstep(0.0, 0.25, f) * (1.0 - sy_smoothstep(0.55, 1.0, f));
    double detail = sy_detail(spacing, w);
    profile = detail * profile + (1 - detail) * 0.42;
    sy_vec c = sy_lerp(m->color[0], m->color[1], 0.55 * profile);
    double fibre = sy_fbm3(sy_v(along * 3, x * 120, y * 120), 1.0, 2, w * 120, m->seed + 2);
    return sy_scale(c, 1.0 + 0.08 * fibre + 0.1 * sy_fbm3(p, 3, 3, w, m->seed + 3));
}

static sy_vec marble(const sy_material *m, const sy_surface *s, double w)
{
    sy_vec p = s->local;
    double turbulence = sy_fbm3(p, 1.2 / m->scale[0], 6, w, m->seed);
    double t = (p.x + 0.6 * p.y + 0.3 * p.z) * 2.0 / m->scale[0] + 5.0 * turbulence;
    double vein_width = 0.1;
    double vein = 1.0 - sy_smoothstep(0.0, vein_width, fabs(sin(M_PI * t)));
    double detail = sy_detail(vein_width * m->scale[0] / (2.0 * M_PI), w);
    vein = detail * vein + (1 - detail) * vein_width * 0.5;
    sy_vec c = sy_lerp(m->color[0], m->color[1], 0.75 * vein);
    return sy_scale(c, 1.0 + 0.08 * sy_fbm3(p, 12, 3, w, m->seed + 1));
}

static sy_vec fabric(const sy_material *m, const sy_surface *s, double w)
{
    double u = s->u, v = s->v;
    sy_vec c = m->color[0];
    if (m->variant == 1) { /* plaid: two colours crossing */
        double a = sy_square(u, 2 * m->scale[0], w), b = sy_square(v, 2 * m->scale[0], w);
        c = sy_lerp(m->color[0], m->color[1], 0.5 * (a + b));
        c = sy_lerp(c, m->color[2], 0.6 * sy_lines(u, 2 * m->scale[0], 0.006, w));
    } else if (m->variant == 2) { /* stripes */
        c = sy_lerp(m->color[0], m->color[1], sy_square(v, m->scale[0], w));
    } else if (m->variant == 3) { /* hanging folds: light and shade across u, painted into the
                                   * colour (the panel itself is flat) */
        double fold = 0.5 + 0.5 * sin(2 * M_PI * u / m->scale[0] + 1.3 * sy_noise2(u * 4, 0.3, m->seed));
        double detail = sy_detail(0.5 * m->scale[0], w);
        c = sy_scale(c, 1.0 - 0.3 * (detail * fold + (1 - detail) * 0.5));
    }
    double weave = sy_fbm2(u, v, 200, 1, w, m->seed) * (0.5 + 0.5 * sy_fbm2(u, v, 20, 2, w, m->seed + 1));
    return sy_scale(c, 1.0 + 0.15 * weave + 0.08 * sy_fbm3(s->local, 4, 3, w, m->seed + 2));
}

/* A picture in the canvas' own coordinates a, b in [0, 1] (b up); e is the footprint in
 * those units. */
static sy_vec painting(const sy_material *m, const sy_surface *s, double w)
{
    double a = s->s, b = s->t, e = w / fmax(fmin(s->size_u, s->size_v), 1e-3);
    sy_vec c;
    if (m->variant == 0) { /* landscape: sky and three ranges of hills */
        c = sy_lerp(m->color[0], sy_v(0.9, 0.85, 0.75), sy_smoothstep(1.0, 0.4, b));
        for (int k = 0; k < 3; k++) {
            double top = 0.62 - 0.17 * k + 0.12 * sy_fbm2(a * (2 + k), k * 3.1, 1.0, 4, e * (2 + k), m->seed + k);
            double inside = sy_smoothstep(top + e, top - e, b);
            sy_vec layer = sy_scale(m->color[1 + k], 1.0 + 0.25 * sy_fbm2(a, b, 8, 3, e, m->seed + 10 + k));
            c = sy_lerp(c, layer, inside);
        }
    } else if (m->variant == 1) { /* abstract: colours by two noise fields */
        double f = sy_fbm2(a, b, 2.5, 5, e, m->seed), g = sy_fbm2(a, b, 1.7, 4, e, m->seed + 1);
        c = sy_lerp(m->color[0], m->color[1], sy_smoothstep(-0.15, 0.15, f));
        c = sy_lerp(c, m->color[2], sy_smoothstep(0.05, 0.2, g));
        c = sy_lerp(c, m->color[3], sy_smoothstep(0.25, 0.35, f + g));
    } else { /* colour fields with soft noisy edges */
        double t = b + 0.03 * sy_fbm2(a, b, 6, 3, e, m->seed);
        c = t > 0.62 ? m->color[0] : t > 0.3 ? m->color[1] : m->color[2];
        double edge = fmin(fabs(t - 0.62), fabs(t - 0.3));
        c = sy_lerp(m->color[3], c, sy_smoothstep(0.0, 0.03 + e, edge));
    }
    return sy_scale(c, 1.0 + 0.06 * sy_fbm2(s->u, s->v, 120, 2, w, m->seed + 7));
}

/* A book: cover colour with two bands on the spine (+y face); pages on top and bottom. */
static sy_vec book(const sy_material *m, const sy_surface *s, double w)
{
    if (s->face == 4 || s->face == 5) return m->color[2];
    double e = w / fmax(s->size_v, 1e-3);
    double band = sy_lines(s->t - 0.15, 1e3, 0.05, e) + sy_lines(s->t - 0.85, 1e3, 0.05, e);
    sy_vec c = s->face == 2 ? sy_lerp(m->color[0], m->color[1], band) : m->color[0];
    return sy_scale(c, 1.0 + 0.1 * sy_fbm3(s->local, 40, 2, w, m->seed));
}

static sy_vec foliage(const sy_material *m, const sy_surface *s, double w)
{
    double n = sy_fbm3(s->local, 9, 4, w, m->seed);
    double leaves = sy_smoothstep(-0.25, 0.25, n);
    sy_vec c = sy_lerp(m->color[1], m->color[0], leaves);
    return sy_scale(c, 1.0 + 0.3 * sy_fbm3(s->local, 40, 2, w, m->seed + 1));
}

static sy_vec ground(const sy_material *m, const sy_surface *s, double w)
{
    double patches = sy_fbm2(s->u, s->v, 0.15, 4, w, m->seed);
    sy_vec c = sy_lerp(m->color[0], m->color[1], sy_smoothstep(-0.2, 0.3, patches));
    return sy_scale(c, 1.0 + 0.3 * sy_fbm2(s->u, s->v, 3, 6, w, m->seed + 1));
}

static sy_vec paint(const sy_material *m, const sy_surface *s, double w)
{
    return sy_scale(m->color[0], 1.0 + 0.05 * sy_fbm3(s->local, 6, 3, w, m->seed));
}

sy_vec sy_texture_solid(const sy_material *m, const sy_surface *s, double w)
{
    switch (m->kind) {
    case SY_MAT_PLASTER: return plaster(m, s, w);
    case SY_MAT_WOOD: return wood(m, s, w);
    case SY_MAT_MARBLE: return marble(m, s, w);
    case SY_MAT_FABRIC: return fabric(m, s, w);
    case SY_MAT_PAINTING: return painting(m, s, w);
    case SY_MAT_BOOK: return book(m, s, w);
    case SY_MAT_FOLIAGE: return foliage(m, s, w);
    case SY_MAT_GROUND: return ground(m, s, w);
    default: return paint(m, s, w);
    }
}
