/* The camera code of the official GaussVid release, as its classes define it (not on the
 * release's inference path; docs/GAUSSVID_RELEASE.md "The official camera encoder"):
 *
 *   Plücker map: Ks [F, 3, 3] and c2ws [F, 4, 4] (camera-to-world, OpenCV axes); poses made
 *   relative to frame 0 (rel_i = c2w_0^-1 c2w_i, rel_0 the identity exactly); at pixel
 *   centres (i + 0.5, j + 0.5) the camera ray ((i + 0.5 - cx) / fx, (j + 0.5 - cy) / fy, 1)
 *   normalised to unit length, rotated by rel's R into d; o = rel's translation; channels
 *   [o x d, d] -> [F, H, W, 6]. Translations are not rescaled (gaussvid's own field divides
 *   them by a per-clip length: plucker.h).
 *
 *   Packing: [1, 6, F, H, W] with three copies of frame 0 in front -> [1, 6, F + 3, H, W].
 *
 *   PluckerTokenEncoder: kernel = stride = (kt, ks, ks) = (temporal_factor * patch_t,
 *   spatial_factor * patch_h, spatial_factor * patch_w), no padding;
 *     F_m = dxo_patch_embed(P[0:3]),  F_d = d_patch_embed(P[3:6])     [N, hidden], tokens in
 *           (t, h, w) order, w fastest
 *     G_m = F_m * sigmoid(gate_dxo_from_d(F_d)),  G_d = F_d * sigmoid(gate_d_from_dxo(F_m)),
 *           each gate Linear(hidden, bottleneck) - SiLU - Linear(bottleneck, hidden)
 *     Y = out_norm(out_proj([G_m, G_d])),  out_proj = Linear(2 hidden, D) - SiLU - Linear(D, D),
 *           out_norm a LayerNorm (affine, eps 1e-5)
 *     tokens = Y * scale                                                      [1, N, D]
 *   with the official parameter names: dxo_patch_embed.{weight,bias}, d_patch_embed.*,
 *   gate_dxo_from_d.{0,2}.*, gate_d_from_dxo.{0,2}.*, out_proj.{0,2}.*, out_norm.*, scale.
 *   The sizes come from the model config: hidden = camera.channels, bottleneck =
 *   camera.gate_hidden, D = dit.dim (camera.proj_hidden must equal it). */
#ifndef GAUSSVID_PLUCKER_OFFICIAL_H
#define GAUSSVID_PLUCKER_OFFICIAL_H

#include "gaussvid/model/model_config.h"
#include "gaussvid/nn/nn.h"
#include "gaussvid/io/safetensors.h"

/* The map: out [frames, height, width, 6]. Fails on a singular c2w_0 or a zero focal length. */
int gv_official_plucker(const float *Ks, const float *c2ws, int frames, int height, int width, float *out);
/* The packing: plucker [frames, height, width, 6] -> packed [6, frames + 3, height, width]. */
void gv_official_pack(const float *plucker, int frames, int height, int width, float *packed);
/* The encoder on packed [6, tp, height, width] with the official weights in w: tokens [N, D]
 * (N = tp/kt * height/ks * width/ks); fails naming a missing or mis-shaped weight, or sizes
 * the kernel does not divide. */
int gv_official_camera_encode(const gv_model_config *c, const gv_st_file *w, const float *packed, int tp, int height,
                              int width, float *tokens);
/* `gaussvid model run --part camera`: inputs Ks [F, 3, 3] + c2ws [F, 4, 4] + size [2]
 * (height, width), or packed [1, 6, Tp, H, W]; outputs plucker [F, H, W, 6] and packed (when
 * built from cameras) and tokens [1, N, D]. */
int gv_camera_run_named(const gv_model_config *c, const char *const *weights, int n_weights, const gv_st_file *inputs,
                        gv_graph *g, gv_st_builder *out);

#endif
