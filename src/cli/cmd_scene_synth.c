/* gaussvid scene synth: a procedural room scene in the shared folder format. */
#include <stdio.h>
#include <stdlib.h>

#include "cli/commands.h"
#include "gaussvid/core/core.h"
#include "gaussvid/synth/synth.h"

static int usage(const char *message)
{
    fprintf(stderr, "gaussvid scene synth: %s (see 'gaussvid scene synth --help')\n", message);
    return 2;
}

/* "WxH" with positive integers and nothing else. */
static int parse_size(const char *text, int *width, int *height)
{
    char *end;
    long w = strtol(text, &end, 10);
    if (end == text || (*end != 'x' && *end != 'X')) return -1;
    const char *rest = end + 1;
    long h = strtol(rest, &end, 10);
    if (end == rest || *end || w < 1 || h < 1 || w > 1000000 || h > 1000000) return -1;
    *width = (int)w;
    *height = (int)h;
    return 0;
}

int cmd_scene_synth(int argc, char **argv)
{
    gv_synth_params p;
    gv_synth_default_params(&p);
    int seed = 1;
    const char *out = NULL, *size = "256x144";
    const gv_flag flags[] = {
        {"seed", GV_FLAG_INT, &seed, "S", "random seed, 0 or more: each seed is a different scene (default 1)", 0},
        {"out", GV_FLAG_STRING, &out, "DIR", "scene folder to write", 1},
        {"frames", GV_FLAG_INT, &p.n_frames, "N", "number of frames, 2 or more (default 160)", 0},
        {"size", GV_FLAG_STRING, &size, "WxH", "image size in pixels, 16 to 4096 each (default 256x144)", 0},
        {"samples", GV_FLAG_INT, &p.samples, "K", "K x K samples on edge pixels, 1 to 8 (default 3)", 0},
        {"texture-detail", GV_FLAG_DOUBLE, &p.texture_detail, "A",
         "0 to 1: non-repeating noise on every surface, for testing feature matching (COLMAP); default 0", 0},
    };
    const gv_command_spec spec = {
        .command = "scene synth",
        .summary = "ray-trace a procedural room scene in the shared folder format",
        .details = "Writes DIR/images/frame_00000.png ..., DIR/transforms.json, DIR/sparse/0/*.txt,\n"
                   "DIR/points3D.ply and DIR/synth.txt (what was generated): a seeded room with\n"
                   "furniture, lamps and sun, seen along a smooth hand-held-like camera path, and a\n"
                   "sparse point cloud of its visible surfaces. The same seed and size give the same\n"
                   "files. DIR is made under a temporary name and renamed when complete; an existing\n"
                   "DIR is replaced only if it holds a previous synthesised scene. See docs/SYNTH.md.",
        .flags = flags,
        .n_flags = (int)(sizeof flags / sizeof flags[0]),
    };
    int rc = gv_args_parse(&spec, argc, argv, NULL, NULL);
    if (rc != GV_ARGS_OK) return gv_args_exit_code(rc);
    if (seed < 0) return usage("--seed must be 0 or more");
    if (parse_size(size, &p.width, &p.height)) return usage("--size needs WxH, for example 256x144");
    p.seed = (uint64_t)seed;
    if (gv_synth_check_params(&p)) {
        fprintf(stderr, "gaussvid %s (see 'gaussvid scene synth --help')\n", gv_last_error());
        return 2;
    }
    if (gv_synth_write(&p, out)) return gv_report_failure();
    return 0;
}
