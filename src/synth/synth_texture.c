/* Procedural 2D patterns on face coordinates (metres): bricks, tiles, planks, stripes,
 * checks, rugs. Joints and stripes are box-filtered over the pixel footprint w, per-cell
 * colours fade to their mean when cells get smaller than the footprint, and every surface
 * gets dirt at a large scale and grain at a fine one, so textures have detail at several
 * scales without aliasing. */
#include "synth/synth_internal.h"

const char *const sy_material_names[SY_MAT_COUNT] = {
    "plaster", "brick", "tiles", "planks", "stripes", "checks", "wood", "marble", "fabric",
    "painting", "paint", "book", "foliage", "rug", "ground", "emitter",
};

/* Two random numbers in [0, 1) for a cell of a pattern. */
static void cell_random(const sy_material *m, double i, double j, double *a, double *b)
{
    uint32_t h = sy_hash3((int32_t)i, (int32_t)j, 7, m->seed);
    *a = sy_hash_unit(h);
    *b = sy_hash_unit(sy_hash(h ^ 0x5bd1e995u));
}

/* A cell's colour: between c0 and c1 with a brightness change, faded to the mean when the
 * cell is below the footprint. */
static sy_vec cell_color(sy_vec c0, sy_vec c1, double a, double b, double amount, double detail)
{
    sy_vec c = sy_lerp(c0, c1, a);
    c = sy_scale(c, 1.0 + amount * (b - 0.5));
    return sy_lerp(sy_lerp(c0, c1, 0.5), c, detail);
}

static sy_vec bricks(const sy_material *m, double u, double v, double w)
{
    double L = m->scale[0], H = m->scale[1], joint = 0.011;
    double row = floor(v / H);
    double shifted = u + ((long)row & 1 ? 0.5 * L : 0.0);
    double col = floor(shifted / L);
    double mortar = 1.0 - (1.0 - sy_lines(v, H, joint, w)) * (1.0 - sy_lines(shifted, L, joint, w));
    double a, b;
    cell_random(m, col, row, &a, &b);
    sy_vec brick = cell_color(m->color[0], m->color[1], a, b, 0.35 * m->variation, sy_detail(H, w));
    brick = sy_scale(brick, 1.0 + 0.18 * m->variation * sy_fbm2(u, v, 18, 4, w, m->seed));
    sy_vec joints = sy_scale(m->color[2], 1.0 + 0.15 * sy_fbm2(u, v, 50, 2, w, m->seed + 3));
    return sy_lerp(brick, joints, mortar);
}

static sy_vec tiles(const sy_material *m, double u, double v, double w)
{
    double su = m->scale[0], sv = m->scale[1], grout = 0.006;
    double row = floor(v / sv), col = floor(u / su);
    double a, b;
    cell_random(m, col, row, &a, &b);
    double detail = sy_detail(fmin(su, sv), w);
    sy_vec tile;
    if (m->variant == 1) { /* checkerboard, box-filtered: product of two square waves */
        double check = 0.5 - 0.5 * (2 * sy_square(u, 2 * su, w) - 1) * (2 * sy_square(v, 2 * sv, w) - 1);
        tile = sy_lerp(m->color[0], m->color[1], check);
        tile = sy_scale(tile, 1.0 + 0.08 * m->variation * (b - 0.5) * detail);
    } else {
        tile = cell_color(m->color[0], m->color[1], a, b, 0.2 * m->variation, detail);
    }
    if (m->variant == 2) { /* veined stone tiles */
        double t = (u + 0.6 * v) * 6.0 + 3.0 * sy_fbm2(u, v, 1.5, 5, w, m->seed + (uint32_t)(a * 1000));
        double vein = (1.0 - sy_smoothstep(0.0, 0.12, fabs(sin(M_PI * t)))) * sy_detail(0.02, w);
        tile = sy_lerp(tile, m->color[3], 0.6 * vein);
    }
    tile = sy_scale(tile, 1.0 + 0.06 * sy_fbm2(u, v, 30, 3, w, m->seed + 5));
    double g = 1.0 - (1.0 - sy_lines(u, su, grout, w)) * (1.0 - sy_lines(v, sv, grout, w));
    return sy_lerp(tile, m->color[2], g);
}

/* Boards along u, rows across v; each row is offset, each board tinted, with grain. */
static sy_vec planks(const sy_material *m, double u, double v, double w)
{
    if (m->variant == 1) { double t = u; u = v; v = t; }
    double width = m->scale[0], length = m->scale[1];
    double row = floor(v / width);
    double offset = sy_hash_unit(sy_hash3(0, (int32_t)row, 1, m->seed)) * length;
    double board = floor((u + offset) / length);
    double a, b;
    cell_random(m, board, row, &a, &b);
    double detail = sy_detail(width, w);
    double grain_period = 0.012;
    double g = (v + 13.7 * a) / grain_period + 2.5 * sy_fbm2(u * 0.8, v * 12, 1.0, 4, w * 12, m->seed + 9);
    double grain = (0.5 + 0.5 * sin(2 * M_PI * g)) * sy_detail(grain_period, w) + 0.5 * (1 - sy_detail(grain_period, w));
    sy_vec wood = sy_lerp(m->color[0], m->color[1], 0.45 * grain);
    double tint = 1.0 + 0.3 * m->variation * (b - 0.5) * detail;
    wood = sy_scale(wood, tint * (1.0 + 0.1 * sy_fbm2(u, v, 4, 5, w, m->seed + 2)));
    double gap = m->scale[2] > 0 ? m->scale[2] : 0.003;
    double seam = 1.0 - (1.0 - sy_lines(v, width, gap, w)) * (1.0 - sy_lines(u + offset, length, gap, w));
    return sy_lerp(wood, m->color[2], 0.8 * seam);
}

static sy_vec stripes(const sy_material *m, double u, double v, double w)
{
    double period = m->scale[0];
    sy_vec c = sy_lerp(m->color[0], m->color[1], sy_square(u, period, w));
    if (m->variant == 1) /* pinstripes in the middle of each band */
        c = sy_lerp(c, m->color[2], 0.8 * sy_lines(u - 0.25 * period, 0.5 * period, 0.004, w));
    if (m->variant == 2) { /* a damask-like motif: noise blobs repeated in every band */
        double blob = sy_fbm2(fmod(u, period), v, 6 / period, 3, w, m->seed);
        c = sy_lerp(c, m->color[2], 0.25 * sy_smoothstep(0.1, 0.3, blob) * sy_detail(period, w));
    }
    return sy_scale(c, 1.0 + 0.05 * sy_fbm2(u, v, 60, 2, w, m->seed + 1));
}

static sy_vec checks(const sy_material *m, double u, double v, double w)
{
    double size = m->scale[0];
    double check = 0.5 - 0.5 * (2 * sy_square(u, 2 * size, w) - 1) * (2 * sy_square(v, 2 * size, w) - 1);
    return sy_lerp(m->color[0], m->color[1], check);
}

/* A rug: border band, a field with a pattern, a thin inner line. */
static sy_vec rug(const sy_material *m, const sy_surface *s, double w)
{
    double u = s->u, v = s->v;
    double edge = fmin(fmin(u, s->size_u - u), fmin(v, s->size_v - v));
    double border = m->scale[0];
    double in_border = 1.0 - sy_smoothstep(border - 0.5 * w, border + 0.5 * w, edge);
    double line = sy_lines(edge - border - 0.04, 1e3, 0.015, w);
    sy_vec field;
    if (m->variant == 0) { /* diamonds */
        double d = fabs(fmod(fabs(u - 0.5 * s->size_u), 0.3) - 0.15) +
                   fabs(fmod(fabs(v - 0.5 * s->size_v), 0.3) - 0.15);
        field = sy_lerp(m->color[0], m->color[3], sy_smoothstep(0.09 - w, 0.09 + w, d));
    } else if (m->variant == 1) { /* plaid */
        double a = sy_square(u, 0.25, w), b = sy_square(v, 0.25, w);
        field = sy_lerp(m->color[0], m->color[3], 0.5 * (a + b));
    } else {
        field = sy_lerp(m->color[0], m->color[3], 0.5 + 0.5 * sy_fbm2(u, v, 2, 4, w, m->seed));
    }
    sy_vec c = sy_lerp(field, m->color[1], in_border);
    c = sy_lerp(c, m->color[2], line);
    return sy_scale(c, 1.0 + 0.12 * sy_fbm2(u, v, 80, 2, w, m->seed + 4));
}

sy_vec sy_texture_pattern(const sy_material *m, const sy_surface *s, double w)
{
    switch (m->kind) {
    case SY_MAT_BRICK: return bricks(m, s->u, s->v, w);
    case SY_MAT_TILES: return tiles(m, s->u, s->v, w);
    case SY_MAT_PLANKS: return planks(m, s->u, s->v, w);
    case SY_MAT_STRIPES: return stripes(m, s->u, s->v, w);
    case SY_MAT_CHECKS: return checks(m, s->u, s->v, w);
    case SY_MAT_RUG: return rug(m, s, w);
    default: return sy_texture_solid(m, s, w);
    }
}

/* Albedos stay below 0.9, as real surfaces do. */
static sy_vec clamp_albedo(sy_vec c)
{
    return sy_v(sy_clamp(c.x, 0, 0.9), sy_clamp(c.y, 0, 0.9), sy_clamp(c.z, 0, 0.9));
}

sy_vec sy_albedo_detail(sy_vec albedo, sy_vec p, double footprint, double amount, uint32_t seed)
{
    double noise = sy_fbm3(p, 3.0, 5, footprint, seed ^ 0x85ebca6bu);
    return clamp_albedo(sy_scale(albedo, 1.0 + amount * noise));
}

sy_vec sy_material_albedo(const sy_material *m, const sy_surface *s, double footprint)
{
    if (m->kind == SY_MAT_EMITTER) return sy_v(0, 0, 0);
    sy_vec c = sy_texture_pattern(m, s, footprint);
    /* dirt and wear at the scale of a metre, the same on every kind */
    double dirt = sy_fbm3(s->p, 0.7, 3, footprint, m->seed ^ 0x9e3779b9u);
    return clamp_albedo(sy_scale(c, 1.0 + 0.12 * m->variation * dirt));
}
