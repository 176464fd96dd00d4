/* Scene frames in memory for the VAE (8-bit, 3 bytes a pixel: a 160-frame 256x144 scene is
 * 17.7 MB), and clips cut from them in the VAE's layout. */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "gaussvid/core/core.h"
#include "gaussvid/scene/scene.h"
#include "gaussvid/train/vae_train.h"

static int load_scene(gv_vae_scene *s, const char *dir, int downscale)
{
    gv_scene scene;
    gv_scene_options so = {.downscale = downscale};
    if (gv_scene_load(dir, &so, &scene)) return -1;
    snprintf(s->dir, sizeof s->dir, "%s", dir);
    s->n_frames = scene.n_frames;
    int rc = 0;
    for (int t = 0; t < scene.n_frames && rc == 0; t++) {
        gv_image img;
        if (gv_scene_load_image(&scene, t, &img)) {
            rc = -1;
            break;
        }
        if (t == 0) {
            s->width = img.width;
            s->height = img.height;
            s->pixels = malloc((size_t)scene.n_frames * img.width * img.height * 3);
            if (!s->pixels) rc = gv_fail("%s: out of memory for %d frames", dir, scene.n_frames);
        } else if (img.width != s->width || img.height != s->height) {
            rc = gv_fail("%s: frame %d is %dx%d, frame 0 %dx%d (the VAE needs one size per scene)", dir, t,
                         img.width, img.height, s->width, s->height);
        }
        if (rc == 0) memcpy(s->pixels + (size_t)t * s->width * s->height * 3, img.pixels, (size_t)s->width * s->height * 3);
        gv_image_free(&img);
    }
    gv_scene_free(&scene);
    return rc;
}

int gv_vae_frames_load(gv_vae_frames *f, const char *const *dirs, int n_dirs, int downscale)
{
    memset(f, 0, sizeof *f);
    if (n_dirs < 1) return gv_fail("vae: no scene folders given");
    f->scenes = calloc((size_t)n_dirs, sizeof *f->scenes);
    if (!f->scenes) return gv_fail("vae: out of memory");
    for (int i = 0; i < n_dirs; i++) {
        f->n = i + 1;
        if (load_scene(&f->scenes[i], dirs[i], downscale)) {
            gv_vae_frames_free(f);
            return -1;
        }
        f->total_frames += f->scenes[i].n_frames;
    }
    return 0;
}

void gv_vae_frames_free(gv_vae_frames *f)
{
    for (int i = 0; f->scenes && i < f->n; i++) free(f->scenes[i].pixels);
    free(f->scenes);
    memset(f, 0, sizeof *f);
}

void gv_vae_clip_extract(const gv_vae_scene *s, int t0, int stride, int T, int x0, int y0, int w, int h, int flip,
                         float *out)
{
    const int64_t plane = (int64_t)h * w;
    for (int t = 0; t < T; t++) {
        const uint8_t *frame = s->pixels + (size_t)(t0 + t * stride) * s->width * s->height * 3;
        for (int y = 0; y < h; y++) {
            const uint8_t *row = frame + ((size_t)(y0 + y) * s->width + x0) * 3;
            for (int x = 0; x < w; x++) {
                const uint8_t *p = row + (size_t)(flip ? w - 1 - x : x) * 3;
                for (int c = 0; c < 3; c++)
                    out[((int64_t)c * T + t) * plane + (int64_t)y * w + x] = (float)p[c] * (2.0f / 255.0f) - 1.0f;
            }
        }
    }
}
