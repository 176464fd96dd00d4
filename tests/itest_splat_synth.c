/* Integration: sparse-view 3DGS on a synthesised scene (40 frames, 128x72), stopped at 1000
 * iterations, with each density control (the reference schedule, the default, with
 * densification at 600..900, and MCMC): the training views reach a PSNR floor, and training on every
 * 12th frame gives a lower held-out PSNR than training on every 2nd. Floors are measured
 * values minus a margin (printed). */
#include "check.h"
#include "gaussvid/core/core.h"
#include "gaussvid/splat/splat_train.h"
#include "gaussvid/synth/synth.h"

typedef struct { double train_psnr, held_psnr, held_ssim; int n; } result;

static int train_and_evaluate(const gv_scene *scene, int interval, gv_splat_densify_mode mode,
                              result *out)
{
    gv_splat_train_options opt;
    gv_splat_train_defaults(&opt);
    opt.densify_mode = mode;
    opt.iterations = 1000;
    opt.seed = 1;
    gv_gaussians g;
    if (gv_splat_train(scene, interval, &opt, &g) != 0) return -1;
    int n = scene->n_frames, frames[64];
    gv_splat_frame_metrics m[64];
    for (int i = 0; i < n; i++) frames[i] = i;
    float bg[3] = {0, 0, 0};
    int ok = gv_splat_evaluate(&g, scene, frames, n, bg, m);
    memset(out, 0, sizeof *out);
    int n_train = 0, n_held = 0;
    for (int i = 0; i < n && ok == 0; i++) {
        if (gv_scene_is_train(i, interval)) out->train_psnr += m[i].psnr, n_train++;
        else out->held_psnr += m[i].psnr, out->held_ssim += m[i].ssim, n_held++;
    }
    out->train_psnr /= n_train, out->held_psnr /= n_held, out->held_ssim /= n_held;
    out->n = g.n;
    printf("%-9s interval %2d: %d Gaussians, training views %.2f dB, held-out %.2f dB / SSIM %.4f\n",
           gv_splat_densify_mode_name(mode), interval, g.n, out->train_psnr, out->held_psnr, out->held_ssim);
    gv_gaussians_free(&g);
    return ok;
}

int main(void)
{
    const char *tmp = check_tmp_dir();
    char dir[4200];
    snprintf(dir, sizeof dir, "%s/scene", tmp);
    gv_synth_params p;
    gv_synth_default_params(&p);
    p.n_frames = 40, p.width = 128, p.height = 72, p.samples = 1;
    gv_log_set_level(GV_LOG_QUIET);
    CHECK(gv_synth_write(&p, dir) == 0);
    gv_scene scene;
    if (gv_scene_load(dir, NULL, &scene) != 0) {
        fprintf(stderr, "%s\n", gv_last_error());
        return 1;
    }
    /* Measured (synth seed 1, training seed 1, float32 loss), reference: interval 2: 44846
     * Gaussians, training views 26.92 dB, held-out 24.03 dB / SSIM 0.905; interval 12: 31683
     * Gaussians, 37.44 dB, held-out 19.48 dB / 0.759. MCMC (its budget, 0.02 per training
     * pixel, is below the 11825 points here, so it only relocates): interval 2: 24.57 dB,
     * held-out 23.31 dB; interval 12: 29.71 dB, held-out 17.83 dB. Floors about 3 dB below
     * (the synthesiser may still change). */
    const gv_splat_densify_mode modes[2] = {GV_DENSIFY_REFERENCE, GV_DENSIFY_MCMC};
    for (int k = 0; k < 2; k++) {
        gv_splat_densify_mode mode = modes[k];
        result dense, sparse;
        CHECK(train_and_evaluate(&scene, 2, mode, &dense) == 0);
        CHECK(train_and_evaluate(&scene, 12, mode, &sparse) == 0);
        CHECK(dense.train_psnr > 21.5);
        CHECK(sparse.train_psnr > 24.0);
        CHECK(dense.held_psnr > 20.5);
        CHECK(sparse.held_psnr < dense.held_psnr - 2.0);
        CHECK(sparse.held_ssim < dense.held_ssim);
    }
    gv_scene_free(&scene);
    return check_summary();
}
