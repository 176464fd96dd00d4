/* Optimisation of a gv_params registry: AdamW, gradient clipping by global norm, and
 * learning-rate schedules with linear warm-up. */
#ifndef GAUSSVID_OPTIM_H
#define GAUSSVID_OPTIM_H

#include "gaussvid/nn/tensor.h"

typedef struct {
    float beta1, beta2, eps, weight_decay;
} gv_adamw_config;

/* PyTorch's defaults: beta1 0.9, beta2 0.999, eps 1e-8, weight decay 0.01. */
gv_adamw_config gv_adamw_defaults(void);
/* One AdamW step (Loshchilov & Hutter) on every trainable parameter at learning rate lr:
 * ps->step += 1; m = b1 m + (1-b1) g; v = b2 v + (1-b2) g^2; p -= lr wd p (decoupled, only
 * where param->decay); p -= lr (m / (1-b1^step)) / (sqrt(v / (1-b2^step)) + eps). Fails
 * (changing nothing) when a gradient is not finite. */
int gv_adamw_step(gv_params *ps, const gv_adamw_config *c, float lr);

/* Euclidean norm of all trainable gradients together (double accumulation in fixed chunks,
 * so the result does not depend on the thread count); NaN or inf if any gradient is. */
double gv_grad_norm(const gv_params *ps);
/* Scales all gradients by max_norm / (norm + 1e-6) when the norm exceeds max_norm (as
 * torch.nn.utils.clip_grad_norm_); returns the norm before clipping. */
double gv_clip_grad_norm(gv_params *ps, double max_norm);

/* After the warm-up: constant lr; cosine from lr to min_lr; linear from lr to min_lr. The
 * decays reach min_lr at total_steps, the step after the last one a run of that length takes. */
typedef enum { GV_LR_CONSTANT = 0, GV_LR_COSINE = 1, GV_LR_LINEAR = 2 } gv_lr_kind;
typedef struct {
    gv_lr_kind kind;
    double lr;           /* peak learning rate */
    double min_lr;       /* end of the decay */
    long warmup_steps;   /* linear from lr/warmup to lr over steps 0..warmup-1 */
    long total_steps;    /* the decay reaches min_lr here */
} gv_lr_schedule;
/* Learning rate at a 0-based step. */
double gv_lr_at(const gv_lr_schedule *s, long step);
/* "constant", "cosine" or "linear", and back (fails naming the unknown name). */
const char *gv_lr_kind_name(gv_lr_kind kind);
int gv_lr_kind_from_name(const char *name, gv_lr_kind *out);

#endif
