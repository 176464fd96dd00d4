/* gaussvid scene: the scene command group. */
#include "cli/commands.h"

static const gv_subcommand scene_commands[] = {
    {"info", cmd_scene_info, "validate a scene folder and describe it (frames, cameras, split)"},
    {"colmap", cmd_scene_colmap, "a scene folder from photos: COLMAP features, matching, mapping, undistortion"},
    {"synth", cmd_scene_synth, "ray-trace a procedural room scene in the shared folder format"},
};

int cmd_scene(int argc, char **argv)
{
    return gv_run_subcommand("scene", scene_commands, (int)(sizeof scene_commands / sizeof scene_commands[0]), argc, argv);
}
