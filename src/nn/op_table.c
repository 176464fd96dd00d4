/* The op table: every gv_op with its name, forward and backward (ggml style). Adding an op
 * touches ops.h (enum + constructor), nn_internal.h (declaration), this table, and the file
 * holding its forward/backward pair. */
#include "nn/nn_internal.h"

static int leaf_forward(gv_graph *g, gv_tensor *out) { return 0; }
static int leaf_backward(gv_graph *g, gv_tensor *out) { return 0; }

const gv_op_info gv_op_table[GV_OP_COUNT] = {
    [GV_OP_LEAF] = {"leaf", leaf_forward, leaf_backward},
    [GV_OP_ADD] = {"add", gv_binary_forward, gv_binary_backward},
    [GV_OP_SUB] = {"sub", gv_binary_forward, gv_binary_backward},
    [GV_OP_MUL] = {"mul", gv_binary_forward, gv_binary_backward},
    [GV_OP_DIV] = {"div", gv_binary_forward, gv_binary_backward},
    [GV_OP_AFFINE] = {"affine", gv_affine_op_forward, gv_affine_op_backward},
    [GV_OP_SUM] = {"sum", gv_sum_op_forward, gv_sum_op_backward},
    [GV_OP_RESHAPE] = {"reshape", gv_reshape_op_forward, gv_reshape_op_backward},
    [GV_OP_PERMUTE] = {"permute", gv_permute_op_forward, gv_permute_op_backward},
    [GV_OP_CONCAT] = {"concat", gv_concat_op_forward, gv_concat_op_backward},
    [GV_OP_SLICE] = {"slice", gv_slice_op_forward, gv_slice_op_backward},
    [GV_OP_REPEAT] = {"repeat", gv_repeat_op_forward, gv_repeat_op_backward},
    [GV_OP_MATMUL] = {"matmul", gv_matmul_op_forward, gv_matmul_op_backward},
    [GV_OP_LINEAR] = {"linear", gv_linear_op_forward, gv_linear_op_backward},
    [GV_OP_LAYER_NORM] = {"layer_norm", gv_layer_norm_op_forward, gv_layer_norm_op_backward},
    [GV_OP_RMS_NORM] = {"rms_norm", gv_rms_norm_op_forward, gv_rms_norm_op_backward},
    [GV_OP_GELU] = {"gelu", gv_gelu_op_forward, gv_gelu_op_backward},
    [GV_OP_SILU] = {"silu", gv_silu_op_forward, gv_silu_op_backward},
    [GV_OP_SIGMOID] = {"sigmoid", gv_sigmoid_op_forward, gv_sigmoid_op_backward},
    [GV_OP_SOFTMAX] = {"softmax", gv_softmax_op_forward, gv_softmax_op_backward},
    [GV_OP_ATTENTION] = {"attention", gv_attention_op_forward, gv_attention_op_backward},
    [GV_OP_ROPE] = {"rope", gv_rope_op_forward, gv_rope_op_backward},
    [GV_OP_CONV] = {"conv", gv_conv_op_forward, gv_conv_op_backward},
    [GV_OP_SPACE_TO_DEPTH] = {"pixel_unshuffle", gv_space_to_depth_op_forward,
                              gv_space_to_depth_op_backward},
    [GV_OP_DEPTH_TO_SPACE] = {"pixel_shuffle", gv_depth_to_space_op_forward,
                              gv_depth_to_space_op_backward},
    [GV_OP_UPSAMPLE] = {"upsample_nearest", gv_upsample_op_forward, gv_upsample_op_backward},
    [GV_OP_L1_LOSS] = {"l1_loss", gv_l1_loss_op_forward, gv_l1_loss_op_backward},
    [GV_OP_L2_LOSS] = {"l2_loss", gv_l2_loss_op_forward, gv_l2_loss_op_backward},
};
