/* A pinhole camera, in the convention used everywhere in the library: OpenCV/COLMAP, x right,
 * y down, z forward; a pose is world-to-camera, X_cam = R X_world + t; intrinsics in pixels
 * with the principal point in continuous coordinates (pixel (i, j) has its centre at
 * (i + 0.5, j + 0.5)). Scenes (scene.h), their file formats and the camera encoder use it. */
#ifndef GAUSSVID_CAMERA_H
#define GAUSSVID_CAMERA_H

typedef struct {
    int width, height;
    double fx, fy, cx, cy;
    double R[9];          /* world-to-camera rotation, row-major */
    double t[3];          /* world-to-camera translation */
    char name[256];       /* image file name relative to the scene's image folder */
} gv_camera;

#endif
