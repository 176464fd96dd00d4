/* BF16 base weights kept in the mapped file and converted per linear layer (dit.h "Memory",
 * tensor.h "Weights kept in bfloat16"), on a widened tiny network (dim 512, FFN 2048, 4
 * blocks and 2 VACE blocks: 19 M parameters, 76 MB in float32) written as BF16:
 *   - the streamed forward pass equals, bit for bit, the forward pass of a float32 model
 *     holding the same BF16-rounded weights (the same products on the same values);
 *   - so do the gradients of the LoRA adapters and of the input in fine-tuning (the frozen
 *     base weights converted again in the backward pass);
 *   - the peak resident set (VmHWM) of a process that loads and runs the streamed model
 *     stays far below that of one that holds the same weights in float32;
 *   - a NaN in a BF16 weight fails the forward pass naming the tensor, and an op other than
 *     a linear layer refuses a BF16 tensor. */
#include <stdint.h>
#include <stdlib.h>
#include <sys/resource.h>
#include <sys/wait.h>
#include <unistd.h>

#include "check.h"
#include "model_testutil.h"
#include "gaussvid/io/safetensors.h"

static void wide_config(gv_model_config *c)
{
    gv_model_config_preset(c, "tiny");
    gv_model_config_set_variant(c, "camera=none", "test");
    c->dit.dim = 512, c->dit.ffn_dim = 2048, c->dit.num_heads = 4, c->dit.num_layers = 4;
    c->dit.vace_layers[0] = 0, c->dit.vace_layers[1] = 2;
}

static uint16_t bf16_bits(float x)
{
    return gv_f32_to_bf16(x);
}

/* The base (DiT + VACE) of m as a BF16 file; m's own values rounded the same way. */
static int write_bf16(gv_dit *m, const char *path, const char *nan_in)
{
    gv_st_builder b;
    gv_st_builder_init(&b);
    int rc = 0;
    for (int i = 0; rc == 0 && i < m->params.n; i++) {
        gv_tensor *t = &m->params.items[i]->t;
        const gv_weight_spec *s = gv_weight_list_find(&m->weights, t->name);
        if (!(gv_module_part(s->module) & (GV_PART_DIT | GV_PART_VACE))) continue;
        for (int64_t k = 0; k < t->numel; k++) t->data[k] = gv_bf16_to_f32(bf16_bits(t->data[k]));
        if (nan_in && !strcmp(t->name, nan_in)) t->data[7] = NAN;
        int64_t shape[GV_MAX_DIMS];
        for (int k = 0; k < t->ndim; k++) shape[k] = t->shape[k];
        rc = gv_st_add_f32(&b, t->name, GV_ST_BF16, shape, t->ndim, t->data);
    }
    if (rc == 0) rc = gv_st_write(&b, path);
    gv_st_builder_free(&b);
    return rc;
}

/* A model whose base comes from the BF16 file (kept mapped), nothing else given values. */
static int load_streamed(gv_dit *m, const gv_model_config *c, const char *path)
{
    const char *paths[1] = {path};
    if (gv_dit_init_parts(m, c, 3, GV_PART_DIT | GV_PART_VACE)) return -1;
    return gv_dit_load(m, paths, 1, GV_PART_DIT | GV_PART_VACE);
}

/* out = forward on fixed inputs; with grads, the backward of sum(out * r) too. */
static gv_tensor *run(gv_dit *m, gv_graph *g, int grads, gv_tensor **latent)
{
    gv_graph_reset(g);
    gv_graph_set_grad(g, grads);
    mt_inputs in;
    if (mt_make_inputs(m, g, NULL, 1, 5, 32, 32, 11, &in)) return NULL;
    if (grads) gv_tensor_requires_grad(in.latent);
    gv_dit_inputs d = mt_dit_inputs(&in);
    gv_tensor *y = gv_dit_forward(m, g, &d);
    if (y && grads) {
        float *r = malloc((size_t)y->numel * sizeof *r);
        gv_fill_normal(r, y->numel, 99, 0, 0, 1);
        if (gv_backward_seed(g, y, r)) y = NULL;
        free(r);
    }
    *latent = in.latent;
    return y;
}

static int same_bits(const float *a, const float *b, int64_t n)
{
    return memcmp(a, b, (size_t)n * sizeof *a) == 0;
}

static void test_equal(const char *path, gv_dit *ref)
{
    gv_dit s;
    gv_model_config c = ref->cfg;
    CHECK(load_streamed(&s, &c, path) == 0);
    int kept = 0;
    int64_t bytes = gv_dit_bf16_bytes(&s, &kept);
    printf("streamed: %d linear weights kept in BF16 (%.1f MB); float32 reference %.1f MB\n", kept, bytes / 1e6,
           gv_params_count(&ref->params, 0) * 4 / 1e6);
    /* every linear weight of the base: 10 per block (4 + 2), before_proj, 2 after_proj, the text
     * and time embeddings' 5 and the head */
    CHECK(kept == 10 * 6 + 1 + 2 + 5 + 1 && s.n_mapped == 1);
    /* the adapters: the same non-zero values in both */
    mt_randomize(ref, 1u << GV_MODULE_LORA, 5);
    for (int i = 0; i < s.params.n; i++) {
        gv_param *p = s.params.items[i];
        const gv_weight_spec *w = gv_weight_list_find(&s.weights, p->t.name);
        if (w->module == GV_MODULE_LORA)
            memcpy(p->t.data, gv_params_find(&ref->params, p->t.name)->t.data, (size_t)p->t.numel * sizeof(float));
    }
    gv_graph g1, g2;
    gv_graph_init(&g1, 0), gv_graph_init(&g2, 0);
    gv_tensor *x1, *x2;
    gv_tensor *y1 = run(&s, &g1, 0, &x1), *y2 = run(ref, &g2, 0, &x2);
    CHECK(y1 && y2 && y1->numel == y2->numel && same_bits(y1->data, y2->data, y1->numel));

    CHECK(gv_dit_set_train_mode(&s, GV_DIT_FINETUNE) == 0 && gv_dit_set_train_mode(ref, GV_DIT_FINETUNE) == 0);
    CHECK(gv_dit_bf16_bytes(&s, NULL) == bytes); /* frozen: still BF16 */
    gv_params_zero_grad(&s.params), gv_params_zero_grad(&ref->params);
    y1 = run(&s, &g1, 1, &x1), y2 = run(ref, &g2, 1, &x2);
    CHECK(y1 && y2 && same_bits(y1->data, y2->data, y1->numel));
    CHECK(x1->grad && x2->grad && same_bits(x1->grad, x2->grad, x1->numel));
    int trained = 0, equal = 0;
    for (int i = 0; i < s.params.n; i++) {
        gv_param *p = s.params.items[i], *q = gv_params_find(&ref->params, p->t.name);
        if (!p->trainable) continue;
        trained++;
        equal += q->trainable && same_bits(p->t.grad, q->t.grad, p->t.numel);
    }
    printf("fine-tuning: %d adapter gradients, %d equal bit for bit\n", trained, equal);
    CHECK(trained > 0 && equal == trained);
    gv_graph_free(&g1), gv_graph_free(&g2);
    gv_dit_free(&s);
}

/* A fresh process (this program, exec'ed) loads the model, streamed or made float32, and runs
 * one forward pass; its peak resident set (wait4's ru_maxrss) in kB. A fresh process rather
 * than a fork: OpenMP's threads do not survive a fork. */
static long child_peak(const char *path, int resident)
{
    pid_t pid = fork();
    if (pid < 0) return -1;
    if (pid == 0) {
        execl("/proc/self/exe", "test_dit_stream", "--peak", path, resident ? "resident" : "streamed", (char *)NULL);
        _exit(127);
    }
    int status = 0;
    struct rusage ru;
    if (wait4(pid, &status, 0, &ru) != pid || !WIFEXITED(status) || WEXITSTATUS(status) != 0) return -1;
    return ru.ru_maxrss;
}

/* The child's work (main with --peak). */
static int peak_child(const char *path, int resident)
{
    gv_model_config c;
    wide_config(&c);
    gv_dit m;
    gv_graph g;
    gv_graph_init(&g, 0);
    gv_tensor *x;
    int rc = load_streamed(&m, &c, path);
    for (int i = 0; rc == 0 && resident && i < m.params.n; i++) rc = gv_param_materialize(m.params.items[i]);
    if (rc == 0 && !run(&m, &g, 0, &x)) rc = -1;
    if (rc) fprintf(stderr, "%s\n", gv_last_error());
    gv_graph_free(&g);
    gv_dit_free(&m);
    return rc ? 1 : 0;
}

static void test_nan(const gv_model_config *c, const char *path)
{
    gv_dit m;
    CHECK(gv_dit_init(&m, c, 1) == 0);
    CHECK(write_bf16(&m, path, "blocks.1.ffn.0.weight") == 0);
    gv_dit_free(&m);
    CHECK(load_streamed(&m, c, path) == 0);
    gv_graph g;
    gv_graph_init(&g, 0);
    gv_tensor *x;
    CHECK(run(&m, &g, 0, &x) == NULL);
    CHECK(strstr(gv_last_error(), "blocks.1.ffn.0.weight: value element 7 is not finite") != NULL);
    /* only a linear layer takes a BF16 weight */
    gv_graph_reset(&g);
    gv_tensor *a = gv_tensor_new(&g, 2, (int[]){3, 512});
    CHECK(gv_matmul(&g, a, m.blocks[0].q.w, 0, 1) == NULL);
    CHECK(strstr(gv_last_error(), "blocks.0.self_attn.q.weight") != NULL);
    gv_graph_free(&g);
    gv_dit_free(&m);
}

int main(int argc, char **argv)
{
    if (argc == 4 && !strcmp(argv[1], "--peak")) return peak_child(argv[2], !strcmp(argv[3], "resident"));
    const char *tmp = check_tmp_dir();
    char path[4200], bad[4200];
    snprintf(path, sizeof path, "%s/base_bf16.safetensors", tmp);
    snprintf(bad, sizeof bad, "%s/nan_bf16.safetensors", tmp);
    gv_model_config c;
    wide_config(&c);
    CHECK(gv_model_config_validate(&c, "test") == 0);
    gv_dit ref;
    CHECK(gv_dit_init(&ref, &c, 1) == 0);
    mt_randomize(&ref, MT_BASE, 2);
    CHECK(write_bf16(&ref, path, NULL) == 0);
    size_t f32_kb = (size_t)gv_params_count(&ref.params, 0) * 4 / 1024;
    gv_dit_free(&ref);

    long streamed = child_peak(path, 0), resident = child_peak(path, 1);
    printf("peak RSS (VmHWM) of load + one forward pass: streamed %ld kB, float32 resident %ld kB (weights %zu kB in "
           "float32)\n", streamed, resident, f32_kb);
#ifdef __SANITIZE_ADDRESS__
    /* AddressSanitizer's allocator keeps freed memory resident: the sizes say nothing here */
    CHECK(streamed > 0 && resident > 0);
#else
    CHECK(streamed > 0 && resident > (long)f32_kb && resident - streamed > (long)f32_kb * 3 / 4);
#endif

    CHECK(gv_dit_init(&ref, &c, 1) == 0);
    mt_randomize(&ref, MT_BASE, 2);
    CHECK(write_bf16(&ref, path, NULL) == 0); /* rounds ref's values as it writes them */
    test_equal(path, &ref);
    gv_dit_free(&ref);
    test_nan(&c, bad);
    return check_summary();
}
