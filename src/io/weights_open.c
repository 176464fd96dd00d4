/* Opening a weight file of any published layout (weight_files.h): the first bytes tell a
 * PyTorch zip ("PK\3\4"), a sharded checkpoint's JSON index ("{") and a safetensors file
 * apart (and the legacy pickle-only torch format is refused by name). A safetensors file starts with its header length as 8 little-endian bytes, at most
 * 100,000,000: its top bytes are zero, never the ASCII of a zip signature or of JSON. */
#include <errno.h>
#include <stdio.h>
#include <string.h>

#include "gaussvid/core.h"
#include "gaussvid/weight_files.h"

int gv_weights_open(gv_st_file *f, const char *path)
{
    memset(f, 0, sizeof *f);
    unsigned char head[8] = {0};
    FILE *in = fopen(path, "rb");
    if (!in) return gv_fail("%s: cannot open: %s", path, strerror(errno));
    size_t got = fread(head, 1, sizeof head, in);
    fclose(in);
    if (got >= 4 && head[0] == 'P' && head[1] == 'K' && head[2] == 3 && head[3] == 4) return gv_pth_open(f, path);
    /* torch.save before 1.6 wrote a bare pickle starting with the magic number as LONG1 */
    if (got == 8 && head[0] == 0x80 && head[1] == 0x02 && head[2] == 0x8a && head[3] == 0x0a)
        return gv_fail("%s: a PyTorch checkpoint in the legacy (pre-1.6, not zip) format: re-save it with a current "
                       "torch.save, or convert it to safetensors", path);
    size_t k = 0;
    while (k < got && (head[k] == ' ' || head[k] == '\t' || head[k] == '\n' || head[k] == '\r')) k++;
    if (k < got && head[k] == '{') return gv_st_index_open(f, path);
    return gv_st_open(f, path);
}
