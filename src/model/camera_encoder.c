/* The Plücker token encoder (paper 3.3.1, eq. 1-3; docs/ARCHITECTURE.md 6.4; the authors' encoders in
 * docs/reference/wan-vace-gaussvid.md 1.4). Its Conv3D kernel and stride are VAE factor x DiT patch
 * in every axis, so it gives one token per video token.
 *   decomposed: F_m = Conv3D_m(m), F_d = Conv3D_d(d); F^_m = F_m sigma(g_d->m(F_d)),
 *               F^_d = F_d sigma(g_m->d(F_m)); g = Linear, SiLU, Linear
 *   monolithic / early: F = Conv3D(m, d) (2C channels); F + MLP(F) (Linear, SiLU, Linear)
 * then x_c = gamma LayerNorm(proj.2(SiLU(proj.0(F)))) with proj.2 zero-initialised and gamma
 * learnable from gamma_init, so x_c = 0 exactly at initialisation. */
#include "model/dit_internal.h"
#include "gaussvid/core/core.h"

/* The authors' nn.LayerNorm(D) keeps PyTorch's default epsilon. */
#define CAMERA_NORM_EPS 1e-5f

gv_tensor *gv_dit_tokens(gv_graph *g, gv_tensor *map)
{
    if (!map) return NULL;
    int B = map->shape[0], C = map->shape[1], N = map->shape[2] * map->shape[3] * map->shape[4];
    return gv_transpose(g, gv_reshape(g, map, 3, (int[]){B, C, N}), 1, 2);
}

static gv_tensor *mlp(gv_graph *g, const gv_dit *m, const gv_dit_linear *a, const gv_dit_linear *b, gv_tensor *x)
{
    return gv_dit_lin(g, m, b, gv_silu(g, gv_dit_lin(g, m, a, x)));
}

gv_tensor *gv_camera_encoder_forward(const gv_dit *m, gv_graph *g, gv_tensor *plucker)
{
    const gv_camera_encoder *e = &m->camera;
    if (!plucker) return NULL;
    if (m->cfg.variant.camera == GV_CAMERA_NONE) {
        gv_fail("%s: the camera variant \"none\" has no camera encoder", m->cfg.name);
        return NULL;
    }
    int k[3];
    gv_model_camera_kernel(&m->cfg, k);
    char s[64];
    if (plucker->ndim != 5 || plucker->shape[1] != 6 || plucker->shape[2] % k[0] || plucker->shape[3] % k[1] ||
        plucker->shape[4] % k[2]) {
        gv_fail("camera encoder: the ray field %s is not [B, 6, T, H, W] with T, H, W multiples of the kernel %dx%dx%d",
                gv_shape_str(plucker, s, sizeof s), k[0], k[1], k[2]);
        return NULL;
    }
    gv_conv_geom geom = {{k[0], k[1], k[2]}, {0, 0, 0, 0, 0, 0}};
    gv_tensor *f;
    if (m->cfg.variant.camera == GV_CAMERA_DECOMPOSED) {
        gv_tensor *fm = gv_dit_tokens(g, gv_conv3d(g, gv_slice(g, plucker, 1, 0, 3), e->conv_m_w, e->conv_m_b, &geom));
        gv_tensor *fd = gv_dit_tokens(g, gv_conv3d(g, gv_slice(g, plucker, 1, 3, 3), e->conv_d_w, e->conv_d_b, &geom));
        gv_tensor *gate_m = gv_sigmoid(g, mlp(g, m, &e->gate_d2m0, &e->gate_d2m2, fd)); /* eq. (2) */
        gv_tensor *gate_d = gv_sigmoid(g, mlp(g, m, &e->gate_m2d0, &e->gate_m2d2, fm));
        f = gv_concat(g, (gv_tensor *[]){gv_mul(g, fm, gate_m), gv_mul(g, fd, gate_d)}, 2, 2);
    } else {
        f = gv_dit_tokens(g, gv_conv3d(g, plucker, e->conv_w, e->conv_b, &geom));
        f = gv_add(g, f, mlp(g, m, &e->mlp0, &e->mlp2, f));
    }
    gv_tensor *h = mlp(g, m, &e->proj0, &e->proj2, f); /* eq. (3) */
    return gv_mul(g, gv_layer_norm(g, h, e->norm_w, e->norm_b, CAMERA_NORM_EPS), e->gamma);
}
