/* Contact sheet of a clip (`dataset show`): what the restorer sees above what it should
 * produce, so a reader can check a clip at a glance. */
#include <string.h>

#include "gaussvid/data/dataset.h"

#define GAP_GREY 32          /* between frames: dark, so frame edges stay visible */
#define SEPARATOR_GREY 224   /* between inputs and targets: light, so the rows read apart */

int gv_clip_contact_sheet(const gv_clip *clip, gv_image *out)
{
    const gv_clip_info *info = &clip->info;
    int w = info->width, h = info->height;
    int sheet_w = GV_CLIP_FRAMES * w + (GV_CLIP_FRAMES - 1) * GV_SHEET_GAP;
    int sheet_h = 2 * h + GV_SHEET_GAP;
    if (gv_image_alloc(out, sheet_w, sheet_h, 3) != 0) return -1;
    memset(out->pixels, GAP_GREY, (size_t)sheet_w * sheet_h * 3);
    memset(out->pixels + (size_t)h * sheet_w * 3, SEPARATOR_GREY, (size_t)GV_SHEET_GAP * sheet_w * 3);
    for (int row = 0; row < 2; row++) {
        uint8_t *frames = row == 0 ? clip->inputs : clip->targets;
        for (int f = 0; f < GV_CLIP_FRAMES; f++) {
            const uint8_t *src = gv_clip_frame(frames, info, f);
            int x0 = f * (w + GV_SHEET_GAP), y0 = row * (h + GV_SHEET_GAP);
            for (int y = 0; y < h; y++)
                memcpy(out->pixels + ((size_t)(y0 + y) * sheet_w + x0) * 3, src + (size_t)y * w * 3,
                       (size_t)w * 3);
        }
    }
    return 0;
}
