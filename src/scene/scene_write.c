/* Writing a scene's description in the shared folder format (docs/SCENES.md): transforms.json,
 * sparse/0/{cameras,images,points3D}.txt and points3D.ply, each file atomically. The images
 * themselves are the caller's: they belong under images/ with the cameras' names. */
#include <stdlib.h>
#include <string.h>

#include "gaussvid/io/colmap.h"
#include "gaussvid/core/core.h"
#include "gaussvid/io/ply.h"
#include "gaussvid/scene/scene.h"
#include "gaussvid/io/transforms.h"

static int same_intrinsics(const gv_camera *a, const gv_colmap_camera *b)
{
    return a->width == b->width && a->height == b->height && a->fx == b->params[0] &&
           a->fy == b->params[1] && a->cx == b->params[2] && a->cy == b->params[3];
}

/* One PINHOLE camera per distinct intrinsics, images 1..n in frame order, points 1..n. */
static int build_colmap(const gv_scene *scene, gv_colmap_model *m)
{
    memset(m, 0, sizeof *m);
    m->cameras = calloc((size_t)scene->n_frames, sizeof *m->cameras);
    m->images = calloc((size_t)scene->n_frames, sizeof *m->images);
    m->points = scene->n_points ? calloc((size_t)scene->n_points, sizeof *m->points) : NULL;
    if (!m->cameras || !m->images || (scene->n_points && !m->points))
        return gv_fail("%s: out of memory", scene->dir);
    for (int i = 0; i < scene->n_frames; i++) {
        const gv_camera *cam = &scene->cameras[i];
        int j = 0;
        while (j < m->n_cameras && !same_intrinsics(cam, &m->cameras[j])) j++;
        if (j == m->n_cameras) {
            gv_colmap_camera *c = &m->cameras[m->n_cameras++];
            *c = (gv_colmap_camera){.id = j + 1, .model = GV_COLMAP_PINHOLE, .width = cam->width,
                                    .height = cam->height, .params = {cam->fx, cam->fy, cam->cx, cam->cy}};
        }
        gv_colmap_image *im = &m->images[m->n_images++];
        im->id = i + 1;
        im->camera_id = j + 1;
        gv_colmap_rotmat_to_qvec(cam->R, im->qvec);
        memcpy(im->tvec, cam->t, sizeof im->tvec);
        snprintf(im->name, sizeof im->name, "%s", cam->name);
    }
    for (int i = 0; i < scene->n_points; i++, m->n_points++) {
        gv_colmap_point *p = &m->points[i];
        p->id = (uint64_t)i + 1;
        for (int k = 0; k < 3; k++) p->xyz[k] = scene->points[3 * i + k], p->rgb[k] = scene->colors[3 * i + k];
    }
    return 0;
}

int gv_scene_write(const char *dir, const gv_scene *scene)
{
    char sparse[4200], path[4300];
    if (scene->n_frames < 1) return gv_fail("%s: the scene has no frames to write", dir);
    snprintf(sparse, sizeof sparse, "%s/sparse/0", dir);
    if (gv_mkdirs(sparse) != 0) return -1;
    snprintf(path, sizeof path, "%s/transforms.json", dir);
    if (gv_transforms_write(path, scene->cameras, scene->n_frames, "images", "points3D.ply") != 0)
        return -1;
    gv_colmap_model m;
    int ok = build_colmap(scene, &m);
    if (ok == 0) ok = gv_colmap_write_text(sparse, &m);
    gv_colmap_free(&m);
    if (ok != 0) return -1;
    snprintf(path, sizeof path, "%s/points3D.ply", dir);
    return gv_points_write_ply(path, scene->n_points, scene->points, scene->colors);
}
