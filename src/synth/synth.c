/* The procedural scene generator: parameters, and building a world stage by stage (room,
 * camera path, furniture, lights, cameras, baked lighting, exposure), each stage drawing from
 * its own Philox stream of the seed so that changing one stage leaves the others' numbers
 * alone. gv_synth_write (synth_write.c) renders and writes it. */
#include "synth/synth_internal.h"

#include <stdio.h>
#include <stdlib.h>

void gv_synth_default_params(gv_synth_params *p)
{
    p->seed = 1;
    p->n_frames = 160;
    p->width = 256;
    p->height = 144;
    p->samples = 3;
    p->texture_detail = 0;
}

int gv_synth_check_params(const gv_synth_params *p)
{
    if (p->n_frames < 2 || p->n_frames > GV_SYNTH_MAX_FRAMES)
        return gv_fail("scene synth: --frames %d is out of range (2 to %d)", p->n_frames, GV_SYNTH_MAX_FRAMES);
    if (p->width < 16 || p->height < 16 || p->width > GV_SYNTH_MAX_SIZE || p->height > GV_SYNTH_MAX_SIZE)
        return gv_fail("scene synth: --size %dx%d is out of range (16 to %d pixels each way)", p->width,
                       p->height, GV_SYNTH_MAX_SIZE);
    if (p->width > 4 * p->height || p->height > 4 * p->width)
        return gv_fail("scene synth: --size %dx%d: the aspect ratio must be within 1:4 and 4:1", p->width, p->height);
    if (p->samples < 1 || p->samples > 8)
        return gv_fail("scene synth: --samples %d is out of range (1 to 8)", p->samples);
    if (!(p->texture_detail >= 0 && p->texture_detail <= 1))
        return gv_fail("scene synth: --texture-detail %g is out of range (0 to 1)", p->texture_detail);
    return 0;
}

/* Stream `stage` of the seed: its own range of Philox counters. */
static void stage_rng(gv_rng *r, uint64_t seed, int stage)
{
    gv_rng_init(r, seed);
    r->counter = (uint64_t)stage << 40;
}

int gv_synth_build(const gv_synth_params *p, gv_synth_world **out)
{
    *out = NULL;
    if (gv_synth_check_params(p)) return -1;
    gv_synth_world *w = calloc(1, sizeof *w);
    if (!w) return gv_fail("scene synth: out of memory");
    w->params = *p;
    w->open_group = -1;
    int (*stages[])(gv_synth_world *, gv_rng *) = {sy_build_room, sy_plan_path, sy_place_furniture,
                                                   sy_build_lights, sy_make_cameras, sy_bake_lighting,
                                                   sy_choose_exposure};
    for (int s = 0; s < (int)(sizeof stages / sizeof stages[0]); s++) {
        gv_rng r;
        stage_rng(&r, p->seed, s + 1);
        /* every primitive is in once the lights are: index the geometry for ray tracing */
        if (stages[s] == sy_bake_lighting && sy_build_bvh(w)) {
            gv_synth_free(w);
            return -1;
        }
        if (stages[s](w, &r)) {
            gv_synth_free(w);
            return -1;
        }
    }
    *out = w;
    return 0;
}

void gv_synth_free(gv_synth_world *w)
{
    if (!w) return;
    free(w->prims);
    free(w->bvh);
    free(w->bvh_prims);
    free(w->groups);
    free(w->materials);
    free(w->patches);
    free(w->lightmap);
    free(w->plan);
    free(w->cameras);
    free(w);
}

int gv_synth_camera(const gv_synth_world *w, int frame, gv_camera *out)
{
    if (frame < 0 || frame >= w->params.n_frames)
        return gv_fail("scene synth: frame %d is out of range (0 to %d)", frame, w->params.n_frames - 1);
    *out = w->cameras[frame];
    return 0;
}

int gv_synth_describe(const gv_synth_world *w, char *out, size_t size)
{
    const char *moods = w->sky.sun_irradiance.x > 0 ? "sun through the openings" : "no direct sun";
    int doors = 0, spheres = 0, panels = 0;
    for (int i = 0; i < w->n_openings; i++) doors += w->openings[i].door;
    for (int i = 0; i < w->n_lights; i++) {
        spheres += w->lights[i].kind == SY_LIGHT_SPHERE;
        panels += w->lights[i].kind == SY_LIGHT_RECT;
    }
    char detail[64] = ""; /* said only when asked for, so default rooms describe themselves as before */
    if (w->params.texture_detail > 0) snprintf(detail, sizeof detail, ", texture detail %g", w->params.texture_detail);
    int n = snprintf(out, size,
        "seed %llu, %d frames of %dx%d, %d samples per edge pixel side%s\n"
        "room %.2f x %.2f x %.2f m; walls %s, floor %s; %d windows, %d doors\n"
        "%d objects: %s\n"
        "lights: %d ceiling panels, %d bulbs or globes, %s\n"
        "camera: %s path, %.2f m long, %.0f degrees of turn; fx = fy = %.4f px, 65.5 degrees across\n"
        "%d primitives, %ld lightmap texels of %.3f m; exposure %.4f\n",
        (unsigned long long)w->params.seed, w->params.n_frames, w->params.width, w->params.height, w->params.samples,
        detail, w->room_hi.x - w->room_lo.x, w->room_hi.y - w->room_lo.y, w->room_hi.z,
        sy_material_names[w->materials[w->wall_material].kind], sy_material_names[w->materials[w->floor_material].kind],
        w->n_openings - doors, doors, w->n_objects, w->n_objects ? w->object_names : "none", panels, spheres, moods,
        w->path_mode == 0 ? "orbit" : "walk", w->path_length, w->path_turn * 180 / M_PI, w->fx, w->n_prims,
        w->n_texels, w->texel_size, w->exposure);
    if (n < 0 || (size_t)n >= size) return gv_fail("scene synth: description too long");
    return 0;
}
