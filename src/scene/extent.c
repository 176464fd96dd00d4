/* Camera centres and the 3DGS scene extent (docs/reference/gaussian-splatting.md 12.1,
 * getNerfppNorm): radius = 1.1 x the largest distance of a camera centre from their mean. */
#include <math.h>

#include "gaussvid/scene/scene.h"

void gv_camera_center(const gv_camera *cam, double center[3])
{
    const double *R = cam->R, *t = cam->t;
    for (int i = 0; i < 3; i++) center[i] = -(R[i] * t[0] + R[3 + i] * t[1] + R[6 + i] * t[2]);
}

double gv_scene_extent(const gv_scene *scene, const int *frames, int n_frames)
{
    if (!frames) n_frames = scene->n_frames;
    if (n_frames < 1) return 0;
    double mean[3] = {0, 0, 0}, c[3];
    for (int i = 0; i < n_frames; i++) {
        gv_camera_center(&scene->cameras[frames ? frames[i] : i], c);
        for (int k = 0; k < 3; k++) mean[k] += c[k];
    }
    for (int k = 0; k < 3; k++) mean[k] /= n_frames;
    double largest = 0;
    for (int i = 0; i < n_frames; i++) {
        gv_camera_center(&scene->cameras[frames ? frames[i] : i], c);
        double d = sqrt((c[0] - mean[0]) * (c[0] - mean[0]) + (c[1] - mean[1]) * (c[1] - mean[1]) +
                        (c[2] - mean[2]) * (c[2] - mean[2]));
        if (d > largest) largest = d;
    }
    return 1.1 * largest; /* getNerfppNorm: radius = diagonal * 1.1 */
}
