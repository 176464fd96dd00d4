/* Opening a weight file of any published layout (weight_files.h): the first bytes tell a
 * PyTorch zip ("PK\3\4"), a sharded checkpoint's JSON index ("{") and a safetensors file
 * apart (and the legacy pickle-only torch format is refused by name). A safetensors file starts with its header length as 8 little-endian bytes, at most
 * 100,000,000: its top bytes are zero, never the ASCII of a zip signature or of JSON. */
#include <errno.h>
#include <fcntl.h>
#include <stdio.h>
#include <string.h>
#include <unistd.h>

#include "gaussvid/core/core.h"
#include "gaussvid/pth/weight_files.h"
#include "io/safetensors_internal.h"

int gv_weights_open(gv_st_file *f, const char *path)
{
    memset(f, 0, sizeof *f);
    unsigned char head[8] = {0};
    int fd = open(path, O_RDONLY | O_CLOEXEC);
    if (fd < 0) return gv_fail("%s: cannot open: %s", path, strerror(errno));
    ssize_t read_bytes = pread(fd, head, sizeof head, 0);
    size_t got = read_bytes > 0 ? (size_t)read_bytes : 0;
    size_t k = 0;
    while (k < got && (head[k] == ' ' || head[k] == '\t' || head[k] == '\n' || head[k] == '\r')) k++;
    int zip = got >= 4 && head[0] == 'P' && head[1] == 'K' && head[2] == 3 && head[3] == 4;
    /* torch.save before 1.6 wrote a bare pickle starting with the magic number as LONG1 */
    int legacy = got == 8 && head[0] == 0x80 && head[1] == 0x02 && head[2] == 0x8a && head[3] == 0x0a;
    int index = k < got && head[k] == '{';
    if (!zip && !legacy && !index) return gv_st_open_fd(f, path, fd); /* mapped from this one open */
    close(fd);
    if (zip) return gv_pth_open(f, path);
    if (legacy)
        return gv_fail("%s: a PyTorch checkpoint in the legacy (pre-1.6, not zip) format: re-save it with a current "
                       "torch.save, or convert it to safetensors", path);
    return gv_st_index_open(f, path);
}
