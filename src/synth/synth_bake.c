/* Baked lighting: the irradiance of every surface, stored in a lightmap of texels over each
 * face and looked up bilinearly when shading. Lighting is diffuse, so it depends on the
 * surface point only, not on the view: baking it once makes soft shadows (9 samples per
 * light) and ambient occlusion (9 hemisphere rays) affordable, and every frame sees the
 * same values. Sample patterns are stratified and shifted per texel by a hash of its index
 * (deterministic, independent of threads); a 3x3 blur removes the remaining grain (9 shifted
 * patterns gave the same pictures as 16 at half the time). Texels are about 4 cm at 256
 * pixels across, coarser for smaller images. */
#include "synth/synth_internal.h"

#include <stdlib.h>
#include <string.h>

#define BASE_TEXEL 0.04
#define GRID 3                   /* GRID x GRID samples per light and for occlusion */
#define AO_DISTANCE 1.0
#define WEAK_LIGHT 0.1
#define MAX_TEXELS_PER_SIDE 512

/* Orthonormal basis around a unit vector (Duff et al. 2017, "Building an orthonormal basis,
 * revisited"). */
static void basis(sy_vec n, sy_vec *t1, sy_vec *t2)
{
    double sign = n.z >= 0 ? 1.0 : -1.0, a = -1.0 / (sign + n.z), b = n.x * n.y * a;
    *t1 = sy_v(1.0 + sign * n.x * n.x * a, sign * b, -sign * n.x);
    *t2 = sy_v(b, sign + n.y * n.y * a, -n.y);
}

/* Sample k of a GRID x GRID stratified pattern shifted by (jx, jy) (Cranley-Patterson). */
static void stratum(int k, double jx, double jy, double *u, double *v)
{
    double a = (k % GRID + 0.5) / GRID + jx, b = (k / GRID + 0.5) / GRID + jy;
    *u = a - floor(a);
    *v = b - floor(b);
}

/* Uniform point on the unit disc from the unit square (Shirley-Chiu concentric map). */
static void concentric(double u, double v, double *x, double *y)
{
    double a = 2 * u - 1, b = 2 * v - 1, r, phi;
    if (a == 0 && b == 0) { *x = *y = 0; return; }
    if (fabs(a) > fabs(b)) { r = a; phi = M_PI / 4 * (b / a); }
    else { r = b; phi = M_PI / 2 - M_PI / 4 * (a / b); }
    *x = r * cos(phi);
    *y = r * sin(phi);
}

/* One sample of a light seen from p: its unshadowed contribution e to the irradiance and
 * the shadow ray (direction d, length dist) that decides whether it counts. */
typedef struct { sy_vec e, d; double dist; } light_ray;

static int light_sample(const sy_light *l, sy_vec p, sy_vec n, double u, double v, light_ray *ray)
{
    const int N = GRID * GRID;
    double x, y;
    concentric(u, v, &x, &y);
    if (l->kind == SY_LIGHT_SUN) {
        sy_vec e1, e2;
        basis(l->dir, &e1, &e2);
        ray->d = sy_normalize(sy_add(l->dir, sy_add(sy_scale(e1, l->angle * x), sy_scale(e2, l->angle * y))));
        double cos_p = sy_dot(n, ray->d);
        ray->e = sy_scale(l->radiance, cos_p / N);
        ray->dist = 1e4;
        return cos_p > 0;
    }
    sy_vec q;
    double area;
    if (l->kind == SY_LIGHT_RECT) {
        q = sy_v(l->pos.x + (2 * u - 1) * l->size[0], l->pos.y + (2 * v - 1) * l->size[1], l->pos.z);
        area = 4 * l->size[0] * l->size[1];
    } else { /* a sphere seen from p is a disc of its radius facing p */
        sy_vec to_c = sy_sub(l->pos, p), e1, e2;
        if (sy_length(to_c) <= 1.01 * l->size[0]) return 0;
        basis(sy_normalize(to_c), &e1, &e2);
        q = sy_add(l->pos, sy_add(sy_scale(e1, l->size[0] * x), sy_scale(e2, l->size[0] * y)));
        area = M_PI * l->size[0] * l->size[0];
    }
    sy_vec to_q = sy_sub(q, p);
    double r2 = sy_dot(to_q, to_q), r = sqrt(r2);
    ray->d = sy_scale(to_q, 1.0 / r);
    ray->dist = r - 1e-3;
    double cos_p = sy_dot(n, ray->d), cos_l = l->kind == SY_LIGHT_RECT ? ray->d.z : 1.0;
    ray->e = sy_scale(l->radiance, cos_p * cos_l * area / (N * fmax(r2, 0.01)));
    return cos_p > 0 && cos_l > 0;
}

static double luminance(sy_vec c) { return 0.2126 * c.x + 0.7152 * c.y + 0.0722 * c.z; }

/* Direct irradiance: every sample of every light with its shadow ray, except that a light
 * giving less than WEAK_LIGHT of the unshadowed total here is tested with one ray (its share
 * of error is small, and rooms with many lamps bake several times faster). */
static sy_vec direct_light(const gv_synth_world *w, sy_vec p, sy_vec n, double jx, double jy)
{
    light_ray rays[SY_MAX_LIGHTS][GRID * GRID];
    int valid[SY_MAX_LIGHTS][GRID * GRID];
    sy_vec unshadowed[SY_MAX_LIGHTS];
    double total = 0;
    for (int i = 0; i < w->n_lights; i++) {
        unshadowed[i] = sy_v(0, 0, 0);
        for (int k = 0; k < GRID * GRID; k++) {
            double u, v;
            stratum(k, jx, jy, &u, &v);
            valid[i][k] = light_sample(&w->lights[i], p, n, u, v, &rays[i][k]);
            if (valid[i][k]) unshadowed[i] = sy_add(unshadowed[i], rays[i][k].e);
        }
        total += luminance(unshadowed[i]);
    }
    sy_vec o = sy_add(p, sy_scale(n, 1e-4)), e = sy_v(0, 0, 0);
    for (int i = 0; i < w->n_lights; i++) {
        int weak = luminance(unshadowed[i]) < WEAK_LIGHT * total;
        for (int k = 0; k < GRID * GRID; k++) {
            int kk = weak ? (k + GRID * GRID / 2) % (GRID * GRID) : k; /* weak: from the middle */
            if (!valid[i][kk]) continue;
            if (!sy_occluded(w, o, rays[i][kk].d, rays[i][kk].dist))
                e = sy_add(e, weak ? unshadowed[i] : rays[i][kk].e);
            if (weak) break;
        }
    }
    return e;
}

/* Direct irradiance and the unoccluded fraction of the cosine-weighted hemisphere. */
static void bake_texel(const gv_synth_world *w, sy_vec p, sy_vec n, uint32_t h, sy_vec *direct, double *open)
{
    double jx = sy_hash_unit(h), jy = sy_hash_unit(sy_hash(h));
    *direct = direct_light(w, p, n, jx, jy);
    sy_vec t1, t2, o = sy_add(p, sy_scale(n, 1e-4));
    basis(n, &t1, &t2);
    int seen = 0;
    for (int k = 0; k < GRID * GRID; k++) {
        double u, v, x, y;
        stratum(k, jy, jx, &u, &v);
        concentric(u, v, &x, &y);
        double z = sqrt(fmax(0.0, 1.0 - x * x - y * y));
        sy_vec d = sy_add(sy_add(sy_scale(t1, x), sy_scale(t2, y)), sy_scale(n, z));
        seen += !sy_occluded(w, o, d, AO_DISTANCE);
    }
    *open = (double)seen / (GRID * GRID);
}

/* One lightmap patch per face; faces that look out of the room get a single texel. */
static int allocate_patches(gv_synth_world *w)
{
    int count = 0;
    for (int i = 0; i < w->n_prims; i++) count += sy_prim_n_faces(&w->prims[i]);
    w->patches = calloc((size_t)count, sizeof *w->patches);
    if (!w->patches) return gv_fail("scene synth: out of memory (%d lightmap patches)", count);
    long offset = 0;
    for (int g = 0; g < w->n_groups; g++) {
        const sy_group *group = &w->groups[g];
        for (int i = group->first; i < group->first + group->count; i++) {
            sy_prim *prim = &w->prims[i];
            prim->first_patch = w->n_patches;
            for (int f = 0; f < sy_prim_n_faces(prim); f++) {
                sy_patch *pa = &w->patches[w->n_patches++];
                double ss, st;
                sy_vec point, normal;
                sy_prim_face_size(prim, f, &ss, &st, &pa->wraps);
                sy_prim_face_point(prim, f, 0.5, 0.5, &point, &normal);
                int hidden = prim->light >= 0 || sy_dot(normal, group->outward) > 0.99;
                pa->prim = i;
                pa->face = f;
                pa->nu = hidden ? 1 : (int)sy_clamp(ceil(ss / w->texel_size), 1, MAX_TEXELS_PER_SIDE);
                pa->nv = hidden ? 1 : (int)sy_clamp(ceil(st / w->texel_size), 1, MAX_TEXELS_PER_SIDE);
                pa->offset = offset;
                offset += (long)pa->nu * pa->nv;
            }
        }
    }
    w->n_texels = offset;
    w->lightmap = calloc((size_t)offset * 3, sizeof *w->lightmap);
    if (!w->lightmap) return gv_fail("scene synth: out of memory (%ld lightmap texels)", offset);
    return 0;
}

/* Separable [1 2 1] / 4 blur inside each patch (edges clamped, wrapping faces wrapped). */
static void blur_patch(float *map, const sy_patch *pa, float *tmp)
{
    int nu = pa->nu, nv = pa->nv;
    float *m = map + 3 * pa->offset;
    for (int pass = 0; pass < 2; pass++) {
        int n_along = pass == 0 ? nu : nv;
        memcpy(tmp, m, sizeof(float) * 3 * (size_t)nu * nv);
        for (int j = 0; j < nv; j++)
            for (int i = 0; i < nu; i++) {
                int a = pass == 0 ? i : j, lo = a - 1, hi = a + 1;
                if (lo < 0) lo = pass == 0 && pa->wraps ? n_along - 1 : 0;
                if (hi >= n_along) hi = pass == 0 && pa->wraps ? 0 : n_along - 1;
                int i0 = pass == 0 ? lo : i, j0 = pass == 0 ? j : lo, i1 = pass == 0 ? hi : i, j1 = pass == 0 ? j : hi;
                for (int c = 0; c < 3; c++)
                    m[3 * (j * nu + i) + c] = 0.25f * tmp[3 * (j0 * nu + i0) + c] + 0.5f * tmp[3 * (j * nu + i) + c] +
                                              0.25f * tmp[3 * (j1 * nu + i1) + c];
            }
    }
}

/* Ambient: a share of the room's mean direct irradiance, tinted by its walls and floor,
 * attenuated by occlusion (a stand-in for light bounced around the room). */
static sy_vec ambient_level(const gv_synth_world *w, gv_rng *r, const float *open)
{
    sy_vec sum = sy_v(0, 0, 0);
    long n = 0;
    for (int p = 0; p < w->n_patches; p++) {
        const sy_patch *pa = &w->patches[p];
        if (pa->nu * pa->nv == 1) continue;
        for (long t = pa->offset; t < pa->offset + (long)pa->nu * pa->nv; t++, n++)
            if (open[t] > 0) /* texels buried in other solids see nothing */
                sum = sy_add(sum, sy_v(w->lightmap[3 * t], w->lightmap[3 * t + 1], w->lightmap[3 * t + 2]));
    }
    sy_vec mean = n ? sy_scale(sum, 1.0 / n) : sy_v(0.1, 0.1, 0.1);
    sy_vec tint = sy_add(w->materials[w->wall_material].color[0], w->materials[w->floor_material].color[0]);
    double lum = 0.2126 * tint.x + 0.7152 * tint.y + 0.0722 * tint.z;
    tint = sy_lerp(sy_v(1, 1, 1), sy_scale(tint, 1.0 / fmax(lum, 1e-3)), 0.5);
    return sy_scale(sy_mul(mean, tint), sy_uniform(r, 0.35, 0.7));
}

int sy_bake_lighting(gv_synth_world *w, gv_rng *r)
{
    w->texel_size = sy_clamp(BASE_TEXEL * 256.0 / w->params.width, 0.02, 0.25);
    if (allocate_patches(w)) return -1;
    /* jobs: one row of one patch each, so that big faces spread over threads */
    long n_rows = 0;
    for (int p = 0; p < w->n_patches; p++) n_rows += w->patches[p].nv;
    int *job_patch = malloc((size_t)n_rows * sizeof *job_patch);
    int *job_row = malloc((size_t)n_rows * sizeof *job_row);
    float *open = malloc((size_t)w->n_texels * sizeof *open);
    if (!job_patch || !job_row || !open) {
        free(job_patch), free(job_row), free(open);
        return gv_fail("scene synth: out of memory (%ld lightmap texels)", w->n_texels);
    }
    long k = 0;
    for (int p = 0; p < w->n_patches; p++)
        for (int j = 0; j < w->patches[p].nv; j++, k++) job_patch[k] = p, job_row[k] = j;
    #pragma omp parallel for schedule(dynamic, 4)
    for (long job = 0; job < n_rows; job++) {
        const sy_patch *pa = &w->patches[job_patch[job]];
        int j = job_row[job];
        for (int i = 0; i < pa->nu; i++) {
            long t = pa->offset + (long)j * pa->nu + i;
            sy_vec p, n, e;
            double visible;
            sy_prim_face_point(&w->prims[pa->prim], pa->face, (i + 0.5) / pa->nu, (j + 0.5) / pa->nv, &p, &n);
            bake_texel(w, p, n, sy_hash((uint32_t)t * 0x9e3779b1u ^ w->sky.seed), &e, &visible);
            w->lightmap[3 * t] = (float)e.x;
            w->lightmap[3 * t + 1] = (float)e.y;
            w->lightmap[3 * t + 2] = (float)e.z;
            open[t] = (float)visible;
        }
    }
    sy_vec ambient = ambient_level(w, r, open);
    for (long t = 0; t < w->n_texels; t++) {
        double a = 0.25 + 0.75 * open[t];
        w->lightmap[3 * t] += (float)(ambient.x * a);
        w->lightmap[3 * t + 1] += (float)(ambient.y * a);
        w->lightmap[3 * t + 2] += (float)(ambient.z * a);
    }
    long biggest = 0;
    for (int p = 0; p < w->n_patches; p++)
        if ((long)w->patches[p].nu * w->patches[p].nv > biggest) biggest = (long)w->patches[p].nu * w->patches[p].nv;
    float *tmp = malloc(sizeof(float) * 3 * (size_t)biggest);
    int ok = tmp != NULL;
    if (ok)
        for (int p = 0; p < w->n_patches; p++) blur_patch(w->lightmap, &w->patches[p], tmp);
    free(tmp), free(job_patch), free(job_row), free(open);
    return ok ? 0 : gv_fail("scene synth: out of memory");
}
