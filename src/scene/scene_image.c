/* A frame's image as the cameras see it: RGB, alpha composited on the scene's background,
 * downscaled in memory when the scene has no images_<k>/ folder, and of the camera's size. */
#include <stdlib.h>

#include "gaussvid/core/core.h"
#include "gaussvid/scene/scene.h"

/* RGB from grey+alpha or RGBA: v * a + background * (1 - a), rounded to nearest, as 3DGS
 * composites RGBA images (docs/reference/gaussian-splatting.md 18.5) on its black or white
 * background. */
static int composite(const gv_image *in, int background, gv_image *out)
{
    if (gv_image_alloc(out, in->width, in->height, 3) != 0) return -1;
    int c = in->channels;
    size_t n = (size_t)in->width * in->height;
    for (size_t i = 0; i < n; i++) {
        const uint8_t *p = in->pixels + i * c;
        unsigned a = p[c - 1];
        for (int k = 0; k < 3; k++) {
            unsigned v = p[c == 2 ? 0 : k];
            out->pixels[3 * i + k] = (uint8_t)((v * a + background * (255 - a) + 127) / 255);
        }
    }
    return 0;
}

static int to_rgb(const gv_image *in, int background, gv_image *out)
{
    if (in->channels == 2 || in->channels == 4) return composite(in, background, out);
    return gv_image_to_rgb(in, out);
}

int gv_scene_load_image(const gv_scene *scene, int frame, gv_image *out)
{
    if (frame < 0 || frame >= scene->n_frames)
        return gv_fail("%s: frame %d out of range (the scene has %d)", scene->dir, frame, scene->n_frames);
    const gv_camera *cam = &scene->cameras[frame];
    char path[8400];
    snprintf(path, sizeof path, "%s/%s", scene->image_dir, cam->name);
    gv_image raw, rgb;
    if (gv_image_read(path, &raw) != 0) return -1;
    int ok = to_rgb(&raw, scene->white_background ? 255 : 0, &rgb);
    gv_image_free(&raw);
    if (ok != 0) return gv_fail_context("%s", path);
    int k = scene->memory_downscale > 1 ? scene->memory_downscale : 1;
    if (k > 1) {
        int w = rgb.width, h = rgb.height;
        ok = gv_image_downscale(&rgb, k, out);
        gv_image_free(&rgb);
        if (ok != 0) return gv_fail_context("%s", path);
        if (out->width != cam->width || out->height != cam->height) {
            gv_image_free(out);
            return gv_fail("%s: is %dx%d, downscaled by %d to %dx%d, but the camera is %dx%d",
                           path, w, h, k, gv_downscaled_size(w, k), gv_downscaled_size(h, k),
                           cam->width, cam->height);
        }
        return 0;
    }
    *out = rgb;
    if (out->width != cam->width || out->height != cam->height) {
        gv_image_free(out);
        return gv_fail("%s: is %dx%d but the camera is %dx%d", path, rgb.width, rgb.height,
                       cam->width, cam->height);
    }
    return 0;
}
