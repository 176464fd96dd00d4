/* The gate's measurement (adapt.h): clips restored exactly as `restore` restores a scene's
 * renders (the same sampler, composition and per-clip noise), and their frames with ground
 * truth measured against it, restored and as rendered. adapt.c runs it on the held-back
 * internal pairs and on their do-no-harm clips. */
#include <stdlib.h>
#include <string.h>

#include "gaussvid/restore/adapt.h"
#include "gaussvid/core/core.h"
#include "gaussvid/io/metrics.h"

/* The clip's name as restore_run.c seeds it: its file name without folders and extension. */
static void clip_stem(const char *path, char *out, size_t size)
{
    const char *slash = strrchr(path, '/');
    snprintf(out, size, "%s", slash ? slash + 1 : path);
    size_t len = strlen(out), ext = strlen(".safetensors");
    if (len > ext && !strcmp(out + len - ext, ".safetensors")) out[len - ext] = 0;
}

/* Adds the PSNR and SSIM of the frames with ground truth to sums (base psnr, ssim, restored
 * psnr, ssim); *frames counts them. */
static int measure_clip(const gv_clip *clip, const uint8_t *restored, double sums[4], int *frames)
{
    const gv_clip_info *info = &clip->info;
    for (int f = 1; f < GV_CLIP_FRAMES - 1; f++) {
        if (info->no_target[f]) continue;
        size_t off = (size_t)f * info->width * info->height * 3;
        gv_image truth = {info->width, info->height, 3, clip->targets + off};
        gv_image shown[2] = {{info->width, info->height, 3, clip->inputs + off},
                             {info->width, info->height, 3, (uint8_t *)restored + off}};
        for (int k = 0; k < 2; k++) {
            double psnr, ssim;
            if (gv_image_psnr_ssim(&shown[k], &truth, &psnr, &ssim)) return -1;
            if (psnr > 100) psnr = 100; /* identical frames: 100 dB, as the run records count them */
            sums[2 * k] += psnr, sums[2 * k + 1] += ssim;
        }
        (*frames)++;
    }
    return 0;
}

int gv_adapt_gate_compose(const gv_scene_adaptation *a, gv_compose *out)
{
    if (gv_compose_from_name(a->gate_compose[0] ? a->gate_compose : "residual", out))
        return gv_fail_context("the scene checkpoint's gate_compose");
    return 0;
}

int gv_adapt_measure(gv_dit *m, gv_vae *vae, const char *dataset_dir, const gv_latent_set *set, const gv_sampler *s,
                     gv_compose compose, gv_gate_measure *out)
{
    double sums[4] = {0, 0, 0, 0};
    int frames = 0, rc = gv_sampler_check(s);
    gv_progress bar;
    gv_progress_start(&bar, "gate", set->count);
    for (int i = 0; rc == 0 && i < set->count; i++) {
        char path[4096], stem[512];
        gv_clip clip;
        if (gv_path_join(path, sizeof path, dataset_dir, set->names[i]) || gv_clip_read(path, &clip)) {
            rc = -1;
            break;
        }
        const gv_clip_latents *l = &set->clips[i];
        const gv_clip_info *info = &clip.info;
        float *z = malloc((size_t)gv_clip_latents_z_count(l) * sizeof *z);
        uint8_t *restored = malloc((size_t)GV_CLIP_FRAMES * info->width * info->height * 3);
        rc = z && restored ? 0 : gv_fail("gate: out of memory");
        clip_stem(set->names[i], stem, sizeof stem);
        if (rc == 0) rc = gv_restore_latent(m, l, s, gv_restore_clip_seed(s->seed, stem), z);
        if (rc == 0) rc = gv_restore_compose(vae, &clip, l, z, compose, s->release, restored);
        if (rc == 0) rc = measure_clip(&clip, restored, sums, &frames);
        if (rc) gv_fail_context("gate: %s", path);
        free(z), free(restored);
        gv_clip_free(&clip);
        if (rc == 0 && frames > 0)
            gv_progress_update(&bar, i + 1, "PSNR %+.2f dB", (sums[2] - sums[0]) / frames);
    }
    gv_progress_finish(&bar);
    if (rc) return -1;
    if (frames == 0) return gv_fail("gate: the clips of %s have no frame with ground truth", dataset_dir);
    out->frames = frames;
    out->psnr_base = sums[0] / frames, out->ssim_base = sums[1] / frames;
    out->psnr_restored = sums[2] / frames, out->ssim_restored = sums[3] / frames;
    return 0;
}
