/* Rotary position embedding: Wan2.1's 3D table (docs/reference/wan-vace-gaussvid.md section 2.6)
 * and the rotation of adjacent (real, imag) pairs of every head by it. */
#include "nn/nn_internal.h"

#define MAX_PAIRS 1024 /* head_dim up to 2048 */

gv_tensor *gv_rope3d_table(gv_graph *g, const int *pos, int n_tokens, int head_dim)
{
    if (head_dim < 6 || head_dim % 2) {
        gv_fail("rope: head dimension %d must be even and at least 6", head_dim);
        return NULL;
    }
    int half = head_dim / 2;
    gv_tensor *t = gv_tensor_new(g, 3, (int[]){n_tokens, half, 2});
    if (!t) return NULL;
    /* Section 2.6: dims d - 4(d/6) for frames, 2(d/6) each for rows and columns; pairs in that
     * order; each axis has its own frequencies 10000^(-2j / axis_dim). */
    int axis_dim[3] = {head_dim - 4 * (head_dim / 6), 2 * (head_dim / 6), 2 * (head_dim / 6)};
    double omega[MAX_PAIRS];
    int axis_of[MAX_PAIRS];
    if (half > MAX_PAIRS) {
        gv_fail("rope: head dimension %d too large", head_dim);
        return NULL;
    }
    for (int axis = 0, j = 0; axis < 3; axis++)
        for (int k = 0; k < axis_dim[axis] / 2; k++, j++) {
            omega[j] = pow(10000.0, -2.0 * k / axis_dim[axis]);
            axis_of[j] = axis;
        }
#pragma omp parallel for schedule(static) if ((int64_t)n_tokens * half >= GV_OMP_MIN)
    for (int n = 0; n < n_tokens; n++)
        for (int j = 0; j < half; j++) {
            double angle = pos[3 * n + axis_of[j]] * omega[j];
            t->data[((int64_t)n * half + j) * 2] = (float)cos(angle);
            t->data[((int64_t)n * half + j) * 2 + 1] = (float)sin(angle);
        }
    return t;
}

gv_tensor *gv_rope3d_table_grid(gv_graph *g, int frames, int rows, int cols, int head_dim)
{
    if (frames < 1 || rows < 1 || cols < 1 || (int64_t)frames * rows * cols > INT32_MAX / 3) {
        gv_fail("rope: bad grid %d x %d x %d", frames, rows, cols);
        return NULL;
    }
    int n = frames * rows * cols;
    int *pos = gv_arena_alloc(&g->arena, (size_t)n * 3 * sizeof(int));
    if (!pos) return NULL;
    for (int f = 0, i = 0; f < frames; f++) /* token order: frame, row, column (section 2.2) */
        for (int y = 0; y < rows; y++)
            for (int x = 0; x < cols; x++, i++) {
                pos[3 * i] = f;
                pos[3 * i + 1] = y;
                pos[3 * i + 2] = x;
            }
    return gv_rope3d_table(g, pos, n, head_dim);
}

/* out [B, N, H, P, 2]: (a, b) -> (a cos - b sin, a sin + b cos) with (cos, sin) = table[n, p];
 * x [B, N, H*2P]; iparam = {B, N, H, P}. The backward rotates by the opposite angle. */
static void rotate(gv_tensor *out, int backward)
{
    int B = out->iparam[0], N = out->iparam[1], H = out->iparam[2], P = out->iparam[3];
    const float *table = out->src[1]->data;
    const float *in = backward ? out->grad : out->src[0]->data;
    float *dst = backward ? out->src[0]->grad : out->data;
    float sign = backward ? -1.0f : 1.0f;
#pragma omp parallel for schedule(static) if (out->numel >= GV_OMP_MIN)
    for (int64_t bn = 0; bn < (int64_t)B * N; bn++) {
        const float *cs = table + (bn % N) * P * 2;
        for (int h = 0; h < H; h++) {
            const float *x = in + (bn * H + h) * 2 * P;
            float *y = dst + (bn * H + h) * 2 * P;
            for (int p = 0; p < P; p++) {
                float c = cs[2 * p], s = sign * cs[2 * p + 1], a = x[2 * p], b = x[2 * p + 1];
                if (backward) {
                    y[2 * p] += a * c - b * s;
                    y[2 * p + 1] += a * s + b * c;
                } else {
                    y[2 * p] = a * c - b * s;
                    y[2 * p + 1] = a * s + b * c;
                }
            }
        }
    }
}

int gv_rope_op_forward(gv_graph *g, gv_tensor *out)
{
    rotate(out, 0);
    return 0;
}

int gv_rope_op_backward(gv_graph *g, gv_tensor *out)
{
    if (gv_wants_grad(out, 0)) rotate(out, 1);
    return 0;
}

gv_tensor *gv_rope(gv_graph *g, gv_tensor *x, gv_tensor *table, int n_heads)
{
    if (!x || !table) return NULL;
    char sx[64], st[64];
    int N = gv_dim(x, -2), C = gv_dim(x, -1);
    if (x->ndim < 2 || table->ndim != 3 || table->shape[2] != 2 || n_heads < 1 ||
        table->shape[0] != N || C != n_heads * 2 * table->shape[1]) {
        gv_fail("rope: x %s does not match table %s with %d heads", gv_shape_str(x, sx, sizeof sx),
                gv_shape_str(table, st, sizeof st), n_heads);
        return NULL;
    }
    gv_tensor *src[2] = {x, table};
    gv_tensor *out = gv_op_new(g, GV_OP_ROPE, x->ndim, x->shape, 2, src, 0);
    if (!out) return NULL;
    out->iparam[0] = (int)(x->numel / ((int64_t)N * C));
    out->iparam[1] = N;
    out->iparam[2] = n_heads;
    out->iparam[3] = table->shape[1];
    return gv_op_run(g, out);
}
