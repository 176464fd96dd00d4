/* Fixtures of the conditioning and restoration tests (include after check.h): synthetic 5-frame
 * clips (a smooth moving pattern as ground truth, the intermediates corrupted by a seeded
 * perturbation), a dataset folder with its manifest, and the tiny model with a tiny VAE that
 * has latent statistics. */
#ifndef GAUSSVID_TESTS_RESTORE_FIXTURES_H
#define GAUSSVID_TESTS_RESTORE_FIXTURES_H

#include <math.h>
#include <stdint.h>

#include "gaussvid/train/condition.h"
#include "gaussvid/core/core.h"
#include "gaussvid/data/dataset.h"
#include "gaussvid/model/dit.h"
#include "gaussvid/model/vae.h"

/* A clip of the scene `scene`, interval n (frames 0, n/4.., n), size w x h, seeded. The
 * anchors' inputs equal their targets; the intermediates' inputs are the targets plus seeded
 * noise of amplitude `noise` (8-bit steps). */
static inline int rf_make_clip(gv_clip *clip, const char *scene, const char *split, int n, int w, int h, int noise,
                               uint64_t seed)
{
    gv_clip_info info;
    memset(&info, 0, sizeof info);
    snprintf(info.id.scene, sizeof info.id.scene, "%s", scene);
    snprintf(info.id.split, sizeof info.id.split, "%s", split);
    info.id.interval = n, info.anchor_gap = 1, info.iters = 100, info.width = w, info.height = h;
    info.sampling = GV_SAMPLING_UNIFORM, info.seed = seed;
    int fr[5] = {0, 1, n / 2, n - 1, n};
    memcpy(info.frames, fr, sizeof fr);
    if (gv_clip_alloc(clip, &info)) return -1;
    for (int f = 0; f < GV_CLIP_FRAMES; f++) {
        uint8_t *t = gv_clip_frame(clip->targets, &info, f), *in = gv_clip_frame(clip->inputs, &info, f);
        for (int y = 0; y < h; y++)
            for (int x = 0; x < w; x++)
                for (int c = 0; c < 3; c++) {
                    double v = 128 + 90 * sin(0.21 * (x + 2 * f) + 0.9 * c + 0.1 * (double)(seed % 5)) *
                                         cos(0.17 * y - 0.3 * c);
                    int64_t i = ((int64_t)y * w + x) * 3 + c;
                    t[i] = (uint8_t)lround(v);
                    int d = (f == 0 || f == 4) ? 0
                                               : (int)lround(noise * (gv_uniform_at(seed + 7, (uint64_t)(f * 1000003 + i)) - 0.5) * 2);
                    int o = t[i] + d;
                    in[i] = (uint8_t)(o < 0 ? 0 : o > 255 ? 255 : o);
                }
        gv_camera cam;
        memset(&cam, 0, sizeof cam);
        double a = 0.04 * f, ca = cos(a), sa = sin(a);
        double R[9] = {ca, 0, -sa, 0, 1, 0, sa, 0, ca};
        memcpy(cam.R, R, sizeof R);
        cam.fx = cam.fy = 0.9 * w, cam.cx = 0.5 * w, cam.cy = 0.5 * h;
        cam.t[0] = -0.25 * f, cam.t[1] = 0.02 * f, cam.t[2] = 1.5;
        gv_clip_set_camera(clip, f, &cam);
    }
    return 0;
}

/* A dataset folder: clips (scene, split, n) written and listed in manifest.json. */
typedef struct {
    const char *scene, *split;
    int n;
} rf_clip_spec;

static inline int rf_make_dataset(const char *dir, const rf_clip_spec *specs, int count, int w, int h, int noise)
{
    char path[4096];
    snprintf(path, sizeof path, "%s/clips", dir);
    if (gv_mkdirs(path)) return -1;
    gv_dataset_params p;
    gv_dataset_default_params(&p);
    gv_manifest m;
    gv_manifest_init(&m, &p);
    int rc = 0;
    for (int i = 0; rc == 0 && i < count; i++) {
        gv_clip clip;
        gv_manifest_clip entry;
        memset(&entry, 0, sizeof entry);
        rc = rf_make_clip(&clip, specs[i].scene, specs[i].split, specs[i].n, w, h, noise, 100 + (uint64_t)i);
        if (rc) break;
        gv_clip_file_name(entry.file, sizeof entry.file, specs[i].scene, specs[i].n, i);
        snprintf(entry.id.scene, sizeof entry.id.scene, "%s", specs[i].scene);
        snprintf(entry.id.split, sizeof entry.id.split, "%s", specs[i].split);
        entry.id.interval = specs[i].n;
        memcpy(entry.frames, clip.info.frames, sizeof entry.frames);
        snprintf(path, sizeof path, "%s/%s", dir, entry.file);
        rc = gv_clip_write(path, &clip);
        gv_clip_free(&clip);
        gv_manifest_run run = {{"", "", specs[i].n}, 1, 1.0};
        snprintf(run.id.scene, sizeof run.id.scene, "%s", specs[i].scene);
        snprintf(run.id.split, sizeof run.id.split, "%s", specs[i].split);
        /* one run per (scene, n) holding its clips: gather them */
        if (rc == 0 && gv_manifest_find_run(&m, run.id.scene, run.id.interval) < 0) {
            gv_manifest_clip group[16];
            int g = 0;
            for (int j = 0; j < count && g < 16; j++) {
                if (strcmp(specs[j].scene, run.id.scene) || specs[j].n != run.id.interval) continue;
                memset(&group[g], 0, sizeof group[g]);
                gv_clip_file_name(group[g].file, sizeof group[g].file, specs[j].scene, specs[j].n, j);
                snprintf(group[g].id.scene, sizeof group[g].id.scene, "%s", specs[j].scene);
                snprintf(group[g].id.split, sizeof group[g].id.split, "%s", specs[j].split);
                group[g].id.interval = specs[j].n;
                int fr[5] = {0, 1, specs[j].n / 2, specs[j].n - 1, specs[j].n};
                memcpy(group[g].frames, fr, sizeof fr);
                g++;
            }
            run.n_clips = g;
            rc = gv_manifest_add_run(&m, &run, group, g);
        }
    }
    if (rc == 0) rc = gv_manifest_write(dir, &m);
    gv_manifest_free(&m);
    return rc;
}

/* The tiny preset and its VAE (random weights, seeded) with per-channel latent statistics. */
static inline int rf_tiny(gv_model_config *cfg, gv_vae *vae, const char *variant, uint64_t seed)
{
    if (gv_model_config_preset(cfg, "tiny")) return -1;
    if (variant && gv_model_config_set_variant(cfg, variant, "test")) return -1;
    if (gv_vae_init(vae, cfg, 0, seed)) return -1;
    double mean[GV_VAE_MAX_Z_DIM], std[GV_VAE_MAX_Z_DIM];
    for (int c = 0; c < cfg->vae.z_dim; c++) mean[c] = 0.01 * c - 0.02, std[c] = 0.05 + 0.01 * c;
    return gv_vae_set_stats(vae, mean, std);
}

/* Largest |a - b| over n floats. */
static inline double rf_max_diff(const float *a, const float *b, int64_t n)
{
    double worst = 0;
    for (int64_t i = 0; i < n; i++) {
        double d = fabs((double)a[i] - b[i]);
        if (!(d <= worst)) worst = d;
    }
    return worst;
}

#endif
