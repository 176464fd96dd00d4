/* The DiT forward pass (docs/reference/wan-vace-gaussvid.md 2.2-2.7, 3.2; paper 3.3;
 * docs/ARCHITECTURE.md 6.3-6.6): patch embedding, time and text embeddings, the camera tokens of
 * the chosen variant, VACE hints, the main blocks, the head and unpatchify. */
#include "model/dit_internal.h"
#include "gaussvid/core/core.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

int gv_dit_init(gv_dit *m, const gv_model_config *cfg, uint64_t seed)
{
    return gv_dit_init_parts(m, cfg, seed, 0);
}

int gv_dit_init_parts(gv_dit *m, const gv_model_config *cfg, uint64_t seed, unsigned loaded_parts)
{
    memset(m, 0, sizeof *m);
    m->cfg = *cfg;
    gv_params_init(&m->params);
    if (gv_weight_list_build(&m->weights, cfg) != 0) return -1;
    m->blocks = calloc((size_t)cfg->dit.num_layers, sizeof *m->blocks);
    m->vace_blocks = calloc((size_t)cfg->dit.n_vace_layers + 1, sizeof *m->vace_blocks);
    m->lora_scale = cfg->lora.rank > 0 ? (float)(cfg->lora.alpha / cfg->lora.rank) : 0.0f;
    int rc = m->blocks && m->vace_blocks ? 0 : gv_fail("%s: out of memory for the blocks", cfg->name);
    if (rc == 0) rc = gv_dit_bind(m, cfg, &m->weights, &m->params, loaded_parts);
    if (rc == 0) rc = gv_dit_init_values(m, seed);
    if (rc != 0) gv_dit_free(m);
    return rc;
}

void gv_dit_free(gv_dit *m)
{
    gv_params_free(&m->params);
    for (int i = 0; i < m->n_mapped; i++) gv_st_close(&m->mapped[i]); /* after the weights pointing into them */
    free(m->mapped);
    free(m->text);
    gv_weight_list_free(&m->weights);
    free(m->blocks);
    free(m->vace_blocks);
    memset(m, 0, sizeof *m);
}

gv_dit_inputs gv_dit_inputs_default(void)
{
    gv_dit_inputs in;
    memset(&in, 0, sizeof in);
    in.context_scale = 1.0f;
    return in;
}

void gv_dit_video_positions(int frames, int rows, int cols, int *pos)
{
    for (int f = 0, n = 0; f < frames; f++) /* token order: frame-major, then row, then column */
        for (int y = 0; y < rows; y++)
            for (int x = 0; x < cols; x++, n++) pos[3 * n] = f, pos[3 * n + 1] = y, pos[3 * n + 2] = x;
}

void gv_dit_camera_positions(int frames, int rows, int cols, int *pos)
{
    /* The camera encoder's output grid is the video token grid, in the same order: camera
     * token i sits where video token i does (docs/ARCHITECTURE.md 6.5). */
    gv_dit_video_positions(frames, rows, cols, pos);
}

/* Timesteps rounded at once for the release's time embedding. */
enum { TIME_MAX_BATCH = 64 };

int gv_dit_time(gv_graph *g, const gv_dit *m, const float *t, int batch, int bf16_time, gv_tensor **e, gv_tensor **e0)
{
    int D = m->cfg.dit.dim;
    float rounded[TIME_MAX_BATCH];
    if (bf16_time && batch > TIME_MAX_BATCH) return gv_fail("dit: batch %d above %d", batch, TIME_MAX_BATCH);
    for (int b = 0; bf16_time && b < batch; b++) rounded[b] = gv_bf16_to_f32(gv_f32_to_bf16(t[b]));
    gv_tensor *s = gv_timestep_embedding(g, bf16_time ? rounded : t, batch, m->cfg.dit.freq_dim);
    for (int64_t k = 0; bf16_time && s && k < s->numel; k++) s->data[k] = gv_bf16_to_f32(gv_f32_to_bf16(s->data[k]));
    *e = gv_dit_lin(g, m, &m->time2, gv_silu(g, gv_dit_lin(g, m, &m->time0, s)));
    *e0 = gv_reshape(g, gv_dit_lin(g, m, &m->time_proj, gv_silu(g, *e)), 3, (int[]){batch, 6, D});
    return *e0 ? 0 : -1;
}

/* Shapes of the inputs against the config; grid[] receives the token grid. */
static int check_inputs(const gv_dit *m, const gv_dit_inputs *in, int grid[3])
{
    const gv_dit_config *d = &m->cfg.dit;
    const gv_tensor *x = in->latent;
    char s[64];
    if (!x || !in->timestep) return gv_fail("dit: the latent and the timestep are required");
    if (x->ndim != 5 || x->shape[1] != d->in_dim)
        return gv_fail("dit: latent %s is not [B, %d, T, H, W]", gv_shape_str(x, s, sizeof s), d->in_dim);
    for (int a = 0; a < 3; a++) {
        if (x->shape[2 + a] % d->patch_size[a])
            return gv_fail("dit: latent %s is not a multiple of the patch %dx%dx%d", gv_shape_str(x, s, sizeof s),
                           d->patch_size[0], d->patch_size[1], d->patch_size[2]);
        grid[a] = x->shape[2 + a] / d->patch_size[a];
    }
    if (m->cfg.variant.per_frame && x->shape[2] != 1) /* docs/ARCHITECTURE.md 6.6: no temporal attention */
        return gv_fail("dit: the per-frame restorer takes single-frame latents (frames as the batch), got %d frames",
                       x->shape[2]);
    int B = x->shape[0];
    if (d->cross_attn && !in->text) return gv_fail("dit: %s needs the text context (cross-attention)", m->cfg.name);
    if (in->text && (!d->cross_attn || in->text->ndim != 3 || in->text->shape[0] != B || in->text->shape[2] != d->text_dim))
        return gv_fail("dit: text context %s is not [%d, L, %d]%s", gv_shape_str(in->text, s, sizeof s), B, d->text_dim,
                       d->cross_attn ? "" : " (and the config has no cross-attention)");
    if (in->vace) {
        const gv_tensor *v = in->vace;
        if (d->n_vace_layers == 0) return gv_fail("dit: %s has no VACE branch for the VACE context", m->cfg.name);
        if (v->ndim != 5 || v->shape[0] != B || v->shape[1] != d->vace_in_dim ||
            memcmp(v->shape + 2, x->shape + 2, 3 * sizeof(int)))
            return gv_fail("dit: VACE context %s is not [%d, %d, %d, %d, %d]", gv_shape_str(v, s, sizeof s), B,
                           d->vace_in_dim, x->shape[2], x->shape[3], x->shape[4]);
    }
    if ((in->plucker || in->camera_cache) && m->cfg.variant.camera == GV_CAMERA_NONE)
        return gv_fail("dit: the camera variant \"none\" takes no cameras");
    const gv_dit_camera_cache *c = in->camera_cache;
    if (c && (c->batch != B || memcmp(c->grid, grid, sizeof c->grid)))
        return gv_fail("dit: the camera cache (batch %d, grid %dx%dx%d) does not fit the latent (batch %d, grid %dx%dx%d)",
                       c->batch, c->grid[0], c->grid[1], c->grid[2], B, grid[0], grid[1], grid[2]);
    if (c && gv_model_has_camera_stream(&m->cfg) && c->n_layers != d->num_layers)
        return gv_fail("dit: the camera cache holds %d blocks, %s has %d (a cache of another model)", c->n_layers,
                       m->cfg.name, d->num_layers);
    if (in->plucker && !c) {
        int k[3];
        gv_model_camera_kernel(&m->cfg, k);
        const gv_tensor *p = in->plucker;
        int ok = p->ndim == 5 && p->shape[0] == B;
        for (int a = 0; ok && a < 3; a++) ok = p->shape[2 + a] == grid[a] * k[a];
        if (!ok)
            return gv_fail("dit: ray field %s is not [%d, 6, %d, %d, %d] (one camera token per video token)",
                           gv_shape_str(p, s, sizeof s), B, grid[0] * k[0], grid[1] * k[1], grid[2] * k[2]);
    }
    return 0;
}

/* y [B, N, P C] in (dt, dy, dx, c) order, c fastest -> [B, C, T, H, W]
 * (docs/reference/wan-vace-gaussvid.md 2.7). */
static gv_tensor *unpatchify(gv_graph *g, const gv_dit *m, gv_tensor *y, const int grid[3])
{
    const int *p = m->cfg.dit.patch_size;
    int B = gv_dim(y, 0), N = gv_dim(y, 1), C = m->cfg.dit.out_dim, P = p[0] * p[1] * p[2];
    gv_tensor *t = gv_permute(g, gv_reshape(g, y, 4, (int[]){B, N, P, C}), (int[]){0, 3, 2, 1}); /* [B, C, P, N] */
    t = gv_reshape(g, t, 5, (int[]){B, C * P, grid[0], grid[1], grid[2]});
    return gv_pixel_shuffle(g, t, p[0], p[1], p[2]);
}

/* Head (docs/reference/wan-vace-gaussvid.md 2.7): modulation [1, 2, D] + e (not e0), shift then
 * scale. */
static gv_tensor *head(gv_graph *g, const gv_dit *m, gv_tensor *x, gv_tensor *e, const int grid[3])
{
    int B = gv_dim(x, 0), D = m->cfg.dit.dim;
    gv_tensor *mod = gv_add(g, m->head_modulation, gv_reshape(g, e, 3, (int[]){B, 1, D}));
    gv_tensor *y = gv_dit_lin(g, m, &m->head, gv_dit_modulate(g, x, mod, 0, (float)m->cfg.dit.eps));
    return y ? unpatchify(g, m, y, grid) : NULL;
}

/* The camera stream's per-block keys and values, from the cache or computed here. */
static int camera_stream(gv_graph *g, gv_dit *m, const gv_dit_inputs *in, gv_tensor *xc, gv_tensor *rope_c,
                         gv_tensor **xs, gv_tensor **ks, gv_tensor **vs)
{
    int L = m->cfg.dit.num_layers;
    const gv_dit_camera_cache *c = in->camera_cache;
    if (c) {
        for (int i = 0; i < L; i++) xs[i] = c->x[i], ks[i] = c->k[i], vs[i] = c->v[i];
        return 0;
    }
    return gv_dit_camera_stream(g, m, xc, rope_c, xs, ks, vs);
}

int gv_dit_keep_only(gv_graph *g, gv_arena_mark mark, gv_tensor **keep, int n)
{
    if (g->grad_enabled) return 0;
    float *saved[4];
    gv_tensor copy[4];
    if (n > 4) return gv_fail("dit: keep_only takes at most 4 tensors");
    for (int i = 0; i < n; i++) {
        copy[i] = *keep[i];
        if (!(saved[i] = malloc((size_t)keep[i]->numel * sizeof(float)))) {
            while (i--) free(saved[i]);
            return gv_fail("dit: out of memory for %lld values", (long long)keep[i]->numel);
        }
        memcpy(saved[i], keep[i]->data, (size_t)keep[i]->numel * sizeof(float));
    }
    gv_arena_rewind(&g->arena, mark);
    int rc = 0;
    for (int i = 0; i < n; i++) {
        if (rc == 0 && !(keep[i] = gv_tensor_new(g, copy[i].ndim, copy[i].shape))) rc = -1;
        if (rc == 0) memcpy(keep[i]->data, saved[i], (size_t)copy[i].numel * sizeof(float));
        free(saved[i]);
    }
    return rc;
}

/* Tables of the video tokens and of their camera tokens. */
static int rope_tables(gv_graph *g, const gv_dit *m, const int grid[3], gv_tensor **video, gv_tensor **camera)
{
    int n = grid[0] * grid[1] * grid[2], hd = m->cfg.dit.dim / m->cfg.dit.num_heads;
    int *pos = malloc((size_t)n * 3 * sizeof *pos);
    if (!pos) return gv_fail("dit: out of memory for %d token positions", n);
    gv_dit_video_positions(grid[0], grid[1], grid[2], pos);
    *video = gv_rope3d_table(g, pos, n, hd);
    gv_dit_camera_positions(grid[0], grid[1], grid[2], pos);
    if (camera) *camera = gv_rope3d_table(g, pos, n, hd);
    free(pos);
    return *video && (!camera || *camera) ? 0 : -1;
}

/* The asymmetric mask of paper eq. (4) over [video (nv); camera (nc)]. */
static gv_tensor *joint_mask(gv_graph *g, int nv, int nc)
{
    int n = nv + nc;
    gv_tensor *mask = gv_tensor_new(g, 2, (int[]){n, n});
    for (int i = nv; mask && i < n; i++)
        for (int j = 0; j < nv; j++) mask->data[(int64_t)i * n + j] = -INFINITY;
    return mask;
}

gv_tensor *gv_dit_forward(gv_dit *m, gv_graph *g, const gv_dit_inputs *in)
{
    int grid[3];
    if (check_inputs(m, in, grid) != 0) return NULL;
    const gv_dit_config *d = &m->cfg.dit;
    const int B = in->latent->shape[0], L = d->num_layers, N = grid[0] * grid[1] * grid[2];
    gv_dit_trace local, *tr = in->trace ? in->trace : &local;
    memset(tr, 0, sizeof *tr);
    gv_conv_geom geom = {{d->patch_size[0], d->patch_size[1], d->patch_size[2]}, {0, 0, 0, 0, 0, 0}};
    gv_tensor *x = gv_dit_tokens(g, gv_conv3d(g, in->latent, m->patch_w, m->patch_b, &geom)), *e, *e0;
    if (gv_dit_time(g, m, in->timestep, B, in->bf16_time, &e, &e0) != 0) return NULL;
    gv_tensor *ctx = in->text ? gv_dit_lin(g, m, &m->text2, gv_gelu(g, gv_dit_lin(g, m, &m->text0, in->text))) : NULL;
    const int cameras = in->plucker || in->camera_cache, stream = cameras && gv_model_has_camera_stream(&m->cfg);
    gv_tensor *rope = NULL, *rope_c = NULL, *xc = NULL;
    if (rope_tables(g, m, grid, &rope, stream ? &rope_c : NULL) != 0) return NULL;
    tr->rope_video = rope;
    tr->rope_camera = rope_c;
    if (cameras) {
        xc = tr->camera_tokens = in->camera_cache ? in->camera_cache->tokens : gv_camera_encoder_forward(m, g, in->plucker);
        if (!xc) return NULL;
        /* early fusion: added to the video tokens once (docs/ARCHITECTURE.md 6.6) */
        if (!stream) x = gv_add(g, x, xc);
    }
    if (in->vace && gv_vace_hints(g, m, in, x, e0, rope, ctx, tr->hints) != 0) return NULL;
    const int done0 = in->vace ? d->n_vace_layers : 0;
    const int joint = stream && m->joint_attention && !in->camera_cache;
    if (stream && !joint && camera_stream(g, m, in, xc, rope_c, tr->camera_x, tr->camera_k, tr->camera_v) != 0) return NULL;
    gv_tensor *rope2 = NULL, *mask = NULL, *e0c = NULL;
    if (joint) {
        rope2 = gv_concat(g, (gv_tensor *[]){rope, rope_c}, 2, 0);
        mask = joint_mask(g, N, N);
        e0c = gv_dit_camera_e0(g, m);
    }
    for (int i = 0, h = 0; i < L; i++) {
        gv_arena_mark mark = gv_arena_get_mark(&g->arena);
        if (joint) {
            if (gv_dit_block_joint(g, m, &m->blocks[i], &x, &xc, e0, e0c, rope2, mask, ctx) != 0) return NULL;
            tr->camera_x[i] = xc;
        } else {
            x = gv_dit_block_video(g, m, &m->blocks[i], x, e0, rope, ctx, tr->camera_k[i], tr->camera_v[i]);
        }
        /* VACE hints join after their block (docs/reference/wan-vace-gaussvid.md 3.2) */
        if (in->vace && h < d->n_vace_layers && d->vace_layers[h] == i) {
            gv_tensor *hint = tr->hints[h++];
            x = gv_add(g, x, in->context_scale == 1.0f ? hint : gv_scale(g, hint, in->context_scale));
        }
        /* inference: drop the block's activations (the trace keeps only what was made before) */
        if (!x || (!joint && !in->trace && gv_dit_keep_only(g, mark, &x, 1) != 0)) return NULL;
        if (in->progress) in->progress(in->progress_ctx, done0 + i + 1, done0 + L);
    }
    return head(g, m, x, e, grid);
}
