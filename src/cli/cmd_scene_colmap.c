/* gaussvid scene colmap --images DIR --out SCENE: a scene folder from photos with COLMAP
 * (docs/SCENES.md "From photos"). */
#include <stdio.h>

#include "cli/commands.h"
#include "gaussvid/core.h"
#include "gaussvid/scene_colmap.h"

int cmd_scene_colmap(int argc, char **argv)
{
    gv_colmap_run_options o;
    gv_colmap_run_defaults(&o);
    int threads = 0;
    const gv_flag flags[] = {
        {"images", GV_FLAG_STRING, &o.images_dir, "DIR", "the photos: .png, .jpg or .jpeg files", 1},
        {"out", GV_FLAG_STRING, &o.out_dir, "SCENE", "the scene folder to write (COLMAP's work and log in SCENE/colmap/)", 1},
        {"camera-model", GV_FLAG_STRING, &o.camera_model, "NAME", "the camera COLMAP fits before undistorting to PINHOLE (default SIMPLE_RADIAL; e.g. OPENCV, PINHOLE)", 0},
        {"matcher", GV_FLAG_STRING, &o.matcher, "NAME", "exhaustive (default) or sequential (frames of a video, in name order)", 0},
        {"min-registered", GV_FLAG_DOUBLE, &o.min_registered, "F", "fail when COLMAP registers fewer than this share of the photos (default 0.5)", 0},
        {"colmap", GV_FLAG_STRING, &o.colmap, "FILE", "the COLMAP program (default: colmap on the PATH)", 0},
        {"colmap-threads", GV_FLAG_INT, &threads, "N", "COLMAP's threads (default: all cores)", 0},
    };
    const gv_command_spec spec = {
        "scene colmap", NULL, "a scene folder from photos: COLMAP features, matching, mapping, undistortion",
        "Runs Debian's COLMAP headless on the CPU: SIFT features (one camera for all photos),\n"
        "matching, incremental mapping, undistortion to PINHOLE cameras. Keeps the largest model\n"
        "and writes SCENE/images/ (the undistorted photos), SCENE/sparse/0 (COLMAP text),\n"
        "SCENE/transforms.json and SCENE/points3D.ply: the scene folder every other command reads.\n"
        "See docs/SCENES.md.",
        flags, sizeof flags / sizeof flags[0], 0, 0};
    int parsed = gv_args_parse(&spec, argc, argv, NULL, NULL);
    if (parsed != GV_ARGS_OK) return gv_args_exit_code(parsed);
    if (!(o.min_registered >= 0 && o.min_registered <= 1) || threads < 0) {
        fprintf(stderr, "gaussvid scene colmap: --min-registered must be in [0, 1] and --colmap-threads not negative\n");
        return 2;
    }
    o.threads = threads;
    gv_colmap_run_result r;
    if (gv_scene_colmap(&o, &r)) return gv_report_failure();
    printf("%s: %d of %d photos registered (%d models mapped, the largest kept), %d points; COLMAP seconds: features "
           "%.1f, matching %.1f, mapping %.1f, undistortion %.1f\n",
           o.out_dir, r.registered, r.images, r.models, r.points, r.seconds[0], r.seconds[1], r.seconds[2],
           r.seconds[3]);
    return 0;
}
