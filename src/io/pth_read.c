/* PyTorch zip checkpoints: not read yet (the next change adds the reader). */
#include "gaussvid/core.h"
#include "gaussvid/weight_files.h"

#include <string.h>

int gv_pth_open(gv_st_file *f, const char *path)
{
    memset(f, 0, sizeof *f);
    return gv_fail("%s: PyTorch zip checkpoints are not read yet", path);
}
