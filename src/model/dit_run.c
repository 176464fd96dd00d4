/* One DiT forward pass on named input tensors from a safetensors file (`gaussvid model run
 * --part dit`; docs/MODEL.md lists the names and layouts): for debugging and for comparing
 * with other implementations of the same architecture. */
#include "model/dit_internal.h"
#include "gaussvid/core/core.h"
#include "gaussvid/model/plucker.h"
#include "gaussvid/io/safetensors.h"

#include <limits.h>
#include <stdlib.h>
#include <string.h>

static const char *const known_inputs[] = {"latent", "timestep", "text", "vace_context", "intrinsics",
                                           "poses", "plucker", "context_scale", NULL};

/* Input `name` as a tensor of `rank` dimensions, the batch axis optional (then B = 1). *out is
 * NULL when the file has no such tensor. */
static int read_input(const gv_st_file *f, const char *name, int rank, gv_graph *g, gv_tensor **out)
{
    *out = NULL;
    const gv_st_tensor *t = gv_st_find(f, name);
    if (!t) return 0;
    if (t->rank != rank && t->rank != rank - 1)
        return gv_fail("%s: input %s has %d dimensions, expected %d (or %d without the batch axis)", f->path, name,
                       t->rank, rank, rank - 1);
    int shape[GV_MAX_DIMS], lead = rank - t->rank;
    shape[0] = 1;
    for (int k = 0; k < t->rank; k++) {
        if (t->shape[k] < 1 || t->shape[k] > INT_MAX)
            return gv_fail("%s: input %s: dimension %d is %lld", f->path, name, k, (long long)t->shape[k]);
        shape[lead + k] = (int)t->shape[k];
    }
    *out = gv_tensor_new(g, rank, shape);
    if (!*out) return -1;
    return gv_st_tensor_to_f32(f, t, (*out)->data) == 0 ? 0 : gv_fail_context("%s: input %s", f->path, name);
}

/* The ray field from intrinsics [B, F, 4] (fx, fy, cx, cy) and poses [B, F, 3, 4] (world-to-
 * camera [R | t]) at the clip's pixel size. */
static gv_tensor *rays_from_cameras(const gv_model_config *c, const gv_st_file *f, gv_tensor *K, gv_tensor *P,
                                    const gv_tensor *latent, gv_graph *g)
{
    int B = latent->shape[0], tf = c->vae.temporal_factor, sf = c->vae.spatial_factor;
    int frames = 1 + (latent->shape[2] - 1) * tf, height = latent->shape[3] * sf, width = latent->shape[4] * sf;
    int packed = gv_plucker_packed_frames(frames, tf);
    if (K->shape[0] != B || K->shape[1] != frames || K->shape[2] != 4 || P->shape[0] != B || P->shape[1] != frames ||
        P->shape[2] != 3 || P->shape[3] != 4) {
        gv_fail("%s: intrinsics and poses must be [%d, %d, 4] and [%d, %d, 3, 4] (%d latent frames are %d frames)", f->path,
                B, frames, B, frames, latent->shape[2], frames);
        return NULL;
    }
    gv_tensor *out = gv_tensor_new(g, 5, (int[]){B, 6, packed, height, width});
    gv_camera *cams = calloc((size_t)frames, sizeof *cams);
    if (!out || !cams) {
        free(cams);
        gv_fail("%s: out of memory for the ray field", f->path);
        return NULL;
    }
    int rc = 0;
    for (int b = 0; rc == 0 && b < B; b++) {
        for (int i = 0; i < frames; i++) {
            const float *k = K->data + ((int64_t)b * frames + i) * 4, *p = P->data + ((int64_t)b * frames + i) * 12;
            gv_camera *cam = &cams[i];
            cam->width = width, cam->height = height;
            cam->fx = k[0], cam->fy = k[1], cam->cx = k[2], cam->cy = k[3];
            for (int r = 0; r < 3; r++) {
                for (int col = 0; col < 3; col++) cam->R[r * 3 + col] = p[r * 4 + col];
                cam->t[r] = p[r * 4 + 3];
            }
        }
        rc = gv_plucker_field(cams, frames, height, width, tf, out->data + (int64_t)b * 6 * packed * height * width, NULL);
    }
    free(cams);
    if (rc != 0) {
        gv_fail_context("%s", f->path);
        return NULL;
    }
    return out;
}

static int check_names(const gv_st_file *f)
{
    for (int i = 0; i < f->n_tensors; i++) {
        int known = 0;
        for (int k = 0; known_inputs[k]; k++) known |= !strcmp(f->tensors[i].name, known_inputs[k]);
        if (!known)
            return gv_fail("%s: unknown input %s (known: latent, timestep, text, vace_context, intrinsics, poses, plucker, "
                           "context_scale)", f->path, f->tensors[i].name);
    }
    return 0;
}

static int add_output(gv_st_builder *out, const char *name, const gv_tensor *t)
{
    int64_t shape[GV_MAX_DIMS];
    for (int k = 0; k < t->ndim; k++) shape[k] = t->shape[k];
    return gv_st_add_f32(out, name, GV_ST_F32, shape, t->ndim, t->data);
}

/* Reads every input; *in receives them and the timesteps (in g). */
static int read_inputs(const gv_model_config *c, const gv_st_file *f, gv_graph *g, gv_dit_inputs *in, gv_tensor **rays)
{
    gv_tensor *t, *scale, *K, *P;
    if (check_names(f) || read_input(f, "latent", 5, g, &in->latent) || read_input(f, "timestep", 1, g, &t) ||
        read_input(f, "text", 3, g, &in->text) || read_input(f, "vace_context", 5, g, &in->vace) ||
        read_input(f, "intrinsics", 3, g, &K) || read_input(f, "poses", 4, g, &P) ||
        read_input(f, "plucker", 5, g, &in->plucker) || read_input(f, "context_scale", 1, g, &scale))
        return -1;
    if (!in->latent || !t) return gv_fail("%s: the inputs latent and timestep are required", f->path);
    int B = in->latent->shape[0];
    if (t->numel != B && t->numel != 1)
        return gv_fail("%s: timestep has %lld values for a batch of %d", f->path, (long long)t->numel, B);
    float *ts = gv_arena_alloc(&g->arena, (size_t)B * sizeof *ts);
    if (!ts) return -1;
    for (int b = 0; b < B; b++) ts[b] = t->data[t->numel == 1 ? 0 : b];
    in->timestep = ts;
    if (scale && scale->numel != 1) return gv_fail("%s: context_scale must be one value", f->path);
    if (scale) in->context_scale = scale->data[0];
    if ((K != NULL) != (P != NULL)) return gv_fail("%s: intrinsics and poses come together", f->path);
    if (K && in->plucker) return gv_fail("%s: give either intrinsics and poses or plucker, not both", f->path);
    if (K && !(in->plucker = *rays = rays_from_cameras(c, f, K, P, in->latent, g))) return -1;
    return 0;
}

int gv_dit_run_named(const gv_model_config *c, const char *const *weights, int n_weights, const gv_st_file *inputs,
                     gv_graph *g, gv_st_builder *out)
{
    gv_dit m;
    if (gv_dit_init(&m, c, 0) != 0) return -1;
    unsigned parts = GV_PART_DIT | (c->dit.n_vace_layers ? GV_PART_VACE : 0) |
                     (c->variant.camera != GV_CAMERA_NONE ? GV_PART_CAMERA : 0) | (c->lora.rank ? GV_PART_LORA : 0);
    gv_dit_inputs in = gv_dit_inputs_default();
    gv_dit_trace trace;
    gv_tensor *rays = NULL, *y = NULL;
    int rc = gv_dit_load(&m, weights, n_weights, parts);
    if (rc == 0) rc = read_inputs(c, inputs, g, &in, &rays);
    if (rc == 0) {
        gv_graph_set_grad(g, 0);
        in.trace = &trace;
        y = gv_dit_forward(&m, g, &in);
        rc = y ? 0 : gv_fail_context("%s", inputs->path);
    }
    if (rc == 0) rc = add_output(out, "velocity", y);
    if (rc == 0 && trace.camera_tokens) rc = add_output(out, "camera_tokens", trace.camera_tokens);
    if (rc == 0 && rays) rc = add_output(out, "plucker", rays);
    gv_dit_free(&m);
    return rc;
}
