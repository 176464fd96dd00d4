/* JPEG written through libjpeg(-turbo) (image.h): the scene folders `scene colmap` writes keep
 * photos as JPEG, a fifth to a tenth of their size as PNG. Errors longjmp back as in
 * image_jpeg.c; the file goes to a temporary name renamed on success. */
#include "gaussvid/io/image.h"
#include "gaussvid/core/core.h"

#include <setjmp.h>
#include <stdio.h>
#include <string.h>

#include <jpeglib.h>

typedef struct {
    struct jpeg_error_mgr pub; /* first, so libjpeg's pointer is ours */
    jmp_buf jump;
    char message[JMSG_LENGTH_MAX];
} jpeg_write_error;

static void write_error_exit(j_common_ptr cinfo)
{
    jpeg_write_error *err = (jpeg_write_error *)cinfo->err;
    err->pub.format_message(cinfo, err->message);
    longjmp(err->jump, 1);
}

/* The only function that calls setjmp: everything that can fail inside libjpeg. */
static int compress(struct jpeg_compress_struct *cinfo, jpeg_write_error *err, FILE *f, const gv_image *img,
                    int quality)
{
    if (setjmp(err->jump)) return -1;
    jpeg_create_compress(cinfo);
    jpeg_stdio_dest(cinfo, f);
    cinfo->image_width = (JDIMENSION)img->width;
    cinfo->image_height = (JDIMENSION)img->height;
    cinfo->input_components = img->channels;
    cinfo->in_color_space = img->channels == 1 ? JCS_GRAYSCALE : JCS_RGB;
    jpeg_set_defaults(cinfo);
    jpeg_set_quality(cinfo, quality, TRUE);
    jpeg_start_compress(cinfo, TRUE);
    while (cinfo->next_scanline < cinfo->image_height) {
        JSAMPROW row = img->pixels + (size_t)cinfo->next_scanline * img->width * img->channels;
        jpeg_write_scanlines(cinfo, &row, 1);
    }
    jpeg_finish_compress(cinfo);
    return 0;
}

int gv_image_write_jpeg(const char *path, const gv_image *img, int quality)
{
    if (img->channels != 1 && img->channels != 3)
        return gv_fail("%s: a JPEG holds 1 or 3 channels, not %d", path, img->channels);
    if (quality < 1 || quality > 100) return gv_fail("%s: JPEG quality %d is not in 1..100", path, quality);
    gv_atomic_file af;
    if (gv_atomic_open(&af, path)) return -1;
    struct jpeg_compress_struct cinfo;
    jpeg_write_error err;
    memset(&cinfo, 0, sizeof cinfo);
    memset(&err, 0, sizeof err);
    cinfo.err = jpeg_std_error(&err.pub);
    err.pub.error_exit = write_error_exit;
    int rc = compress(&cinfo, &err, af.f, img, quality);
    jpeg_destroy_compress(&cinfo);
    if (rc) {
        gv_atomic_abort(&af);
        return gv_fail("%s: JPEG encoding failed: %s", path, err.message);
    }
    return gv_atomic_commit(&af);
}
