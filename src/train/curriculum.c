/* The fine-tuning schedules of the paper's section 3.4: the progressive latent loss weight and
 * the difficulty-aware curriculum (difficulty of an interval n, the progress-dependent
 * threshold delta_max(s), the soft weight w_cur, and the choice of a step's clips). */
#include <math.h>

#include "gaussvid/core/core.h"
#include "gaussvid/train/train.h"

double gv_progressive_weight(long step, long warmup, double t, double tau_p, double lambda)
{
    double ramp = warmup > 0 ? (double)(step - warmup) / (double)warmup : 1.0;
    ramp = ramp < 0 ? 0 : ramp > 1 ? 1 : ramp;
    double low_noise = tau_p > 0 ? 1.0 - t / tau_p : 0.0;
    return lambda * ramp * (low_noise > 0 ? low_noise : 0.0);
}

double gv_curriculum_difficulty(int n, int n_min, int n_max)
{
    if (n_max <= n_min) return 0.0;
    double delta = (double)(n - n_min) / (double)(n_max - n_min);
    return delta < 0 ? 0 : delta > 1 ? 1 : delta;
}

/* Paper 3.4: 0 -> 0.2 over the warm-up fraction p_w of the run, then linearly to 1 at S. */
double gv_curriculum_threshold(long step, long total, double p_w)
{
    double s = (double)step, warm = (double)total * p_w;
    double d = s < warm ? 0.2 * s / warm : 0.2 + 0.8 * (s - warm) / ((double)total * (1.0 - p_w));
    return d > 1 ? 1 : d;
}

double gv_curriculum_weight(double delta, double delta_max)
{
    if (delta > delta_max) return 0.0;
    if (delta_max <= 0) return 1.0; /* delta = delta_max = 0: the easiest clips at the start */
    return 1.0 - 0.4 * delta / delta_max;
}

int gv_curriculum_batch(gv_data_order *d, const double *difficulty, double threshold, int batch, long *pos,
                        int *index, double *weight, int *skipped)
{
    if (d->count < 1 || batch < 1) return gv_fail("training: no clips to draw a batch of %d from", batch);
    double easiest = INFINITY;
    for (int i = 0; threshold >= 0 && i < d->count; i++)
        if (difficulty[i] < easiest) easiest = difficulty[i];
    if (threshold >= 0 && threshold < easiest) threshold = easiest; /* no clip would pass */
    *skipped = 0;
    for (int b = 0; b < batch;) {
        int i = gv_data_order_at(d, (*pos)++);
        if (i < 0) return -1;
        double w = threshold < 0 ? 1.0 : gv_curriculum_weight(difficulty[i], threshold);
        if (w <= 0) {
            (*skipped)++;
            continue;
        }
        index[b] = i;
        weight[b++] = w;
    }
    return 0;
}
