/* gaussvid scene colmap --images DIR | --video FILE --out SCENE: a scene folder from photos or
 * a video with COLMAP (docs/SCENES.md "From photos"). */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "cli/commands.h"
#include "gaussvid/core/core.h"
#include "gaussvid/scene/scene_colmap.h"

/* "--downscales 2,4,8" or "none". */
static int parse_downscales(const gv_flag_list *list, gv_colmap_run_options *o)
{
    if (list->n == 0) return 0;
    o->n_downscales = 0;
    if (list->n == 1 && !strcmp(list->items[0], "none")) return 0;
    for (int i = 0; i < list->n; i++) {
        char *end;
        long k = strtol(list->items[i], &end, 10);
        if (*end || k < 2 || k > 64 || o->n_downscales == GV_COLMAP_MAX_DOWNSCALES) {
            fprintf(stderr, "gaussvid scene colmap: --downscales %s: expected up to %d factors in 2..64, or none\n",
                    list->items[i], GV_COLMAP_MAX_DOWNSCALES);
            return -1;
        }
        o->downscales[o->n_downscales++] = (int)k;
    }
    return 0;
}

int cmd_scene_colmap(int argc, char **argv)
{
    gv_colmap_run_options o;
    gv_colmap_run_defaults(&o);
    int threads = 0;
    gv_flag_list downscales = {0};
    const gv_flag flags[] = {
        {"images", GV_FLAG_STRING, &o.images_dir, "DIR", "the photos: .png, .jpg or .jpeg files (or --video)", 0},
        {"video", GV_FLAG_STRING, &o.video, "FILE", "a video instead: ffmpeg takes --fps frames a second into SCENE/frames/", 0},
        {"fps", GV_FLAG_DOUBLE, &o.fps, "K", "frames a second taken from --video (default 2)", 0},
        {"out", GV_FLAG_STRING, &o.out_dir, "SCENE", "the scene folder to write (COLMAP's database and log in SCENE/colmap/, kept: a rerun continues)", 1},
        {"matcher", GV_FLAG_STRING, &o.matcher, "NAME", "exhaustive, sequential or vocab_tree (default: sequential with loop closure for ordered names such as IMG_0001.JPG and for a video, vocab_tree with --vocab-tree, else exhaustive)", 0},
        {"vocab-tree", GV_FLAG_STRING, &o.vocab_tree, "FILE", "a COLMAP vocabulary tree: unordered photos are matched by it, ordered ones get its loop closures too", 0},
        {"downscales", GV_FLAG_LIST, &downscales, "K,...", "also write SCENE/images_K/ downscaled by each K (default 2,4,8; none for none)", 0},
        {"camera-model", GV_FLAG_STRING, &o.camera_model, "NAME", "the camera COLMAP fits before undistorting to PINHOLE (default SIMPLE_RADIAL; e.g. OPENCV, PINHOLE)", 0},
        {"min-registered", GV_FLAG_DOUBLE, &o.min_registered, "F", "fail when COLMAP registers fewer than this share of the photos (default 0.5)", 0},
        {"colmap", GV_FLAG_STRING, &o.colmap, "FILE", "the COLMAP program (default: colmap on the PATH)", 0},
        {"ffmpeg", GV_FLAG_STRING, &o.ffmpeg, "FILE", "the ffmpeg program for --video (default: ffmpeg on the PATH)", 0},
        {"colmap-threads", GV_FLAG_INT, &threads, "N", "COLMAP's threads (default: all cores)", 0},
    };
    const gv_command_spec spec = {
        "scene colmap", NULL, "a scene folder from photos or a video: COLMAP features, matching, mapping, undistortion",
        "Runs Debian's COLMAP headless on the CPU: SIFT features (one camera for all photos),\n"
        "matching (the matcher chosen by the input, named on the first line), incremental\n"
        "mapping, undistortion to PINHOLE cameras, each with a progress bar. JPEGs are turned\n"
        "upright by their EXIF orientation. Keeps the largest model and writes SCENE/images/\n"
        "(the undistorted photos), SCENE/images_2/, images_4/, images_8/ (downscaled copies,\n"
        "which --downscale K of other commands reads), SCENE/sparse/0 (COLMAP text),\n"
        "SCENE/transforms.json and SCENE/points3D.ply. The database in SCENE/colmap/ is kept:\n"
        "run again after a kill and COLMAP skips the features and pairs it holds.\n"
        "See docs/SCENES.md.",
        flags, sizeof flags / sizeof flags[0], 0, 0};
    int parsed = gv_args_parse(&spec, argc, argv, NULL, NULL);
    if (parsed != GV_ARGS_OK) return gv_args_exit_code(parsed);
    if (!(o.min_registered >= 0 && o.min_registered <= 1) || threads < 0) {
        fprintf(stderr, "gaussvid scene colmap: --min-registered must be in [0, 1] and --colmap-threads not negative\n");
        return 2;
    }
    if (!o.images_dir == !o.video) {
        fprintf(stderr, "gaussvid scene colmap: give --images DIR or --video FILE (one of them)\n");
        return 2;
    }
    if (parse_downscales(&downscales, &o)) return 2;
    o.threads = threads;
    gv_colmap_run_result r;
    if (gv_scene_colmap(&o, &r)) return gv_report_failure();
    printf("%s: %d of %d photos registered (%d model%s mapped, the largest kept), %d points; matcher %s", o.out_dir,
           r.registered, r.images, r.models, r.models == 1 ? "" : "s", r.points, r.matcher);
    if (r.pairs) printf(" (%ld pairs)", r.pairs);
    printf("%s; seconds: ", r.resumed ? ", database resumed" : "");
    if (o.video) printf("frames %.1f, ", r.seconds[0]);
    printf("features %.1f, matching %.1f, mapping %.1f, undistortion %.1f\n", r.seconds[1], r.seconds[2],
           r.seconds[3], r.seconds[4]);
    return 0;
}
