/* LPIPS (AlexNet): the layer table shared by the loader (lpips.c) and the forward pass
 * (lpips_forward.c). */
#ifndef GAUSSVID_EVAL_LPIPS_INTERNAL_H
#define GAUSSVID_EVAL_LPIPS_INTERNAL_H

#include "gaussvid/eval/lpips.h"

/* One slice of the package's `alexnet` (lpips/pretrained_networks.py): an optional 3x3
 * stride-2 max-pool, a convolution and a ReLU, cut from torchvision's alexnet().features,
 * whose module index the weight names keep (slice2 holds features[2..4], its conv is 3). */
typedef struct {
    const char *weight_name, *bias_name, *lin_name;
    int c_in, c_out, kernel, stride, pad;
    int pool_before;
} gv_lpips_layer;

extern const gv_lpips_layer gv_lpips_layers[GV_LPIPS_LAYERS];

/* The ScalingLayer of LPIPS v0.1 (lpips/lpips.py): x' = (x - shift) / scale per RGB channel,
 * x in [-1, 1]. */
extern const float gv_lpips_shift[3], gv_lpips_scale[3];

/* Output size of a convolution or (pad 0) a max-pool along one axis; < 1 when empty. */
static inline int gv_lpips_out_size(int in, int kernel, int stride, int pad)
{
    int span = in + 2 * pad - kernel;
    return span < 0 ? 0 : span / stride + 1;
}

#endif
