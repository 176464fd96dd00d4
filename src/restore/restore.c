/* The network's velocity on one clip for the samplers: the clip's VACE context, its camera
 * stream computed once (docs/ARCHITECTURE.md 6.5: it depends neither on x_t nor on t) and, for configs with
 * cross-attention, the model's text context (the prompt's, or zeros: gv_dit_text_input); and
 * the restored latent of a clip. */
#include <stdlib.h>
#include <string.h>

#include "gaussvid/core/core.h"
#include "gaussvid/restore/restore.h"
#include "gaussvid/train/train.h"

uint64_t gv_restore_clip_seed(uint64_t seed, const char *clip_name)
{
    return gv_seed_for_name(seed, clip_name);
}

int gv_restore_net_init(gv_restore_net *r, gv_dit *m, const gv_clip_latents *l, int use_camera_cache)
{
    memset(r, 0, sizeof *r);
    r->model = m, r->clip = l;
    gv_graph_init(&r->graph, 0);
    gv_graph_set_grad(&r->graph, 0);
    const gv_dit_config *d = &m->cfg.dit;
    if (d->in_dim != l->z_dim || d->vace_in_dim != l->vace_dim)
        return gv_fail("restore: the clip's latents (%d channels, context %d) do not fit %s (%d, %d)", l->z_dim,
                       l->vace_dim, m->cfg.name, d->in_dim, d->vace_in_dim);
    int camera = m->cfg.variant.camera != GV_CAMERA_NONE;
    if (camera && !l->plucker) return gv_fail("restore: %s needs the clip's Plücker field", m->cfg.name);
    if (camera && use_camera_cache) {
        gv_graph g;
        gv_graph_init(&g, 0);
        gv_graph_set_grad(&g, 0);
        int shape[5] = {l->batch, 6, l->plucker_frames, l->height, l->width};
        gv_tensor *p = gv_tensor_from(&g, 5, shape, l->plucker);
        int rc = p ? gv_dit_camera_cache_build(m, p, &r->cache) : -1;
        gv_graph_free(&g);
        if (rc) return -1;
        r->has_cache = 1;
    }
    return 0;
}

void gv_restore_net_free(gv_restore_net *r)
{
    if (r->has_cache) gv_dit_camera_cache_free(&r->cache);
    gv_graph_free(&r->graph);
    memset(r, 0, sizeof *r);
}

int gv_restore_net_velocity(void *ctx, const float *x, double sigma, float *v)
{
    gv_restore_net *r = ctx;
    const gv_clip_latents *l = r->clip;
    const gv_dit_config *d = &r->model->cfg.dit;
    gv_graph *g = &r->graph;
    gv_graph_reset(g);
    int zs[5] = {l->batch, l->z_dim, l->latent_frames, l->lh, l->lw};
    int vs[5] = {l->batch, l->vace_dim, l->latent_frames, l->lh, l->lw};
    float timestep[8];
    if (l->batch > 8) return gv_fail("restore: batch %d above 8", l->batch);
    /* t = 1000 sigma (docs/reference/wan-vace-gaussvid.md 2.3) */
    for (int b = 0; b < l->batch; b++) timestep[b] = 1000.0f * (float)sigma;
    gv_dit_inputs in = gv_dit_inputs_default();
    in.latent = gv_tensor_from(g, 5, zs, x);
    in.timestep = timestep;
    in.bf16_time = r->bf16_time;
    in.vace = d->n_vace_layers ? gv_tensor_from(g, 5, vs, l->vace) : NULL;
    if (d->cross_attn && !(in.text = gv_dit_text_input(r->model, g, l->batch))) return -1;
    if (r->has_cache) {
        in.camera_cache = &r->cache;
    } else if (r->model->cfg.variant.camera != GV_CAMERA_NONE) {
        int ps[5] = {l->batch, 6, l->plucker_frames, l->height, l->width};
        in.plucker = gv_tensor_from(g, 5, ps, l->plucker);
    }
    gv_tensor *y = gv_dit_forward(r->model, g, &in);
    if (!y) return -1;
    if (y->numel != gv_clip_latents_z_count(l))
        return gv_fail("restore: the network returned %lld values for a latent of %lld", (long long)y->numel,
                       (long long)gv_clip_latents_z_count(l));
    if (r->model->cfg.variant.skip) { /* v = S + sigma F (train.h), as in fine-tuning */
        gv_flow_skip_from_x(l->z_corrupt, x, sigma, y->numel, v);
        for (int64_t i = 0; i < y->numel; i++) v[i] += (float)sigma * y->data[i];
    } else if (r->model->cfg.variant.residual) { /* v = R - F (train.h), as in fine-tuning */
        gv_flow_residual_from_x(l->z_corrupt, x, sigma, y->numel, v);
        for (int64_t i = 0; i < y->numel; i++) v[i] -= y->data[i];
    } else {
        memcpy(v, y->data, (size_t)y->numel * sizeof *v);
    }
    r->evaluations++;
    return 0;
}

int gv_restore_latent(gv_dit *m, const gv_clip_latents *l, const gv_sampler *s, uint64_t clip_seed, float *z_out)
{
    return gv_restore_latent_with(m, l, s, clip_seed, gv_restore_net_velocity, z_out);
}

int gv_restore_latent_with(gv_dit *m, const gv_clip_latents *l, const gv_sampler *s, uint64_t clip_seed,
                           gv_velocity_fn velocity, float *z_out)
{
    if (gv_sampler_check(s)) return -1;
    if (s->kind == GV_SAMPLER_IDENTITY) {
        memcpy(z_out, l->z_corrupt, (size_t)gv_clip_latents_z_count(l) * sizeof *z_out);
        return 0;
    }
    gv_restore_net net;
    int rc = gv_restore_net_init(&net, m, l, 1);
    net.bf16_time = s->release;
    if (rc == 0) rc = gv_sample(s, velocity, &net, l->z_corrupt, gv_clip_latents_z_count(l), clip_seed, z_out);
    gv_restore_net_free(&net);
    return rc;
}
