/* Checkpoints and VAE weights (safetensors whose metadata carries a model config), as
 * `model run`, `restore`, `train --resume` and `train --vae` read them: the first byte picks
 * the info read, the restorer's load (network and VAE), or the VAE load with the config in its metadata. */
#include "fuzz.h"
#include "gaussvid/checkpoint.h"
#include "gaussvid/train.h"

static int fuzz_one(const uint8_t *data, size_t size)
{
    if (size < 1) return 0;
    const char *path = fuzz_file("model.safetensors", data + 1, size - 1);
    gv_model_config cfg;
    gv_clear_error();
    int kind = data[0] % 3;
    if (kind == 0) {
        gv_train_state state;
        fuzz_check_failure(gv_checkpoint_read_info(path, &cfg, &state), "model.safetensors");
    } else if (kind == 1) {
        gv_restorer r;
        int rc = gv_restorer_load(path, &r);
        fuzz_check_failure(rc, "model.safetensors");
        if (rc == 0) gv_restorer_free(&r);
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
