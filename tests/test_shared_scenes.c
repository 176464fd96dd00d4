/* The shared scenes (data/scenes; skipped when absent): courtyard's point cloud
 * reads as written, and both descriptions of courtyard and livingroom (COLMAP and
 * transforms.json) load and describe the same cameras. */
#include <math.h>
#include <stdint.h>

#include "check.h"
#include "gaussvid/core/core.h"
#include "gaussvid/io/image.h"
#include "gaussvid/io/ply.h"
#include "gaussvid/scene/scene.h"

/* courtyard's points3D.ply. */
static void test_points(const char *scenes)
{
    char path[4200];
    snprintf(path, sizeof path, "%s/courtyard/points3D.ply", scenes);
    int n = 0;
    float *xyz = NULL;
    uint8_t *rgb = NULL;
    CHECK(gv_points_read_ply(path, &n, &xyz, &rgb) == 0);
    /* The header says 12000; the first row is "-3.984487 1.267649 0.000000 157 151 156". */
    CHECK(n == 12000);
    CHECK(xyz && xyz[0] == -3.984487f && xyz[1] == 1.267649f && xyz[2] == 0.0f);
    CHECK(rgb && rgb[0] == 157 && rgb[1] == 151 && rgb[2] == 156);
    free(xyz);
    free(rgb);
}

/* The shared scenes: both descriptions load and describe the same cameras. */
static void test_scenes(const char *root)
{
    static const char *names[2] = {"courtyard", "livingroom"};
    for (int n = 0; n < 2; n++) {
        char dir[4200];
        snprintf(dir, sizeof dir, "%s/%s", root, names[n]);
        gv_scene colmap, json;
        gv_scene_options prefer = {.downscale = 1, .prefer_transforms = 1};
        double start = gv_now();
        REQUIRE(gv_scene_load(dir, NULL, &colmap) == 0);
        REQUIRE(gv_scene_load(dir, &prefer, &json) == 0);
        printf("%s: both descriptions loaded in %.2f s\n", names[n], gv_now() - start);
        CHECK(colmap.source == GV_SCENE_FROM_COLMAP_TEXT && json.source == GV_SCENE_FROM_TRANSFORMS);
        CHECK(colmap.n_frames == 160 && json.n_frames == 160);
        CHECK(colmap.n_points == 12000 && json.n_points == 12000);
        double worst = 0;
        for (int i = 0; i < colmap.n_frames && i < json.n_frames; i++) {
            const gv_camera *a = &colmap.cameras[i], *b = &json.cameras[i];
            CHECK(!strcmp(a->name, b->name) && a->width == 256 && b->height == 144);
            for (int k = 0; k < 9; k++) worst = fmax(worst, fabs(a->R[k] - b->R[k]));
            for (int k = 0; k < 3; k++) worst = fmax(worst, fabs(a->t[k] - b->t[k]));
            worst = fmax(worst, fabs(a->fx - b->fx) + fabs(a->fy - b->fy) + fabs(a->cx - b->cx) + fabs(a->cy - b->cy));
        }
        printf("%s: COLMAP vs transforms.json cameras: max difference %.3g\n", names[n], worst);
        CHECK(worst < 1e-5);
        CHECK(json.n_points == colmap.n_points &&
              !memcmp(json.points, colmap.points, 3 * sizeof(float) * (size_t)json.n_points));
        CHECK(!strcmp(colmap.cameras[0].name, "frame_00000.png"));
        gv_image img;
        CHECK(gv_scene_load_image(&json, 159, &img) == 0 && img.width == 256 && img.height == 144);
        gv_image_free(&img);
        printf("%s: extent %.4f\n", names[n], gv_scene_extent(&colmap, NULL, 0));
        gv_scene_free(&colmap);
        gv_scene_free(&json);
    }
}

int main(void)
{
    const char *scenes = check_shared_scenes();
    if (!scenes) return CHECK_SKIP;
    test_points(scenes);
    test_scenes(scenes);
    return check_summary();
}
