/* Rendering a model from a scene's cameras to 8-bit images, and PSNR / SSIM as the 3DGS
 * evaluation computes them (docs/reference/gaussian-splatting.md section 19.1; metrics.py): the
 * render is clamped and quantised to 8 bits as save_image writes it, then compared with the 8-bit
 * ground truth, both read as v / 255. */
#include <stdlib.h>

#include "gaussvid/core/core.h"
#include "gaussvid/io/metrics.h"
#include "gaussvid/splat/splat_train.h"

int gv_splat_render_camera(gv_splat_renderer *r, const gv_gaussians *g, const gv_camera *cam,
                           const float bg[3], gv_image *out)
{
    gv_splat_view view;
    if (gv_splat_view_from_camera(&view, cam) != 0) return gv_fail_context("camera %s", cam->name);
    float *pixels = malloc((size_t)cam->width * cam->height * 3 * sizeof(float));
    if (!pixels) return gv_fail("render: out of memory for a %dx%d image", cam->width, cam->height);
    int ok = gv_splat_render_forward(r, g, &view, g->sh_degree, bg, pixels);
    if (ok == 0) ok = gv_image_alloc(out, cam->width, cam->height, 3);
    if (ok == 0) gv_image_from_float(out, pixels);
    free(pixels);
    return ok == 0 ? 0 : gv_fail_context("render %s", cam->name);
}

int gv_splat_evaluate(const gv_gaussians *g, const gv_scene *scene, const int *frames,
                      int n_frames, const float bg[3], gv_splat_frame_metrics *metrics)
{
    gv_splat_renderer r = {0};
    gv_progress bar;
    gv_progress_start(&bar, "evaluate", n_frames);
    int ok = 0;
    for (int i = 0; i < n_frames && ok == 0; i++) {
        int f = frames[i];
        gv_image render = {0}, truth = {0};
        metrics[i] = (gv_splat_frame_metrics){.frame = f};
        ok = gv_scene_load_image(scene, f, &truth);
        if (ok == 0) ok = gv_splat_render_camera(&r, g, &scene->cameras[f], bg, &render);
        if (ok == 0) ok = gv_image_psnr_ssim(&render, &truth, &metrics[i].psnr, &metrics[i].ssim);
        gv_image_free(&render), gv_image_free(&truth);
        gv_progress_update(&bar, i + 1, NULL);
    }
    gv_progress_finish(&bar);
    gv_splat_renderer_free(&r);
    return ok;
}
