/* Resource limits on what a file can ask for (issue 25): a header that claims 10^12 elements,
 * JSON nested 10^5 deep, a PNG or JPEG of 65535x65535, a safetensors header of 1 GiB, a
 * checkpoint or VAE whose config describes a network far larger than the file. Each is
 * refused with one line naming the file, before allocating: the test runs with allocations
 * capped (an address-space limit, or under AddressSanitizer its maximum allocation size), so a
 * reader that tried to allocate first would fail with "out of memory" instead, and the check
 * of the message would catch it. */
#include <stdint.h>
#include <stdio.h>
#include <sys/resource.h>
#include <jpeglib.h>
#include <zlib.h>

#include "check.h"
#include "gaussvid/train/checkpoint.h"
#include "gaussvid/io/colmap.h"
#include "gaussvid/core/core.h"
#include "gaussvid/data/dataset.h"
#include "gaussvid/io/image.h"
#include "gaussvid/model/model_config.h"
#include "gaussvid/io/ply.h"
#include "gaussvid/io/safetensors.h"
#include "gaussvid/train/train.h"
#include "gaussvid/io/transforms.h"

/* Under ASan an allocation above 2 GiB returns NULL instead of being tried. */
const char *__asan_default_options(void);
const char *__asan_default_options(void)
{
    return "max_allocation_size_mb=2048:allocator_may_return_null=1";
}

static char dir[4096];

static const char *at(const char *name)
{
    static char paths[4][4200];
    static int next;
    char *p = paths[next++ % 4];
    snprintf(p, sizeof paths[0], "%s/%s", dir, name);
    return p;
}

static const char *put(const char *name, const void *data, size_t size)
{
    const char *path = at(name);
    FILE *f = fopen(path, "wb");
    if (!f || fwrite(data, 1, size, f) != size || fclose(f) != 0) {
        fprintf(stderr, "cannot write %s\n", path);
        exit(1);
    }
    return path;
}

static const char *put_text(const char *name, const char *text)
{
    return put(name, text, strlen(text));
}

/* The last failure is one line that names the file and says `why`, not "out of memory". */
static int refused(const char *file, const char *why)
{
    const char *m = gv_last_error();
    int good = !strchr(m, '\n') && strstr(m, file) && strstr(m, why) && !strstr(m, "out of memory");
    if (!good) fprintf(stderr, "  message: %s\n", m);
    return good;
}

static void test_ply(void)
{
    const char *binary = "ply\nformat binary_little_endian 1.0\nelement vertex 1000000000000\n"
                         "property float x\nproperty float y\nproperty float z\nend_header\n0123456789ab";
    const char *path = put_text("huge.ply", binary);
    gv_gaussians g;
    CHECK(gv_gaussians_read_ply(path, &g) != 0);
    int n;
    float *xyz;
    uint8_t *rgb;
    CHECK(gv_points_read_ply(path, &n, &xyz, &rgb) != 0 && refused("huge.ply", "1000000000000"));
    const char *ascii = "ply\nformat ascii 1.0\nelement vertex 1000000000000\nproperty float x\n"
                        "property float y\nproperty float z\nend_header\n0 0 0\n";
    path = put_text("huge_ascii.ply", ascii);
    CHECK(gv_points_read_ply(path, &n, &xyz, &rgb) != 0 && refused("huge_ascii.ply", "1000000000000"));
}

static void test_safetensors(void)
{
    /* A tensor of 10^12 elements in a file of a few bytes. */
    const char *header = "{\"w\":{\"dtype\":\"F32\",\"shape\":[1000000,1000000],\"data_offsets\":[0,4000000000000]}}";
    char file[256];
    uint64_t n = strlen(header);
    memcpy(file, &n, 8);
    memcpy(file + 8, header, n);
    memcpy(file + 8 + n, "abcd", 4);
    const char *path = put("huge_tensor.safetensors", file, 8 + n + 4);
    gv_st_file f;
    CHECK(gv_st_open(&f, path) != 0 && refused("huge_tensor.safetensors", "run past"));

    /* A header of 1 GiB in a file of 1.1 GiB (sparse: no disk used). */
    path = at("huge_header.safetensors");
    FILE *out = fopen(path, "wb");
    uint64_t gib = (uint64_t)1 << 30;
    CHECK(out && fwrite(&gib, 8, 1, out) == 1 && fclose(out) == 0);
    CHECK(truncate(path, (off_t)(gib + gib / 10)) == 0);
    CHECK(gv_st_open(&f, path) != 0 && refused("huge_header.safetensors", "beyond the format's limit"));
    unlink(path);
    /* and one that claims 2^63 bytes */
    uint64_t absurd = (uint64_t)1 << 63;
    path = put("absurd_header.safetensors", &absurd, 8);
    CHECK(gv_st_open(&f, path) != 0 && refused("absurd_header.safetensors", "header length"));
}

/* depth copies of open, then depth copies of close, between prefix and suffix. */
static char *nested(const char *prefix, const char *open, const char *close, int depth, const char *suffix)
{
    size_t lo = strlen(open), lc = strlen(close), lp = strlen(prefix), ls = strlen(suffix);
    char *text = malloc(lp + (lo + lc) * (size_t)depth + ls + 1), *p = text;
    memcpy(p, prefix, lp), p += lp;
    for (int i = 0; i < depth; i++) memcpy(p, open, lo), p += lo;
    for (int i = 0; i < depth; i++) memcpy(p, close, lc), p += lc;
    memcpy(p, suffix, ls + 1);
    return text;
}

static void test_deep_json(void)
{
    enum { DEPTH = 100000 };
    char *arrays = nested("{\"frames\": ", "[", "]", DEPTH, "}");
    char *objects = nested("{\"dit\": ", "{\"a\": ", "}", DEPTH, "}");
    gv_transforms t;
    CHECK(gv_transforms_read(put_text("transforms.json", arrays), &t) != 0 && refused("transforms.json", "JSON"));
    CHECK(gv_transforms_read(put_text("transforms.json", objects), &t) != 0 && refused("transforms.json", "JSON"));
    gv_model_config c;
    CHECK(gv_model_config_load(&c, put_text("config.json", objects)) != 0 && refused("config.json", "JSON"));
    CHECK(gv_model_config_load(&c, put_text("config.json", arrays)) != 0 && refused("config.json", "JSON"));
    CHECK(gv_mkdirs(at("data")) == 0);
    put_text("data/manifest.json", arrays);
    gv_manifest m;
    int found;
    CHECK(gv_manifest_read(at("data"), &m, &found) != 0 && refused("manifest.json", "JSON"));
    gv_run_record r;
    CHECK(gv_run_record_read(put_text("run.json", objects), &r) != 0 && refused("run.json", "JSON"));
    /* a safetensors header */
    char *deep = nested("{\"__metadata__\": ", "[", "]", DEPTH, "}");
    uint64_t n = strlen(deep);
    char *file = malloc(8 + n);
    memcpy(file, &n, 8);
    memcpy(file + 8, deep, n);
    gv_st_file f;
    CHECK(gv_st_open(&f, put("deep.safetensors", file, 8 + n)) != 0 && refused("deep.safetensors", "deeper"));
    free(file), free(deep), free(arrays), free(objects);
}

/* Reads a whole file written by the test. */
static uint8_t *slurp(const char *path, size_t *size)
{
    char *data;
    if (gv_read_file(path, &data, size) != 0) return NULL;
    return (uint8_t *)data;
}

static void put_be32(uint8_t *p, uint32_t v)
{
    p[0] = (uint8_t)(v >> 24), p[1] = (uint8_t)(v >> 16), p[2] = (uint8_t)(v >> 8), p[3] = (uint8_t)v;
}

/* A real 4x4 PNG and JPEG, their headers then patched to say 65535x65535 (the JPEG also
 * 65500x65500, libjpeg's own largest). */
static void test_images(void)
{
    gv_image small, img;
    CHECK(gv_image_alloc(&small, 4, 4, 3) == 0);
    const char *path = at("huge.png");
    CHECK(gv_image_write_png(path, &small) == 0);
    size_t size;
    uint8_t *png = slurp(path, &size);
    CHECK(png && size > 33 && !memcmp(png + 12, "IHDR", 4));
    put_be32(png + 16, 65535);
    put_be32(png + 20, 65535);
    put_be32(png + 29, (uint32_t)crc32(0, png + 12, 17)); /* the chunk's CRC covers type and data */
    CHECK(gv_image_read(put("huge.png", png, size), &img) != 0 && refused("huge.png", "65535x65535"));
    free(png);

    path = at("huge.jpg");
    FILE *f = fopen(path, "wb");
    struct jpeg_compress_struct c;
    struct jpeg_error_mgr e;
    c.err = jpeg_std_error(&e);
    jpeg_create_compress(&c);
    jpeg_stdio_dest(&c, f);
    c.image_width = 4, c.image_height = 4, c.input_components = 3, c.in_color_space = JCS_RGB;
    jpeg_set_defaults(&c);
    jpeg_start_compress(&c, TRUE);
    for (int y = 0; y < 4; y++) {
        JSAMPROW row = small.pixels + y * 12;
        jpeg_write_scanlines(&c, &row, 1);
    }
    jpeg_finish_compress(&c);
    jpeg_destroy_compress(&c);
    fclose(f);
    uint8_t *jpg = slurp(path, &size);
    size_t sof = 0;
    for (size_t i = 2; jpg && i + 9 < size && !sof; i++)
        if (jpg[i] == 0xff && jpg[i + 1] == 0xc0) sof = i;
    CHECK(sof > 0);
    jpg[sof + 5] = jpg[sof + 7] = 0xff; /* height, width: 65535 (libjpeg refuses above 65500) */
    jpg[sof + 6] = jpg[sof + 8] = 0xff;
    CHECK(gv_image_read(put("huge.jpg", jpg, size), &img) != 0 && refused("huge.jpg", "65500"));
    jpg[sof + 6] = jpg[sof + 8] = 0xdc; /* 65500x65500: our own bound on what the file can hold */
    CHECK(gv_image_read(put("huge.jpg", jpg, size), &img) != 0 && refused("huge.jpg", "65500x65500"));
    free(jpg);
    gv_image_free(&small);
}

static void test_colmap(void)
{
    uint64_t count = 1000000000000ULL;
    uint8_t file[8 + 24] = {0};
    memcpy(file, &count, 8);
    gv_colmap_model model;
    memset(&model, 0, sizeof model);
    CHECK(gv_colmap_read_cameras_bin(put("cameras.bin", file, sizeof file), &model) != 0 &&
          refused("cameras.bin", "1000000000000"));
    CHECK(gv_colmap_read_images_bin(put("images.bin", file, sizeof file), &model) != 0 &&
          refused("images.bin", "1000000000000"));
    CHECK(gv_colmap_read_points3d_bin(put("points3D.bin", file, sizeof file), &model) != 0 &&
          refused("points3D.bin", "1000000000000"));
    gv_colmap_free(&model);
}

/* A checkpoint of a few hundred bytes whose config is the 14B model: loading it must not
 * allocate the 14B network before finding the file cannot hold it. */
static void test_checkpoint_config(void)
{
    gv_model_config big;
    CHECK(gv_model_config_preset(&big, "wan2.1-vace-14b") == 0);
    char *json = gv_model_config_to_json(&big);
    gv_st_builder b;
    gv_st_builder_init(&b);
    const char *meta[][2] = {{"format", GV_CHECKPOINT_FORMAT}, {"format_version", "1"}, {"kind", "base"},
                             {"config", json}, {"step", "1"}, {"steps", "1"}, {"adamw_step", "1"},
                             {"data_position", "0"}, {"clips_used", "1"}, {"clips_skipped", "0"},
                             {"seed", "0"}, {"seconds", "1"}, {"loss", "0.5"}};
    for (size_t i = 0; i < sizeof meta / sizeof meta[0]; i++) gv_st_add_metadata(&b, meta[i][0], meta[i][1]);
    float one = 1;
    int64_t shape[1] = {1};
    gv_st_add_f32(&b, "head.head.bias", GV_ST_F32, shape, 1, &one);
    const char *path = at("big.safetensors");
    CHECK(gv_st_write(&b, path) == 0);
    gv_st_builder_free(&b);
    gv_restorer restorer;
    gv_model_config cfg;
    CHECK(gv_restorer_load(path, &restorer) != 0 && refused("big.safetensors", "holds"));

    /* The same for VAE weights whose config describes the 14B model's VAE scaled up. */
    gv_st_builder_init(&b);
    big.vae.dim = 4096;
    free(json);
    json = gv_model_config_to_json(&big);
    gv_st_add_metadata(&b, "config", json);
    gv_st_add_f32(&b, "conv1.bias", GV_ST_F32, shape, 1, &one);
    path = at("big_vae.safetensors");
    CHECK(gv_st_write(&b, path) == 0);
    gv_st_builder_free(&b);
    gv_vae vae;
    if (gv_vae_file_config(path, &cfg) == 0) {
        CHECK(gv_train_load_vae(path, &cfg, &vae) != 0 && refused("big_vae.safetensors", "holds"));
    } else {
        CHECK(refused("big_vae.safetensors", "")); /* the config itself refused: also fine */
    }
    free(json);
}

/* A message quotes what the file holds: a newline there must not break the one line. */
static void test_one_line(void)
{
    gv_fail("%s: unknown key '%s'", "f.json", "a\nb\r\x1b[31m");
    CHECK(!strcmp(gv_last_error(), "f.json: unknown key 'a?b??[31m'"));
    gv_model_config c;
    CHECK(gv_model_config_parse(&c, "{\"name\": \"x\", \"li\\nne\": 1}", "k.json") != 0 &&
          refused("k.json", "li?ne"));
}

int main(void)
{
    snprintf(dir, sizeof dir, "%s", check_tmp_dir());
#ifndef __SANITIZE_ADDRESS__
    struct rlimit cap = {(rlim_t)4 << 30, (rlim_t)4 << 30}; /* 4 GiB of address space */
    if (setrlimit(RLIMIT_AS, &cap) != 0) perror("setrlimit");
#endif
    gv_log_set_level(GV_LOG_QUIET);
    test_ply();
    test_safetensors();
    test_deep_json();
    test_images();
    test_colmap();
    test_checkpoint_config();
    test_one_line();
    return check_summary();
}
