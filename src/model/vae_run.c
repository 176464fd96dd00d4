/* `gaussvid model run --part vae-encode | vae-decode`: one VAE pass on named tensors of a
 * safetensors file, for debugging and for comparing with other implementations of Wan's VAE
 * (docs/VAE.md lists the names). Clips are [3, T, H, W] or [B, 3, T, H, W] in [-1, 1];
 * latents [z, T', h, w] or [B, z, T', h, w]; the batch is processed clip by clip, each
 * chunked through the causal caches as Wan does. Outputs live in the graph's arena until
 * the caller writes them. */
#include <string.h>

#include "gaussvid/core/core.h"
#include "gaussvid/io/safetensors.h"
#include "gaussvid/model/vae.h"
#include "gaussvid/pth/weight_files.h"

/* Loads the VAE from the first weight file that holds its tensors (others may hold the DiT). */
static int load_vae(gv_vae *v, const gv_model_config *c, const char *const *weights, int n_weights)
{
    if (gv_vae_init(v, c, 0, 0)) return -1;
    for (int i = 0; i < n_weights; i++) {
        gv_st_file f;
        if (gv_weights_open(&f, weights[i])) {
            gv_vae_free(v);
            return -1;
        }
        int has = gv_st_find(&f, "conv2.weight") != NULL;
        gv_st_close(&f);
        if (!has) continue;
        if (gv_vae_load(v, weights[i], 1) == 0) return 0;
        gv_vae_free(v);
        return -1;
    }
    gv_vae_free(v);
    return gv_fail("%s%s: no VAE tensors (conv2.weight, encoder.*, decoder.*)", weights[0], n_weights > 1 ? ", ..." : "");
}

/* Reads the first of the names present as a float tensor [(B,) channels, T, H, W] into the
 * arena; returns its index in names, or -1. */
static int read_input(const gv_st_file *f, gv_graph *g, const char *const *names, int n_names, int channels,
                      float **data, int64_t shape[5], int *rank)
{
    for (int k = 0; k < n_names; k++) {
        const gv_st_tensor *t = gv_st_find(f, names[k]);
        if (!t) continue;
        int off = t->rank - 4;
        if ((t->rank != 4 && t->rank != 5) || t->shape[off] != channels) {
            char s[64];
            gv_fail("%s: %s is %s, expected [%s%d, T, H, W]", f->path, names[k], gv_st_shape_str(s, sizeof s, t->shape, t->rank),
                    t->rank == 5 ? "B, " : "", channels);
            return -1;
        }
        for (int d = 0; d < t->rank; d++)
            if (t->shape[d] < 1 || t->shape[d] > 65536) {
                gv_fail("%s: %s has a dimension of %lld", f->path, names[k], (long long)t->shape[d]);
                return -1;
            }
        *rank = t->rank;
        shape[0] = t->rank == 5 ? t->shape[0] : 1;
        for (int d = 0; d < 4; d++) shape[d + 1] = t->shape[off + d];
        if (!(*data = gv_arena_alloc(&g->arena, (size_t)t->n_elements * sizeof **data))) return -1;
        return gv_st_tensor_to_f32(f, t, *data) ? -1 : k;
    }
    gv_fail("%s: no tensor named %s%s%s", f->path, names[0], n_names > 1 ? " or " : "", n_names > 1 ? names[1] : "");
    return -1;
}

static int add_output(gv_st_builder *b, const char *name, int rank, int64_t B, int64_t c, int64_t t, int64_t h, int64_t w,
                      const float *data)
{
    int64_t s5[5] = {B, c, t, h, w}, s4[4] = {c, t, h, w};
    return gv_st_add_f32(b, name, GV_ST_F32, rank == 5 ? s5 : s4, rank, data);
}

static int encode(gv_vae *v, const gv_st_file *in, gv_graph *g, gv_st_builder *b)
{
    const char *names[1] = {"video"};
    int64_t s[5];
    int rank, z = v->cfg.z_dim, sf = v->cfg.spatial_factor, r = v->cfg.temporal_factor, tl = 0;
    float *video;
    if (read_input(in, g, names, 1, 3, &video, s, &rank) < 0) return -1;
    if (gv_vae_check_clip(&v->cfg, (int)s[2], (int)s[3], (int)s[4]) || gv_vae_latent_frames(&v->cfg, (int)s[2], &tl))
        return gv_fail_context("%s: video", in->path);
    int64_t clip = 3 * s[2] * s[3] * s[4], lat = (int64_t)z * tl * (s[3] / sf) * (s[4] / sf);
    float *mean = gv_arena_alloc(&g->arena, sizeof(float) * (size_t)(s[0] * lat));
    float *latent = v->has_stats ? gv_arena_alloc(&g->arena, sizeof(float) * (size_t)(s[0] * lat)) : NULL;
    if (!mean || (v->has_stats && !latent)) return -1;
    for (int64_t i = 0; i < s[0]; i++) {
        const float *x = video + i * clip;
        if (gv_vae_encode(v, x, (int)s[2], (int)s[3], (int)s[4], 0, r, mean + i * lat) ||
            (latent && gv_vae_encode(v, x, (int)s[2], (int)s[3], (int)s[4], 1, r, latent + i * lat)))
            return -1;
    }
    if (add_output(b, "mean", rank, s[0], z, tl, s[3] / sf, s[4] / sf, mean)) return -1;
    return latent ? add_output(b, "latent", rank, s[0], z, tl, s[3] / sf, s[4] / sf, latent) : 0;
}

static int decode(gv_vae *v, const gv_st_file *in, gv_graph *g, gv_st_builder *b)
{
    const char *names[2] = {"latent", "mean"};
    int64_t s[5];
    int rank, z = v->cfg.z_dim, sf = v->cfg.spatial_factor, r = v->cfg.temporal_factor;
    float *lat;
    int which = read_input(in, g, names, 2, z, &lat, s, &rank);
    if (which < 0) return -1;
    int64_t T = 1 + r * (s[2] - 1), H = sf * s[3], W = sf * s[4], clip = 3 * T * H * W, lat_n = z * s[2] * s[3] * s[4];
    float *video = gv_arena_alloc(&g->arena, sizeof(float) * (size_t)(s[0] * clip));
    if (!video) return -1;
    for (int64_t i = 0; i < s[0]; i++)
        if (gv_vae_decode(v, lat + i * lat_n, (int)s[2], (int)s[3], (int)s[4], which == 0, 1, video + i * clip))
            return gv_fail_context("%s: %s", in->path, names[which]);
    return add_output(b, "video", rank, s[0], 3, T, H, W, video);
}

int gv_vae_run_encode_named(const gv_model_config *c, const char *const *weights, int n_weights,
                            const gv_st_file *inputs, gv_graph *g, gv_st_builder *out)
{
    gv_vae v;
    if (load_vae(&v, c, weights, n_weights)) return -1;
    int rc = encode(&v, inputs, g, out);
    gv_vae_free(&v);
    return rc;
}

int gv_vae_run_decode_named(const gv_model_config *c, const char *const *weights, int n_weights,
                            const gv_st_file *inputs, gv_graph *g, gv_st_builder *out)
{
    gv_vae v;
    if (load_vae(&v, c, weights, n_weights)) return -1;
    int rc = decode(&v, inputs, g, out);
    gv_vae_free(&v);
    return rc;
}
