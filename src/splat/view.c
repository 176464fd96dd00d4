/* Views: a camera's intrinsics and world-to-camera pose in the float form the projection
 * reads, with the 3DGS limits of the Jacobian clamp. */
#include <math.h>
#include <string.h>

#include "gaussvid/core/core.h"
#include "gaussvid/splat/splat.h"

int gv_splat_view_init(gv_splat_view *v, int width, int height, double fx, double fy,
                       double cx, double cy, const double R[9], const double t[3])
{
    memset(v, 0, sizeof *v);
    if (width <= 0 || height <= 0 || width > GV_SPLAT_MAX_RADIUS || height > GV_SPLAT_MAX_RADIUS)
        return gv_fail("camera: bad image size %dx%d", width, height);
    if (!(fx > 0) || !(fy > 0) || !isfinite(fx) || !isfinite(fy) || !isfinite(cx) ||
        !isfinite(cy))
        return gv_fail("camera: bad intrinsics fx %g fy %g cx %g cy %g", fx, fy, cx, cy);
    for (int i = 0; i < 9; i++)
        if (!isfinite(R[i])) return gv_fail("camera: non-finite rotation");
    for (int i = 0; i < 3; i++)
        if (!isfinite(t[i])) return gv_fail("camera: non-finite translation");
    v->width = width;
    v->height = height;
    v->fx = (float)fx, v->fy = (float)fy, v->cx = (float)cx, v->cy = (float)cy;
    for (int i = 0; i < 9; i++) v->R[i] = (float)R[i];
    for (int i = 0; i < 3; i++) v->t[i] = (float)t[i];
    for (int j = 0; j < 3; j++)
        v->campos[j] = (float)-(R[0 * 3 + j] * t[0] + R[1 * 3 + j] * t[1] + R[2 * 3 + j] * t[2]);
    /* gsplat's asymmetric limits: the image edge plus 0.3 of the half width beyond it. With
     * cx = W/2 each is W/(2 fx) + 0.3 W/(2 fx) = 1.3 tan(fov_x/2), the 3DGS clamp. */
    double margin_x = (GV_SPLAT_CLAMP_FOV - 1.0) * width / (2.0 * fx);
    double margin_y = (GV_SPLAT_CLAMP_FOV - 1.0) * height / (2.0 * fy);
    v->lim_x_neg = (float)(cx / fx + margin_x);
    v->lim_x_pos = (float)((width - cx) / fx + margin_x);
    v->lim_y_neg = (float)(cy / fy + margin_y);
    v->lim_y_pos = (float)((height - cy) / fy + margin_y);
    return 0;
}

int gv_splat_view_from_camera(gv_splat_view *v, const gv_camera *cam)
{
    return gv_splat_view_init(v, cam->width, cam->height, cam->fx, cam->fy, cam->cx, cam->cy,
                              cam->R, cam->t);
}
