/* Sharded safetensors checkpoints (docs/SAFETENSORS.md "Sharded checkpoints"): the index
 * "diffusion_pytorch_model.safetensors.index.json" and its shards, opened by
 * gv_weights_open as `model import` opens a release's DiT, then every tensor read
 * (fuzz_weights.h: BF16 and F16 shards converted to float32 as the loaders do). The input is
 * the index, then the shards separated by "#PIECE#"; shard k of n is written under the
 * published name "diffusion_pytorch_model-0000k-of-0000n.safetensors" beside the index. */
#include "fuzz_weights.h"
#include "gaussvid/pth/weight_files.h"

enum { MAX_SHARDS = 8 };

/* The files of the previous input, removed before the next one is written, so that an index
 * never finds a shard another input left. */
static char written[MAX_SHARDS][600];
static int n_written;

static int fuzz_one(const uint8_t *data, size_t size)
{
    for (int i = 0; i < n_written; i++) unlink(written[i]);
    n_written = 0;
    fuzz_piece pieces[MAX_SHARDS + 1];
    int n = fuzz_split(data, size, pieces, MAX_SHARDS + 1);
    for (int k = 1; k < n; k++) {
        char name[80];
        snprintf(name, sizeof name, "diffusion_pytorch_model-%05d-of-%05d.safetensors", k, n - 1);
        snprintf(written[n_written++], sizeof written[0], "%s", fuzz_file(name, pieces[k].data, pieces[k].size));
    }
    const char *path = fuzz_file("diffusion_pytorch_model.safetensors.index.json", pieces[0].data, pieces[0].size);
    gv_st_file f;
    gv_clear_error();
    int rc = gv_weights_open(&f, path);
    fuzz_check_failure(rc, "diffusion_pytorch_model");
    if (rc) return fuzz_report(rc, NULL), 0;
    fuzz_read_tensors(&f, "diffusion_pytorch_model");
    char what[64];
    snprintf(what, sizeof what, "opened: %d tensors", f.n_tensors);
    fuzz_report(0, what);
    gv_st_close(&f);
    return 0;
}
