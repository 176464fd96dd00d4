/* Training runs (train.h, checkpoint.h) with the tiny preset on a few synthetic clips encoded by
 * a tiny random VAE: the loss falls over a few dozen steps on a fixed clip; N steps straight and
 * N/2 + resume + N/2 end with bit-identical weights (pretraining and fine-tuning); every
 * ablation switch changes the result; checkpoints load for inference with their VAE; and bad
 * inputs (corrupt or foreign files, another network, another run's checkpoint) fail with one
 * line naming the file. */
#include "check.h"
#include "model_testutil.h"
#include "test_restore_fixtures.h"
#include "gaussvid/train/checkpoint.h"
#include "gaussvid/train/train.h"
#include "train/train_internal.h"

static const char *tmp;
static char data_dir[4096], vae_path[4200];

static const rf_clip_spec specs[] = {
    {"alpha", "train", 6}, {"alpha", "train", 12}, {"alpha", "train", 26}, {"beta", "train", 6},
    {"beta", "train", 16}, {"gamma", "eval", 6},
};
enum { TRAIN_CLIPS = 5 };

static void path_of(char *out, size_t size, const char *name)
{
    snprintf(out, size, "%s/%s", tmp, name);
}

/* The tiny config with the test VAE's statistics (and a variant), and its training clips. */
static void setup_variant(const char *variant, gv_model_config *cfg, gv_latent_set *set)
{
    gv_vae vae;
    CHECK(gv_model_config_preset(cfg, "tiny") == 0);
    if (variant) CHECK(gv_model_config_set_variant(cfg, variant, "test") == 0);
    CHECK(gv_train_load_vae(vae_path, cfg, &vae) == 0);
    CHECK(cfg->vae.has_latent_stats);
    CHECK(gv_latent_set_load(data_dir, "train", vae_path, &vae, cfg, set) == 0);
    CHECK(set->count == TRAIN_CLIPS);
    gv_vae_free(&vae);
}

static void setup_data(void)
{
    snprintf(data_dir, sizeof data_dir, "%s/clips", tmp);
    path_of(vae_path, sizeof vae_path, "vae.safetensors");
    CHECK(rf_make_dataset(data_dir, specs, (int)(sizeof specs / sizeof specs[0]), 32, 32, 40) == 0);
    gv_model_config cfg;
    gv_vae vae;
    CHECK(rf_tiny(&cfg, &vae, NULL, 5) == 0);
    CHECK(gv_vae_save(&vae, &cfg, vae_path, NULL, NULL, 0) == 0);
    gv_vae_free(&vae);
}

static gv_train_state meta_for(const char *kind, const gv_latent_set *set, const char *base)
{
    gv_train_state s;
    memset(&s, 0, sizeof s);
    snprintf(s.kind, sizeof s.kind, "%s", kind);
    snprintf(s.vae, sizeof s.vae, "%s", vae_path);
    snprintf(s.base, sizeof s.base, "%s", base ? base : "");
    snprintf(s.clips, sizeof s.clips, "%s", data_dir);
    gv_train_data_text(set, "train", s.data, sizeof s.data);
    gv_model_config c;
    gv_vae v;
    CHECK(gv_model_config_preset(&c, "tiny") == 0 && gv_train_load_vae(vae_path, &c, &v) == 0);
    gv_checkpoint_vae_checksum(&v, s.vae_checksum, sizeof s.vae_checksum);
    gv_vae_free(&v);
    return s;
}

/* 1 when every tensor of file a is in file b with the same bytes (and b has no others). */
static int same_tensors(const char *a, const char *b, const char *prefix_only)
{
    gv_st_file fa, fb;
    if (gv_st_open(&fa, a) || gv_st_open(&fb, b)) return 0;
    int same = fa.n_tensors == fb.n_tensors, checked = 0;
    for (int i = 0; same && i < fa.n_tensors; i++) {
        const gv_st_tensor *x = &fa.tensors[i], *y = gv_st_find(&fb, x->name);
        if (prefix_only && strncmp(x->name, prefix_only, strlen(prefix_only))) continue;
        same = y && x->end - x->begin == y->end - y->begin && !memcmp(x->data, y->data, x->end - x->begin);
        checked++;
    }
    gv_st_close(&fa), gv_st_close(&fb);
    return same && checked > 0;
}

/* A tensor of a checkpoint, copied (n floats). */
static float *tensor_of(const char *path, const char *name, int64_t *n)
{
    gv_st_file f;
    if (gv_st_open(&f, path)) return NULL;
    const gv_st_tensor *t = gv_st_find(&f, name);
    float *out = t ? malloc((size_t)t->n_elements * sizeof *out) : NULL;
    if (out) gv_st_tensor_to_f32(&f, t, out), *n = t->n_elements;
    gv_st_close(&f);
    return out;
}

/* ---- pretraining ---------------------------------------------------------------------------- */
static void pretrain(const char *out, long stop_after, int resume, gv_train_report *r)
{
    gv_model_config cfg, pre;
    gv_latent_set set;
    setup_variant(NULL, &cfg, &set);
    pre = cfg;
    pre.lora.rank = 0; /* the base is trained without adapters */
    gv_dit m;
    CHECK(gv_dit_init(&m, &pre, 1) == 0 && gv_dit_set_train_mode(&m, GV_DIT_FULL) == 0);
    gv_train_options o;
    gv_train_defaults(&o, GV_OBJECTIVE_PRETRAIN);
    o.steps = 6, o.batch = 2, o.lr = 1e-3, o.warmup = 2, o.min_lr = 1e-4, o.checkpoint_every = 2;
    o.stop_after = stop_after, o.resume = resume, o.out = out, o.seed = 3;
    o.render_context = 0.5; /* both contexts, so that resuming covers the draw */
    gv_train_state meta = meta_for("base", &set, NULL);
    CHECK(gv_train_run(&m, &cfg, &set, &o, &meta, r) == 0);
    gv_dit_free(&m);
    gv_latent_set_free(&set);
}

static void test_pretrain_resume(void)
{
    char a[4200], b[4200], b_ckpt[4300];
    path_of(a, sizeof a, "base.safetensors");
    path_of(b, sizeof b, "base_resumed.safetensors");
    snprintf(b_ckpt, sizeof b_ckpt, "%s.ckpt", b);
    gv_train_report r;
    pretrain(a, 0, 0, &r);
    CHECK(r.start_step == 0 && r.end_step == 6 && r.clips_used == 12 && r.clips_skipped == 0);
    CHECK(gv_file_exists(a));
    pretrain(b, 3, 0, &r); /* interrupted after step 3 */
    CHECK(!gv_file_exists(b) && gv_file_exists(b_ckpt) && r.end_step == 3);
    gv_model_config c;
    gv_train_state s;
    CHECK(gv_checkpoint_read_info(b_ckpt, &c, &s) == 0);
    CHECK(s.step == 3 && s.steps == 6 && s.data_position == 6 && s.adamw_step == 3 && !strcmp(s.kind, "base"));
    CHECK(c.lora.rank == 2); /* the base keeps the config fine-tuning will use */
    pretrain(b, 0, 1, &r);
    CHECK(r.start_step == 3 && r.end_step == 6 && gv_file_exists(b));
    CHECK(same_tensors(a, b, NULL)); /* bit for bit */
    char a_ckpt[4300];
    snprintf(a_ckpt, sizeof a_ckpt, "%s.ckpt", a);
    CHECK(same_tensors(a_ckpt, b_ckpt, "adamw.")); /* the moments too */
}

/* ---- fine-tuning ------------------------------------------------------------------------------ */
typedef struct {
    const char *variant;
    int curriculum, progressive;
    long latent_warmup, steps, stop_after;
    int resume;
    double lr;
    const char *val_log;         /* validate on the eval split, logging here (NULL: no validation) */
} ft_case;

static int finetune(const char *base, const char *out, const ft_case *k, gv_train_report *r)
{
    gv_model_config cfg;
    gv_latent_set set;
    setup_variant(k->variant, &cfg, &set);
    gv_dit m;
    int camera_loaded = -1;
    CHECK(gv_dit_init(&m, &cfg, 2) == 0);
    int rc = gv_checkpoint_load_base(base, &m, 1, &camera_loaded);
    if (rc == 0) rc = gv_dit_set_train_mode(&m, GV_DIT_FINETUNE);
    gv_train_options o;
    gv_train_defaults(&o, GV_OBJECTIVE_FINETUNE);
    o.steps = k->steps, o.batch = 2, o.lr = k->lr > 0 ? k->lr : 1e-3, o.checkpoint_every = 2;
    o.curriculum = k->curriculum, o.progressive = k->progressive, o.latent_warmup = k->latent_warmup;
    o.stop_after = k->stop_after, o.resume = k->resume, o.out = out, o.seed = 4;
    gv_latent_set val;
    memset(&val, 0, sizeof val);
    if (k->val_log) {
        CHECK(gv_train_load_val(data_dir, vae_path, &cfg, &val) == 0 && val.count == 1);
        o.val = &val, o.val_every = 2, o.val_log = k->val_log;
    }
    gv_train_state meta = meta_for("finetune", &set, base);
    if (rc == 0) rc = gv_train_run(&m, &cfg, &set, &o, &meta, r);
    gv_dit_free(&m);
    gv_latent_set_free(&set);
    gv_latent_set_free(&val);
    return rc;
}

/* A stand-in pretrained base: the tiny network with random weights of a trained scale. */
static void write_random_base(const char *path)
{
    gv_model_config cfg;
    gv_latent_set set;
    setup_variant(NULL, &cfg, &set);
    gv_dit m;
    CHECK(gv_dit_init(&m, &cfg, 7) == 0);
    mt_randomize(&m, MT_BASE | (1u << GV_MODULE_CAMERA), 12);
    for (int i = 0; i < m.params.n; i++) /* fresh adapters: B = 0 */
        if (strstr(m.params.items[i]->t.name, "lora_B")) memset(m.params.items[i]->t.data, 0, (size_t)m.params.items[i]->t.numel * 4);
    gv_train_state meta = meta_for("base", &set, NULL);
    CHECK(gv_checkpoint_save(path, &m, &cfg, &meta, 0) == 0);
    gv_dit_free(&m);
    gv_latent_set_free(&set);
}

static void test_finetune_resume(const char *base)
{
    char a[4200], b[4200];
    path_of(a, sizeof a, "ft.safetensors");
    path_of(b, sizeof b, "ft_resumed.safetensors");
    gv_train_report r;
    ft_case k = {NULL, 1, 1, 1, 6, 0, 0, 0, NULL};
    CHECK(finetune(base, a, &k, &r) == 0);
    CHECK(r.clips_skipped > 0); /* the curriculum passed over hard clips early on */
    k.stop_after = 3;
    CHECK(finetune(base, b, &k, &r) == 0 && r.end_step == 3);
    k.stop_after = 0, k.resume = 1;
    CHECK(finetune(base, b, &k, &r) == 0 && r.start_step == 3 && r.end_step == 6);
    CHECK(same_tensors(a, b, NULL));
    /* the fine-tuned checkpoint holds the base weights unchanged and trained adapters */
    int64_t n1 = 0, n2 = 0, n3 = 0;
    float *w_base = tensor_of(base, "blocks.0.ffn.0.weight", &n1), *w_ft = tensor_of(a, "blocks.0.ffn.0.weight", &n2);
    float *lb = tensor_of(a, "blocks.0.self_attn.q.lora_B.weight", &n3);
    CHECK(w_base && w_ft && n1 == n2 && !memcmp(w_base, w_ft, (size_t)n1 * 4));
    double mx = 0;
    for (int64_t i = 0; lb && i < n3; i++) mx = fmax(mx, fabs(lb[i]));
    CHECK(mx > 0);
    free(w_base), free(w_ft), free(lb);
    /* resuming with other options or other clips is refused, naming the checkpoint */
    char b_ckpt[4300];
    snprintf(b_ckpt, sizeof b_ckpt, "%s.ckpt", b);
    k.lr = 2e-3;
    CHECK_FAILS_WITH(finetune(base, b, &k, &r), "other training options");
    k.lr = 0;
    k.variant = "camera=monolithic";
    CHECK_FAILS_WITH(finetune(base, b, &k, &r), "another model config");
}

/* The loss at fixed draws, and a few dozen steps on one clip. */
static double fixed_loss(gv_dit *m, const gv_clip_latents *l)
{
    gv_graph g;
    gv_graph_init(&g, 0);
    int64_t n = gv_clip_latents_z_count(l);
    float *eps = malloc((size_t)n * sizeof *eps);
    double sum = 0;
    for (int k = 0; k < 6; k++) {
        gv_fill_normal(eps, n, 500 + (uint64_t)k, 0, 0.0f, 1.0f);
        gv_sample_draw d = {0.04f + 0.08f * k, 1.0, 1.0, 0.0, 0};
        gv_sample_losses s;
        CHECK(gv_train_sample(m, &g, l, GV_OBJECTIVE_FINETUNE, &d, eps, 1.0, 0, &s) == 0);
        sum += s.fm / 6;
    }
    free(eps);
    gv_graph_free(&g);
    return sum;
}

static void test_loss_decreases(const char *base)
{
    gv_model_config cfg;
    gv_latent_set set;
    setup_variant(NULL, &cfg, &set);
    gv_latent_set one = set;
    one.count = 1; /* a fixed clip: every step trains on it */
    gv_dit m;
    int cam = 0;
    CHECK(gv_dit_init(&m, &cfg, 2) == 0 && gv_checkpoint_load_base(base, &m, 1, &cam) == 0 && cam == 1);
    CHECK(gv_dit_set_train_mode(&m, GV_DIT_FINETUNE) == 0);
    double before = fixed_loss(&m, &one.clips[0]);
    gv_train_options o;
    gv_train_defaults(&o, GV_OBJECTIVE_FINETUNE);
    char out[4200];
    path_of(out, sizeof out, "fixed.safetensors");
    o.steps = 40, o.batch = 1, o.lr = 1e-2, o.curriculum = 0, o.progressive = 0, o.out = out, o.checkpoint_every = 40;
    gv_train_state meta = meta_for("finetune", &one, base);
    gv_train_report r;
    CHECK(gv_train_run(&m, &cfg, &one, &o, &meta, &r) == 0);
    double after = fixed_loss(&m, &one.clips[0]);
    printf("fixed clip: velocity loss %.4f before, %.4f after 40 steps (%.1f clips/s, arena peak %.1f MiB)\n", before,
           after, r.clips_per_second, r.arena_peak / 1048576.0);
    CHECK(after < 0.8 * before);
    gv_dit_free(&m);
    gv_latent_set_free(&set);
}

/* --relative-loss weights on hand-made clips of known identity loss: constant latent errors of
 * 0.1 and 0.2 (identities 0.01 and 0.04) and none (floored at 1e-3 of the mean, 0.05 / 3). */
static void test_relative_weights(void)
{
    enum { N = 24 };
    gv_clip_latents clips[3];
    float clean[3][N], corrupt[3][N];
    const float err[3] = {0.1f, 0.2f, 0.0f};
    for (int c = 0; c < 3; c++) {
        memset(&clips[c], 0, sizeof clips[c]);
        clips[c].batch = 1, clips[c].z_dim = 2, clips[c].latent_frames = 3, clips[c].lh = 2, clips[c].lw = 2;
        for (int i = 0; i < N; i++) clean[c][i] = 0.5f * (float)(i % 5), corrupt[c][i] = clean[c][i] + (i % 2 ? err[c] : -err[c]);
        clips[c].z_clean = clean[c], clips[c].z_corrupt = corrupt[c];
    }
    gv_latent_set set = {.count = 3, .clips = clips};
    double *w = NULL;
    CHECK(gv_train_relative_weights(&set, &w) == 0 && w);
    double floor_id = 1e-3 * (0.01 + 0.04 + 0.0) / 3, inv[3] = {1 / 0.01, 1 / 0.04, 1 / floor_id};
    double mean = (inv[0] + inv[1] + inv[2]) / 3;
    for (int c = 0; c < 3; c++) CHECK_NEAR(w[c], inv[c] / mean, 1e-6 * inv[c] / mean);
    CHECK_NEAR(w[0] / w[1], 4.0, 1e-5);
    free(w);
}

static double max_abs(const gv_dit *m, const char *name)
{
    const gv_param *p = gv_params_find(&m->params, name);
    double mx = -1;
    for (int64_t i = 0; p && i < p->t.numel; i++) mx = fmax(mx, fabs(p->t.data[i]));
    return mx;
}

/* What fine-tuning starts from: the base's camera encoder, or its fresh initialisation with
 * take_camera 0 (--fresh-camera); the base's output layer, or zeros in the residual variant,
 * which therefore starts as the identity restorer. */
static void test_base_start(const char *base)
{
    gv_model_config cfg, res;
    gv_latent_set set;
    setup_variant(NULL, &cfg, &set);
    gv_dit a, fresh, r;
    int cam = -1;
    CHECK(gv_dit_init(&a, &cfg, 2) == 0 && gv_dit_init(&fresh, &cfg, 2) == 0);
    CHECK(gv_checkpoint_load_base(base, &a, 0, &cam) == 0 && cam == 0);
    const char *camera_w = NULL;
    for (int i = 0; i < a.params.n && !camera_w; i++)
        if (gv_weight_list_find(&a.weights, a.params.items[i]->t.name)->module == GV_MODULE_CAMERA &&
            max_abs(&a, a.params.items[i]->t.name) > 0)
            camera_w = a.params.items[i]->t.name;
    CHECK(camera_w != NULL);
    const gv_param *pa = gv_params_find(&a.params, camera_w), *pf = gv_params_find(&fresh.params, camera_w);
    CHECK(pa && pf && !memcmp(pa->t.data, pf->t.data, (size_t)pa->t.numel * sizeof(float)));
    CHECK(max_abs(&a, "head.head.weight") > 0); /* the base's (random) head */
    res = cfg;
    CHECK(gv_model_config_set_variant(&res, "residual", "test") == 0);
    CHECK(gv_dit_init(&r, &res, 2) == 0 && gv_checkpoint_load_base(base, &r, 1, &cam) == 0 && cam == 1);
    CHECK(max_abs(&r, "head.head.weight") == 0 && max_abs(&r, "head.head.bias") == 0);
    CHECK(gv_dit_set_train_mode(&r, GV_DIT_FINETUNE) == 0 && gv_params_find(&r.params, "head.head.weight")->trainable);
    gv_dit_free(&a), gv_dit_free(&fresh), gv_dit_free(&r);
    gv_latent_set_free(&set);
}

/* Validation: the residual variant starts as the identity, so its loss is the identity's, which
 * is mean (z0* - z-hat)^2 computed here independently; the per-n groups average to the whole;
 * the draws are fixed; and validating during a run leaves its trajectory bit for bit alone. */
static void test_validation(const char *base)
{
    gv_model_config cfg;
    gv_latent_set set;
    setup_variant("residual", &cfg, &set);
    gv_dit m;
    int cam = -1;
    CHECK(gv_dit_init(&m, &cfg, 2) == 0 && gv_checkpoint_load_base(base, &m, 1, &cam) == 0);
    gv_graph g;
    gv_graph_init(&g, 0);
    gv_validation v, again;
    CHECK(gv_train_validate(&m, &g, &set, 0.48, &v) == 0);
    CHECK(v.groups == 4 && v.all_clips == TRAIN_CLIPS); /* n = 6, 12, 26, 16 */
    double id_all = 0, from_groups = 0;
    for (int i = 0; i < set.count; i++) {
        const gv_clip_latents *l = &set.clips[i];
        int64_t n = gv_clip_latents_z_count(l);
        double sum = 0;
        for (int64_t j = 0; j < n; j++) sum += ((double)l->z_clean[j] - l->z_corrupt[j]) * (l->z_clean[j] - l->z_corrupt[j]);
        id_all += sum / (double)n / set.count;
    }
    for (int k = 0; k < v.groups; k++) {
        CHECK_NEAR(v.loss[k], v.identity[k], 1e-5 * v.identity[k]);
        CHECK_NEAR(v.gain_db[k], 0, 1e-4); /* 10 log10(identity / loss) of the identity */
        from_groups += v.loss[k] * v.clips[k] / v.all_clips;
    }
    CHECK(v.intervals[0] == 6 && v.clips[0] == 2);
    CHECK_NEAR(v.all_identity, id_all, 1e-12);
    CHECK_NEAR(v.all_loss, from_groups, 1e-12);
    CHECK(v.all_identity > 0);
    CHECK(gv_train_validate(&m, &g, &set, 0.48, &again) == 0 && again.all_loss == v.all_loss);
    gv_graph_free(&g);
    gv_dit_free(&m);
    gv_latent_set_free(&set);

    char a[4200], b[4200], log[4200];
    path_of(a, sizeof a, "val_off.safetensors");
    path_of(b, sizeof b, "val_on.safetensors");
    path_of(log, sizeof log, "val.tsv");
    ft_case k = {"residual", 1, 1, 1, 4, 0, 0, 0, NULL};
    gv_train_report r;
    CHECK(finetune(base, a, &k, &r) == 0);
    k.val_log = log;
    CHECK(finetune(base, b, &k, &r) == 0);
    CHECK(same_tensors(a, b, NULL));
    FILE *f = fopen(log, "r");
    char line[256];
    int rows = 0, steps_ok = 1;
    long step;
    double loss = 0, identity = 0, gain = 0;
    CHECK(f && fgets(line, sizeof line, f) && !strcmp(line, "step\tn\tclips\tloss\tidentity\tgain_db\n"));
    while (f && fgets(line, sizeof line, f)) {
        int n, clips;
        if (sscanf(line, "%ld\t%d\t%d\t%lf\t%lf\t%lf", &step, &n, &clips, &loss, &identity, &gain) == 6) {
            steps_ok &= step == 2 * (rows / 2) && n == 6 && clips == 1; /* a row per n, then "all" */
        } else {
            CHECK(sscanf(line, "%ld\tall\t%d\t%lf\t%lf\t%lf", &step, &clips, &loss, &identity, &gain) == 5);
        }
        CHECK_NEAR(gain, 10 * log10(identity / loss), 1e-3); /* one clip: the mean is its own */
        if (rows == 1) CHECK_NEAR(loss, identity, 1e-5 * identity); /* step 0: the identity */
        rows++;
    }
    if (f) fclose(f);
    CHECK(rows == 6 && steps_ok && step == 4); /* steps 0, 2 and 4 */
    CHECK(fabs(loss - identity) > 1e-6 * identity); /* trained: no longer the identity */
}

/* Every switch of the ablations changes what is trained. */
static void test_ablation_switches(const char *base)
{
    const ft_case cases[] = {
        {NULL, 1, 1, 1, 4, 0, 0, 0, NULL},           /* ours */
        {NULL, 0, 1, 1, 4, 0, 0, 0, NULL},           /* shuffle instead of the curriculum */
        {NULL, 1, 0, 1, 4, 0, 0, 0, NULL},           /* no progressive latent loss */
        {"camera=none", 1, 1, 1, 4, 0, 0, 0, NULL},
        {"camera=early", 1, 1, 1, 4, 0, 0, 0, NULL},
        {"camera=monolithic", 1, 1, 1, 4, 0, 0, 0, NULL},
        {"anchors=first", 1, 1, 1, 4, 0, 0, 0, NULL},
        {"anchors=none", 1, 1, 1, 4, 0, 0, 0, NULL},
        {"per-frame", 1, 1, 1, 4, 0, 0, 0, NULL},
        {NULL, 1, 1, 4, 4, 0, 0, 0, NULL},           /* S_w = S: the latent loss never switches on */
    };
    enum { N = sizeof cases / sizeof cases[0] };
    float *w[N];
    int64_t n[N];
    double first[N];
    for (int i = 0; i < N; i++) {
        char out[4200], name[64];
        snprintf(name, sizeof name, "ablation_%d.safetensors", i);
        path_of(out, sizeof out, name);
        gv_train_report r;
        CHECK(finetune(base, out, &cases[i], &r) == 0);
        first[i] = r.first_loss;
        w[i] = tensor_of(out, "blocks.1.ffn.2.lora_B.weight", &n[i]);
        CHECK(w[i] != NULL);
    }
    int distinct = 1;
    for (int i = 0; i < N - 1; i++)
        for (int j = i + 1; j < N - 1; j++)
            if (w[i] && w[j] && n[i] == n[j] && !memcmp(w[i], w[j], (size_t)n[i] * 4)) {
                printf("ablation cases %d and %d trained the same weights\n", i, j);
                distinct = 0;
            }
    CHECK(distinct);
    /* the progressive loss acts only through its weight: with S_w = S it is the same as off */
    CHECK(w[2] && w[N - 1] && !memcmp(w[2], w[N - 1], (size_t)n[2] * 4));
    CHECK(first[0] == first[2]);           /* step 0: the latent loss is still warming up */
    CHECK(first[0] != first[1]);           /* the curriculum chose other clips */
    for (int i = 0; i < N; i++) free(w[i]);
}

/* ---- checkpoints for inference, bad inputs ---------------------------------------------------- */
static void copy_file(const char *from, const char *to)
{
    char *data;
    size_t size;
    CHECK(gv_read_file(from, &data, &size) == 0);
    FILE *f = fopen(to, "wb");
    CHECK(f && fwrite(data, 1, size, f) == size);
    if (f) fclose(f);
    free(data);
}

static void test_checkpoint_load(void)
{
    char ft[4200], moved_dir[4200], moved[4300], moved_vae[4300], bad[4200];
    path_of(ft, sizeof ft, "ft.safetensors");
    gv_restorer r;
    CHECK(gv_restorer_load(ft, &r) == 0);
    CHECK(r.net.mode == GV_DIT_FROZEN && r.cfg.vae.has_latent_stats && r.vae.has_stats && !strcmp(r.vae_path, vae_path));
    CHECK(!strcmp(r.state.kind, "finetune"));
    int64_t n = 0;
    float *lb = tensor_of(ft, "blocks.0.self_attn.q.lora_B.weight", &n);
    gv_param *p = gv_params_find(&r.net.params, "blocks.0.self_attn.q.lora_B.weight");
    CHECK(lb && p && p->t.numel == n && !memcmp(p->t.data, lb, (size_t)n * 4));
    free(lb);
    gv_vae orig;
    gv_model_config c0;
    CHECK(gv_model_config_preset(&c0, "tiny") == 0 && gv_train_load_vae(vae_path, &c0, &orig) == 0);
    CHECK(gv_vae_checksum(&orig) == gv_vae_checksum(&r.vae));
    gv_vae_free(&orig);
    gv_restorer_free(&r);
    /* moved with its VAE into another folder: the VAE is found beside the checkpoint */
    path_of(moved_dir, sizeof moved_dir, "moved");
    CHECK(gv_mkdirs(moved_dir) == 0);
    snprintf(moved, sizeof moved, "%s/ft.safetensors", moved_dir);
    snprintf(moved_vae, sizeof moved_vae, "%s/vae.safetensors", moved_dir);
    copy_file(ft, moved);
    copy_file(vae_path, moved_vae);
    char hidden[4300];
    snprintf(hidden, sizeof hidden, "%s.hidden", vae_path);
    CHECK(rename(vae_path, hidden) == 0);
    CHECK(gv_restorer_load(moved, &r) == 0 && !strcmp(r.vae_path, moved_vae));
    gv_restorer_free(&r);
    CHECK_FAILS_WITH(gv_restorer_load(ft, &r), "is not found");
    /* another VAE under that name */
    gv_model_config c;
    gv_vae other;
    CHECK(rf_tiny(&c, &other, NULL, 6) == 0 && gv_vae_save(&other, &c, vae_path, NULL, NULL, 0) == 0);
    gv_vae_free(&other);
    CHECK_FAILS_WITH(gv_restorer_load(ft, &r), "not the one it was trained with");
    CHECK(rename(hidden, vae_path) == 0);
    /* a truncated file, a file that is no checkpoint */
    char *data;
    size_t size;
    CHECK(gv_read_file(ft, &data, &size) == 0);
    path_of(bad, sizeof bad, "truncated.safetensors");
    FILE *f = fopen(bad, "wb");
    fwrite(data, 1, size / 2, f);
    fclose(f);
    free(data);
    CHECK_FAILS_WITH(gv_restorer_load(bad, &r), "truncated.safetensors");
    CHECK_FAILS_WITH(gv_restorer_load(vae_path, &r), "not a gaussvid checkpoint");
    path_of(bad, sizeof bad, "missing.safetensors");
    CHECK_FAILS_WITH(gv_restorer_load(bad, &r), "missing.safetensors");
    /* a base of another network */
    gv_model_config wide;
    CHECK(gv_model_config_preset(&wide, "tiny") == 0);
    wide.dit.dim = 48, wide.camera.proj_hidden = 48;
    CHECK(gv_model_config_validate(&wide, "test") == 0);
    CHECK(gv_dit_init(&r.net, &wide, 1) == 0);
    int cam;
    CHECK_FAILS_WITH(gv_checkpoint_load_base(ft, &r.net, 1, &cam), "another network");
    gv_dit_free(&r.net);
}

int main(void)
{
    tmp = check_tmp_dir();
    setup_data();
    char base[4200];
    path_of(base, sizeof base, "random_base.safetensors");
    test_pretrain_resume();
    write_random_base(base);
    test_finetune_resume(base);
    test_loss_decreases(base);
    test_relative_weights();
    test_base_start(base);
    test_validation(base);
    test_ablation_switches(base);
    test_checkpoint_load();
    return check_summary();
}
