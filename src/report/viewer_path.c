/* The viewer's fly-through path: the scene's cameras in their order, converted from the
 * library's convention (OpenCV: world-to-camera R, t; x right, y down, z forward) to what
 * three.js places (OpenGL: camera-to-world, y up, looking down -z). The principal point is
 * taken as centred (three.js's perspective camera has no offset); the vertical field of view
 * is 2 atan(h / 2 fy). */
#include "viewer_internal.h"

#include "gaussvid/core/core.h"
#include "gaussvid/scene/scene.h"

#include <math.h>

/* A JSON string that is also safe inside <script>: '<' is written \u003c. */
static void json_string(report_text *t, const char *s)
{
    text_append(t, "\"");
    for (; *s; s++) {
        unsigned char c = (unsigned char)*s;
        if (c == '"' || c == '\\') text_printf(t, "\\%c", c);
        else if (c < 0x20 || c == '<') text_printf(t, "\\u%04x", c);
        else text_append_n(t, s, 1);
    }
    text_append(t, "\"");
}

static void camera_json(report_text *t, const gv_camera *cam, int frame, int interval)
{
    double centre[3];
    gv_camera_center(cam, centre);
    /* camera-to-world rotation R^T; OpenGL's y and z axes are OpenCV's negated */
    double r[9];
    for (int i = 0; i < 3; i++) {
        r[3 * i + 0] = cam->R[0 * 3 + i];
        r[3 * i + 1] = -cam->R[1 * 3 + i];
        r[3 * i + 2] = -cam->R[2 * 3 + i];
    }
    double fov_y = 2 * atan(cam->height / (2 * cam->fy)) * 180 / M_PI;
    text_printf(t, "{\"frame\":%d,\"train\":%s,\"fov_y\":%.6g,\"position\":[%.9g,%.9g,%.9g],\"rotation\":[",
                frame, interval > 0 && gv_scene_is_train(frame, interval) ? "true" : "false", fov_y,
                centre[0], centre[1], centre[2]);
    for (int k = 0; k < 9; k++) text_printf(t, "%s%.9g", k ? "," : "", r[k]);
    text_append(t, "]}");
}

int viewer_path_json(report_text *t, const char *scene_dir, int interval, const char *title, long gaussians)
{
    gv_scene scene;
    if (gv_scene_load(scene_dir, NULL, &scene) != 0) return -1;
    if (scene.n_frames < 1) {
        gv_scene_free(&scene);
        return gv_fail("%s: the scene has no cameras", scene_dir);
    }
    double extent = gv_scene_extent(&scene, NULL, 0);
    if (!(extent > 0)) extent = 1;
    text_append(t, "{\"title\":");
    json_string(t, title);
    text_printf(t, ",\"width\":%d,\"height\":%d,\"near\":%.6g,\"far\":%.6g,\"background\":\"black\",\"gaussians\":%ld,\"cameras\":[\n",
                scene.cameras[0].width, scene.cameras[0].height, extent * 1e-3, extent * 100, gaussians);
    for (int i = 0; i < scene.n_frames; i++) {
        camera_json(t, &scene.cameras[i], i, interval);
        text_append(t, i + 1 < scene.n_frames ? ",\n" : "\n");
    }
    text_append(t, "]}");
    gv_scene_free(&scene);
    return 0;
}
