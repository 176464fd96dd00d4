/* Internals of the procedural scene generator (src/synth/synth_*.c): vectors, primitives,
 * materials, lights, the lightmap and the world. World frame: metres, +z up, the room's
 * floor at z = 0 centred on the origin (as the shared Blender scenes: +Z up). */
#ifndef GAUSSVID_SCENE_SYNTH_INTERNAL_H
#define GAUSSVID_SCENE_SYNTH_INTERNAL_H

#include <math.h>
#include <stdint.h>

#include "gaussvid/core/core.h"
#include "gaussvid/synth/synth.h"

/* ---- Vectors ------------------------------------------------------------------------- */
typedef struct { double x, y, z; } sy_vec;

static inline sy_vec sy_v(double x, double y, double z) { sy_vec v = {x, y, z}; return v; }
static inline sy_vec sy_add(sy_vec a, sy_vec b) { return sy_v(a.x + b.x, a.y + b.y, a.z + b.z); }
static inline sy_vec sy_sub(sy_vec a, sy_vec b) { return sy_v(a.x - b.x, a.y - b.y, a.z - b.z); }
static inline sy_vec sy_scale(sy_vec a, double s) { return sy_v(a.x * s, a.y * s, a.z * s); }
static inline sy_vec sy_mul(sy_vec a, sy_vec b) { return sy_v(a.x * b.x, a.y * b.y, a.z * b.z); }
static inline double sy_dot(sy_vec a, sy_vec b) { return a.x * b.x + a.y * b.y + a.z * b.z; }
static inline sy_vec sy_cross(sy_vec a, sy_vec b)
{
    return sy_v(a.y * b.z - a.z * b.y, a.z * b.x - a.x * b.z, a.x * b.y - a.y * b.x);
}
static inline double sy_length(sy_vec a) { return sqrt(sy_dot(a, a)); }
static inline sy_vec sy_normalize(sy_vec a) { return sy_scale(a, 1.0 / sy_length(a)); }
static inline sy_vec sy_lerp(sy_vec a, sy_vec b, double t) { return sy_add(a, sy_scale(sy_sub(b, a), t)); }
static inline double sy_clamp(double x, double lo, double hi) { return x < lo ? lo : x > hi ? hi : x; }
static inline double sy_smoothstep(double a, double b, double x)
{
    double t = sy_clamp((x - a) / (b - a), 0.0, 1.0);
    return t * t * (3.0 - 2.0 * t);
}
static inline double sy_mix(double a, double b, double t) { return a + (b - a) * t; }

/* ---- Geometry (synth_geometry.c) -------------------------------------------------------
 * Every primitive has its own frame: translated to `center`, rotated by `yaw` about +z.
 * Box: half extents `half`. Sphere: radius half.x. Cylinder: axis +z, radius half.x, base
 * disc at the local origin, height half.z. Faces (lightmap patches): box 0..5 = +x,-x,+y,
 * -y,+z,-z; sphere 0; cylinder 0 side, 1 top, 2 bottom. */
typedef enum { SY_BOX, SY_SPHERE, SY_CYLINDER } sy_shape;

typedef struct {
    sy_shape shape;
    sy_vec center, half;
    double yaw, cos_yaw, sin_yaw;
    int material;
    int light;          /* index of the light it shows (emitters do not cast shadows), or -1 */
    int first_patch;    /* lightmap patch of face 0 */
} sy_prim;

enum { SY_HIT_NONE = -1, SY_HIT_GROUND = -2 };

typedef struct {
    double t;
    int prim;           /* index, SY_HIT_NONE (sky) or SY_HIT_GROUND (the outside ground) */
    int face;
} sy_hit;

/* What shading needs about a hit. */
typedef struct {
    sy_vec p, n;        /* world position; unit normal on the side the ray came from */
    sy_vec local;       /* position in the primitive's frame (solid textures) */
    double u, v;        /* face coordinates in metres (2D patterns; v is up on walls) */
    double size_u, size_v; /* the face's extent in u and v (metres) */
    int face;           /* the primitive's face (0 for the ground) */
    int patch;          /* lightmap patch, -1 for the ground */
    double s, t;        /* position in the patch, [0, 1]^2 */
} sy_surface;

void sy_prim_set_yaw(sy_prim *p, double yaw);
int sy_prim_n_faces(const sy_prim *p);
/* Closest intersection with t in (tmin, tmax); returns 1 and sets *t, *face when found. */
int sy_prim_intersect(const sy_prim *p, sy_vec o, sy_vec d, double tmin, double tmax,
                      double *t, int *face);
/* Surface record of a hit at distance t along o + t d on face `face`. */
void sy_prim_surface(const sy_prim *p, int face, sy_vec o, sy_vec d, double t, sy_surface *s);
/* Point and outward normal at patch coordinates (s, t) of a face (for baking). */
void sy_prim_face_point(const sy_prim *p, int face, double s, double t, sy_vec *point, sy_vec *normal);
/* Extent of a face in metres along its patch axes, and whether s wraps around. */
void sy_prim_face_size(const sy_prim *p, int face, double *size_s, double *size_t, int *wraps);
/* World-space bounding box. */
void sy_prim_bounds(const sy_prim *p, sy_vec *lo, sy_vec *hi);
/* 1 when the point is inside the solid. */
int sy_prim_contains(const sy_prim *p, sy_vec point);

/* ---- Noise and filtered patterns (synth_noise.c) ------------------------------------- */
uint32_t sy_hash(uint32_t x);
uint32_t sy_hash3(int32_t x, int32_t y, int32_t z, uint32_t seed);
double sy_hash_unit(uint32_t h); /* [0, 1) */
double sy_noise2(double x, double y, uint32_t seed);          /* value noise in [-1, 1] */
double sy_noise3(sy_vec p, uint32_t seed);                    /* value noise in [-1, 1] */
/* Fractal sums of value noise from frequency `freq` (cycles per metre) upwards, each octave
 * faded out as its period approaches the footprint (metres): band-limited, so no aliasing. */
double sy_fbm2(double x, double y, double freq, int octaves, double footprint, uint32_t seed);
double sy_fbm3(sy_vec p, double freq, int octaves, double footprint, uint32_t seed);
/* Fraction of the box [x - w/2, x + w/2] covered by lines of width `width` centred on the
 * multiples of `period` (exact box filter of the line pattern). */
double sy_lines(double x, double period, double width, double w);
/* Box-filtered square wave: fraction of [x - w/2, x + w/2] in the first half of a period. */
double sy_square(double x, double period, double w);
/* Contrast fade for details of size `size` seen through a footprint `w`: 1 when sharp,
 * 0 when the footprint covers them (per-cell colours then average out instead of shimmering). */
double sy_detail(double size, double w);

/* ---- Materials (synth_texture*.c, synth_palette.c) ------------------------------------ */
typedef enum {
    SY_MAT_PLASTER, SY_MAT_BRICK, SY_MAT_TILES, SY_MAT_PLANKS, SY_MAT_STRIPES, SY_MAT_CHECKS,
    SY_MAT_WOOD, SY_MAT_MARBLE, SY_MAT_FABRIC, SY_MAT_PAINTING, SY_MAT_PAINT, SY_MAT_BOOK,
    SY_MAT_FOLIAGE, SY_MAT_RUG, SY_MAT_GROUND, SY_MAT_EMITTER, SY_MAT_COUNT
} sy_material_kind;

typedef struct {
    sy_material_kind kind;
    sy_vec color[4];    /* linear RGB albedos (or radiance for emitters) */
    double scale[3];    /* pattern sizes in metres (per kind; planks: width, length, seam) */
    double variation;   /* strength of per-cell and noise variation, 0..1 */
    int variant;        /* a kind's sub-style */
    int axis;           /* wood: grain axis (0 x, 1 y, 2 z) in the primitive's frame */
    uint32_t seed;
} sy_material;

extern const char *const sy_material_names[SY_MAT_COUNT];
/* Diffuse albedo (linear RGB) at a surface seen through a footprint (metres). */
sy_vec sy_material_albedo(const sy_material *m, const sy_surface *s, double footprint);
/* The albedo times 1 + amount x band-limited noise of the point in space (periods 33 cm down
 * to 2 cm): detail that never repeats, for scenes meant for feature matching. */
sy_vec sy_albedo_detail(sy_vec albedo, sy_vec p, double footprint, double amount, uint32_t seed);
/* The 2D-pattern kinds (bricks, tiles, planks, ...) and the solid ones, in two files. */
sy_vec sy_texture_pattern(const sy_material *m, const sy_surface *s, double w);
sy_vec sy_texture_solid(const sy_material *m, const sy_surface *s, double w);

/* Colours: HSV (all in [0, 1]) to linear RGB, and seeded choices per role. */
sy_vec sy_hsv(double h, double s, double v);
double sy_srgb_to_linear(double c);
double sy_linear_to_srgb(double c);

/* ---- Lights (synth_light.c) ----------------------------------------------------------- */
typedef enum { SY_LIGHT_RECT, SY_LIGHT_SPHERE, SY_LIGHT_SUN } sy_light_kind;

typedef struct {
    sy_light_kind kind;
    sy_vec pos;         /* rect: centre of the emitting face (facing -z); sphere: centre */
    double size[2];     /* rect: half sizes in x and y; sphere: radius in size[0] */
    sy_vec dir;         /* sun: unit vector towards the sun */
    double angle;       /* sun: angular radius (radians) */
    sy_vec radiance;    /* rect, sphere: emitted radiance; sun: irradiance at normal incidence */
} sy_light;

#define SY_MAX_LIGHTS 8

/* ---- The world ------------------------------------------------------------------------ */
typedef struct {
    sy_vec lo, hi;
    int first, count;   /* primitives [first, first + count) */
    int furniture;      /* 1 for objects (the camera keeps clear of them), 0 for the shell */
    sy_vec outward;     /* shell: faces with this normal look out of the room (never seen) */
} sy_group;

typedef struct {
    int prim, face;
    int nu, nv;         /* texels along s and t */
    int wraps;          /* s is periodic */
    long offset;        /* first texel in the lightmap */
} sy_patch;

/* A node of the bounding volume hierarchy: a leaf holds bvh_prims[first, first + count);
 * an inner node (count 0) has children first and first + 1. */
typedef struct {
    sy_vec lo, hi;
    int first, count;
} sy_bvh_node;

/* An opening in a wall: a door (from the floor) or a window. */
typedef struct {
    int wall;           /* 0 south (y = lo), 1 east (x = hi), 2 north (y = hi), 3 west (x = lo) */
    double s0, s1;      /* extent along the wall, metres from the wall's start corner */
    double z0, z1;
    int door;
} sy_opening;

#define SY_MAX_OPENINGS 8
#define SY_MAX_WAYPOINTS 12

typedef struct {
    sy_vec zenith, horizon, hills; /* sky radiance colours */
    sy_vec sun_dir;
    sy_vec sun_irradiance;         /* zero when the room has no sun */
    double ground_z;
    int ground_material;
    uint32_t seed;
} sy_sky;

struct gv_synth_world {
    gv_synth_params params;
    sy_vec room_lo, room_hi;     /* the empty interior box */
    /* Geometry: primitives in groups (one piece of furniture, one wall, ...) */

    sy_prim *prims;
    int n_prims, cap_prims;
    sy_bvh_node *bvh;            /* built once all primitives are in (synth_bvh.c) */
    int n_bvh;
    int *bvh_prims;
    sy_group *groups;
    int n_groups, cap_groups;
    int open_group;              /* group being filled, or -1 */
    sy_material *materials;
    int n_materials, cap_materials;
    sy_light lights[SY_MAX_LIGHTS];
    int n_lights;
    sy_opening openings[SY_MAX_OPENINGS];
    int n_openings;
    sy_sky sky;
    int wall_material, floor_material; /* the room's main ones (ambient tint, description) */
    int n_objects;               /* furniture placed, and their kinds (for the description) */
    char object_names[512];

    /* Lightmap: irradiance (linear RGB) per texel of every face. */
    sy_patch *patches;
    int n_patches;
    float *lightmap;
    long n_texels;
    double texel_size;

    /* Camera path: waypoints, dense centres for planning, then one camera per frame. */
    sy_vec waypoints[SY_MAX_WAYPOINTS];
    int n_waypoints;
    sy_vec *plan;                /* dense samples of the translation path */
    int n_plan;
    int path_mode;               /* 0 orbit, 1 walk */
    double path_length;          /* metres, over the frames */
    double path_turn;            /* total view rotation over the frames (radians) */
    gv_camera *cameras;
    double exposure;             /* multiplies linear radiance before the tone curve */
    double fx;                   /* focal length in pixels (fx = fy) */
};

/* World building (synth_world.c): growable arrays; every add fails only on memory. */
int sy_add_material(gv_synth_world *w, const sy_material *m);
int sy_begin_group(gv_synth_world *w, int furniture);
void sy_end_group(gv_synth_world *w);
int sy_add_box(gv_synth_world *w, sy_vec center, sy_vec half, double yaw, int material);
int sy_add_sphere(gv_synth_world *w, sy_vec center, double radius, int material);
int sy_add_cylinder(gv_synth_world *w, sy_vec base, double radius, double height, double yaw, int material);

/* The hierarchy over the primitives (synth_bvh.c); sy_trace and sy_occluded use it. */
int sy_build_bvh(gv_synth_world *w);
/* Closest hit in (tmin, hit->t) updating hit, or with any_hit the first primitive that casts
 * shadows; returns 1 when something was hit. */
int sy_bvh_traverse(const gv_synth_world *w, sy_vec o, sy_vec d, double tmin, sy_hit *hit, int any_hit);

/* Ray queries (synth_trace.c). Directions are unit vectors. */
int sy_trace(const gv_synth_world *w, sy_vec o, sy_vec d, double tmax, sy_hit *hit);
/* 1 when something that casts shadows lies along o + t d, t in (0, tmax). */
int sy_occluded(const gv_synth_world *w, sy_vec o, sy_vec d, double tmax);
/* Surface record of a hit (also for the ground). */
void sy_surface_at(const gv_synth_world *w, sy_vec o, sy_vec d, const sy_hit *hit, sy_surface *s);
/* Distance from a point to the nearest furniture bounding box (0 inside one). */
double sy_furniture_clearance(const gv_synth_world *w, sy_vec p);

/* Stages of gv_synth_build, each from its own random stream. */
int sy_build_room(gv_synth_world *w, gv_rng *rng);          /* synth_layout.c */
int sy_plan_path(gv_synth_world *w, gv_rng *rng);           /* synth_path.c */
int sy_place_furniture(gv_synth_world *w, gv_rng *rng);     /* synth_furniture.c */
int sy_build_lights(gv_synth_world *w, gv_rng *rng);        /* synth_light.c */
/* A glowing sphere that lights the room (its radiance is set by sy_build_lights); a plain
 * one when all light slots are taken. */
int sy_add_sphere_light(gv_synth_world *w, sy_vec center, double radius);
int sy_make_cameras(gv_synth_world *w, gv_rng *rng);        /* synth_camera.c */
int sy_bake_lighting(gv_synth_world *w, gv_rng *rng);       /* synth_bake.c */
int sy_choose_exposure(gv_synth_world *w, gv_rng *rng);     /* synth_render.c */

/* Point at global parameter g in [0, n - 1] of a Catmull-Rom spline through p[0..n) (alpha
 * 0.5 centripetal, 0 uniform), ends extended by reflection (synth_path.c). */
sy_vec sy_spline_at(const sy_vec *p, int n, double g, double alpha);

/* Materials by role (synth_palette.c). */
int sy_material_for(gv_synth_world *w, gv_rng *rng, const char *role);

/* Parts of objects, placed in the object's frame (synth_world.c). */
typedef struct {
    sy_vec origin;      /* floor centre of the footprint */
    double yaw;
} sy_frame;
int sy_part_box(gv_synth_world *w, const sy_frame *f, sy_vec center, sy_vec half, int material);
int sy_part_cylinder(gv_synth_world *w, const sy_frame *f, sy_vec base, double r, double h, int material);
int sy_part_sphere(gv_synth_world *w, const sy_frame *f, sy_vec center, double r, int material);

/* Shading (synth_shade.c): linear radiance seen along a ray whose pixel subtends
 * pixel_angle, the hit it came from (id: prim * 8 + face, -1 sky, -2 ground) and its point
 * (hit_point may be NULL). */
sy_vec sy_radiance(const gv_synth_world *w, sy_vec o, sy_vec d, double pixel_angle, int *id,
                   sy_vec *hit_point);
/* Irradiance at a surface from the lightmap (and the sun and sky for the ground). */
sy_vec sy_irradiance(const gv_synth_world *w, const sy_surface *s);
/* Radiance of the sky (with distant hills) in direction d. */
sy_vec sy_sky_radiance(const gv_synth_world *w, sy_vec d);
/* Exposure, filmic tone curve and sRGB encoding to 8 bits. */
void sy_tone_map(const gv_synth_world *w, sy_vec radiance, uint8_t rgb[3]);
/* Primary ray of a camera through continuous pixel coordinates (px, py) (synth_render.c). */
void sy_camera_ray(const gv_camera *cam, double px, double py, sy_vec *o, sy_vec *d);

/* Random helpers: a uniform number in [lo, hi), an integer in [0, n). */
static inline double sy_uniform(gv_rng *r, double lo, double hi) { return lo + (hi - lo) * gv_rng_uniform(r); }
static inline int sy_choice(gv_rng *r, int n) { return (int)(gv_rng_uniform(r) * n) % n; }

#endif
