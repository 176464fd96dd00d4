/* The VAE's inference speed on one clip (issue 5 "Performance"): encoding chunked as Wan does
 * (the first frame alone, then groups of the temporal factor through the causal caches) and
 * decoding one latent frame at a time, with the arena peak of the largest chunk. The weights
 * are random: the time does not depend on their values. */
#include <stdlib.h>
#include <time.h>

#include "bench/bench_model.h"
#include "gaussvid/core/core.h"
#include "gaussvid/model/vae.h"

static double cpu_seconds(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &ts);
    return ts.tv_sec + 1e-9 * ts.tv_nsec;
}

/* One chunked pass, encode or decode (the latent is random: only the time matters); returns
 * the wall time, *cpu the process CPU time. */
static double chunked_pass(gv_vae *v, gv_graph *g, int decode, gv_tensor *video, gv_tensor *latent, size_t *peak,
                           double *cpu)
{
    gv_vae_stream s;
    const gv_vae_coder *coder = decode ? &v->decoder : &v->encoder;
    if (gv_vae_stream_init(&s, coder->n_slots) != 0) return -1;
    int T = video->shape[2], H = video->shape[3], W = video->shape[4], z = v->cfg.z_dim, r = v->cfg.temporal_factor;
    int Tl = latent->shape[2], h = latent->shape[3], w = latent->shape[4];
    double t0 = gv_now(), c0 = cpu_seconds();
    int rc = 0;
    for (int i = 0; rc == 0 && i < (decode ? Tl : T);) {
        int n = decode ? 1 : i == 0 ? 1 : r;
        gv_graph_reset(g);
        gv_arena_reset_peak(&g->arena);
        const int shape[5] = {1, decode ? z : 3, n, decode ? h : H, decode ? w : W};
        gv_tensor *x = gv_tensor_new(g, 5, shape);
        const gv_tensor *src = decode ? latent : video;
        int64_t plane = (int64_t)shape[3] * shape[4];
        for (int c = 0; x && c < shape[1]; c++)
            for (int k = 0; k < n; k++)
                for (int64_t p = 0; p < plane; p++)
                    x->data[((int64_t)c * n + k) * plane + p] = src->data[((int64_t)c * src->shape[2] + i + k) * plane + p];
        gv_tensor *y = !x ? NULL : decode ? gv_vae_decoder_forward(g, v, x, &s) : gv_vae_encoder_forward(g, v, x, &s);
        if (!y) rc = -1;
        if (g->arena.peak > *peak) *peak = g->arena.peak;
        i += n;
    }
    double t = gv_now() - t0;
    *cpu = cpu_seconds() - c0;
    gv_vae_stream_free(&s);
    return rc == 0 ? t : -1;
}

int gv_bench_model_vae(const gv_model_config *c, int frames, int height, int width, int trials, gv_bench_vae_result *r)
{
    int tl, sf = c->vae.spatial_factor;
    if (gv_vae_check_clip(&c->vae, frames, height, width) || gv_vae_latent_frames(&c->vae, frames, &tl))
        return gv_fail_context("bench model: %s VAE", c->name);
    gv_vae v;
    if (gv_vae_init(&v, c, 0, 1) != 0) return -1;
    gv_graph inputs, g;
    gv_graph_init(&inputs, 0);
    gv_graph_init(&g, 0);
    gv_graph_set_grad(&g, 0);
    gv_tensor *video = gv_tensor_new(&inputs, 5, (int[]){1, 3, frames, height, width});
    gv_tensor *latent = gv_tensor_new(&inputs, 5, (int[]){1, c->vae.z_dim, tl, height / sf, width / sf});
    int rc = video && latent ? 0 : -1;
    if (rc == 0) {
        gv_fill_uniform(video->data, video->numel, 7, 0, -1.0f, 1.0f);
        gv_fill_normal(latent->data, latent->numel, 8, 0, 0.0f, 1.0f);
    }
    size_t enc_peak = 0, dec_peak = 0;
    r->encode_s = r->decode_s = r->encode_cpu_s = r->decode_cpu_s = 1e30;
    for (int i = 0; rc == 0 && i <= trials; i++) { /* trial 0 warms up */
        double ce = 0, cd = 0;
        double te = chunked_pass(&v, &g, 0, video, latent, &enc_peak, &ce);
        double td = te < 0 ? -1 : chunked_pass(&v, &g, 1, video, latent, &dec_peak, &cd);
        if (te < 0 || td < 0) rc = -1;
        else if (i > 0 || trials == 0) {
            if (te < r->encode_s) r->encode_s = te;
            if (td < r->decode_s) r->decode_s = td;
            if (ce < r->encode_cpu_s) r->encode_cpu_s = ce;
            if (cd < r->decode_cpu_s) r->decode_cpu_s = cd;
        }
    }
    r->encode_peak_mib = enc_peak / 1048576.0;
    r->decode_peak_mib = dec_peak / 1048576.0;
    r->params = gv_params_count(&v.params, 0);
    r->weights_mib = 4.0 * (double)r->params / 1048576.0;
    gv_graph_free(&g);
    gv_graph_free(&inputs);
    gv_vae_free(&v);
    return rc;
}
