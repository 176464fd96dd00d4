/* LPIPS v0.1 with the AlexNet trunk (Zhang et al. 2018, the `lpips` Python package's
 * lpips.LPIPS(net='alex')), forward only, for evaluation (docs/LPIPS.md).
 *
 * Both images go through torchvision's AlexNet `features` (after the package's input
 * scaling); the ReLU outputs relu1..relu5 are unit-normalised over channels, their squared
 * difference is weighted per channel by the learned 1x1 heads lin0..lin4, averaged over the
 * layer's pixels, and the five layer values are summed. 0 means identical.
 *
 * The weights are one safetensors file with the names of the package's state dict
 * (net.slice1.0.weight, ..., lin0.model.1.weight, ...; docs/LPIPS.md lists them). A loaded
 * net is read-only: any number of threads may call the distance functions on it at once. */
#ifndef GAUSSVID_LPIPS_H
#define GAUSSVID_LPIPS_H

#include <stddef.h>

#include "gaussvid/io/image.h"

#define GV_LPIPS_LAYERS 5
/* Smallest width and height AlexNet's features accept: conv1 (11x11, stride 4, pad 2) gives
 * 7, pool1 3, pool2 1 pixel; one less and a max-pool has no output (PyTorch refuses too). */
#define GV_LPIPS_MIN_SIZE 31

typedef struct {
    float *conv_weight[GV_LPIPS_LAYERS]; /* AlexNet conv l: [C_out, C_in, k, k] */
    float *conv_bias[GV_LPIPS_LAYERS];   /* [C_out] */
    float *lin_weight[GV_LPIPS_LAYERS];  /* LPIPS head l (1x1 conv, no bias): [C_out] */
    float *params;                       /* one allocation holding all of the above */
    size_t n_params;
} gv_lpips;

/* Loads and checks the weights: every expected name with its shape, F32, F16 or BF16,
 * finite values; a bad file fails with one line listing the missing, unexpected and
 * mis-shaped keys. */
int gv_lpips_load(gv_lpips *net, const char *path);
/* Frees the weights; safe on a zeroed or failed net. */
void gv_lpips_free(gv_lpips *net);
/* Fails, naming the size, when an image of that size is too small for AlexNet. */
int gv_lpips_check_size(int width, int height);
/* LPIPS of two 8-bit RGB images (3 channels) of the same size, at least 31x31; values are
 * read as v / 127.5 - 1 (the package's im2tensor). */
int gv_lpips_distance(const gv_lpips *net, const gv_image *a, const gv_image *b,
                      double *distance);
/* LPIPS of two float RGB images, HWC in [0, 1] (mapped to 2 x - 1 as LPIPS(normalize=True)
 * does); per_layer (may be NULL) receives the five layer terms that sum to *distance. */
int gv_lpips_distance_f32(const gv_lpips *net, const float *a, const float *b, int width,
                          int height, double per_layer[GV_LPIPS_LAYERS], double *distance);

#endif
