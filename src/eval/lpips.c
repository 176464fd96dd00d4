/* LPIPS (AlexNet) weights: the layer table, and loading one safetensors file whose names are
 * those of lpips.LPIPS(net='alex').state_dict() (docs/LPIPS.md), checked name by name and
 * shape by shape before anything is allocated. */
#include "gaussvid/eval/lpips.h"

#include <math.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "eval/lpips_internal.h"
#include "gaussvid/core/core.h"
#include "gaussvid/io/safetensors.h"

/* torchvision alexnet().features: 0 conv 11x11/4 pad 2, 1 ReLU | 2 pool, 3 conv 5x5 pad 2,
 * 4 ReLU | 5 pool, 6 conv 3x3 pad 1, 7 ReLU | 8 conv 3x3 pad 1, 9 ReLU | 10 conv 3x3 pad 1,
 * 11 ReLU (| 12 pool: not used by LPIPS). The package cuts slices at the bars (relu1..5) and
 * names the heads lin0..lin4, each Sequential(Dropout, Conv2d 1x1 no bias): index 1. */
const gv_lpips_layer gv_lpips_layers[GV_LPIPS_LAYERS] = {
    {"net.slice1.0.weight", "net.slice1.0.bias", "lin0.model.1.weight", 3, 64, 11, 4, 2, 0},
    {"net.slice2.3.weight", "net.slice2.3.bias", "lin1.model.1.weight", 64, 192, 5, 1, 2, 1},
    {"net.slice3.6.weight", "net.slice3.6.bias", "lin2.model.1.weight", 192, 384, 3, 1, 1, 1},
    {"net.slice4.8.weight", "net.slice4.8.bias", "lin3.model.1.weight", 384, 256, 3, 1, 1, 0},
    {"net.slice5.10.weight", "net.slice5.10.bias", "lin4.model.1.weight", 256, 256, 3, 1, 1, 0},
};

/* lpips/lpips.py ScalingLayer (v0.1): ImageNet statistics rescaled to inputs in [-1, 1]. */
const float gv_lpips_shift[3] = {-0.030f, -0.088f, -0.188f};
const float gv_lpips_scale[3] = {0.458f, 0.448f, 0.450f};

/* Keys of the state dict: 5 layers x (conv weight, conv bias, head). The state dict also holds
 * the ScalingLayer buffers and, through the ModuleList `lins`, a second name for each head;
 * those are accepted when present and checked, but not required. */
enum { KEY_WEIGHT, KEY_BIAS, KEY_LIN, KEYS_PER_LAYER };
enum { N_REQUIRED = GV_LPIPS_LAYERS * KEYS_PER_LAYER, N_OPTIONAL = 2 + GV_LPIPS_LAYERS };
#define SCALING_SHIFT "scaling_layer.shift"
#define SCALING_SCALE "scaling_layer.scale"

/* Name and shape of required key k (0..N_REQUIRED) or optional key N_REQUIRED + j. */
static int key_info(int k, char *name, size_t size, int64_t shape[4])
{
    if (k >= N_REQUIRED) {
        int j = k - N_REQUIRED;
        shape[0] = 1, shape[2] = 1, shape[3] = 1;
        if (j < 2) {
            snprintf(name, size, "%s", j == 0 ? SCALING_SHIFT : SCALING_SCALE);
            shape[1] = 3;
        } else {
            snprintf(name, size, "lins.%d.model.1.weight", j - 2);
            shape[1] = gv_lpips_layers[j - 2].c_out;
        }
        return 4;
    }
    const gv_lpips_layer *L = &gv_lpips_layers[k / KEYS_PER_LAYER];
    switch (k % KEYS_PER_LAYER) {
    case KEY_WEIGHT:
        snprintf(name, size, "%s", L->weight_name);
        shape[0] = L->c_out, shape[1] = L->c_in, shape[2] = L->kernel, shape[3] = L->kernel;
        return 4;
    case KEY_BIAS:
        snprintf(name, size, "%s", L->bias_name);
        shape[0] = L->c_out;
        return 1;
    default: /* a 1x1 convolution from C_out channels to one */
        snprintf(name, size, "%s", L->lin_name);
        shape[0] = 1, shape[1] = L->c_out, shape[2] = 1, shape[3] = 1;
        return 4;
    }
}

/* ---- the one-line report of everything wrong with a file --------------------------- */
enum { LIST_SHOWN = 4 }; /* entries named per list; the rest are counted */
typedef struct {
    char text[400];
    int count;
} problem_list;

static void list_add(problem_list *l, const char *fmt, ...) __attribute__((format(printf, 2, 3)));
static void list_add(problem_list *l, const char *fmt, ...)
{
    if (l->count++ >= LIST_SHOWN) return;
    size_t used = strlen(l->text);
    if (used) used += (size_t)snprintf(l->text + used, sizeof l->text - used, ", ");
    if (used >= sizeof l->text) return;
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(l->text + used, sizeof l->text - used, fmt, ap);
    va_end(ap);
}

static void list_append(char *out, size_t size, const char *what, const problem_list *l)
{
    size_t used = strlen(out);
    if (!l->count || used >= size) return;
    used += (size_t)snprintf(out + used, size - used, "%s%s %s", used ? "; " : "", what, l->text);
    if (l->count > LIST_SHOWN && used < size)
        snprintf(out + used, size - used, " and %d more", l->count - LIST_SHOWN);
}

static int is_accepted_dtype(gv_st_dtype d)
{
    return d == GV_ST_F32 || d == GV_ST_F16 || d == GV_ST_BF16;
}

/* Checks every name, dtype and shape; one line lists all that is wrong. */
static int check_keys(const gv_st_file *f, const char *path)
{
    problem_list missing = {{0}, 0}, unexpected = {{0}, 0}, shapes = {{0}, 0}, dtypes = {{0}, 0};
    char name[64], want[96], got[96];
    int64_t shape[4];
    for (int k = 0; k < N_REQUIRED + N_OPTIONAL; k++) {
        int rank = key_info(k, name, sizeof name, shape);
        const gv_st_tensor *t = gv_st_find(f, name);
        if (!t) {
            if (k < N_REQUIRED) list_add(&missing, "%s", name);
            continue;
        }
        if (!is_accepted_dtype(t->dtype))
            list_add(&dtypes, "%s is %s", name, gv_st_dtype_name(t->dtype));
        int same = t->rank == rank;
        for (int i = 0; same && i < rank; i++) same = t->shape[i] == shape[i];
        if (!same)
            list_add(&shapes, "%s is %s, expected %s", name,
                     gv_st_shape_str(got, sizeof got, t->shape, t->rank),
                     gv_st_shape_str(want, sizeof want, shape, rank));
    }
    for (int i = 0; i < f->n_tensors; i++) {
        int known = 0;
        for (int k = 0; k < N_REQUIRED + N_OPTIONAL && !known; k++) {
            key_info(k, name, sizeof name, shape);
            known = strcmp(name, f->tensors[i].name) == 0;
        }
        if (!known) list_add(&unexpected, "%s", f->tensors[i].name);
    }
    if (!missing.count && !unexpected.count && !shapes.count && !dtypes.count) return 0;
    char report[900] = "";
    list_append(report, sizeof report, "missing", &missing);
    list_append(report, sizeof report, "unexpected", &unexpected);
    list_append(report, sizeof report, "wrong shape:", &shapes);
    list_append(report, sizeof report, "wrong dtype (F32, F16 or BF16 expected):", &dtypes);
    return gv_fail("%s: not LPIPS (AlexNet) weights: %s", path, report);
}

/* ---- values -------------------------------------------------------------------------- */
static int read_finite(const gv_st_file *f, const char *path, const char *name, float *dst)
{
    const gv_st_tensor *t = gv_st_find(f, name);
    if (gv_st_tensor_to_f32(f, t, dst) != 0) return -1;
    for (int64_t i = 0; i < t->n_elements; i++)
        if (!isfinite(dst[i]))
            return gv_fail("%s: %s has a non-finite value (%g) at element %lld", path, name,
                           (double)dst[i], (long long)i);
    return 0;
}

/* The optional copies must agree with what the computation uses: the ScalingLayer buffers
 * with its constants (to the rounding of BF16, the coarsest accepted type), the `lins.l`
 * heads with `lin l` exactly. */
static int check_optional(const gv_lpips *net, const gv_st_file *f, const char *path)
{
    char name[64];
    int64_t shape[4];
    float values[384];
    for (int j = 0; j < N_OPTIONAL; j++) {
        key_info(N_REQUIRED + j, name, sizeof name, shape);
        if (!gv_st_find(f, name)) continue;
        if (read_finite(f, path, name, values) != 0) return -1;
        for (int i = 0; i < shape[1]; i++) {
            float want = j == 0 ? gv_lpips_shift[i] : j == 1 ? gv_lpips_scale[i]
                                                               : net->lin_weight[j - 2][i];
            float tol = j < 2 ? 4e-3f * fabsf(want) : 0.0f;
            if (fabsf(values[i] - want) > tol)
                return gv_fail("%s: %s[%d] is %g where LPIPS v0.1 uses %g (%s)", path, name,
                               i, (double)values[i], (double)want,
                               j < 2 ? "ScalingLayer constant" : "its lin head");
        }
    }
    return 0;
}

static int load_values(gv_lpips *net, const gv_st_file *f, const char *path)
{
    char name[64];
    int64_t shape[4];
    size_t total = 0;
    for (int k = 0; k < N_REQUIRED; k++) {
        int rank = key_info(k, name, sizeof name, shape);
        size_t n = 1;
        for (int i = 0; i < rank; i++) n *= (size_t)shape[i];
        total += n;
    }
    net->params = malloc(total * sizeof *net->params);
    if (!net->params) return gv_fail("%s: out of memory for %zu LPIPS weights", path, total);
    net->n_params = total;
    float *p = net->params;
    for (int k = 0; k < N_REQUIRED; k++) {
        int rank = key_info(k, name, sizeof name, shape);
        size_t n = 1;
        for (int i = 0; i < rank; i++) n *= (size_t)shape[i];
        int l = k / KEYS_PER_LAYER, kind = k % KEYS_PER_LAYER;
        if (kind == KEY_WEIGHT) net->conv_weight[l] = p;
        else if (kind == KEY_BIAS) net->conv_bias[l] = p;
        else net->lin_weight[l] = p;
        if (read_finite(f, path, name, p) != 0) return -1;
        p += n;
    }
    return check_optional(net, f, path);
}

int gv_lpips_load(gv_lpips *net, const char *path)
{
    memset(net, 0, sizeof *net);
    gv_st_file f;
    if (gv_st_open(&f, path) != 0) return -1;
    int rc = check_keys(&f, path);
    if (rc == 0) rc = load_values(net, &f, path);
    gv_st_close(&f);
    if (rc != 0) gv_lpips_free(net);
    return rc;
}

void gv_lpips_free(gv_lpips *net)
{
    free(net->params);
    memset(net, 0, sizeof *net);
}
