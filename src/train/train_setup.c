/* Setting up a training run: the VAE whose latents the network learns (its config must be the
 * run's, and its latent statistics become part of the run's config), the clips, and the
 * network (pretrain, train and bench train set it up here). */
#include <stdio.h>
#include <string.h>

#include "gaussvid/core/core.h"
#include "gaussvid/train/train.h"
#include "train/train_internal.h"

int gv_train_load_vae(const char *path, gv_model_config *cfg, gv_vae *vae)
{
    gv_model_config file_cfg;
    memset(vae, 0, sizeof *vae);
    gv_st_file f;
    if (gv_st_open(&f, path)) return -1;
    int has_config = gv_st_metadata(&f, "config") != NULL;
    gv_st_close(&f);
    if (has_config) {
        if (gv_vae_file_config(path, &file_cfg)) return -1;
        gv_model_config a = *cfg, b = *cfg;
        a.vae = file_cfg.vae;
        a.vae.has_latent_stats = b.vae.has_latent_stats; /* statistics may differ */
        memcpy(a.vae.latent_mean, b.vae.latent_mean, sizeof a.vae.latent_mean);
        memcpy(a.vae.latent_std, b.vae.latent_std, sizeof a.vae.latent_std);
        if (!gv_model_config_equal(&a, &b))
            return gv_fail("%s: a VAE of another config (dim %d, z_dim %d) than %s (dim %d, z_dim %d)", path,
                           file_cfg.vae.dim, file_cfg.vae.z_dim, cfg->name, cfg->vae.dim, cfg->vae.z_dim);
    }
    if (gv_vae_init(vae, cfg, 0, 0) || gv_vae_load(vae, path, 0)) {
        gv_vae_free(vae);
        return -1;
    }
    if (!vae->has_stats) {
        gv_vae_free(vae);
        return gv_fail("%s: the VAE has no latent statistics (latent_mean, latent_std): finish `gaussvid vae train`",
                       path);
    }
    cfg->vae = vae->cfg;
    cfg->vae.has_latent_stats = 1;
    for (int c = 0; c < cfg->vae.z_dim; c++) {
        cfg->vae.latent_mean[c] = vae->mean[c];
        cfg->vae.latent_std[c] = vae->std[c];
    }
    return 0;
}

int gv_train_load_data(const char *clips_dir, const char *vae_path, const char *want_checksum, gv_model_config *cfg,
                       gv_latent_set *set, gv_train_state *meta)
{
    gv_vae vae;
    memset(set, 0, sizeof *set);
    if (gv_train_load_vae(vae_path, cfg, &vae)) return -1;
    gv_checkpoint_vae_checksum(&vae, meta->vae_checksum, sizeof meta->vae_checksum);
    int rc = 0;
    if (want_checksum && *want_checksum && strcmp(want_checksum, meta->vae_checksum))
        rc = gv_fail("%s: not the VAE the base was trained with (checksum %s, the base's %s)", vae_path,
                     meta->vae_checksum, want_checksum);
    if (rc == 0) rc = gv_latent_set_load(clips_dir, "train", vae_path, &vae, cfg, set);
    gv_vae_free(&vae);
    if (rc) return -1;
    snprintf(meta->vae, sizeof meta->vae, "%s", vae_path);
    snprintf(meta->clips, sizeof meta->clips, "%s", clips_dir);
    gv_train_data_text(set, "train", meta->data, sizeof meta->data);
    return gv_train_record_scenes(meta, clips_dir, "train");
}

int gv_train_load_val(const char *clips_dir, const char *vae_path, gv_model_config *cfg, gv_latent_set *set)
{
    gv_vae vae;
    memset(set, 0, sizeof *set);
    if (gv_train_load_vae(vae_path, cfg, &vae)) return -1;
    int rc = gv_latent_set_load(clips_dir, "eval", vae_path, &vae, cfg, set);
    gv_vae_free(&vae);
    return rc; /* an empty split fails in the load, naming the folder */
}

int gv_train_model(const gv_model_config *cfg, gv_objective objective, const char *base, int fresh_camera,
                   uint64_t seed, gv_dit *m, gv_train_state *meta)
{
    int pretrain = objective == GV_OBJECTIVE_PRETRAIN, camera_loaded = 0;
    gv_model_config net = *cfg;
    if (pretrain) net.lora.rank = 0;
    snprintf(meta->kind, sizeof meta->kind, "%s", pretrain ? "base" : "finetune");
    if (base) snprintf(meta->base, sizeof meta->base, "%s", base);
    /* with a base, its DiT and VACE come from the file (a BF16 base stays BF16, mapped) */
    if (gv_dit_init_parts(m, &net, seed, base ? GV_PART_DIT | GV_PART_VACE : 0) ||
        (base && gv_checkpoint_load_base(base, m, !fresh_camera, &camera_loaded)) ||
        gv_dit_set_train_mode(m, pretrain ? GV_DIT_FULL : GV_DIT_FINETUNE))
        return -1;
    if (base) { /* the fine-tuned checkpoint names its base's text context */
        gv_model_config c;
        gv_train_state s;
        if (gv_checkpoint_read_info(base, &c, &s)) return -1;
        meta->text = s.text;
        if (gv_train_add_scenes(meta, s.scenes)) return -1; /* what the base learned from is learned from too */
    }
    if (gv_params_count(&m->params, 1) == 0)
        return gv_fail("%s: nothing to train in this variant (no LoRA adapters, no camera encoder)", cfg->name);
    if (base && cfg->variant.camera != GV_CAMERA_NONE)
        gv_info("train: camera encoder %s", camera_loaded ? "continued from the base" : "trained from its fresh start");
    return 0;
}
