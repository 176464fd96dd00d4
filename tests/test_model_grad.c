/* Full-network gradient checks of the tiny preset against central finite differences, for
 * every variant (camera none / early / monolithic / decomposed, the joint-mask reference form,
 * the per-frame restorer) and for fine-tuning (only LoRA and the camera encoder trainable):
 * a few random elements of every tensor and of the inputs (latent, text, VACE context, ray
 * field). All tensors are random first, so the zero-initialised paths carry gradient too. */
#include <omp.h>

#include "check.h"
#include "model_testutil.h"
#include "nn_testutil.h"

/* The sanitizer build (about 20x slower) checks every 4th tensor: it is there for memory
 * errors, which every forward and backward path still exercises; the full list runs in the
 * normal build. */
#if defined(__SANITIZE_ADDRESS__)
#define TENSOR_STRIDE 4
#else
#define TENSOR_STRIDE 1
#endif

typedef struct {
    gv_dit *m;
    mt_inputs in;
} ctx;

static gv_tensor *build(gv_graph *g, void *p)
{
    ctx *c = p;
    gv_dit_inputs d = mt_dit_inputs(&c->in);
    return gv_dit_forward(c->m, g, &d);
}

static void check_variant(const char *label, const char *variant, int joint, gv_dit_train_mode mode, int frames,
                          int batch, int per_tensor)
{
    gv_dit m;
    CHECK(mt_model(&m, variant, 5) == 0);
    mt_randomize(&m, MT_ALL, 6);
    m.joint_attention = joint;
    CHECK(gv_dit_set_train_mode(&m, mode) == 0);
    ctx c = {&m, {0}};
    /* the inputs are trainable "parameters" of the same registry, so they are checked too */
    CHECK(mt_make_inputs(&m, NULL, &m.params, batch, frames, 32, 32, 7, &c.in) == 0);
    if (mode == GV_DIT_FINETUNE) /* inputs stay variables; the base is frozen */
        for (int i = 0; i < m.params.n; i++) {
            gv_param *p = m.params.items[i];
            const gv_weight_spec *s = gv_weight_list_find(&m.weights, p->t.name);
            if (s) CHECK(p->trainable == s->trainable && (p->t.grad != NULL) == s->trainable);
        }
    for (int i = 0; i < m.params.n; i++)
        if (i % TENSOR_STRIDE && strncmp(m.params.items[i]->t.name, "input.", 6)) gv_param_set_trainable(m.params.items[i], 0);
    gv_gradcheck_opts o = gv_gradcheck_defaults();
    o.max_per_tensor = per_tensor;
    o.h = 1e-2;
    o.seed = 3;
    nt_gradcheck(label, &m.params, build, &c, &o);
    gv_dit_free(&m);
}

int main(void)
{
    omp_set_num_threads(1); /* tiny shapes: threads only add synchronisation */
    check_variant("decomposed (full)", "decomposed", 0, GV_DIT_FULL, 5, 2, 2);
    check_variant("decomposed (fine-tuning)", "decomposed", 0, GV_DIT_FINETUNE, 5, 1, 3);
    check_variant("decomposed, joint mask", "decomposed", 1, GV_DIT_FULL, 5, 1, 1);
    check_variant("monolithic", "monolithic", 0, GV_DIT_FULL, 5, 1, 1);
    check_variant("early fusion", "early", 0, GV_DIT_FULL, 5, 1, 1);
    check_variant("camera none, anchors first", "camera=none,anchors=first", 0, GV_DIT_FULL, 5, 1, 1);
    check_variant("per-frame restorer", "per-frame", 0, GV_DIT_FULL, 1, 2, 1);
    return check_summary();
}
