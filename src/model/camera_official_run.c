/* `gaussvid model run --part camera`: the official GaussVid camera code
 * (include/gaussvid/model/plucker_official.h) on named input tensors, for comparison with the
 * official classes (docs/GAUSSVID_RELEASE.md "The official camera encoder"). */
#include "gaussvid/model/plucker_official.h"

#include <limits.h>
#include <stdlib.h>
#include <string.h>

#include "gaussvid/core/core.h"
#include "gaussvid/pth/weight_files.h"

static const char *const known_inputs[] = {"Ks", "c2ws", "size", "packed", NULL};

/* Input `name` of the given shape (-1: any size) as floats in g; NULL when absent. */
static int read_input(const gv_st_file *f, const char *name, int rank, const int *shape, gv_graph *g, gv_tensor **out)
{
    *out = NULL;
    const gv_st_tensor *t = gv_st_find(f, name);
    if (!t) return 0;
    int ok = t->rank == rank, dims[GV_MAX_DIMS];
    for (int k = 0; ok && k < rank; k++) {
        ok = t->shape[k] >= 1 && t->shape[k] <= INT_MAX / 16 && (shape[k] < 0 || t->shape[k] == shape[k]);
        dims[k] = ok ? (int)t->shape[k] : 0;
    }
    char s[64];
    if (!ok)
        return gv_fail("%s: input %s is %s, expected rank %d (%s)", f->path, name, gv_st_shape_str(s, sizeof s, t->shape, t->rank),
                       rank, !strcmp(name, "Ks") ? "[F, 3, 3]" : !strcmp(name, "c2ws") ? "[F, 4, 4]" : !strcmp(name, "size") ? "[2]" : "[1, 6, Tp, H, W]");
    if (!(*out = gv_tensor_new(g, rank, dims))) return -1;
    return gv_st_tensor_to_f32(f, t, (*out)->data) == 0 ? 0 : gv_fail_context("%s: input %s", f->path, name);
}

static int add_output(gv_st_builder *out, const char *name, const gv_tensor *t)
{
    int64_t shape[GV_MAX_DIMS];
    for (int k = 0; k < t->ndim; k++) shape[k] = t->shape[k];
    return gv_st_add_f32(out, name, GV_ST_F32, shape, t->ndim, t->data);
}

/* The packed field from Ks, c2ws and size; plucker and packed are added to out. */
static gv_tensor *packed_from_cameras(const gv_st_file *f, gv_graph *g, gv_st_builder *out)
{
    gv_tensor *K, *P, *size;
    if (read_input(f, "Ks", 3, (int[]){-1, 3, 3}, g, &K) || read_input(f, "c2ws", 3, (int[]){-1, 4, 4}, g, &P) ||
        read_input(f, "size", 1, (int[]){2}, g, &size))
        return NULL;
    if (!K || !P || !size) {
        gv_fail("%s: give Ks [F, 3, 3], c2ws [F, 4, 4] and size [2] (height, width), or packed [1, 6, Tp, H, W]", f->path);
        return NULL;
    }
    int frames = K->shape[0], height = (int)size->data[0], width = (int)size->data[1];
    if (P->shape[0] != frames || height < 1 || width < 1 || size->data[0] != height || size->data[1] != width ||
        (double)height * width * (frames + 3) > 1e9) {
        gv_fail("%s: Ks has %d frames, c2ws %d; size must be two positive whole numbers (height, width)", f->path, frames,
                P->shape[0]);
        return NULL;
    }
    gv_tensor *plucker = gv_tensor_new(g, 4, (int[]){frames, height, width, 6});
    gv_tensor *packed = gv_tensor_new(g, 5, (int[]){1, 6, frames + 3, height, width});
    if (!plucker || !packed || gv_official_plucker(K->data, P->data, frames, height, width, plucker->data)) return NULL;
    gv_official_pack(plucker->data, frames, height, width, packed->data);
    return add_output(out, "plucker", plucker) || add_output(out, "packed", packed) ? NULL : packed;
}

int gv_camera_run_named(const gv_model_config *c, const char *const *weights, int n_weights, const gv_st_file *inputs,
                        gv_graph *g, gv_st_builder *out)
{
    for (int i = 0; i < inputs->n_tensors; i++) {
        int known = 0;
        for (int k = 0; known_inputs[k]; k++) known |= !strcmp(inputs->tensors[i].name, known_inputs[k]);
        if (!known)
            return gv_fail("%s: unknown input %s (camera inputs: Ks, c2ws, size, packed)", inputs->path,
                           inputs->tensors[i].name);
    }
    if (n_weights != 1) return gv_fail("--weights: the camera part takes one file (the encoder's weights)");
    gv_tensor *packed;
    if (read_input(inputs, "packed", 5, (int[]){1, 6, -1, -1, -1}, g, &packed)) return -1;
    if (packed && (gv_st_find(inputs, "Ks") || gv_st_find(inputs, "c2ws")))
        return gv_fail("%s: give the cameras (Ks, c2ws, size) or packed, not both", inputs->path);
    if (!packed && !(packed = packed_from_cameras(inputs, g, out))) return -1;
    int k[3];
    gv_model_camera_kernel(c, k);
    int tp = packed->shape[2], height = packed->shape[3], width = packed->shape[4];
    int64_t n = (int64_t)(tp / k[0]) * (height / k[1]) * (width / k[2]);
    gv_tensor *tokens = gv_tensor_new(g, 3, (int[]){1, n > 0 ? (int)n : 1, c->dit.dim});
    gv_st_file w;
    if (!tokens || gv_weights_open(&w, weights[0])) return -1;
    int rc = gv_official_camera_encode(c, &w, packed->data, tp, height, width, tokens->data);
    gv_st_close(&w);
    return rc == 0 ? add_output(out, "tokens", tokens) : -1;
}
