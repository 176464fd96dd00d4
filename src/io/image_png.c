/* PNG read (any colour type and bit depth, to 8 bits) and 8-bit write through libpng.
 * libpng reports errors by longjmp to the setjmp in the function that called it; every
 * object that setjmp function changes lives in a context struct owned by its caller, so
 * nothing is indeterminate after the jump (C11 7.13.2.1). */
#include "gaussvid/io/image.h"
#include "gaussvid/core/core.h"

#include <errno.h>
#include <png.h>
#include <setjmp.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>

/* Deflate cannot expand by more than 1032:1 (zlib technical details), so the raw image
 * data a file can hold is bounded by its size; this refuses absurd headers before any
 * allocation. The slack covers tiny files. */
#define PNG_MAX_INFLATE_RATIO 1032
#define PNG_SIZE_SLACK 65536

typedef struct {
    const char *path;
    FILE *f;
    long file_size;
    png_structp png;
    png_infop info;
    png_bytep *rows;
    gv_image *img;
    char message[256];
} png_context;

static void png_error_to_context(png_structp png, png_const_charp msg)
{
    png_context *ctx = png_get_error_ptr(png);
    if (ctx->f && feof(ctx->f))
        snprintf(ctx->message, sizeof ctx->message, "unexpected end of file");
    else
        snprintf(ctx->message, sizeof ctx->message, "%s", msg ? msg : "libpng error");
    png_longjmp(png, 1);
}

static void png_warning_ignored(png_structp png, png_const_charp msg)
{
    (void)png;
    gv_debug("libpng warning: %s", msg);
}

/* Sets the transformations that bring any PNG to 8-bit samples, then checks the header's
 * claims against the file size. Returns 0 or -1 with ctx->message set. */
static int png_setup_transforms(png_context *ctx)
{
    png_structp png = ctx->png;
    png_infop info = ctx->info;
    png_uint_32 width = png_get_image_width(png, info), height = png_get_image_height(png, info);
    int depth = png_get_bit_depth(png, info), color = png_get_color_type(png, info);
    int raw_channels = png_get_channels(png, info);
    double raw_bytes = ((double)width * depth * raw_channels / 8.0 + 1.0) * height;
    if (raw_bytes > (double)PNG_MAX_INFLATE_RATIO * ctx->file_size + PNG_SIZE_SLACK) {
        snprintf(ctx->message, sizeof ctx->message,
                 "header claims %ux%u pixels, more than a %ld-byte file can hold",
                 (unsigned)width, (unsigned)height, ctx->file_size);
        return -1;
    }
    if (color == PNG_COLOR_TYPE_PALETTE) png_set_palette_to_rgb(png);
    if (color == PNG_COLOR_TYPE_GRAY && depth < 8) png_set_expand_gray_1_2_4_to_8(png);
    if (png_get_valid(png, info, PNG_INFO_tRNS)) png_set_tRNS_to_alpha(png);
    if (depth == 16) png_set_strip_16(png); /* high byte, as PIL and OpenCV */
    if (png_get_interlace_type(png, info) != PNG_INTERLACE_NONE) png_set_interlace_handling(png);
    png_read_update_info(png, info);
    return 0;
}

/* Everything after png_create_read_struct; the only function here that calls setjmp. */
static int png_read_body(png_context *ctx)
{
    if (setjmp(png_jmpbuf(ctx->png))) return -1;
    png_init_io(ctx->png, ctx->f);
    /* Ancillary chunks we do not use are skipped unread, and no chunk may make libpng allocate
     * more than the file holds: a 158-byte file whose sPLT chunk claimed 1.7 GB had libpng
     * allocate and touch that much before finding the end of the file (found by fuzz/). */
    static const png_byte unused[] = "bKGD\0cHRM\0eXIf\0gAMA\0hIST\0iCCP\0iTXt\0oFFs\0pCAL\0pHYs\0"
                                     "sBIT\0sCAL\0sPLT\0sRGB\0tEXt\0tIME\0zTXt";
    png_set_keep_unknown_chunks(ctx->png, PNG_HANDLE_CHUNK_NEVER, unused, (int)(sizeof unused / 5));
    png_set_chunk_malloc_max(ctx->png, (png_alloc_size_t)ctx->file_size + 1);
    png_read_info(ctx->png, ctx->info);
    if (png_setup_transforms(ctx) != 0) return -1;
    int width = (int)png_get_image_width(ctx->png, ctx->info);
    int height = (int)png_get_image_height(ctx->png, ctx->info);
    int channels = png_get_channels(ctx->png, ctx->info);
    if (png_get_bit_depth(ctx->png, ctx->info) != 8 ||
        png_get_rowbytes(ctx->png, ctx->info) != (size_t)width * channels) {
        snprintf(ctx->message, sizeof ctx->message, "unsupported pixel layout");
        return -1;
    }
    if (gv_image_alloc(ctx->img, width, height, channels) != 0) {
        snprintf(ctx->message, sizeof ctx->message, "%s", gv_last_error());
        return -1;
    }
    ctx->rows = malloc(sizeof *ctx->rows * (size_t)height);
    if (!ctx->rows) {
        snprintf(ctx->message, sizeof ctx->message, "out of memory");
        return -1;
    }
    for (int y = 0; y < height; y++)
        ctx->rows[y] = ctx->img->pixels + (size_t)y * width * channels;
    png_read_image(ctx->png, ctx->rows);
    png_read_end(ctx->png, NULL);
    return 0;
}

int gv_image_read_png(const char *path, gv_image *out)
{
    memset(out, 0, sizeof *out);
    png_context ctx = {.path = path, .img = out};
    struct stat st;
    if (stat(path, &st) != 0) return gv_fail("%s: cannot open: %s", path, strerror(errno));
    if (!S_ISREG(st.st_mode)) return gv_fail("%s: not a regular file", path);
    ctx.file_size = (long)st.st_size;
    ctx.f = fopen(path, "rb");
    if (!ctx.f) return gv_fail("%s: cannot open: %s", path, strerror(errno));
    ctx.png = png_create_read_struct(PNG_LIBPNG_VER_STRING, &ctx, png_error_to_context,
                                     png_warning_ignored);
    ctx.info = ctx.png ? png_create_info_struct(ctx.png) : NULL;
    int rc = -1;
    if (!ctx.png || !ctx.info) snprintf(ctx.message, sizeof ctx.message, "out of memory");
    else rc = png_read_body(&ctx);
    if (ctx.png) png_destroy_read_struct(&ctx.png, ctx.info ? &ctx.info : NULL, NULL);
    free(ctx.rows);
    fclose(ctx.f);
    if (rc != 0) {
        gv_image_free(out);
        return gv_fail("%s: corrupt or truncated PNG: %s", path, ctx.message);
    }
    return 0;
}

/* Everything after png_create_write_struct; the only writer function that calls setjmp. */
static int png_write_body(png_context *ctx, const gv_image *img)
{
    static const int color_types[5] = {0, PNG_COLOR_TYPE_GRAY, PNG_COLOR_TYPE_GRAY_ALPHA,
                                       PNG_COLOR_TYPE_RGB, PNG_COLOR_TYPE_RGBA};
    if (setjmp(png_jmpbuf(ctx->png))) return -1;
    png_init_io(ctx->png, ctx->f);
    png_set_IHDR(ctx->png, ctx->info, (png_uint_32)img->width, (png_uint_32)img->height, 8,
                 color_types[img->channels], PNG_INTERLACE_NONE, PNG_COMPRESSION_TYPE_DEFAULT,
                 PNG_FILTER_TYPE_DEFAULT);
    png_write_info(ctx->png, ctx->info);
    for (int y = 0; y < img->height; y++)
        png_write_row(ctx->png, img->pixels + (size_t)y * img->width * img->channels);
    png_write_end(ctx->png, NULL);
    return 0;
}

/* The whole PNG of img through ctx->f (a file or a memory stream); errno is the stream's. */
static int png_write_stream(png_context *ctx, const gv_image *img)
{
    ctx->png = png_create_write_struct(PNG_LIBPNG_VER_STRING, ctx, png_error_to_context, png_warning_ignored);
    ctx->info = ctx->png ? png_create_info_struct(ctx->png) : NULL;
    int rc = -1;
    if (!ctx->png || !ctx->info) snprintf(ctx->message, sizeof ctx->message, "out of memory");
    else rc = png_write_body(ctx, img);
    int err = errno;
    if (ctx->png) png_destroy_write_struct(&ctx->png, ctx->info ? &ctx->info : NULL);
    errno = err;
    return rc;
}

int gv_image_write_png(const char *path, const gv_image *img)
{
    if (!img->pixels || img->width <= 0 || img->height <= 0 || img->channels < 1 ||
        img->channels > 4)
        return gv_fail("%s: cannot write an empty or invalid image (%dx%dx%d)", path,
                       img->width, img->height, img->channels);
    gv_atomic_file af;
    if (gv_atomic_open(&af, path) != 0) return -1;
    png_context ctx = {.path = path, .f = af.f};
    int rc = png_write_stream(&ctx, img);
    int err = errno, write_failed = rc != 0 && ferror(af.f); /* a full disk: say so, not libpng's "Write Error" */
    if (rc != 0) {
        gv_atomic_abort(&af);
        if (write_failed) return gv_fail("%s: write error: %s", path, strerror(err));
        return gv_fail("%s: cannot write PNG: %s", path, ctx.message);
    }
    return gv_atomic_commit(&af);
}

int gv_image_encode_png(const gv_image *img, uint8_t **bytes, size_t *size)
{
    *bytes = NULL;
    *size = 0;
    if (!img->pixels || img->width <= 0 || img->height <= 0 || img->channels < 1 ||
        img->channels > 4)
        return gv_fail("cannot encode an empty or invalid image (%dx%dx%d) as PNG", img->width,
                       img->height, img->channels);
    char *buffer = NULL;
    size_t length = 0;
    FILE *f = open_memstream(&buffer, &length); /* libpng writes through stdio, here into memory */
    if (!f) return gv_fail("cannot encode a PNG in memory: %s", strerror(errno));
    png_context ctx = {.path = "(memory)", .f = f};
    int rc = png_write_stream(&ctx, img);
    if (fclose(f) != 0 && rc == 0) {
        rc = -1;
        snprintf(ctx.message, sizeof ctx.message, "out of memory");
    }
    if (rc != 0) {
        free(buffer);
        return gv_fail("cannot encode a PNG in memory: %s", ctx.message);
    }
    *bytes = (uint8_t *)buffer;
    *size = length;
    return 0;
}
