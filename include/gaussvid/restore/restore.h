/* Restoration of a clip's intermediate frames with a trained network, and its evaluation
 * (paper 3.4, 4; docs/ARCHITECTURE.md 7 "note on inference", 9; docs/RESTORATION.md).
 *
 * The network was trained on x_t = (1 - t) z-hat + t eps with target v = eps - z0*, so for an
 * exact network eps - v(x_t) = z0* while x_t - t v = (1 - t) z-hat + t z0*. The samplers:
 *   onestep   z = eps - v((1 - t0) z-hat + t0 eps, t0)                        (1 evaluation)
 *             or, with blend b < 1, z = z-hat + b (eps - v - z-hat): the correction shrunk
 *             toward the input, for a network whose estimate is still poor
 *   iterate   the one-step restoration repeated on its own output at the decreasing times
 *             sigma_0 = t0 > sigma_1 > ... > sigma_{steps-1} (fresh noise each time)
 *   euler     the reference's ODE sampler: x = (1 - t0) z-hat + t0 eps, then
 *             x += v(x, sigma_k) (sigma_{k+1} - sigma_k) down to sigma_steps = 0
 *             (docs/reference/wan-vace-gaussvid.md 5.3)
 *   identity  z = z-hat (the network is not run: the baseline through the same pipeline)
 * "released" is euler as the authors' inference runs it: strength 0.2, shift 5, 10 steps, so
 * t0 = 0.5556 (docs/reference/wan-vace-gaussvid.md 1.2, 5.4), on their float32 sigma table with
 * the DiT's time embedding of bf16 timesteps, and (in restore and eval) their tiled VAE and
 * truncating 8-bit output (docs/GAUSSVID_RELEASE.md). Time grids:
 * sigma_k = shift(u (1 - k / steps)) with u the unshifted start, shift(u) = t0. Every
 * evaluation of onestep and iterate averages `samples` noise draws. The noise of step k,
 * draw j is N(0, 1) at Philox position (k samples + j) n of the clip's stream
 * gv_restore_clip_seed(seed, clip name), so results are reproducible.
 *
 * Composition of the restored clip (8-bit frames): the anchors are the input's; the three
 * intermediates are either the decoded restored latent (decoded) or render + D(z) - D(z-hat)
 * (residual: the VAE's own reconstruction error cancels where the restorer changes nothing;
 * with z = z-hat it gives the render exactly), or residual only on the pixels no anchor sees
 * and the render elsewhere (unseen: needs the clip's coverage plane; the restorer completes
 * what the anchors cannot show and leaves alone what they confirm). */
#ifndef GAUSSVID_RESTORE_H
#define GAUSSVID_RESTORE_H

#include <stdint.h>
#include <stdio.h>

#include "gaussvid/train/checkpoint.h"
#include "gaussvid/train/condition.h"
#include "gaussvid/data/dataset.h"
#include "gaussvid/model/dit.h"
#include "gaussvid/model/vae.h"

/* ---- samplers (sampler.c) ---------------------------------------------------------------- */
typedef enum { GV_SAMPLER_ONESTEP, GV_SAMPLER_ITERATE, GV_SAMPLER_EULER, GV_SAMPLER_IDENTITY } gv_sampler_kind;

#define GV_SAMPLER_MAX_STEPS 1000

typedef struct {
    gv_sampler_kind kind;
    double t0;       /* the first time the network sees, in (0, 1) */
    int steps;       /* network evaluations in time (onestep: 1) */
    double shift;    /* the time grid's shift (>= 1; 1 = a uniform grid) */
    int samples;     /* noise draws averaged per evaluation (onestep, iterate; euler: 1) */
    double blend;    /* fraction of each step's correction applied, in (0, 1] (euler: 1) */
    uint64_t seed;   /* base seed of the noise */
    int release;     /* the release's grid: sigmas in float32 as torch computes them
                        (gv_release_sigmas) and the DiT's time embedding of bf16 timesteps
                        (gv_dit_inputs.bf16_time); set by "released" */
} gv_sampler;

/* The defaults (docs/RESTORATION.md says how they were chosen). */
#define GV_SAMPLER_DEFAULT "onestep"
#define GV_COMPOSE_DEFAULT "residual"
/* The default sampler: GV_SAMPLER_DEFAULT with its defaults. */
gv_sampler gv_sampler_default(void);
/* A named sampler with its defaults: "onestep", "iterate", "euler", "released", "identity". */
int gv_sampler_from_name(const char *name, gv_sampler *out);
const char *gv_sampler_kind_name(gv_sampler_kind kind);
/* Checks the fields (t0 in (0, 1), 1 <= steps <= GV_SAMPLER_MAX_STEPS, onestep has 1 step,
 * shift >= 1, samples >= 1 and 1 for euler, blend in (0, 1] and 1 for euler); fails naming the
 * field. */
int gv_sampler_check(const gv_sampler *s);
/* The release's time grid (docs/GAUSSVID_RELEASE.md): sigma_k = shift(linspace(strength, 0,
 * steps + 1)[k]) for k < steps, every operation in float32 as torch's CPU linspace and the
 * DiffSynth scheduler do it (the first half from the start, the second from the end), and
 * t_k = 1000 sigma_k in float32; timesteps_bf16 (may be NULL) gets bf16(t_k), what the DiT
 * sees. steps <= GV_SAMPLER_MAX_STEPS. */
void gv_release_sigmas(float strength, float shift, int steps, float *sigmas, float *timesteps_bf16);
/* The times sigma_0..sigma_steps (steps + 1 values, the last 0). */
int gv_sampler_sigmas(const gv_sampler *s, double *sigmas);
/* A named sampler with fields overridden where given (t0 > 0, steps > 0, shift > 0,
 * samples > 0, blend > 0; 0 keeps the name's default), then checked. */
int gv_sampler_configure(const char *name, double t0, int steps, double shift, int samples, double blend,
                         uint64_t seed, gv_sampler *out);
/* One line describing the sampler, e.g. "onestep t0=0.3 steps=1 shift=1 samples=1 blend=1 seed=0". */
void gv_sampler_describe(const gv_sampler *s, char *out, size_t size);

/* The network as the sampler sees it: the velocity v [n] at x [n] and time sigma. */
typedef int (*gv_velocity_fn)(void *ctx, const float *x, double sigma, float *v);
/* Runs the sampler from z_hat (n floats) with the noise stream `seed`; z_out [n]. */
int gv_sample(const gv_sampler *s, gv_velocity_fn velocity, void *ctx, const float *z_hat, int64_t n, uint64_t seed,
              float *z_out);

/* ---- the network on one clip (restore.c) ------------------------------------------------- */
/* A clip's stream seed: the sampler's seed and the clip's name (its file name), hashed. */
uint64_t gv_restore_clip_seed(uint64_t seed, const char *clip_name);
/* The network's velocity for one clip, with the camera stream computed once (docs/ARCHITECTURE.md 6.5). */
typedef struct {
    gv_dit *model;
    const gv_clip_latents *clip;
    gv_graph graph;
    gv_dit_camera_cache cache;
    int has_cache;
    int evaluations;                   /* network evaluations so far */
    int bf16_time;                     /* the release's time embedding (gv_sampler.release) */
} gv_restore_net;
int gv_restore_net_init(gv_restore_net *r, gv_dit *m, const gv_clip_latents *l, int use_camera_cache);
void gv_restore_net_free(gv_restore_net *r);
/* gv_velocity_fn of a gv_restore_net: ctx is the gv_restore_net. */
int gv_restore_net_velocity(void *ctx, const float *x, double sigma, float *v);
/* The restored latent of a clip (gv_clip_latents_z_count floats). */
int gv_restore_latent(gv_dit *m, const gv_clip_latents *l, const gv_sampler *s, uint64_t clip_seed, float *z_out);
/* The same with the sampler calling velocity (ctx: the gv_restore_net) instead of
   gv_restore_net_velocity: a caller that observes each network evaluation wraps that one. */
int gv_restore_latent_with(gv_dit *m, const gv_clip_latents *l, const gv_sampler *s, uint64_t clip_seed,
                           gv_velocity_fn velocity, float *z_out);

/* ---- composition (restore_compose.c) ----------------------------------------------------- */
typedef enum { GV_COMPOSE_DECODED, GV_COMPOSE_RESIDUAL, GV_COMPOSE_UNSEEN } gv_compose;
/* "decoded", "residual" or "unseen", and back. */
const char *gv_compose_name(gv_compose c);
int gv_compose_from_name(const char *name, gv_compose *out);
/* The restored clip: out [5, H, W, 3] 8-bit (the clip's layout and size). z_restored holds
 * gv_clip_latents_z_count(l) floats; l is the clip's conditioning (its z_corrupt). A clip off
 * the network's block (condition.h) has latents of its padded size: it is composed padded and
 * cropped back, so out is always the clip's own size.
 * Pixels are (x + 1) 127.5 rounded half up, or with release set as the release converts
 * them (gv_release_to_u8). */
int gv_restore_compose(gv_vae *vae, const gv_clip *clip, const gv_clip_latents *l, const float *z_restored,
                       gv_compose mode, int release, uint8_t *out);
/* The release's pixel conversion: uint8(clip((x + 1) 127.5, 0, 255)) on a bf16 tensor, each
 * operation rounded to bf16 and the conversion truncating (docs/GAUSSVID_RELEASE.md). */
uint8_t gv_release_to_u8(float x);

/* ---- whole runs (restore_run.c) ----------------------------------------------------------- */
typedef struct {
    gv_sampler sampler;
    gv_compose compose;
    const char *split;                 /* dataset runs: "train", "eval" or NULL (all) */
    const char *scene;                 /* only clips of this scene (folder name); NULL: all */
    int interval;                      /* only clips of this interval n; 0: all */
    const char *out_dir;               /* restore: PNGs (and clips) go here; NULL: none */
    int save_clips;                    /* restore: also <out>/<clip>.safetensors */
    int use_cache;                     /* dataset runs: the latent cache (1) or encode each clip */
    /* called with each restored clip [5, H, W, 3] (may be NULL), e.g. gv_eval_add_restored;
     * what it writes into note (size bytes, empty at the call) is shown on the progress bar */
    int (*each)(void *ctx, const gv_clip *clip, const uint8_t *restored, char *note, size_t size);
    void *each_ctx;
    int keep_renders;                  /* the restored clip is the input clip, bit for bit: the
                                          restorer is not used (it may be NULL), no latent cache
                                          is read (a scene checkpoint's closed gate) */
} gv_restore_options;

/* Restores clip files (paths) or every clip of a dataset folder (dataset_dir, split), with a
 * progress bar; each restored clip is written (when out_dir) and handed to o->each. With
 * o->scene or o->interval a dataset run takes only the matching clips (and fails when none
 * matches) and a clip file of another scene or interval is refused. */
int gv_restore_files(gv_restorer *r, const char *const *paths, int n_paths, const gv_restore_options *o);
int gv_restore_dataset(gv_restorer *r, const char *dataset_dir, const gv_restore_options *o);

#endif
