/* One clip, one safetensors file (docs/FORMATS-DATASET.md): the frames, cameras and
 * metadata of a clean-corrupted-clean training sample (paper section 3.2). The reader
 * checks everything the writer guarantees, so a clip that reads is a clip that trains. */
#include <cjson/cJSON.h>
#include <errno.h>
#include <inttypes.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "gaussvid/splat/coverage.h"
#include "gaussvid/data/dataset.h"
#include "gaussvid/io/safetensors.h"

#define MAX_SIDE 16384

int gv_clip_alloc(gv_clip *clip, const gv_clip_info *info)
{
    memset(clip, 0, sizeof *clip);
    if (info->width < 1 || info->height < 1 || info->width > MAX_SIDE || info->height > MAX_SIDE)
        return gv_fail("clip size %dx%d: outside 1..%d", info->width, info->height, MAX_SIDE);
    size_t bytes = (size_t)GV_CLIP_FRAMES * info->width * info->height * 3;
    clip->info = *info;
    clip->inputs = calloc(bytes, 1);
    clip->targets = calloc(bytes, 1);
    if (!clip->inputs || !clip->targets) {
        gv_clip_free(clip);
        return gv_fail("out of memory for a %dx%d clip", info->width, info->height);
    }
    return 0;
}

void gv_clip_free(gv_clip *clip)
{
    free(clip->inputs);
    free(clip->targets);
    free(clip->coverage);
    clip->inputs = clip->targets = clip->coverage = NULL;
}

uint8_t *gv_clip_frame(uint8_t *frames, const gv_clip_info *info, int f)
{
    return frames + (size_t)f * info->width * info->height * 3;
}

void gv_clip_set_camera(gv_clip *clip, int f, const gv_camera *cam)
{
    float *k = clip->intrinsics[f], *pose = clip->poses[f];
    k[0] = (float)cam->fx, k[1] = (float)cam->fy, k[2] = (float)cam->cx, k[3] = (float)cam->cy;
    for (int r = 0; r < 3; r++) {
        for (int c = 0; c < 3; c++) pose[r * 4 + c] = (float)cam->R[r * 3 + c];
        pose[r * 4 + 3] = (float)cam->t[r];
    }
}

int gv_clip_check_info(const gv_clip_info *info, const char *what)
{
    if (!info->id.scene[0] || strchr(info->id.scene, '/'))
        return gv_fail("%s: scene name '%s' is empty or holds a '/'", what, info->id.scene);
    if (strcmp(info->id.split, "train") && strcmp(info->id.split, "eval"))
        return gv_fail("%s: split '%s': expected train or eval", what, info->id.split);
    if (info->id.interval < 2 || info->anchor_gap < 1 || info->iters < 0)
        return gv_fail("%s: n %d, anchor_gap %d, iters %d: need n >= 2, anchor_gap >= 1, "
                       "iters >= 0", what, info->id.interval, info->anchor_gap, info->iters);
    if (info->width < 1 || info->height < 1 || info->width > MAX_SIDE || info->height > MAX_SIDE)
        return gv_fail("%s: size %dx%d: outside 1..%d", what, info->width, info->height, MAX_SIDE);
    if ((unsigned)info->sampling > GV_SAMPLING_RELEASED)
        return gv_fail("%s: unknown sampling %d", what, (int)info->sampling);
    const int *fr = info->frames, o = info->offset;
    for (int i = 1; i < GV_CLIP_FRAMES; i++)
        if (fr[i] <= fr[i - 1])
            return gv_fail("%s: frame_indices are not strictly increasing", what);
    if (o < 0 || o >= info->id.interval)
        return gv_fail("%s: offset %d: expected 0..n - 1 (n = %d)", what, o, info->id.interval);
    if (fr[0] < o || !gv_scene_is_train(fr[0] - o, info->id.interval) ||
        (long)fr[4] - fr[0] != (long)info->anchor_gap * info->id.interval)
        return gv_fail("%s: anchors %d and %d are not training views %d * n apart (n = %d, offset %d)",
                       what, fr[0], fr[4], info->anchor_gap, info->id.interval, o);
    for (int i = 1; i < 4; i++)
        if (gv_scene_is_train(fr[i] - o, info->id.interval))
            return gv_fail("%s: intermediate frame %d is a training view (n = %d, offset %d)", what,
                           fr[i], info->id.interval, o);
    int supervised = 0;
    for (int i = 0; i < GV_CLIP_FRAMES; i++) {
        int anchor = i == 0 || i == GV_CLIP_FRAMES - 1;
        if (info->no_target[i] > 1 || (anchor && info->no_target[i]))
            return gv_fail("%s: target_mask: frame %d must be %s", what, i, anchor ? "1 (an anchor)" : "0 or 1");
        supervised += !anchor && !info->no_target[i];
    }
    if (!supervised) return gv_fail("%s: target_mask: no intermediate frame has ground truth", what);
    return 0;
}

/* 1 when the clip has a frame without ground truth (then target_mask is written). */
static int has_mask(const gv_clip_info *info)
{
    for (int i = 0; i < GV_CLIP_FRAMES; i++)
        if (info->no_target[i]) return 1;
    return 0;
}

/* Every value of the coverage plane is made of the two anchors' bits. */
static int check_coverage(const char *path, const gv_clip *clip)
{
    size_t n = (size_t)(GV_CLIP_FRAMES - 2) * clip->info.width * clip->info.height;
    for (size_t i = 0; i < n; i++)
        if (clip->coverage[i] > (GV_COVERED_FIRST | GV_COVERED_LAST))
            return gv_fail("%s: coverage value %d at frame %d: expected 0..3 (bits of the anchors that see the "
                           "pixel)", path, clip->coverage[i], 1 + (int)(i / ((size_t)clip->info.width * clip->info.height)));
    return 0;
}

/* ---- writing ------------------------------------------------------------------------ */

static int add_int(gv_st_builder *b, const char *key, long long value)
{
    char text[32];
    snprintf(text, sizeof text, "%lld", value);
    return gv_st_add_metadata(b, key, text);
}

/* The JSON list of the frame indices (what 0), the frame names (1) or the target mask (2);
 * NULL when memory runs out. */
static char *frames_json(const gv_clip_info *info, int what)
{
    cJSON *list = cJSON_CreateArray();
    for (int i = 0; list && i < GV_CLIP_FRAMES; i++) {
        cJSON *item = what == 1 ? cJSON_CreateString(info->frame_names[i])
                                : cJSON_CreateNumber(what == 2 ? !info->no_target[i] : info->frames[i]);
        if (!item || !cJSON_AddItemToArray(list, item)) {
            cJSON_Delete(item);
            cJSON_Delete(list);
            return NULL;
        }
    }
    char *text = list ? cJSON_PrintUnformatted(list) : NULL;
    cJSON_Delete(list);
    return text;
}

static int add_metadata(gv_st_builder *b, const gv_clip_info *info)
{
    char seed[32];
    snprintf(seed, sizeof seed, "%" PRIu64, info->seed);
    char *indices = frames_json(info, 0), *names = frames_json(info, 1);
    int rc = (!indices || !names) ? gv_fail("out of memory") : 0;
    if (rc == 0)
        rc = gv_st_add_metadata(b, "format", GV_CLIP_FORMAT) ||
             add_int(b, "format_version", GV_CLIP_FORMAT_VERSION) ||
             gv_st_add_metadata(b, "scene", info->id.scene) ||
             gv_st_add_metadata(b, "split", info->id.split) || add_int(b, "n", info->id.interval) ||
             add_int(b, "anchor_gap", info->anchor_gap) ||
             gv_st_add_metadata(b, "frame_indices", indices) ||
             gv_st_add_metadata(b, "frame_names", names) || add_int(b, "iters", info->iters) ||
             gv_st_add_metadata(b, "sampling", gv_sampling_name(info->sampling)) ||
             gv_st_add_metadata(b, "seed", seed) || add_int(b, "width", info->width) ||
             add_int(b, "height", info->height);
    if (rc == 0 && info->offset) rc = add_int(b, "offset", info->offset);
    if (rc == 0 && info->subsets) rc = add_int(b, "subsets", info->subsets);
    char *mask = rc == 0 && has_mask(info) ? frames_json(info, 2) : NULL;
    if (rc == 0 && has_mask(info)) rc = mask ? gv_st_add_metadata(b, "target_mask", mask) : gv_fail("out of memory");
    free(mask);
    free(indices);
    free(names);
    return rc ? -1 : 0;
}

int gv_clip_write(const char *path, const gv_clip *clip)
{
    const gv_clip_info *info = &clip->info;
    if (gv_clip_check_info(info, path) != 0) return -1;
    const int64_t frames_shape[4] = {GV_CLIP_FRAMES, info->height, info->width, 3};
    const int64_t intrinsics_shape[2] = {GV_CLIP_FRAMES, 4};
    const int64_t poses_shape[3] = {GV_CLIP_FRAMES, 3, 4};
    const int64_t coverage_shape[3] = {GV_CLIP_FRAMES - 2, info->height, info->width};
    if (clip->coverage && check_coverage(path, clip)) return -1;
    gv_st_builder b;
    gv_st_builder_init(&b);
    int rc = gv_st_add_raw(&b, "inputs", GV_ST_U8, frames_shape, 4, clip->inputs) ||
             gv_st_add_raw(&b, "targets", GV_ST_U8, frames_shape, 4, clip->targets) ||
             gv_st_add_f32(&b, "intrinsics", GV_ST_F32, intrinsics_shape, 2, &clip->intrinsics[0][0]) ||
             gv_st_add_f32(&b, "poses", GV_ST_F32, poses_shape, 3, &clip->poses[0][0]) ||
             (clip->coverage && gv_st_add_raw(&b, "coverage", GV_ST_U8, coverage_shape, 3, clip->coverage)) ||
             add_metadata(&b, info);
    if (rc != 0) gv_fail_context("%s", path);
    else rc = gv_st_write(&b, path); /* its messages name the file */
    gv_st_builder_free(&b);
    return rc ? -1 : 0;
}

/* ---- reading ------------------------------------------------------------------------ */

static int meta_string(const gv_st_file *f, const char *key, const char **out)
{
    *out = gv_st_metadata(f, key);
    if (!*out) return gv_fail("%s: not a gaussvid clip: no '%s' in __metadata__", f->path, key);
    return 0;
}

static int meta_int(const gv_st_file *f, const char *key, long min, long max, int *out)
{
    const char *text;
    if (meta_string(f, key, &text) != 0) return -1;
    char *end;
    errno = 0;
    long v = strtol(text, &end, 10);
    if (errno || end == text || *end || v < min || v > max)
        return gv_fail("%s: metadata %s '%s': expected an integer in %ld..%ld", f->path, key, text,
                       min, max);
    *out = (int)v;
    return 0;
}

/* target_mask (optional): a JSON list of 5 values 0 or 1, into no_target (1 - value). */
static int meta_mask(const gv_st_file *f, gv_clip_info *info)
{
    const char *text = gv_st_metadata(f, "target_mask");
    if (!text) return 0;
    cJSON *list = cJSON_Parse(text);
    int ok = cJSON_IsArray(list) && cJSON_GetArraySize(list) == GV_CLIP_FRAMES;
    for (int i = 0; ok && i < GV_CLIP_FRAMES; i++) {
        cJSON *item = cJSON_GetArrayItem(list, i);
        ok = cJSON_IsNumber(item) && (item->valuedouble == 0 || item->valuedouble == 1);
        if (ok) info->no_target[i] = item->valuedouble == 0;
    }
    cJSON_Delete(list);
    if (!ok) return gv_fail("%s: metadata target_mask '%.60s': expected a JSON list of %d values 0 or 1", f->path, text, GV_CLIP_FRAMES);
    return 0;
}

/* frame_indices (5 integers) or frame_names (5 strings, optional). */
static int meta_frames(const gv_st_file *f, gv_clip_info *info, int names)
{
    const char *key = names ? "frame_names" : "frame_indices";
    const char *text = gv_st_metadata(f, key);
    if (!text && names) return 0;
    if (!text) return meta_string(f, key, &text);
    cJSON *list = cJSON_Parse(text);
    int ok = cJSON_IsArray(list) && cJSON_GetArraySize(list) == GV_CLIP_FRAMES;
    for (int i = 0; ok && i < GV_CLIP_FRAMES; i++) {
        cJSON *item = cJSON_GetArrayItem(list, i);
        if (names) {
            ok = cJSON_IsString(item) && strlen(item->valuestring) < sizeof info->frame_names[i];
            if (ok) strcpy(info->frame_names[i], item->valuestring);
        } else {
            ok = cJSON_IsNumber(item) && item->valuedouble >= 0 && item->valuedouble <= 1e9 &&
                 item->valuedouble == (int)item->valuedouble;
            if (ok) info->frames[i] = (int)item->valuedouble;
        }
    }
    cJSON_Delete(list);
    if (!ok)
        return gv_fail("%s: metadata %s '%.60s': expected a JSON list of %d %s", f->path, key,
                       text, GV_CLIP_FRAMES, names ? "names" : "non-negative integers");
    return 0;
}

static int read_metadata(const gv_st_file *f, gv_clip_info *info)
{
    const char *format, *scene, *split, *sampling, *seed;
    int version;
    memset(info, 0, sizeof *info);
    if (meta_string(f, "format", &format) != 0) return -1;
    if (strcmp(format, GV_CLIP_FORMAT))
        return gv_fail("%s: format '%s' is not a gaussvid clip ('%s')", f->path, format, GV_CLIP_FORMAT);
    if (meta_int(f, "format_version", 1, 1000000, &version) != 0) return -1;
    if (version != GV_CLIP_FORMAT_VERSION)
        return gv_fail("%s: clip format version %d; this program reads version %d", f->path,
                       version, GV_CLIP_FORMAT_VERSION);
    if (meta_string(f, "scene", &scene) || meta_string(f, "split", &split) ||
        meta_string(f, "sampling", &sampling) || meta_string(f, "seed", &seed))
        return -1;
    if (strlen(scene) >= sizeof info->id.scene)
        return gv_fail("%s: scene name longer than %zu bytes", f->path, sizeof info->id.scene - 1);
    snprintf(info->id.scene, sizeof info->id.scene, "%s", scene);
    snprintf(info->id.split, sizeof info->id.split, "%.7s", split);
    if (strlen(split) >= sizeof info->id.split || gv_sampling_from_name(sampling, &info->sampling))
        return gv_fail("%s: split '%s' or sampling '%s' is not valid", f->path, split, sampling);
    char *end;
    errno = 0;
    info->seed = strtoull(seed, &end, 10);
    if (errno || end == seed || *end || seed[0] == '-')
        return gv_fail("%s: metadata seed '%s': expected an unsigned integer", f->path, seed);
    if (meta_int(f, "n", 2, 1000000, &info->id.interval) || meta_int(f, "anchor_gap", 1, 1000000, &info->anchor_gap) ||
        meta_int(f, "iters", 0, 1000000000, &info->iters) ||
        meta_int(f, "width", 1, MAX_SIDE, &info->width) ||
        meta_int(f, "height", 1, MAX_SIDE, &info->height) || meta_frames(f, info, 0) ||
        meta_frames(f, info, 1) || meta_mask(f, info) ||
        (gv_st_metadata(f, "offset") && meta_int(f, "offset", 0, 1000000, &info->offset)) ||
        (gv_st_metadata(f, "subsets") && meta_int(f, "subsets", 3, 1000000, &info->subsets)))
        return -1;
    return gv_clip_check_info(info, f->path);
}

static const char *tensor_names[5] = {"inputs", "targets", "intrinsics", "poses", "coverage"};

/* Exactly the four tensors and the optional coverage plane, with their dtypes and shapes;
 * info->has_coverage says whether the plane is there. */
static int check_tensors(const gv_st_file *f, gv_clip_info *info)
{
    for (int i = 0; i < f->n_tensors; i++) {
        int known = 0;
        for (int k = 0; k < 5; k++) known |= !strcmp(f->tensors[i].name, tensor_names[k]);
        if (!known) return gv_fail("%s: unexpected tensor '%s' in a clip", f->path, f->tensors[i].name);
        if (!strcmp(f->tensors[i].name, "coverage")) info->has_coverage = 1;
    }
    const int64_t coverage_shape[3] = {GV_CLIP_FRAMES - 2, info->height, info->width};
    const int64_t frames_shape[4] = {GV_CLIP_FRAMES, info->height, info->width, 3};
    const int64_t intrinsics_shape[2] = {GV_CLIP_FRAMES, 4};
    const int64_t poses_shape[3] = {GV_CLIP_FRAMES, 3, 4};
    const gv_st_tensor *t;
    return gv_st_get(f, "inputs", GV_ST_U8, frames_shape, 4, &t) ||
                   gv_st_get(f, "targets", GV_ST_U8, frames_shape, 4, &t) ||
                   gv_st_get(f, "intrinsics", GV_ST_F32, intrinsics_shape, 2, &t) ||
                   gv_st_get(f, "poses", GV_ST_F32, poses_shape, 3, &t) ||
                   (info->has_coverage && gv_st_get(f, "coverage", GV_ST_U8, coverage_shape, 3, &t))
               ? -1 : 0;
}

int gv_clip_read_info(const char *path, gv_clip_info *info)
{
    gv_st_file f;
    if (gv_st_open(&f, path) != 0) return -1;
    int rc = read_metadata(&f, info) || check_tensors(&f, info) ? -1 : 0;
    gv_st_close(&f);
    return rc;
}

/* Finite cameras with positive focal lengths and rotations that are rotations. */
static int check_cameras(const char *path, const gv_clip *clip)
{
    for (int i = 0; i < GV_CLIP_FRAMES; i++) {
        const float *k = clip->intrinsics[i], *p = clip->poses[i];
        for (int j = 0; j < 4; j++)
            if (!isfinite(k[j])) return gv_fail("%s: intrinsics of frame %d are not finite", path, i);
        if (k[0] <= 0 || k[1] <= 0) return gv_fail("%s: frame %d: focal lengths must be positive", path, i);
        for (int j = 0; j < 12; j++)
            if (!isfinite(p[j])) return gv_fail("%s: pose of frame %d is not finite", path, i);
        for (int a = 0; a < 3; a++) {
            for (int b = 0; b < 3; b++) {
                double dot = 0;
                for (int c = 0; c < 3; c++) dot += (double)p[a * 4 + c] * p[b * 4 + c];
                if (fabs(dot - (a == b)) > 1e-3)
                    return gv_fail("%s: pose of frame %d: R is not a rotation (R R^T differs from "
                                   "I by %.2g)", path, i, fabs(dot - (a == b)));
            }
        }
    }
    return 0;
}

int gv_clip_read(const char *path, gv_clip *clip)
{
    memset(clip, 0, sizeof *clip);
    gv_st_file f;
    gv_clip_info info;
    if (gv_st_open(&f, path) != 0) return -1;
    int rc = read_metadata(&f, &info) || check_tensors(&f, &info) ? -1 : 0;
    if (rc == 0) rc = gv_clip_alloc(clip, &info);
    const int64_t frames_shape[4] = {GV_CLIP_FRAMES, info.height, info.width, 3};
    const int64_t intrinsics_shape[2] = {GV_CLIP_FRAMES, 4};
    const int64_t poses_shape[3] = {GV_CLIP_FRAMES, 3, 4};
    if (rc == 0)
        rc = gv_st_read_raw(&f, "inputs", GV_ST_U8, frames_shape, 4, clip->inputs) ||
                     gv_st_read_raw(&f, "targets", GV_ST_U8, frames_shape, 4, clip->targets) ||
                     gv_st_read_f32(&f, "intrinsics", &clip->intrinsics[0][0], intrinsics_shape, 2) ||
                     gv_st_read_f32(&f, "poses", &clip->poses[0][0], poses_shape, 3)
                 ? -1 : 0;
    const int64_t coverage_shape[3] = {GV_CLIP_FRAMES - 2, info.height, info.width};
    if (rc == 0 && info.has_coverage) {
        clip->coverage = malloc((size_t)(GV_CLIP_FRAMES - 2) * info.width * info.height);
        rc = !clip->coverage ? gv_fail("%s: out of memory for the coverage plane", path)
             : gv_st_read_raw(&f, "coverage", GV_ST_U8, coverage_shape, 3, clip->coverage) ? -1
                                                                                            : check_coverage(path, clip);
    }
    gv_st_close(&f);
    if (rc == 0) rc = check_cameras(path, clip);
    size_t frame_bytes = (size_t)info.width * info.height * 3;
    for (int i = 0; rc == 0 && i < GV_CLIP_FRAMES; i += GV_CLIP_FRAMES - 1)
        if (memcmp(gv_clip_frame(clip->inputs, &info, i), gv_clip_frame(clip->targets, &info, i),
                   frame_bytes))
            rc = gv_fail("%s: anchor frame %d differs between inputs and targets (anchors are "
                         "clean ground truth)", path, i);
    for (int i = 1; rc == 0 && i < GV_CLIP_FRAMES - 1; i++)
        if (info.no_target[i] && memcmp(gv_clip_frame(clip->inputs, &info, i),
                                        gv_clip_frame(clip->targets, &info, i), frame_bytes))
            rc = gv_fail("%s: frame %d has no ground truth (target_mask 0) but its targets frame "
                         "differs from its input", path, i);
    if (rc != 0) gv_clip_free(clip);
    return rc;
}
