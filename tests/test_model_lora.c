/* LoRA (docs/ARCHITECTURE.md 6.7) and weights by name: zero B gives the base output, merged equals unmerged,
 * what fine-tuning trains (and that the frozen base owns no gradient buffers), save / load
 * round trips of a whole model and of adapters alone onto a base checkpoint, files with
 * missing, unexpected or mis-shaped tensors, and the published Wan presets' tensor names
 * (1.3B and 14B: checked without allocating their data). */
#include <omp.h>

#include "check.h"
#include "model/dit_internal.h"
#include "model_testutil.h"

static float *run(gv_dit *m, const mt_inputs *in, int64_t *n)
{
    gv_graph g;
    gv_graph_init(&g, 0);
    gv_graph_set_grad(&g, 0);
    gv_dit_inputs d = mt_dit_inputs(in);
    gv_tensor *y = gv_dit_forward(m, &g, &d);
    float *out = NULL;
    if (y) {
        out = malloc((size_t)y->numel * sizeof *out);
        memcpy(out, y->data, (size_t)y->numel * sizeof *out);
        *n = y->numel;
    } else {
        fprintf(stderr, "forward failed: %s\n", gv_last_error());
    }
    gv_graph_free(&g);
    return out;
}

/* Copies every tensor of `from` that `to` has too. */
static void copy_shared(gv_dit *to, const gv_dit *from)
{
    for (int i = 0; i < to->params.n; i++) {
        gv_tensor *t = &to->params.items[i]->t;
        gv_param *p = gv_params_find(&from->params, t->name);
        if (p) memcpy(t->data, p->t.data, (size_t)t->numel * sizeof(float));
    }
}

static void test_zero_b_and_merge(void)
{
    gv_dit m, base;
    CHECK(mt_model(&m, NULL, 1) == 0);
    CHECK(mt_model(&base, "lora=0", 2) == 0);
    CHECK(base.params.n < m.params.n);
    mt_randomize(&m, MT_BASE | (1u << GV_MODULE_CAMERA), 3);
    copy_shared(&base, &m);
    gv_graph g;
    gv_graph_init(&g, 0);
    mt_inputs in;
    CHECK(mt_make_inputs(&m, &g, NULL, 1, 5, 32, 32, 4, &in) == 0);
    int64_t n = 0, n2 = 0;
    float *adapted = run(&m, &in, &n), *plain = run(&base, &in, &n2);
    CHECK(adapted && plain && n == n2 && !memcmp(adapted, plain, (size_t)n * sizeof(float))); /* B = 0 */
    free(adapted), free(plain);
    mt_randomize(&m, 1u << GV_MODULE_LORA, 5); /* B != 0 now */
    float *unmerged = run(&m, &in, &n);
    float *old_base = run(&base, &in, &n2);
    CHECK(unmerged && old_base && mt_max_abs_diff(unmerged, old_base, n) > 1e-3); /* adapters matter */
    CHECK(gv_dit_set_train_mode(&m, GV_DIT_FINETUNE) == 0);
    CHECK(gv_dit_merge_lora(&m) == 0);
    float *merged = run(&m, &in, &n2);
    double diff = merged && unmerged ? mt_max_abs_diff(merged, unmerged, n) : 1, scale = mt_max_abs(unmerged, n);
    printf("LoRA merged vs unmerged: max |diff| %.2e (output scale %.2e)\n", diff, scale);
    CHECK(diff <= 2e-5 * (1 + scale));
    /* merged adapters are no longer trained; the camera encoder still is */
    gv_param *a = gv_params_find(&m.params, "blocks.0.self_attn.q.lora_A.weight");
    gv_param *cam = gv_params_find(&m.params, "camera_encoder.proj.2.weight");
    CHECK(a && !a->trainable && a->t.grad == NULL && cam && cam->trainable);
    CHECK_FAILS_WITH(gv_dit_merge_lora(&m), "already merged");
    CHECK_FAILS_WITH(gv_dit_save(&m, "/tmp/never-written.safetensors", GV_PART_ALL), "merged");
    free(unmerged), free(old_base), free(merged);
    gv_graph_free(&g);
    gv_dit_free(&base);
    gv_dit_free(&m);
}

/* Fine-tuning trains LoRA and the camera encoder only; the base has no gradient buffers and
 * no AdamW moments; a backward pass reaches every trainable tensor. */
static void test_trainable(void)
{
    gv_dit m;
    CHECK(mt_model(&m, NULL, 11) == 0);
    mt_randomize(&m, MT_BASE, 12);
    CHECK(gv_dit_set_train_mode(&m, GV_DIT_FINETUNE) == 0);
    gv_weight_counts counts;
    gv_weight_list_count(&m.weights, &counts);
    int64_t vae = counts.params[GV_MODULE_VAE_ENCODER] + counts.params[GV_MODULE_VAE_DECODER];
    CHECK(gv_params_count(&m.params, 1) == counts.trainable);
    CHECK(gv_params_count(&m.params, 0) == counts.total - vae);
    int bad = 0;
    for (int i = 0; i < m.params.n; i++) {
        gv_param *p = m.params.items[i];
        const gv_weight_spec *s = gv_weight_list_find(&m.weights, p->t.name);
        int want = s->module == GV_MODULE_LORA || s->module == GV_MODULE_CAMERA;
        bad += p->trainable != want || (p->t.grad != NULL) != want || (p->m != NULL) != want || (p->v != NULL) != want;
    }
    CHECK(bad == 0);
    gv_graph g;
    gv_graph_init(&g, 0);
    mt_inputs in;
    CHECK(mt_make_inputs(&m, &g, NULL, 1, 5, 32, 32, 13, &in) == 0);
    gv_dit_inputs d = mt_dit_inputs(&in);
    gv_tensor *y = gv_dit_forward(&m, &g, &d);
    CHECK(y && gv_backward(&g, gv_mean_all(&g, gv_mul(&g, y, y))) == 0);
    /* at initialisation the zero B and the zero camera projection get gradient */
    gv_param *b = gv_params_find(&m.params, "blocks.1.ffn.2.lora_B.weight");
    gv_param *proj = gv_params_find(&m.params, "camera_encoder.proj.2.weight");
    CHECK(b && b->t.grad && mt_max_abs(b->t.grad, b->t.numel) > 0);
    CHECK(proj && proj->t.grad && mt_max_abs(proj->t.grad, proj->t.numel) > 0);
    CHECK(gv_dit_set_train_mode(&m, GV_DIT_FULL) == 0 && gv_params_count(&m.params, 1) == gv_params_count(&m.params, 0));
    CHECK(gv_dit_set_train_mode(&m, GV_DIT_FROZEN) == 0 && gv_params_count(&m.params, 1) == 0);
    gv_graph_free(&g);
    gv_dit_free(&m);
}

static void path_in(char *out, size_t size, const char *name)
{
    static const char *dir;
    if (!dir) dir = check_tmp_dir();
    snprintf(out, size, "%s/%s", dir, name);
}

static void test_save_load(void)
{
    gv_dit m, fresh, other;
    CHECK(mt_model(&m, NULL, 21) == 0);
    mt_randomize(&m, MT_ALL, 22);
    gv_graph g;
    gv_graph_init(&g, 0);
    mt_inputs in;
    CHECK(mt_make_inputs(&m, &g, NULL, 1, 5, 32, 32, 23, &in) == 0);
    int64_t n = 0, n2 = 0;
    float *want = run(&m, &in, &n);
    char all[512], base[512], adapters[512];
    path_in(all, sizeof all, "all.safetensors");
    path_in(base, sizeof base, "base.safetensors");
    path_in(adapters, sizeof adapters, "adapters.safetensors");
    CHECK(gv_dit_save(&m, all, GV_PART_ALL) == 0);
    CHECK(gv_dit_save(&m, base, GV_PART_DIT | GV_PART_VACE) == 0);
    CHECK(gv_dit_save(&m, adapters, GV_PART_ADAPTERS) == 0);
    /* the adapter file holds exactly the camera and LoRA tensors, with the config */
    gv_st_file f;
    CHECK(gv_st_open(&f, adapters) == 0);
    gv_weight_counts counts;
    gv_weight_list_count(&m.weights, &counts);
    CHECK(f.n_tensors == counts.tensors[GV_MODULE_CAMERA] + counts.tensors[GV_MODULE_LORA]);
    CHECK(gv_st_find(&f, "blocks.0.self_attn.q.lora_A.weight") && gv_st_find(&f, "camera_encoder.gamma") &&
          !gv_st_find(&f, "blocks.0.self_attn.q.weight"));
    gv_model_config parsed;
    const char *json = gv_st_metadata(&f, "config");
    CHECK(json && gv_model_config_parse(&parsed, json, "metadata") == 0 && gv_model_config_equal(&parsed, &m.cfg));
    CHECK(gv_st_metadata(&f, "parts") && !strcmp(gv_st_metadata(&f, "parts"), "camera,lora"));
    gv_st_close(&f);
    /* whole file; then base + adapters onto a fresh model */
    CHECK(mt_model(&fresh, NULL, 99) == 0);
    const char *one[1] = {all};
    CHECK(gv_dit_load(&fresh, one, 1, GV_PART_ALL) == 0);
    float *got = run(&fresh, &in, &n2);
    CHECK(want && got && n == n2 && !memcmp(want, got, (size_t)n * sizeof(float)));
    free(got);
    CHECK(mt_model(&other, NULL, 98) == 0);
    const char *two[2] = {base, adapters};
    CHECK(gv_dit_load(&other, two, 1, GV_PART_DIT | GV_PART_VACE) == 0);
    CHECK(gv_dit_load(&other, two + 1, 1, GV_PART_ADAPTERS) == 0);
    got = run(&other, &in, &n2);
    CHECK(want && got && !memcmp(want, got, (size_t)n * sizeof(float)));
    free(got);
    /* an adapter file alone does not make a base */
    CHECK_FAILS_WITH(gv_dit_load(&fresh, two + 1, 1, GV_PART_ALL), "missing");
    /* a NaN is refused naming the file it is in (the second here) and the tensor */
    char nan_adapters[512];
    path_in(nan_adapters, sizeof nan_adapters, "nan-adapters.safetensors");
    gv_param *bad = gv_params_find(&m.params, "camera_encoder.proj.0.weight");
    float kept = bad->t.data[3];
    bad->t.data[3] = NAN;
    CHECK(gv_dit_save(&m, nan_adapters, GV_PART_ADAPTERS) == 0);
    bad->t.data[3] = kept;
    const char *with_nan[2] = {base, nan_adapters};
    CHECK_FAILS_WITH(gv_dit_load(&fresh, with_nan, 2, GV_PART_ALL), "nan-adapters.safetensors: camera_encoder.proj.0.weight: value element 3");
    free(want);
    gv_graph_free(&g);
    gv_dit_free(&other);
    gv_dit_free(&fresh);
    gv_dit_free(&m);
}

/* A reduced Wan2.1-VACE: the published structure and key names (cross-attention, norm3, VACE
 * before/after_proj, text 4096 wide) at toy widths and two layers. */
static int reduced_wan(gv_model_config *c)
{
    if (gv_model_config_preset(c, "wan2.1-vace-1.3b") != 0) return -1;
    c->dit.dim = 24, c->dit.ffn_dim = 40, c->dit.num_heads = 2, c->dit.num_layers = 2;
    c->dit.n_vace_layers = 1, c->dit.vace_layers[0] = 0, c->dit.freq_dim = 16, c->dit.text_len = 4;
    c->camera.proj_hidden = 24;
    snprintf(c->name, sizeof c->name, "reduced-wan");
    return gv_model_config_set_variant(c, "camera=none,lora=0", "test");
}

/* Writes the tensors of the list's DiT and VACE modules with values from their names, except
 * `skip`, renaming `rename` to `new_name` and reshaping `reshape`. */
static int write_wan(const char *path, const gv_weight_list *l, const char *skip, const char *rename, const char *new_name,
                     const char *reshape)
{
    gv_st_builder b;
    gv_st_builder_init(&b);
    float *data = calloc(1 << 20, sizeof(float));
    int rc = 0;
    for (int i = 0; rc == 0 && i < l->n; i++) {
        const gv_weight_spec *w = &l->items[i];
        if (gv_module_part(w->module) & GV_PART_VAE || (skip && !strcmp(w->name, skip))) continue;
        int64_t shape[GV_WEIGHT_MAX_RANK];
        memcpy(shape, w->shape, sizeof shape);
        if (reshape && !strcmp(w->name, reshape)) shape[0] += 1;
        float *x = data + (i * 7919) % 1000;
        for (int64_t k = 0; k < w->numel + w->numel / w->shape[0]; k++) x[k] = (float)((k + i) % 13) / 13.0f - 0.5f;
        rc = gv_st_add_f32(&b, rename && !strcmp(w->name, rename) ? new_name : w->name, GV_ST_F32, shape, w->rank, x);
    }
    if (rc == 0) rc = gv_st_write(&b, path);
    gv_st_builder_free(&b);
    free(data);
    return rc;
}

static void test_wan_files(void)
{
    gv_model_config c;
    CHECK(reduced_wan(&c) == 0);
    gv_dit m;
    CHECK(gv_dit_init(&m, &c, 1) == 0);
    char path[512];
    path_in(path, sizeof path, "wan.safetensors");
    const char *paths[1] = {path};
    CHECK(write_wan(path, &m.weights, NULL, NULL, NULL, NULL) == 0);
    CHECK(gv_dit_load(&m, paths, 1, GV_PART_BASE) == 0);
    gv_param *q = gv_params_find(&m.params, "vace_blocks.0.cross_attn.q.weight");
    int idx = -1;
    for (int i = 0; i < m.weights.n; i++)
        if (!strcmp(m.weights.items[i].name, "vace_blocks.0.cross_attn.q.weight")) idx = i;
    CHECK(q && idx >= 0 && q->t.data[5] == (float)((5 + idx) % 13) / 13.0f - 0.5f);
    gv_graph g;
    gv_graph_init(&g, 0);
    mt_inputs in;
    CHECK(mt_make_inputs(&m, &g, NULL, 1, 5, 64, 64, 3, &in) == 0);
    int64_t n = 0;
    float *y = run(&m, &in, &n);
    CHECK(y && n == 16 * 2 * 8 * 8);
    free(y);
    gv_graph_free(&g);
    /* each kind of bad file is refused with the tensor named */
    CHECK(write_wan(path, &m.weights, "blocks.1.norm3.bias", NULL, NULL, NULL) == 0);
    CHECK_FAILS_WITH(gv_dit_load(&m, paths, 1, GV_PART_BASE), "blocks.1.norm3.bias");
    CHECK(write_wan(path, &m.weights, NULL, "head.head.bias", "head.head.beta", NULL) == 0);
    CHECK_FAILS_WITH(gv_dit_load(&m, paths, 1, GV_PART_BASE), "head.head.beta");
    CHECK(write_wan(path, &m.weights, NULL, NULL, NULL, "blocks.0.ffn.2.weight") == 0);
    CHECK_FAILS_WITH(gv_dit_load(&m, paths, 1, GV_PART_BASE), "blocks.0.ffn.2.weight");
    path_in(path, sizeof path, "absent.safetensors");
    CHECK_FAILS_WITH(gv_dit_load(&m, paths, 1, GV_PART_BASE), "absent.safetensors");
    gv_dit_free(&m);
}

/* The published presets: the network binds exactly the names and shapes of the checkpoint
 * lists, for every variant; a list of another config is refused with the tensor named. */
static void test_wan_names(void)
{
    const char *presets[] = {"wan2.1-vace-1.3b", "wan2.1-vace-14b", "small", "tiny"};
    const char *variants[] = {"decomposed", "monolithic", "early", "none,lora=0", "per-frame"};
    for (int p = 0; p < 4; p++)
        for (int v = 0; v < 5; v++) {
            gv_model_config c;
            CHECK(gv_model_config_preset(&c, presets[p]) == 0 && gv_model_config_set_variant(&c, variants[v], "test") == 0);
            gv_clear_error();
            int rc = gv_dit_check_names(&c);
            if (rc) fprintf(stderr, "%s %s: %s\n", presets[p], variants[v], gv_last_error());
            CHECK(rc == 0);
        }
    gv_model_config c, text_free;
    CHECK(gv_model_config_preset(&c, "tiny") == 0);
    text_free = c;
    text_free.dit.cross_attn = 0;
    gv_weight_list l;
    CHECK(gv_weight_list_build(&l, &text_free) == 0);
    gv_dit m;
    memset(&m, 0, sizeof m);
    gv_dit_block blocks[2], vace[2];
    m.blocks = blocks, m.vace_blocks = vace;
    CHECK_FAILS_WITH(gv_dit_bind(&m, &c, &l, NULL, 0), "text_embedding.0.weight");
    gv_weight_list_free(&l);
    CHECK(gv_weight_list_build(&l, &c) == 0);
    c.camera.channels = 5; /* the list says 4 */
    CHECK_FAILS_WITH(gv_dit_bind(&m, &c, &l, NULL, 0), "camera_encoder.conv_m.weight");
    gv_weight_list_free(&l);
}

int main(void)
{
    omp_set_num_threads(2);
    test_zero_b_and_merge();
    test_trainable();
    test_save_load();
    test_wan_files();
    test_wan_names();
    return check_summary();
}
