/* LoRA in the DiT (docs/ARCHITECTURE.md 6.7): adapters of rank r on the targeted linear layers of the main
 * and VACE blocks (q, k, v, o and the FFN by default), y = x W^T + b + (alpha / r) (x A^T) B^T
 * with B zero-initialised; what is trainable in each mode; merging adapters into the base. */
#include "model/dit_internal.h"
#include "gaussvid/core/core.h"

gv_tensor *gv_dit_lin(gv_graph *g, const gv_dit *m, const gv_dit_linear *l, gv_tensor *x)
{
    if (!l->lora_a || m->lora_merged) return gv_linear(g, x, l->w, l->b);
    if (m->lora_scale != 1.0f) return gv_lora_linear(g, x, l->w, l->b, l->lora_a, l->lora_b, m->lora_scale);
    /* alpha = r (the default, as PEFT in the authors' code): the same sum without a pass that
     * multiplies the update by 1 */
    return gv_add(g, gv_linear(g, x, l->w, l->b), gv_linear(g, gv_linear(g, x, l->lora_a, NULL), l->lora_b, NULL));
}

int gv_dit_set_train_mode(gv_dit *m, gv_dit_train_mode mode)
{
    for (int i = 0; i < m->params.n; i++) {
        gv_param *p = m->params.items[i];
        const gv_weight_spec *s = gv_weight_list_find(&m->weights, p->t.name);
        int is_lora = s && s->module == GV_MODULE_LORA;
        int trainable = mode == GV_DIT_FULL || (mode == GV_DIT_FINETUNE && s && s->trainable);
        if (is_lora && m->lora_merged) trainable = 0; /* folded into the base: no longer used */
        if (gv_param_set_trainable(p, trainable) != 0) return -1;
    }
    m->mode = mode;
    return 0;
}

/* Every linear layer of a block that may carry an adapter. */
static int block_linears(gv_dit_block *b, gv_dit_linear **out)
{
    gv_dit_linear *all[] = {&b->q, &b->k, &b->v, &b->o, &b->cq, &b->ck, &b->cv, &b->co,
                            &b->ffn0, &b->ffn2, &b->before_proj, &b->after_proj};
    int n = 0;
    for (int i = 0; i < (int)(sizeof all / sizeof all[0]); i++)
        if (all[i]->lora_a) out[n++] = all[i];
    return n;
}

static int merge_block(gv_dit *m, gv_dit_block *b)
{
    gv_dit_linear *l[12];
    int n = block_linears(b, l);
    for (int i = 0; i < n; i++) {
        gv_param *w = gv_params_of(&m->params, l[i]->w);
        if (!w || gv_param_materialize(w) != 0) return -1; /* a BF16 weight changes: float32 from now */
        if (gv_lora_merge(l[i]->w, l[i]->lora_a, l[i]->lora_b, m->lora_scale) != 0) return -1;
    }
    return 0;
}

int gv_dit_merge_lora(gv_dit *m)
{
    if (m->lora_merged) return gv_fail("%s: LoRA adapters are already merged", m->cfg.name);
    for (int i = 0; i < m->cfg.dit.num_layers; i++)
        if (merge_block(m, &m->blocks[i]) != 0) return -1;
    for (int j = 0; j < m->cfg.dit.n_vace_layers; j++)
        if (merge_block(m, &m->vace_blocks[j]) != 0) return -1;
    m->lora_merged = 1;
    return gv_dit_set_train_mode(m, m->mode);
}
