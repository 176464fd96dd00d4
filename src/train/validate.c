/* Validation during fine-tuning: the objective's loss on clips the run never trains on, beside
 * the loss of the identity (returning the render unchanged), per sparsity interval n.
 *
 * The one-step restoration is eps - v (docs/RESTORATION.md), and the target is v* = eps - z0*,
 * so the velocity's squared error is exactly the squared error of the restored latent. The
 * identity's velocity eps - z-hat therefore scores mean((z0* - z-hat)^2) at every t: a run
 * whose validation loss is not below that number restores nothing on unseen clips, whatever
 * its training loss says. The draws are fixed (GV_VAL_TIMES evenly spaced timesteps in
 * [0, t_max] and noise from a seed of their own), so every evaluation of a run, and every run,
 * is measured on the same samples; nothing here touches the training state.
 *
 * Pooled losses are dominated by the clips with the largest errors, while the mean PSNR of an
 * evaluation weighs every clip alike: so each clip's latent "gain" 10 log10(identity / loss)
 * is averaged too, the latent analogue of the mean PSNR change (negative: damage). */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "gaussvid/core/core.h"
#include "gaussvid/nn/tensor.h"
#include "gaussvid/train/train.h"

#define GV_VAL_SEED 0x76616c6964617465ULL /* "validate": independent of the run's seed */

/* The group of interval n in out (added when new); -1 when the table is full. */
static int group_of(gv_validation *out, int n)
{
    for (int i = 0; i < out->groups; i++)
        if (out->intervals[i] == n) return i;
    if (out->groups == GV_VAL_GROUPS) return -1;
    out->intervals[out->groups] = n;
    return out->groups++;
}

int gv_train_validate(gv_dit *m, gv_graph *g, const gv_latent_set *val, double t_max, gv_validation *out)
{
    memset(out, 0, sizeof *out);
    int64_t most = gv_latent_set_max_z_count(val);
    float *eps = malloc((size_t)(most > 0 ? most : 1) * sizeof *eps);
    if (!eps) return gv_fail("validation: out of memory");
    int rc = 0;
    for (int i = 0; rc == 0 && i < val->count; i++) {
        const gv_clip_latents *l = &val->clips[i];
        int64_t n = gv_clip_latents_z_count(l);
        double loss = 0;
        for (int k = 0; rc == 0 && k < GV_VAL_TIMES; k++) {
            gv_sample_draw d = {(float)(t_max * (k + 0.5) / GV_VAL_TIMES), 1.0, 1.0, 0.0, 1};
            gv_sample_losses s;
            gv_fill_normal(eps, n, GV_VAL_SEED, (uint64_t)(i * GV_VAL_TIMES + k) * (uint64_t)most, 0.0f, 1.0f);
            rc = gv_train_sample(m, g, l, GV_OBJECTIVE_FINETUNE, &d, eps, 1.0, 0, &s);
            if (rc) gv_fail_context("validation clip %s", val->names[i]);
            loss += s.fm / GV_VAL_TIMES;
        }
        int k = group_of(out, l->interval);
        if (k < 0) {
            rc = gv_fail("validation: clips of more than %d intervals n", GV_VAL_GROUPS);
            break;
        }
        double id = gv_clip_latents_identity_loss(l), gain = loss > 0 && id > 0 ? 10 * log10(id / loss) : 0;
        out->clips[k]++, out->loss[k] += loss, out->identity[k] += id, out->gain_db[k] += gain;
        out->all_loss += loss, out->all_identity += id, out->all_gain_db += gain;
    }
    free(eps);
    if (rc) return -1;
    for (int k = 0; k < out->groups; k++)
        out->loss[k] /= out->clips[k], out->identity[k] /= out->clips[k], out->gain_db[k] /= out->clips[k];
    out->all_clips = val->count;
    if (val->count) out->all_loss /= val->count, out->all_identity /= val->count, out->all_gain_db /= val->count;
    return 0;
}
