/* gaussvid dataset show CLIP --out sheet.png: a contact sheet of one clip (inputs above,
 * targets below) and a line describing it, with the PSNR of each corrupted frame. */
#include <stdio.h>

#include "cli/commands.h"
#include "gaussvid/core/core.h"
#include "gaussvid/data/dataset.h"
#include "gaussvid/io/metrics.h"

/* PSNR of input frame f against its target. */
static double frame_psnr(const gv_clip *clip, int f)
{
    gv_image a = {clip->info.width, clip->info.height, 3, gv_clip_frame(clip->inputs, &clip->info, f)};
    gv_image b = {clip->info.width, clip->info.height, 3, gv_clip_frame(clip->targets, &clip->info, f)};
    double psnr, ssim;
    return gv_image_psnr_ssim(&a, &b, &psnr, &ssim) == 0 ? psnr : 0;
}

int cmd_dataset_show(int argc, char **argv)
{
    const char *out = NULL;
    const gv_flag flags[] = {
        {"out", GV_FLAG_STRING, &out, "FILE.png", "the contact sheet", 1},
    };
    const gv_command_spec spec = {
        "dataset show", "CLIP", "contact sheet of a clip: inputs above, targets below",
        "Top row: the 5 inputs (clean anchor, 3 corrupted renders, clean anchor); bottom row:\n"
        "the 5 targets (ground truth); a light line between the rows.",
        flags, sizeof flags / sizeof flags[0], 1, 1};
    char *positional[1];
    int n_positional;
    int parsed = gv_args_parse(&spec, argc, argv, positional, &n_positional);
    if (parsed != GV_ARGS_OK) return gv_args_exit_code(parsed);
    gv_clip clip;
    if (gv_clip_read(positional[0], &clip) != 0) return gv_report_failure();
    gv_image sheet;
    int rc = gv_clip_contact_sheet(&clip, &sheet);
    if (rc == 0) {
        rc = gv_image_write_png(out, &sheet);
        gv_image_free(&sheet);
    }
    if (rc == 0) {
        const gv_clip_info *i = &clip.info;
        printf("%s: scene %s (%s), n=%d, frames [%d, %d, %d, %d, %d], %dx%d, %d iterations; "
               "corrupted PSNR %.2f / %.2f / %.2f dB -> %s\n", positional[0], i->id.scene, i->id.split,
               i->id.interval, i->frames[0], i->frames[1], i->frames[2], i->frames[3], i->frames[4],
               i->width, i->height, i->iters, frame_psnr(&clip, 1), frame_psnr(&clip, 2),
               frame_psnr(&clip, 3), out);
    }
    gv_clip_free(&clip);
    return rc == 0 ? 0 : gv_report_failure();
}
