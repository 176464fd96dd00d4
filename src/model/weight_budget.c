/* What a file's own config may ask us to allocate: a checkpoint or VAE file names the network
 * it holds in its metadata, and the loaders build that network before reading its tensors.
 * A few hundred bytes claiming the 14B model would have us allocate (and initialise) 56 GB
 * before finding the tensors missing; so the config's parameter count is checked against the
 * bytes the file holds first (issue 25: refuse before allocating). Two bytes per parameter is
 * the least any loadable dtype (F16, BF16) takes. */
#include <inttypes.h>

#include "gaussvid/core/core.h"
#include "gaussvid/model/weight_names.h"

int gv_weights_fit(const gv_model_config *c, unsigned parts, uint64_t bytes, const char *path)
{
    gv_weight_list l;
    if (gv_weight_list_build(&l, c)) return gv_fail_context("%s", path);
    int64_t params = 0;
    for (int i = 0; i < l.n; i++)
        if (gv_module_part(l.items[i].module) & parts) params += l.items[i].numel;
    gv_weight_list_free(&l);
    if ((uint64_t)params > bytes / 2)
        return gv_fail("%s: its config (%s) describes %" PRId64 " parameters (at least %" PRIu64
                       " bytes), but the file holds %" PRIu64 " bytes of tensors", path, c->name, params,
                       2 * (uint64_t)params, bytes);
    return 0;
}
