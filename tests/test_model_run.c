/* `model run --part dit` as a library call (gv_dit_run_named): named inputs from a safetensors
 * file give the same velocity, camera tokens and ray field as the direct forward pass, with
 * or without the batch axis; inconsistent inputs are refused with the file named. */
#include <omp.h>

#include "check.h"
#include "model_testutil.h"

enum { FRAMES = 5, HEIGHT = 32, WIDTH = 32 };

typedef struct {
    float K[FRAMES * 4], P[FRAMES * 12];
    gv_camera cams[FRAMES];
} clip_cameras;

/* The cameras rounded to float, as the input file stores them. */
static void cameras(clip_cameras *c)
{
    mt_cameras(c->cams, FRAMES, HEIGHT, WIDTH, 0.1);
    for (int f = 0; f < FRAMES; f++) {
        gv_camera *cam = &c->cams[f];
        float *k = c->K + 4 * f, *p = c->P + 12 * f;
        k[0] = (float)cam->fx, k[1] = (float)cam->fy, k[2] = (float)cam->cx, k[3] = (float)cam->cy;
        cam->fx = k[0], cam->fy = k[1], cam->cx = k[2], cam->cy = k[3];
        for (int r = 0; r < 3; r++) {
            for (int col = 0; col < 3; col++) p[r * 4 + col] = (float)cam->R[r * 3 + col], cam->R[r * 3 + col] = p[r * 4 + col];
            p[r * 4 + 3] = (float)cam->t[r], cam->t[r] = p[r * 4 + 3];
        }
    }
}

static int write_inputs(const char *path, const mt_inputs *in, const clip_cameras *c, int batch_axis, const char *extra)
{
    gv_st_builder b;
    gv_st_builder_init(&b);
    int o = batch_axis ? 0 : 1; /* leave the batch axis out */
    int64_t ls[5], ts[3], vs[5];
    for (int k = 0; k < 5; k++) ls[k] = in->latent->shape[k], vs[k] = in->vace->shape[k];
    for (int k = 0; k < 3; k++) ts[k] = in->text->shape[k];
    int rc = gv_st_add_f32(&b, "latent", GV_ST_F32, ls + o, 5 - o, in->latent->data) ||
             gv_st_add_f32(&b, "timestep", GV_ST_F32, (int64_t[]){1}, 1, in->t) ||
             gv_st_add_f32(&b, "text", GV_ST_F32, ts + o, 3 - o, in->text->data) ||
             gv_st_add_f32(&b, "vace_context", GV_ST_F32, vs + o, 5 - o, in->vace->data) ||
             gv_st_add_f32(&b, "intrinsics", GV_ST_F32, (int64_t[]){1, FRAMES, 4} + o, 3 - o, c->K) ||
             gv_st_add_f32(&b, "poses", GV_ST_F32, (int64_t[]){1, FRAMES, 3, 4} + o, 4 - o, c->P);
    if (rc == 0 && extra && !strcmp(extra, "plucker"))
        rc = gv_st_add_f32(&b, "plucker", GV_ST_F32, (int64_t[]){6, 8, HEIGHT, WIDTH}, 4, in->plucker->data);
    if (rc == 0 && extra && !strcmp(extra, "timesteps"))
        rc = gv_st_add_f32(&b, "context_scale", GV_ST_F32, (int64_t[]){3}, 1, in->t);
    if (rc == 0) rc = gv_st_write(&b, path);
    gv_st_builder_free(&b);
    return rc;
}

static int run_named(const gv_model_config *c, const char *weights, const char *inputs, gv_graph *g, gv_st_builder *out)
{
    gv_st_file f;
    if (gv_st_open(&f, inputs) != 0) return -1;
    const char *w[1] = {weights};
    int rc = gv_dit_run_named(c, w, 1, &f, g, out);
    gv_st_close(&f);
    return rc;
}

static void test_run_named(void)
{
    const char *dir = check_tmp_dir();
    char weights[512], inputs[512], outputs[512];
    snprintf(weights, sizeof weights, "%s/w.safetensors", dir);
    snprintf(inputs, sizeof inputs, "%s/in.safetensors", dir);
    snprintf(outputs, sizeof outputs, "%s/out.safetensors", dir);
    gv_dit m;
    CHECK(mt_model(&m, NULL, 1) == 0);
    mt_randomize(&m, MT_ALL, 2);
    CHECK(gv_dit_save(&m, weights, GV_PART_ALL) == 0);
    gv_graph g;
    gv_graph_init(&g, 0);
    mt_inputs in;
    CHECK(mt_make_inputs(&m, &g, NULL, 1, FRAMES, HEIGHT, WIDTH, 3, &in) == 0);
    clip_cameras cams;
    cameras(&cams);
    CHECK(gv_plucker_field(cams.cams, FRAMES, HEIGHT, WIDTH, 4, in.plucker->data, NULL) == 0);
    gv_dit_trace tr;
    gv_dit_inputs d = mt_dit_inputs(&in);
    d.trace = &tr;
    gv_tensor *want = gv_dit_forward(&m, &g, &d);
    CHECK(want != NULL);
    for (int batch_axis = 0; want && batch_axis < 2; batch_axis++) {
        CHECK(write_inputs(inputs, &in, &cams, batch_axis, NULL) == 0);
        gv_graph g2;
        gv_graph_init(&g2, 0);
        gv_st_builder out;
        gv_st_builder_init(&out);
        CHECK(run_named(&m.cfg, weights, inputs, &g2, &out) == 0);
        CHECK(gv_st_write(&out, outputs) == 0);
        gv_st_file f;
        CHECK(gv_st_open(&f, outputs) == 0);
        float *got = malloc((size_t)want->numel * sizeof(float) * 2);
        CHECK(gv_st_read_f32(&f, "velocity", got, (int64_t[]){1, 4, 2, 4, 4}, 5) == 0);
        CHECK(!memcmp(got, want->data, (size_t)want->numel * sizeof(float)));
        CHECK(gv_st_read_f32(&f, "camera_tokens", got, (int64_t[]){1, 8, 32}, 3) == 0);
        CHECK(!memcmp(got, tr.camera_tokens->data, (size_t)tr.camera_tokens->numel * sizeof(float)));
        float *rays = malloc((size_t)in.plucker->numel * sizeof(float));
        CHECK(gv_st_read_f32(&f, "plucker", rays, (int64_t[]){1, 6, 8, HEIGHT, WIDTH}, 5) == 0);
        CHECK(!memcmp(rays, in.plucker->data, (size_t)in.plucker->numel * sizeof(float)));
        free(rays), free(got);
        gv_st_close(&f);
        gv_st_builder_free(&out);
        gv_graph_free(&g2);
    }
    /* refused: cameras twice, a context_scale of 3 values; the file is named */
    const char *bad[2] = {"plucker", "timesteps"}, *needle[2] = {"not both", "context_scale"};
    for (int i = 0; i < 2; i++) {
        CHECK(write_inputs(inputs, &in, &cams, 0, bad[i]) == 0);
        gv_graph g2;
        gv_graph_init(&g2, 0);
        gv_st_builder out;
        gv_st_builder_init(&out);
        gv_clear_error();
        int rc = run_named(&m.cfg, weights, inputs, &g2, &out);
        CHECK(rc != 0 && strstr(gv_last_error(), needle[i]) && strstr(gv_last_error(), "in.safetensors"));
        if (rc == 0 || !strstr(gv_last_error(), needle[i])) fprintf(stderr, "got: %s\n", gv_last_error());
        gv_st_builder_free(&out);
        gv_graph_free(&g2);
    }
    gv_graph_free(&g);
    gv_dit_free(&m);
}

int main(void)
{
    omp_set_num_threads(2);
    test_run_named();
    return check_summary();
}
