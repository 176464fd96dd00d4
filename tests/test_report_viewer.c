/* The viewer page (src/report/viewer*.c, docs/REPORT.md): the model's bytes come back exactly
 * from the page, the path's cameras are the scene's converted to three.js's convention
 * (hand-derived), the title cannot end the script element; plus base64 against RFC 4648's
 * vectors and the in-memory PNG encoder against the PNG reader. */
#include "check.h"

#include <cjson/cJSON.h>

#include "gaussvid/core/core.h"
#include "gaussvid/io/image.h"
#include "gaussvid/report/report.h"
#include "gaussvid/scene/scene.h"

static char tmp[4096];

static void test_base64(void)
{
    /* RFC 4648 section 10 */
    static const char *plain[7] = {"", "f", "fo", "foo", "foob", "fooba", "foobar"};
    static const char *coded[7] = {"", "Zg==", "Zm8=", "Zm9v", "Zm9vYg==", "Zm9vYmE=", "Zm9vYmFy"};
    for (int i = 0; i < 7; i++) {
        char *e = gv_base64_encode((const uint8_t *)plain[i], strlen(plain[i]));
        CHECK(e && !strcmp(e, coded[i]));
        free(e);
        uint8_t *d;
        size_t n;
        CHECK(gv_base64_decode(coded[i], strlen(coded[i]), &d, &n) == 0 && n == strlen(plain[i]) &&
              !memcmp(d, plain[i], n));
        free(d);
    }
    uint8_t bytes[1000];
    for (int i = 0; i < 1000; i++) bytes[i] = (uint8_t)(i * 7919 >> 3);
    for (size_t n = 997; n <= 1000; n++) {
        char *e = gv_base64_encode(bytes, n);
        uint8_t *d;
        size_t m;
        CHECK(e && gv_base64_decode(e, strlen(e), &d, &m) == 0 && m == n && !memcmp(d, bytes, n));
        free(e);
        free(d);
    }
    uint8_t *d;
    size_t n;
    CHECK_FAILS_WITH(gv_base64_decode("Zm9", 3, &d, &n), "not a multiple of 4");
    CHECK_FAILS_WITH(gv_base64_decode("Zm*v", 4, &d, &n), "invalid character at offset 2");
    CHECK_FAILS_WITH(gv_base64_decode("Z=9v", 4, &d, &n), "invalid character at offset 1");
}

static void test_png_in_memory(void)
{
    gv_image img, back;
    if (gv_image_alloc(&img, 5, 3, 3) != 0) exit(1);
    for (int i = 0; i < 45; i++) img.pixels[i] = (uint8_t)(i * 53);
    uint8_t *png;
    size_t size;
    REQUIRE(gv_image_encode_png(&img, &png, &size) == 0);
    CHECK(size > 8 && !memcmp(png, "\x89PNG\r\n\x1a\n", 8));
    char path[4200];
    snprintf(path, sizeof path, "%s/memory.png", tmp);
    FILE *f = fopen(path, "wb");
    CHECK(f && fwrite(png, 1, size, f) == size);
    fclose(f);
    free(png);
    CHECK(gv_image_read_png(path, &back) == 0 && back.width == 5 && back.height == 3 && back.channels == 3 &&
          !memcmp(back.pixels, img.pixels, 45));
    gv_image_free(&back);
    gv_image_free(&img);
}

/* Three cameras on a line looking along +x (OpenCV: z forward = world +x, y down = world -z). */
static void make_scene(const char *dir, gv_scene *s)
{
    memset(s, 0, sizeof *s);
    s->n_frames = 3;
    s->cameras = calloc(3, sizeof *s->cameras);
    char path[4200];
    snprintf(path, sizeof path, "%s/images", dir);
    CHECK(gv_mkdirs(path) == 0);
    for (int i = 0; i < 3; i++) {
        gv_camera *c = &s->cameras[i];
        c->width = 16, c->height = 8, c->fx = c->fy = 4, c->cx = 8, c->cy = 4;
        /* rows: camera x = world -y, camera y = world -z, camera z = world +x */
        const double R[9] = {0, -1, 0, 0, 0, -1, 1, 0, 0};
        memcpy(c->R, R, sizeof R);
        const double centre[3] = {i, 2, 0.5}; /* t = -R C */
        for (int r = 0; r < 3; r++) c->t[r] = -(R[3 * r] * centre[0] + R[3 * r + 1] * centre[1] + R[3 * r + 2] * centre[2]);
        snprintf(c->name, sizeof c->name, "frame_%05d.png", i);
        gv_image img;
        if (gv_image_alloc(&img, 16, 8, 3) != 0) exit(1);
        snprintf(path, sizeof path, "%s/images/%s", dir, c->name);
        CHECK(gv_image_write_png(path, &img) == 0);
        gv_image_free(&img);
    }
    static float points[3] = {1, 2, 3};
    static uint8_t colors[3] = {4, 5, 6};
    s->n_points = 1, s->points = points, s->colors = colors;
    CHECK(gv_scene_write(dir, s) == 0);
}

/* The text between <script id="ID" ...> and </script>. */
static char *script_text(const char *html, const char *id, size_t *length)
{
    char needle[64];
    snprintf(needle, sizeof needle, "<script id=\"%s\"", id);
    const char *at = strstr(html, needle);
    if (!at) return NULL;
    at = strchr(at, '>') + 1;
    *length = (size_t)(strstr(at, "</script>") - at);
    return (char *)at;
}

static void test_viewer(void)
{
    if (!gv_viewer_available()) {
        printf("this build has no viewer JavaScript (scripts/setup.sh vendors it): viewer checks skipped\n");
        char splat[4200];
        snprintf(splat, sizeof splat, "%s/none.splat", tmp);
        CHECK_FAILS_WITH(gv_viewer_write(splat, tmp, 2, "t", splat), "built without the viewer's JavaScript");
        return;
    }
    char scene_dir[4200], splat[4200], out[4200];
    snprintf(scene_dir, sizeof scene_dir, "%s/scene", tmp);
    gv_scene scene;
    make_scene(scene_dir, &scene);
    free(scene.cameras);

    /* a model of 3 Gaussians: every byte value appears, so base64 is exercised fully */
    uint8_t model[96];
    for (int i = 0; i < 96; i++) model[i] = (uint8_t)(255 - i * 3);
    snprintf(splat, sizeof splat, "%s/m.splat", tmp);
    FILE *f = fopen(splat, "wb");
    CHECK(f && fwrite(model, 1, 96, f) == 96);
    fclose(f);
    snprintf(out, sizeof out, "%s/viewer.html", tmp);
    REQUIRE(gv_viewer_write(splat, scene_dir, 2, "room </script> & co", out) == 0);
    char *html;
    size_t size, length;
    REQUIRE(gv_read_file(out, &html, &size) == 0);

    /* the model round-trips exactly */
    char *b64 = script_text(html, "gv-model", &length);
    REQUIRE(b64 != NULL);
    uint8_t *bytes;
    size_t n;
    CHECK(gv_base64_decode(b64, length, &bytes, &n) == 0 && n == 96 && !memcmp(bytes, model, 96));
    free(bytes);
    CHECK(strstr(html, "data-bytes=\"96\"") != NULL);

    /* the title cannot close a script element: one </script> per <script> */
    int opened = 0, closed = 0;
    for (const char *p = strstr(html, "<script"); p; p = strstr(p + 1, "<script")) opened++;
    for (const char *p = strstr(html, "</script"); p; p = strstr(p + 1, "</script")) closed++;
    CHECK(opened == 3 && closed == 3);
    CHECK(strstr(html, "<title>room &lt;/script&gt; &amp; co</title>") != NULL);

    /* the path: OpenGL camera-to-world of each camera */
    char *json = script_text(html, "gv-path", &length);
    REQUIRE(json != NULL);
    cJSON *path = cJSON_ParseWithLength(json, length);
    REQUIRE(path != NULL);
    CHECK(!strcmp(cJSON_GetObjectItem(path, "title")->valuestring, "room </script> & co"));
    CHECK(cJSON_GetObjectItem(path, "width")->valueint == 16 && cJSON_GetObjectItem(path, "height")->valueint == 8);
    CHECK(cJSON_GetObjectItem(path, "gaussians")->valueint == 3);
    const cJSON *cameras = cJSON_GetObjectItem(path, "cameras");
    CHECK(cJSON_GetArraySize(cameras) == 3);
    /* columns of the rotation: the camera's x (world -y), up (-y_cv = world +z) and back
     * (-z_cv = world -x) axes, so the camera looks along world +x with z up */
    const double want_rotation[9] = {0, 0, -1, -1, 0, 0, 0, 1, 0};
    for (int i = 0; i < 3; i++) {
        const cJSON *c = cJSON_GetArrayItem(cameras, i);
        CHECK(cJSON_GetObjectItem(c, "frame")->valueint == i);
        CHECK(cJSON_IsTrue(cJSON_GetObjectItem(c, "train")) == (i % 2 == 0));
        CHECK_NEAR(cJSON_GetObjectItem(c, "fov_y")->valuedouble, 90, 1e-4); /* 2 atan(8 / (2 * 4)) */
        const cJSON *p = cJSON_GetObjectItem(c, "position"), *r = cJSON_GetObjectItem(c, "rotation");
        CHECK_NEAR(cJSON_GetArrayItem(p, 0)->valuedouble, i, 1e-9);
        CHECK_NEAR(cJSON_GetArrayItem(p, 1)->valuedouble, 2, 1e-9);
        CHECK_NEAR(cJSON_GetArrayItem(p, 2)->valuedouble, 0.5, 1e-9);
        for (int k = 0; k < 9; k++) CHECK_NEAR(cJSON_GetArrayItem(r, k)->valuedouble, want_rotation[k], 1e-9);
    }
    cJSON_Delete(path);
    /* the renderer is inside: the last script is the bundle, and nothing is fetched from a URL */
    const char *last = strstr(html, "<script>\n");
    CHECK(last && strlen(last) > 100000);
    CHECK(strstr(html, "<script src") == NULL && strstr(html, "<link") == NULL);
    free(html);

    /* bad models */
    f = fopen(splat, "wb");
    CHECK(f && fwrite(model, 1, 33, f) == 33);
    fclose(f);
    CHECK_FAILS_WITH(gv_viewer_write(splat, scene_dir, 2, "t", out), "33 bytes, not a .splat file");
    snprintf(splat, sizeof splat, "%s/missing.splat", tmp);
    CHECK_FAILS_WITH(gv_viewer_write(splat, scene_dir, 2, "t", out), "missing.splat");
}

int main(void)
{
    snprintf(tmp, sizeof tmp, "%s", check_tmp_dir());
    test_base64();
    test_png_in_memory();
    test_viewer();
    return check_summary();
}
