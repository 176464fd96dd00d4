/* Per-scene adaptation, the training side (scene_adapt.h): which internal clips are held
 * back; scene checkpoints holding the adapters alone, loaded over their base by
 * gv_restorer_load (found as written or beside the scene checkpoint, checked by checksum),
 * with their record; the bare adapter files of the best step. Tiny preset, random weights. */
#include "check.h"
#include "model_testutil.h"
#include "gaussvid/train/scene_adapt.h"

/* A latent set of `count` named clips (no arrays: the split only moves entries). */
static void names_set(gv_latent_set *s, int count)
{
    memset(s, 0, sizeof *s);
    s->clips = calloc((size_t)count, sizeof *s->clips);
    s->names = calloc((size_t)count, sizeof *s->names);
    for (int i = 0; i < count; i++) {
        char name[32];
        snprintf(name, sizeof name, "c%02d", i);
        s->names[i] = strdup(name);
        s->clips[i].interval = i; /* a tag to follow the entry */
    }
    s->count = count;
}

static void test_hold_back(void)
{
    const int counts[4] = {3, 5, 8, 25}, held_want[4] = {1, 2, 3, 8};
    for (int k = 0; k < 4; k++) {
        gv_latent_set all, train, held;
        names_set(&all, counts[k]);
        CHECK(gv_latent_set_hold_back(&all, 3, &train, &held) == 0);
        CHECK(all.count == 0 && held.count == held_want[k] && train.count == counts[k] - held_want[k]);
        for (int i = 0; i < held.count; i++) {
            char want[32];
            snprintf(want, sizeof want, "c%02d", 1 + 3 * i);
            CHECK(held.clips[i].interval == 1 + 3 * i && !strcmp(held.names[i], want));
        }
        int ok = 1;
        for (int i = 0; i < train.count; i++) ok &= train.clips[i].interval % 3 != 1;
        CHECK(ok);
        gv_latent_set_free(&train), gv_latent_set_free(&held), gv_latent_set_free(&all);
    }
    gv_latent_set one, train, held;
    names_set(&one, 1);
    CHECK_FAILS_WITH(gv_latent_set_hold_back(&one, 3, &train, &held), "1 internal clips cannot be split");
    gv_latent_set_free(&one);
}

/* The joined view: a's clips then b's, b's names prefixed, the clips shared (the sets still
 * own them: freeing the view first, then the sets, frees each once, as ASan checks). */
static void test_join(void)
{
    gv_latent_set a, b, view;
    names_set(&a, 3);
    names_set(&b, 2);
    CHECK(gv_latent_set_join(&a, &b, "harm/", &view) == 0);
    CHECK(view.count == 5 && !strcmp(view.names[0], "c00") && !strcmp(view.names[2], "c02"));
    CHECK(!strcmp(view.names[3], "harm/c00") && !strcmp(view.names[4], "harm/c01"));
    CHECK(view.clips[1].interval == 1 && view.clips[3].interval == 0 && view.clips[4].interval == 1);
    gv_latent_set_view_free(&view);
    CHECK(view.count == 0 && a.count == 3 && !strcmp(a.names[2], "c02"));
    gv_latent_set_free(&a), gv_latent_set_free(&b);
}

/* Largest |a - b| over the tensors of two networks whose names match `adapters` (1: the
 * adapters, 0: the rest). */
static double max_diff(const gv_dit *a, const gv_dit *b, int adapters)
{
    double d = 0;
    for (int i = 0; i < a->params.n; i++) {
        const gv_tensor *x = &a->params.items[i]->t, *y = &b->params.items[i]->t;
        const gv_weight_spec *s = gv_weight_list_find(&a->weights, x->name);
        if (!s || !s->trainable != !adapters) continue;
        for (int64_t j = 0; j < x->numel; j++) d = fmax(d, fabs((double)x->data[j] - y->data[j]));
    }
    return d;
}

static void test_scene_checkpoint(const char *tmp)
{
    gv_dit base, tuned;
    CHECK(mt_model(&base, NULL, 3) == 0 && mt_model(&tuned, NULL, 3) == 0);
    mt_randomize(&base, MT_ALL, 5);
    mt_randomize(&tuned, MT_ALL, 5);
    mt_randomize(&tuned, 1u << GV_MODULE_LORA | 1u << GV_MODULE_CAMERA, 9); /* fine-tuned adapters */
    gv_train_state st;
    memset(&st, 0, sizeof st);
    snprintf(st.kind, sizeof st.kind, "finetune");
    st.step = st.steps = 4;
    char dir[4200], base_path[4400], scene_path[4400];
    snprintf(dir, sizeof dir, "%s/a", tmp);
    gv_mkdirs(dir);
    snprintf(base_path, sizeof base_path, "%s/base.safetensors", dir);
    snprintf(scene_path, sizeof scene_path, "%s/scene.safetensors", dir);
    /* the base names its VAE (gv_restorer_load loads it with the network) */
    char vae_path[4400];
    snprintf(vae_path, sizeof vae_path, "%s/vae.safetensors", dir);
    gv_vae vae;
    CHECK(gv_vae_init(&vae, &base.cfg, 0, 7) == 0 && gv_vae_save(&vae, &base.cfg, vae_path, NULL, NULL, 0) == 0);
    gv_vae_free(&vae);
    snprintf(st.vae, sizeof st.vae, "%s", vae_path);
    CHECK(gv_checkpoint_save(base_path, &base, &base.cfg, &st, 0) == 0);
    gv_scene_adaptation a;
    memset(&a, 0, sizeof a);
    snprintf(a.scene, sizeof a.scene, "room");
    a.interval = 16, a.iters = 3000, a.train_clips = 5, a.held_back = 3, a.best_step = 150;
    a.val_gain_db = 0.125, a.gate_open = 0, a.gate_margin_db = 0.05, a.gate_frames = 3;
    a.gate_psnr_base = 30.5, a.gate_psnr_restored = 30.25, a.seconds_train = 12.5;
    a.harm_max_loss_db = 0.05, a.harm_frames = 3, a.harm_psnr_base = 38.5, a.harm_psnr_restored = 38.375;
    snprintf(a.gate_sampler, sizeof a.gate_sampler, "onestep t0=0.05");
    snprintf(a.gate_compose, sizeof a.gate_compose, "unseen");
    CHECK(gv_file_checksum(base_path, a.base_checksum, sizeof a.base_checksum) == 0);
    snprintf(st.base, sizeof st.base, "%s", base_path);
    CHECK(gv_scene_checkpoint_save(scene_path, &tuned, &tuned.cfg, &st, &a) == 0);

    /* the adapters alone, the record back */
    gv_st_file f;
    CHECK(gv_st_open(&f, scene_path) == 0);
    int adapters = 0, others = 0;
    for (int i = 0; i < f.n_tensors; i++) {
        const gv_weight_spec *s = gv_weight_list_find(&tuned.weights, f.tensors[i].name);
        adapters += s && s->trainable, others += !s || !s->trainable;
    }
    CHECK(adapters > 0 && others == 0 && !strcmp(gv_st_metadata(&f, "kind"), "scene"));
    CHECK(!strcmp(gv_st_metadata(&f, "parts"), "camera,lora"));
    gv_st_close(&f);
    gv_scene_adaptation back;
    CHECK(gv_scene_checkpoint_read(scene_path, &back) == 0);
    CHECK(!strcmp(back.scene, "room") && back.interval == 16 && back.best_step == 150 && !back.gate_open);
    CHECK(back.gate_psnr_restored == 30.25 && back.val_gain_db == 0.125 && !strcmp(back.gate_sampler, "onestep t0=0.05"));
    CHECK(!strcmp(back.gate_compose, "unseen"));
    CHECK_NEAR(gv_scene_gate_change(&back), -0.25, 1e-12);
    CHECK(back.harm_frames == 3 && back.harm_max_loss_db == 0.05 && back.harm_psnr_base == 38.5);
    CHECK_NEAR(gv_scene_harm_change(&back), -0.125, 1e-12);
    CHECK(gv_scene_checkpoint_is(scene_path) == 1 && gv_scene_checkpoint_is(base_path) == 0);
    CHECK_FAILS_WITH(gv_scene_checkpoint_read(base_path, &back), "not a scene checkpoint");

    /* loaded as any checkpoint: the base's weights, the scene's adapters, the base's VAE */
    gv_restorer r;
    CHECK(gv_restorer_load(scene_path, &r) == 0);
    CHECK(max_diff(&r.net, &base, 0) == 0 && max_diff(&r.net, &tuned, 1) == 0 && max_diff(&base, &tuned, 1) > 0);
    CHECK(!strcmp(r.state.kind, "scene") && !strcmp(r.vae_path, vae_path));
    /* ... with what callers need: the record, the base as found and its checksum (streamed
     * through the one open of the base) equal to the file's, the base's training scenes */
    CHECK(r.loaded && r.scene && !strcmp(r.adaptation.scene, "room") && r.adaptation.interval == 16);
    CHECK(!r.adaptation.gate_open && !strcmp(r.base_path, base_path) && !strcmp(r.base_checksum, a.base_checksum));
    CHECK(r.scenes_known == 0 && !r.training_scenes[0]); /* the base records none */
    gv_restorer_free(&r);
    /* the record alone, or the network only when the gate opens (it is closed): no weights */
    CHECK(gv_restorer_open(scene_path, GV_RESTORER_RECORD, &r) == 0 && !r.loaded && r.scene);
    CHECK(!strcmp(r.base_checksum, a.base_checksum) && r.net.params.n == 0);
    gv_restorer_free(&r);
    CHECK(gv_restorer_open(scene_path, GV_RESTORER_NETWORK_IF_GATE_OPEN, &r) == 0 && !r.loaded && r.scene);
    gv_restorer_free(&r);
    CHECK(gv_restorer_open(base_path, GV_RESTORER_NETWORK_IF_GATE_OPEN, &r) == 0 && r.loaded && !r.scene);
    CHECK(max_diff(&r.net, &base, 0) == 0);
    gv_restorer_free(&r);

    /* both moved elsewhere: the base is found beside the scene checkpoint */
    char moved[4200], cmd[9000];
    snprintf(moved, sizeof moved, "%s/b", tmp);
    snprintf(cmd, sizeof cmd, "mv '%s' '%s'", dir, moved);
    CHECK(system(cmd) == 0);
    snprintf(scene_path, sizeof scene_path, "%s/scene.safetensors", moved);
    CHECK(gv_restorer_load(scene_path, &r) == 0 && max_diff(&r.net, &tuned, 1) == 0);
    gv_restorer_free(&r);
    /* another base under its name: refused by its checksum; no base at all: named */
    snprintf(base_path, sizeof base_path, "%s/base.safetensors", moved);
    CHECK(gv_checkpoint_save(base_path, &tuned, &tuned.cfg, &st, 0) == 0);
    CHECK_FAILS_WITH(gv_restorer_load(scene_path, &r), "is not the base its adapters were trained on");
    /* the record stands without its base; what the base would tell is unknown, and says why */
    CHECK(gv_restorer_open(scene_path, GV_RESTORER_RECORD, &r) == 0 && r.scenes_known == -1);
    CHECK_FAILS_WITH(gv_warn_if_trained_on(&r, scene_path, "room"), "is not the base its adapters were trained on");
    gv_restorer_free(&r);
    CHECK(remove(base_path) == 0);
    CHECK_FAILS_WITH(gv_restorer_load(scene_path, &r), "is not found");

    /* the bare adapters of a best step */
    char best[4400];
    snprintf(best, sizeof best, "%s/best.safetensors", tmp);
    const char *keys[1] = {"step"}, *values[1] = {"150"};
    CHECK(gv_adapters_save(best, &tuned, keys, values, 1) == 0);
    CHECK(gv_adapters_load(best, &base) == 0 && max_diff(&base, &tuned, 1) == 0);
    gv_dit_free(&base), gv_dit_free(&tuned);
}

/* The gate's decision on hand-set measurements: every condition strict, each one alone closes it. */
static void test_gate_decide(void)
{
    gv_scene_adaptation a;
    memset(&a, 0, sizeof a);
    a.gate_margin_db = 0.0, a.gate_min_frames = 4, a.harm_max_loss_db = 0.05;
    a.gate_frames = 6, a.gate_psnr_base = 20.0, a.gate_psnr_restored = 20.3;
    CHECK(gv_scene_gate_decide(&a) == 1); /* gains; the do-no-harm clips not measured (an older checkpoint) */
    a.harm_frames = 6, a.harm_psnr_base = 36.0, a.harm_psnr_restored = 35.96;
    CHECK(gv_scene_gate_decide(&a) == 1); /* -0.04 dB on the nearly clean renders: allowed */
    a.harm_psnr_restored = 35.94;
    CHECK(gv_scene_gate_decide(&a) == 0); /* -0.06 dB: it overshoots */
    a.harm_psnr_restored = 36.5;
    CHECK(gv_scene_gate_decide(&a) == 1);
    a.gate_frames = 3;
    CHECK(gv_scene_gate_decide(&a) == 0); /* too few frames */
    a.gate_frames = 4, a.gate_psnr_restored = 20.0;
    CHECK(gv_scene_gate_decide(&a) == 0); /* no gain: the margin is strict */
    a.gate_psnr_restored = 20.3, a.gate_margin_db = 0.5;
    CHECK(gv_scene_gate_decide(&a) == 0); /* under the margin */
    /* the unseen composition: the do-no-harm clips are measured but do not rule; the rest does */
    a.gate_margin_db = 0.0, a.harm_psnr_restored = 25.0;
    CHECK(gv_scene_harm_rules(&a) == 1 && gv_scene_gate_decide(&a) == 0);
    snprintf(a.gate_compose, sizeof a.gate_compose, "residual");
    CHECK(gv_scene_harm_rules(&a) == 1 && gv_scene_gate_decide(&a) == 0);
    snprintf(a.gate_compose, sizeof a.gate_compose, "unseen");
    CHECK(gv_scene_harm_rules(&a) == 0 && gv_scene_gate_decide(&a) == 1);
    a.gate_frames = 3;
    CHECK(gv_scene_gate_decide(&a) == 0); /* too few frames, whatever the composition */
    a.gate_frames = 4, a.gate_psnr_restored = 19.9;
    CHECK(gv_scene_gate_decide(&a) == 0); /* a loss on the pairs */
}

int main(void)
{
    const char *tmp = check_tmp_dir();
    gv_log_set_level(GV_LOG_QUIET);
    test_gate_decide();
    test_join();
    test_hold_back();
    test_scene_checkpoint(tmp);
    return check_summary();
}
