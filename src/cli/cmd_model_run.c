/* gaussvid model run: one forward pass of a part of the restoration network on named input
 * tensors, writing the named outputs (docs/MODEL.md lists them per part). For debugging and
 * for comparing with other implementations of the same architecture. Each part is one line
 * of `model_parts` below: a library function that reads its inputs from the open file and
 * adds its outputs to the builder. */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "cli/commands.h"
#include "gaussvid/core/core.h"
#include "gaussvid/model/dit.h"
#include "gaussvid/model/model_config.h"
#include "gaussvid/model/plucker_official.h"
#include "gaussvid/io/safetensors.h"
#include "gaussvid/model/vae.h"

enum { MAX_WEIGHTS = 64 };

/* Loads the weights, runs the part on `inputs`, adds the outputs to `out` (data in g). */
typedef int (*model_part_fn)(const gv_model_config *c, const char *const *weights, int n_weights,
                             const gv_st_file *inputs, gv_graph *g, gv_st_builder *out);

static const struct {
    const char *name;
    model_part_fn run;
} model_parts[] = {
    {"dit", gv_dit_run_named},
    {"vae-encode", gv_vae_run_encode_named},
    {"vae-decode", gv_vae_run_decode_named},
    {"camera", gv_camera_run_named},
};
static const int n_model_parts = (int)(sizeof model_parts / sizeof model_parts[0]);

/* Splits "a,b,c" into names (pointers into the copy `buf`); -1 when too many. */
static int split_list(char *buf, const char **names)
{
    int n = 0;
    for (char *save = NULL, *p = strtok_r(buf, ",", &save); p; p = strtok_r(NULL, ",", &save)) {
        if (n == MAX_WEIGHTS) return -1;
        names[n++] = p;
    }
    return n;
}

static int run_part(model_part_fn fn, const char *part, gv_model_config c, const char *weights, const char *inputs,
                    const char *out_path)
{
    char *buf = strdup(weights);
    const char *names[MAX_WEIGHTS];
    int n = buf ? split_list(buf, names) : -1;
    if (n <= 0) {
        free(buf);
        return gv_fail("--weights: give 1 to %d files separated by commas", MAX_WEIGHTS);
    }
    gv_st_file in;
    gv_graph g;
    gv_graph_init(&g, 0);
    gv_st_builder out;
    gv_st_builder_init(&out);
    char *json = NULL;
    int rc = gv_st_open(&in, inputs);
    if (rc == 0) {
        double t0 = gv_now();
        rc = fn(&c, names, n, &in, &g, &out);
        if (rc == 0) gv_info("model run: part %s of %s in %.3f s", part, c.name, gv_now() - t0);
        gv_st_close(&in);
    }
    if (rc == 0 && !(json = gv_model_config_to_json(&c))) rc = gv_fail("out of memory for the config");
    if (rc == 0) rc = gv_st_add_metadata(&out, "config", json);
    if (rc == 0) rc = gv_st_add_metadata(&out, "part", part);
    if (rc == 0) rc = gv_st_write(&out, out_path);
    free(json);
    gv_st_builder_free(&out);
    gv_graph_free(&g);
    free(buf);
    return rc;
}

int cmd_model_run(int argc, char **argv)
{
    const char *config = NULL, *weights = NULL, *inputs = NULL, *out = NULL, *part = "dit", *variant = NULL;
    const gv_flag flags[] = {
        {"config", GV_FLAG_STRING, &config, "PRESET|FILE",
         "a preset (tiny, small, wan2.1-vace-1.3b, wan2.1-vace-14b) or a JSON config", 1},
        {"weights", GV_FLAG_STRING, &weights, "FILE[,FILE]", "safetensors weight files (e.g. base,adapters)", 1},
        {"inputs", GV_FLAG_STRING, &inputs, "FILE", "safetensors file of named input tensors", 1},
        {"out", GV_FLAG_STRING, &out, "FILE", "safetensors file for the named outputs", 1},
        {"part", GV_FLAG_STRING, &part, "P", "the part to run: dit (default), vae-encode, vae-decode, camera", 0},
        {"variant", GV_FLAG_STRING, &variant, "V", GV_VARIANT_HELP, 0},
    };
    const gv_command_spec spec = {
        "model run", NULL, "one forward pass of a network part on named input tensors",
        "--part dit reads latent [B, C, T, H, W], timestep [B] (0..1000), text [B, L, text_dim]\n"
        "(configs with cross-attention), vace_context [B, vace_in_dim, T, H, W] (optional), and\n"
        "the cameras as intrinsics [B, F, 4] (fx, fy, cx, cy in pixels) + poses [B, F, 3, 4]\n"
        "(world-to-camera [R|t], OpenCV) or as a packed plucker field [B, 6, Tp, H*sf, W*sf];\n"
        "the batch axis may be left out. Writes velocity [B, C, T, H, W], camera_tokens [B, N, D]\n"
        "and the plucker field it built. Weights load by name (docs/MODEL.md).\n"
        "--part vae-encode reads video [B, 3, T, H, W] in [-1, 1] and writes mean (and latent,\n"
        "normalised, when the VAE has statistics); --part vae-decode reads latent (or mean)\n"
        "[B, z, T', h, w] and writes video, clamped; the batch axis may be left out (docs/VAE.md).\n"
        "--part camera runs the official GaussVid camera code with its parameter names: reads Ks\n"
        "[F, 3, 3] + c2ws [F, 4, 4] (camera-to-world, OpenCV) + size [2] (height, width), or a\n"
        "packed field [1, 6, Tp, H, W]; writes plucker [F, H, W, 6], packed [1, 6, F + 3, H, W]\n"
        "and tokens [1, N, D]; the config gives D (dit.dim), hidden (camera.channels) and the\n"
        "gates' bottleneck (camera.gate_hidden) (docs/GAUSSVID_RELEASE.md).",
        flags, (int)(sizeof flags / sizeof flags[0]), 0, 0};
    int parsed = gv_args_parse(&spec, argc, argv, NULL, NULL);
    if (parsed != GV_ARGS_OK) return gv_args_exit_code(parsed);
    int which = -1;
    for (int i = 0; i < n_model_parts; i++)
        if (!strcmp(part, model_parts[i].name)) which = i;
    if (which < 0) {
        fprintf(stderr, "gaussvid model run: --part %s is not one of:", part);
        for (int i = 0; i < n_model_parts; i++) fprintf(stderr, " %s", model_parts[i].name);
        fprintf(stderr, "\n");
        return 2;
    }
    gv_model_config c;
    if (gv_model_config_load(&c, config) != 0) return gv_report_failure();
    if (variant && gv_model_config_set_variant(&c, variant, "--variant") != 0) {
        fprintf(stderr, "gaussvid model run: %s\n", gv_last_error());
        return 2;
    }
    return run_part(model_parts[which].run, part, c, weights, inputs, out) == 0 ? 0 : gv_report_failure();
}
