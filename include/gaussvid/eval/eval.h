/* Evaluation (docs/ARCHITECTURE.md 9): the restoration tables of the paper (baseline against restored, per
 * interval n) and the VAE's evaluation (its reconstruction quality, and what residual decoding
 * gives on dataset clips). PSNR and SSIM as metrics.h computes them; LPIPS as lpips.h. */
#ifndef GAUSSVID_EVAL_H
#define GAUSSVID_EVAL_H

#include <stdint.h>
#include <stdio.h>

#include "gaussvid/data/dataset.h"
#include "gaussvid/eval/lpips.h"
#include "gaussvid/model/vae.h"
#include "gaussvid/train/vae_train.h"

/* ---- restoration tables (eval/tables.c) -------------------------------------------------- */
/* PSNR and SSIM (metrics.h, as the 3DGS evaluation) of the three intermediates, baseline
 * (the corrupted inputs) and restored, summed per interval n. */
typedef struct {
    int interval;
    int clips, frames;
    double psnr_base, ssim_base, psnr_rest, ssim_rest; /* sums until gv_eval_finish, then means */
    double lpips_base, lpips_rest;                     /* the same, when the table has LPIPS */
} gv_eval_row;

typedef struct {
    int n_rows;
    gv_eval_row rows[GV_MAX_INTERVALS]; /* by increasing n */
    gv_eval_row mean;                   /* over every frame (n = 0) */
    int finished;
    const gv_lpips *lpips;              /* AlexNet-LPIPS weights (lpips.h), or NULL: no LPIPS */
    int release_metric;                 /* the GaussVid release's PSNR and SSIM (scikit-image's:
                                           gv_image_ssim_skimage) instead of the 3DGS evaluation's */
} gv_eval_table;

/* An empty table; lpips may be NULL (no LPIPS column). */
void gv_eval_init(gv_eval_table *t, const gv_lpips *lpips);
/* Adds a clip: its targets against its inputs (baseline) and against `restored` [5, H, W, 3]. */
int gv_eval_add(gv_eval_table *t, const gv_clip *clip, const uint8_t *restored);
/* gv_eval_add as gv_restore_options.each (ctx: the table): notes the mean PSNR change. */
int gv_eval_add_restored(void *table, const gv_clip *clip, const uint8_t *restored, char *note, size_t size);
/* Turns the sums into means (per row and overall). */
void gv_eval_finish(gv_eval_table *t);
/* The Markdown table: one row per n and the mean, baseline and restored PSNR / SSIM (/ LPIPS)
 * and the PSNR change. */
void gv_eval_print_markdown(const gv_eval_table *t, FILE *out);
/* JSON: {"baseline": {"psnr", "ssim", ["lpips",] "clips"}, "restored": {...}, "per_n": [{"n",
 * "clips", "baseline": {...}, "restored": {...}}], plus the `info` pairs (n_info, may be 0)}
 * written atomically. */
int gv_eval_write_json(const gv_eval_table *t, const char *path, const char *const *info_keys,
                       const char *const *info_values, int n_info);

/* ---- the VAE (eval/vae_eval.c) ------------------------------------------------------------ */
/* Reconstruction quality on clips of `frames` frames spaced by `stride`, full frames cropped
 * to multiples of the spatial factor, non-overlapping, at most max_clips per scene (0: all):
 * each clip is encoded (chunked, as Wan), decoded, clamped and compared with its frames. */
int gv_vae_evaluate(gv_vae *v, const gv_vae_frames *f, int frames, int stride, int max_clips,
                    gv_vae_eval_result *r);

/* ---- residual decoding on dataset clips (eval/vae_residual.c) ----------------------------
 * What the VAE costs a restorer on real inputs: per scored frame, the PSNR / SSIM against the
 * ground truth of the render itself (the sparse-3DGS baseline), of D(E(render)) (the render
 * through the VAE), of D(E(target)) (a perfect restorer, decoded plainly), of the residual
 * composition with z_restored = z_render (must equal the render: max_abs_same = 0) and with
 * z_restored = E(target) (a perfect restorer, decoded as a residual: the upper bound). */
enum {
    GV_VAE_RESIDUAL_RENDER, GV_VAE_RESIDUAL_VAE_RENDER, GV_VAE_RESIDUAL_VAE_TARGET, GV_VAE_RESIDUAL_SAME,
    GV_VAE_RESIDUAL_UPPER, GV_VAE_RESIDUAL_KINDS
};
typedef struct {
    int n_clips, n_frames;                  /* frames scored */
    double psnr[GV_VAE_RESIDUAL_KINDS];     /* sums until gv_vae_residual_finish, then means */
    double ssim[GV_VAE_RESIDUAL_KINDS];
    double max_abs_same;                    /* largest |residual(z_render) - render| in [-1, 1] units */
} gv_vae_residual_scores;

/* Adds one clip: inputs (the renders, anchors included) and targets (ground truth) are 8-bit
 * [frames, height, width, 3]; frames t with score[t] != 0 are scored (the corrupted ones).
 * Frames are centre-cropped to multiples of the spatial factor, encoded chunked as Wan. */
int gv_vae_residual_score_clip(gv_vae *v, const uint8_t *inputs, const uint8_t *targets, int frames, int height,
                               int width, const int *score, gv_vae_residual_scores *s);
/* Turns the sums into means over the scored frames. */
void gv_vae_residual_finish(gv_vae_residual_scores *s);

#endif
