/* JPEG read through libjpeg(-turbo). libjpeg's default error handler calls exit(); ours
 * records the message and longjmps back, and treats warnings (corrupt data, premature end
 * of file) as errors too, like TurboJPEG's "stop on warning", so that a damaged file is
 * refused instead of decoded into grey blocks. libjpeg does not apply the EXIF orientation:
 * the APP1 segments are kept and the tag read (image_orient.c). */
#include "gaussvid/io/image.h"
#include "gaussvid/core/core.h"

#include <errno.h>
#include <setjmp.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>

#include <jpeglib.h>

/* A Huffman-coded block of 64 samples takes at least one bit, so a file of n bytes holds at
 * most a few thousand decoded bytes per byte (more with 4:2:0 chroma or arithmetic coding);
 * anything beyond this generous bound is an absurd header. */
#define JPEG_MAX_EXPANSION 2048.0
#define JPEG_SIZE_SLACK (64.0 * 1024 * 1024)

typedef struct {
    struct jpeg_error_mgr pub; /* first, so libjpeg's pointer is ours */
    jmp_buf jump;
    char message[JMSG_LENGTH_MAX];
} jpeg_error_context;

typedef struct {
    FILE *f;
    long file_size;
    struct jpeg_decompress_struct cinfo;
    jpeg_error_context err;
    gv_image *img;
    int orientation; /* EXIF, 1..8; 1 without a tag */
} jpeg_context;

static void jpeg_error_exit_jump(j_common_ptr cinfo)
{
    jpeg_error_context *err = (jpeg_error_context *)cinfo->err;
    err->pub.format_message(cinfo, err->message);
    longjmp(err->jump, 1);
}

/* Level -1 is a warning (corrupt data): fatal here. Trace levels are ignored. */
static void jpeg_emit_message(j_common_ptr cinfo, int level)
{
    if (level < 0) jpeg_error_exit_jump(cinfo);
}

/* Everything that can fail inside libjpeg; the only JPEG function that calls setjmp. */
static int jpeg_read_body(jpeg_context *ctx)
{
    struct jpeg_decompress_struct *cinfo = &ctx->cinfo;
    if (setjmp(ctx->err.jump)) return -1;
    jpeg_create_decompress(cinfo);
    jpeg_stdio_src(cinfo, ctx->f);
    jpeg_save_markers(cinfo, JPEG_APP0 + 1, 0xFFFF);
    jpeg_read_header(cinfo, TRUE);
    ctx->orientation = 1;
    for (jpeg_saved_marker_ptr m = cinfo->marker_list; m; m = m->next)
        if (m->marker == JPEG_APP0 + 1 && m->data_length >= 6 && !memcmp(m->data, "Exif\0\0", 6)) {
            ctx->orientation = gv_exif_orientation(m->data, m->data_length);
            break;
        }
    if (cinfo->jpeg_color_space == JCS_CMYK || cinfo->jpeg_color_space == JCS_YCCK) {
        snprintf(ctx->err.message, sizeof ctx->err.message, "CMYK JPEG is not supported");
        return -1;
    }
    cinfo->out_color_space = cinfo->num_components == 1 ? JCS_GRAYSCALE : JCS_RGB;
    double bytes = (double)cinfo->image_width * cinfo->image_height * cinfo->num_components;
    if (bytes > JPEG_MAX_EXPANSION * ctx->file_size + JPEG_SIZE_SLACK) {
        snprintf(ctx->err.message, sizeof ctx->err.message,
                 "header claims %ux%u pixels, more than a %ld-byte file can hold",
                 cinfo->image_width, cinfo->image_height, ctx->file_size);
        return -1;
    }
    jpeg_start_decompress(cinfo);
    int width = (int)cinfo->output_width, height = (int)cinfo->output_height;
    int channels = cinfo->output_components;
    if (channels != 1 && channels != 3) {
        snprintf(ctx->err.message, sizeof ctx->err.message, "%d output components", channels);
        return -1;
    }
    if (gv_image_alloc(ctx->img, width, height, channels) != 0) {
        snprintf(ctx->err.message, sizeof ctx->err.message, "%s", gv_last_error());
        return -1;
    }
    while (cinfo->output_scanline < cinfo->output_height) {
        JSAMPROW row = ctx->img->pixels + (size_t)cinfo->output_scanline * width * channels;
        jpeg_read_scanlines(cinfo, &row, 1);
    }
    jpeg_finish_decompress(cinfo);
    return 0;
}

int gv_image_read_jpeg_stored(const char *path, gv_image *out, int *orientation)
{
    memset(out, 0, sizeof *out);
    *orientation = 1;
    struct stat st;
    if (stat(path, &st) != 0) return gv_fail("%s: cannot open: %s", path, strerror(errno));
    if (!S_ISREG(st.st_mode)) return gv_fail("%s: not a regular file", path);
    jpeg_context ctx;
    memset(&ctx, 0, sizeof ctx);
    ctx.img = out;
    ctx.file_size = (long)st.st_size;
    ctx.f = fopen(path, "rb");
    if (!ctx.f) return gv_fail("%s: cannot open: %s", path, strerror(errno));
    ctx.cinfo.err = jpeg_std_error(&ctx.err.pub);
    ctx.err.pub.error_exit = jpeg_error_exit_jump;
    ctx.err.pub.emit_message = jpeg_emit_message;
    int rc = jpeg_read_body(&ctx);
    jpeg_destroy_decompress(&ctx.cinfo); /* safe when creation failed: mem is NULL */
    fclose(ctx.f);
    if (rc != 0) {
        gv_image_free(out);
        return gv_fail("%s: corrupt or truncated JPEG: %s", path, ctx.err.message);
    }
    *orientation = ctx.orientation;
    return 0;
}

int gv_image_read_jpeg(const char *path, gv_image *out)
{
    int orientation;
    if (gv_image_read_jpeg_stored(path, out, &orientation)) return -1;
    if (orientation == 1) return 0;
    gv_image stored = *out;
    int rc = gv_image_orient(&stored, orientation, out);
    gv_image_free(&stored);
    return rc ? gv_fail_context("%s", path) : 0;
}
