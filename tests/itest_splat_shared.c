/* Integration: sparse-view 3DGS on the shared courtyard scene (160 frames, downscaled 2x to
 * 128x72, interval 6: 27 training views), the reference schedule stopped at 1000 iterations;
 * the training views reach a measured PSNR floor and held-out views stay below them.
 * Skipped (ctest says so) when the shared data is not present. */
#include "check.h"
#include "gaussvid/core/core.h"
#include "gaussvid/splat/splat_train.h"

int main(void)
{
    const char *scenes = check_shared_scenes();
    if (!scenes) return CHECK_SKIP;
    char dir[4200];
    snprintf(dir, sizeof dir, "%s/courtyard", scenes);
    gv_scene_options so = {.downscale = 2};
    gv_scene scene;
    if (gv_scene_load(dir, &so, &scene) != 0) {
        fprintf(stderr, "%s\n", gv_last_error());
        return 1;
    }
    CHECK(scene.n_frames == 160 && scene.cameras[0].width == 128 && scene.cameras[0].height == 72);
    gv_splat_train_options opt;
    gv_splat_train_defaults(&opt);
    opt.iterations = 1000;
    opt.seed = 1;
    gv_log_set_level(GV_LOG_QUIET);
    gv_gaussians g;
    CHECK(gv_splat_train(&scene, 6, &opt, &g) == 0);
    int frames[160];
    gv_splat_frame_metrics m[160];
    for (int i = 0; i < 160; i++) frames[i] = i;
    float bg[3] = {0, 0, 0};
    CHECK(gv_splat_evaluate(&g, &scene, frames, 160, bg, m) == 0);
    double train = 0, held = 0;
    for (int i = 0; i < 160; i++) {
        if (gv_scene_is_train(i, 6)) train += m[i].psnr / 27;
        else held += m[i].psnr / 133;
    }
    printf("courtyard 128x72, interval 6, 1000 iterations: %d Gaussians, training views %.2f dB, "
           "held-out %.2f dB\n", g.n, train, held);
    /* Measured (seed 1, float32 loss): 31516 Gaussians, training views 29.68 dB, held-out
     * 28.67 dB. */
    CHECK(train > 27.0);
    CHECK(held < train);
    gv_gaussians_free(&g);
    gv_scene_free(&scene);
    return check_summary();
}
