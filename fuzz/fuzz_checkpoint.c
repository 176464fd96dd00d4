/* Checkpoints and weights (safetensors whose metadata carries a model config), as `model
 * run`, `restore`, `train --resume`, `train --vae` and `eval --lpips` read them: the first
 * byte picks the info read, the restorer's load (network and VAE), the VAE load with the config in its
 * metadata, the LPIPS weights, or a resume (the file's network built, then restored). */
#include "fuzz.h"
#include "gaussvid/train/checkpoint.h"
#include "gaussvid/eval/lpips.h"
#include "gaussvid/train/train.h"

static int fuzz_one(const uint8_t *data, size_t size)
{
    if (size < 1) return 0;
    const char *path = fuzz_file("model.safetensors", data + 1, size - 1);
    gv_model_config cfg;
    gv_clear_error();
    int kind = data[0] % 5;
    if (kind == 0) {
        gv_train_state state;
        fuzz_check_failure(gv_checkpoint_read_info(path, &cfg, &state), "model.safetensors");
    } else if (kind == 1) {
        gv_restorer r;
        int rc = gv_restorer_load(path, &r);
        fuzz_check_failure(rc, "model.safetensors");
        if (rc == 0) gv_restorer_free(&r);
    } else if (kind == 3) { /* LPIPS weights (--lpips of restore and eval) */
        gv_lpips net;
        int rc = gv_lpips_load(&net, path);
        fuzz_check_failure(rc, "model.safetensors");
        if (rc == 0) gv_lpips_free(&net);
    } else if (kind == 4) { /* resuming: the network of the file's config, then its state */
        gv_train_state state;
        gv_dit m;
        int rc = gv_checkpoint_read_info(path, &cfg, &state);
        if (rc == 0) {
            rc = gv_dit_init(&m, &cfg, 0);
            if (rc == 0) {
                rc = gv_checkpoint_restore(path, &m, &state);
                gv_dit_free(&m);
            }
        }
        fuzz_check_failure(rc, NULL);
    } else {
        gv_vae vae;
        if (gv_model_config_preset(&cfg, "tiny")) abort();
        int rc = gv_vae_file_config(path, &cfg); /* the config the file names, as `vae eval` */
        if (rc == 0) rc = gv_train_load_vae(path, &cfg, &vae);
        fuzz_check_failure(rc, "model.safetensors");
        if (rc == 0) gv_vae_free(&vae);
    }
    return 0;
}
