/* One training sample of either objective (docs/ARCHITECTURE.md 7; paper 3.4, eq. 6-10): the noisy latent
 * and its velocity target, the VACE context the objective allows, the DiT forward pass, the
 * flow-matching loss, the progressive latent loss on x_t - t v, and the backward pass. */
#include <math.h>
#include <string.h>

#include "gaussvid/core/core.h"
#include "gaussvid/train/train.h"

void gv_objective_inputs(const gv_clip_latents *l, gv_objective obj, float t, const float *eps, float *x_t,
                         float *target)
{
    int64_t n = gv_clip_latents_z_count(l);
    gv_flow_noisy(obj == GV_OBJECTIVE_PRETRAIN ? l->z_clean : l->z_corrupt, eps, t, n, x_t);
    gv_flow_target(l->z_clean, eps, n, target);
}

/* Channels [z_dim, 2 z_dim) of the context are the reactive latents (condition.h): the
 * corrupted renders. Without them the model generates the intermediates from the anchors. */
void gv_objective_vace(const gv_clip_latents *l, int renders, float *out)
{
    memcpy(out, l->vace, (size_t)gv_clip_latents_vace_count(l) * sizeof(float));
    if (renders) return;
    int64_t plane = (int64_t)l->latent_frames * l->lh * l->lw;
    for (int b = 0; b < l->batch; b++)
        memset(out + ((int64_t)b * l->vace_dim + l->z_dim) * plane, 0, (size_t)(l->z_dim * plane) * sizeof(float));
}

/* mean |x_t - t v - z0*| over the latent where mask is 1 (everywhere without a mask): the
 * progressive loss's value, also shown when its weight is 0. */
static double latent_l1(const float *x_t, const float *v, const float *z0, const float *mask, float t, int64_t n)
{
    double sum = 0, count = 0;
    for (int64_t i = 0; i < n; i++)
        if (!mask || mask[i] != 0) sum += fabsf(x_t[i] - t * v[i] - z0[i]), count++;
    return count ? sum / count : 0;
}

/* Frames without ground truth (the clip's target_mask, docs/TRAINING.md "Frames without
 * ground truth"): a 0/1 tensor of the latent's shape, 0 on the latent frames that have none,
 * and the share of the latent it keeps. NULL (share 1) when every frame has ground truth, so
 * such clips take exactly the computation they always did. */
static gv_tensor *target_mask(gv_graph *g, const gv_clip_latents *l, const int shape[5], double *share)
{
    *share = 1.0;
    if (!gv_clip_latents_masked(l)) return NULL;
    gv_tensor *m = gv_tensor_new(g, 5, shape);
    if (!m) return NULL;
    const int64_t plane = (int64_t)l->lh * l->lw;
    int64_t kept = 0, i = 0;
    for (int b = 0; b < l->batch; b++)
        for (int c = 0; c < l->z_dim; c++)
            for (int t = 0; t < l->latent_frames; t++, i += plane) {
                float keep = l->no_target[b * l->latent_frames + t] ? 0.0f : 1.0f;
                for (int64_t k = 0; k < plane; k++) m->data[i + k] = keep;
                kept += keep != 0.0f ? plane : 0;
            }
    *share = (double)kept / (double)m->numel;
    if (kept == 0) {
        gv_fail("clip n%d: no latent frame has ground truth", l->interval);
        return NULL;
    }
    return m;
}

/* The mean squared (or absolute) error over the latent frames with ground truth: pred and
 * target are multiplied by the mask, so a masked frame adds nothing to the loss or to the
 * gradient, whatever its target holds, and the mean is taken over the frames kept. */
static gv_tensor *masked_loss(gv_graph *g, gv_tensor *pred, gv_tensor *target, gv_tensor *mask, double share,
                              int squared)
{
    if (mask) pred = gv_mul(g, pred, mask), target = gv_mul(g, target, mask);
    gv_tensor *loss = squared ? gv_l2_loss(g, pred, target, NULL) : gv_l1_loss(g, pred, target, NULL);
    return mask ? gv_scale(g, loss, (float)(1.0 / share)) : loss;
}

/* The network's inputs besides the latent (NULL where the config has no such part). */
static int side_inputs(gv_dit *m, gv_graph *g, const gv_clip_latents *l, int renders, gv_dit_inputs *in)
{
    const gv_model_config *c = &m->cfg;
    int B = l->batch, T = l->latent_frames;
    if (c->dit.n_vace_layers > 0) {
        if (l->vace_dim != c->dit.vace_in_dim)
            return gv_fail("clip n%d: VACE context of %d channels, the model takes %d", l->interval, l->vace_dim, c->dit.vace_in_dim);
        in->vace = gv_tensor_new(g, 5, (int[]){B, l->vace_dim, T, l->lh, l->lw});
        if (!in->vace) return -1;
        gv_objective_vace(l, renders, in->vace->data);
    }
    if (c->dit.cross_attn && !(in->text = gv_dit_text_input(m, g, B))) return -1; /* the prompt's, or zeros */
    if (c->variant.camera != GV_CAMERA_NONE) {
        if (!l->plucker) return gv_fail("clip n%d: no Plücker field (prepared without cameras)", l->interval);
        in->plucker = gv_tensor_from(g, 5, (int[]){B, 6, l->plucker_frames, l->height, l->width}, l->plucker);
        if (!in->plucker) return -1;
    }
    return 0;
}

int gv_train_sample(gv_dit *m, gv_graph *g, const gv_clip_latents *l, gv_objective obj, const gv_sample_draw *d,
                    const float *eps, double scale, int backward, gv_sample_losses *out)
{
    const int B = l->batch, shape[5] = {B, l->z_dim, l->latent_frames, l->lh, l->lw};
    float timestep[GV_CLIP_FRAMES];
    if (B < 1 || B > GV_CLIP_FRAMES) return gv_fail("clip n%d: batch %d of latents", l->interval, B);
    if (l->z_dim != m->cfg.dit.in_dim) return gv_fail("clip n%d: latents of %d channels, the model takes %d", l->interval, l->z_dim, m->cfg.dit.in_dim);
    /* t = 1000 sigma (docs/reference/wan-vace-gaussvid.md 2.3) */
    for (int b = 0; b < B; b++) timestep[b] = 1000.0f * d->t;
    gv_graph_reset(g);
    int was = gv_graph_set_grad(g, backward);
    gv_dit_inputs in = gv_dit_inputs_default();
    gv_tensor *x_t = gv_tensor_new(g, 5, shape), *target = gv_tensor_new(g, 5, shape);
    int rc = x_t && target ? side_inputs(m, g, l, obj == GV_OBJECTIVE_FINETUNE || d->renders, &in) : -1;
    gv_tensor *v = NULL, *loss = NULL, *fm = NULL, *mask = NULL;
    double share = 1.0;
    if (rc == 0 && gv_clip_latents_masked(l) && !(mask = target_mask(g, l, shape, &share))) rc = gv_fail_context("clip n%d", l->interval);
    if (rc == 0) {
        gv_objective_inputs(l, obj, d->t, eps, x_t->data, target->data);
        in.latent = x_t;
        in.timestep = timestep;
        v = gv_dit_forward(m, g, &in);
        if (v && obj == GV_OBJECTIVE_FINETUNE && m->cfg.variant.skip) { /* v = S + t F (train.h) */
            gv_tensor *skip = gv_tensor_new(g, 5, shape);
            if (skip) gv_flow_skip_from_noise(l->z_corrupt, eps, d->t, skip->numel, skip->data);
            v = skip ? gv_add(g, skip, gv_scale(g, v, d->t)) : NULL;
        } else if (v && obj == GV_OBJECTIVE_FINETUNE && m->cfg.variant.residual) { /* v = R - F (train.h) */
            gv_tensor *known = gv_tensor_new(g, 5, shape);
            if (known) gv_flow_residual_from_noise(l->z_corrupt, eps, known->numel, known->data);
            v = known ? gv_sub(g, known, v) : NULL;
        }
        fm = masked_loss(g, v, target, mask, share, 1); /* paper eq. 7 as a mean over the latent */
        loss = gv_scale(g, fm, (float)(scale * d->w_cur * d->w_t));
        if (d->w_lat > 0) { /* paper eq. 8: L1(x_t - t v, z0*) */
            gv_tensor *z0 = gv_tensor_from(g, 5, shape, l->z_clean);
            gv_tensor *lat = masked_loss(g, gv_sub(g, x_t, gv_scale(g, v, d->t)), z0, mask, share, 0);
            loss = gv_add(g, loss, gv_scale(g, lat, (float)(scale * d->w_cur * d->w_lat)));
        }
        if (!loss) rc = gv_fail_context("clip n%d", l->interval);
    }
    if (rc == 0 && backward) rc = gv_backward(g, loss);
    if (rc == 0 && out) {
        out->fm = fm->data[0];
        out->latent = latent_l1(x_t->data, v->data, l->z_clean, mask ? mask->data : NULL, d->t, x_t->numel);
        out->loss = d->w_cur * (d->w_t * out->fm + d->w_lat * out->latent);
    }
    gv_graph_set_grad(g, was);
    return rc;
}
