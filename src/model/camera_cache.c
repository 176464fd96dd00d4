/* The camera stream computed once per clip (docs/ARCHITECTURE.md 6.5): camera tokens are modulated from
 * t = 0 and attend to camera keys only, so nothing in them depends on the noisy latent or on
 * t. Sampling computes them (and every block's camera keys and values) once and passes the
 * cache to each step; the video tokens then attend to the cached keys and values. The values
 * are bit-identical to the ones a forward pass computes itself (tested). */
#include "model/dit_internal.h"
#include "gaussvid/core/core.h"

#include <stdlib.h>
#include <string.h>

void gv_dit_camera_cache_free(gv_dit_camera_cache *c)
{
    gv_graph_free(&c->graph);
    free(c->x);
    free(c->k);
    free(c->v);
    memset(c, 0, sizeof *c);
}

int gv_dit_camera_cache_build(gv_dit *m, gv_tensor *plucker, gv_dit_camera_cache *c)
{
    memset(c, 0, sizeof *c);
    if (!plucker) return gv_fail("camera cache: no ray field");
    gv_graph_init(&c->graph, 0);
    gv_graph_set_grad(&c->graph, 0);
    gv_graph *g = &c->graph;
    c->tokens = gv_camera_encoder_forward(m, g, plucker);
    if (!c->tokens) {
        gv_dit_camera_cache_free(c);
        return gv_fail_context("camera cache");
    }
    int k[3];
    gv_model_camera_kernel(&m->cfg, k);
    c->batch = plucker->shape[0];
    for (int a = 0; a < 3; a++) c->grid[a] = plucker->shape[2 + a] / k[a];
    if (!gv_model_has_camera_stream(&m->cfg)) return 0; /* early fusion: the tokens alone */
    int L = m->cfg.dit.num_layers, n = c->grid[0] * c->grid[1] * c->grid[2];
    c->n_layers = L;
    c->x = calloc((size_t)L, sizeof *c->x);
    c->k = calloc((size_t)L, sizeof *c->k);
    c->v = calloc((size_t)L, sizeof *c->v);
    int *pos = malloc((size_t)n * 3 * sizeof *pos);
    int rc = c->x && c->k && c->v && pos ? 0 : gv_fail("camera cache: out of memory");
    if (rc == 0) {
        gv_dit_camera_positions(c->grid[0], c->grid[1], c->grid[2], pos);
        gv_tensor *rope = gv_rope3d_table(g, pos, n, m->cfg.dit.dim / m->cfg.dit.num_heads);
        rc = rope ? gv_dit_camera_stream(g, m, c->tokens, rope, c->x, c->k, c->v) : -1;
    }
    free(pos);
    if (rc != 0) {
        gv_dit_camera_cache_free(c);
        return gv_fail_context("camera cache");
    }
    return 0;
}
