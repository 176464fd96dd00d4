/* Restoring clip files or a dataset folder (restore.h): conditioning (from the latent cache
 * when asked), sampling, composition, the restored frames written as PNGs and optionally as a
 * clip file, and each restored clip handed to the caller (e.g. an evaluation table). */
#include <stdlib.h>
#include <string.h>

#include "gaussvid/core/core.h"
#include "gaussvid/io/image.h"
#include "gaussvid/restore/restore.h"

/* The file name of a clip path without folders and ".safetensors". */
static void clip_stem(const char *path, char *out, size_t size)
{
    const char *slash = strrchr(path, '/');
    snprintf(out, size, "%s", slash ? slash + 1 : path);
    size_t len = strlen(out), ext = strlen(".safetensors");
    if (len > ext && !strcmp(out + len - ext, ".safetensors")) out[len - ext] = 0;
}

/* <out>/<stem>/f0.png .. f4.png, and <out>/<stem>.safetensors (inputs = the restored frames). */
static int write_outputs(const char *out_dir, const char *stem, const gv_clip *clip, uint8_t *frames, int save_clip)
{
    char dir[4096], path[4200];
    if (gv_path_join(dir, sizeof dir, out_dir, stem) || gv_mkdirs(dir)) return -1;
    const gv_clip_info *info = &clip->info;
    for (int f = 0; f < GV_CLIP_FRAMES; f++) {
        gv_image img = {info->width, info->height, 3, gv_clip_frame(frames, info, f)};
        snprintf(path, sizeof path, "%s/f%d.png", dir, f);
        if (gv_image_write_png(path, &img)) return -1;
    }
    if (!save_clip) return 0;
    gv_clip restored = *clip;
    restored.inputs = frames;
    snprintf(path, sizeof path, "%s/%s.safetensors", out_dir, stem);
    return gv_clip_write(path, &restored);
}

/* A clip left as rendered (o->keep_renders): its input frames, written and handed on as a
 * restored clip would be. */
static int keep_one(const gv_clip *clip, const char *name, const gv_restore_options *o, char *note, size_t note_size)
{
    const gv_clip_info *info = &clip->info;
    size_t bytes = (size_t)GV_CLIP_FRAMES * info->width * info->height * 3;
    uint8_t *frames = malloc(bytes);
    if (!frames) return gv_fail("restore: out of memory");
    memcpy(frames, clip->inputs, bytes);
    int rc = 0;
    if (o->out_dir) {
        char stem[512];
        clip_stem(name, stem, sizeof stem);
        rc = write_outputs(o->out_dir, stem, clip, frames, o->save_clips);
    }
    if (rc == 0 && o->each) rc = o->each(o->each_ctx, clip, frames, note, note_size);
    free(frames);
    return rc;
}

/* One clip: latents l (NULL: prepared here), restored, written, handed to o->each. */
static int restore_one(gv_restorer *r, const gv_clip *clip, const char *name, const gv_clip_latents *given,
                       const gv_restore_options *o, char *note, size_t note_size)
{
    gv_clip_latents own;
    const gv_clip_latents *l = given;
    if (o->keep_renders) return keep_one(clip, name, o, note, note_size);
    if (!l) {
        if (gv_clip_latents_prepare(&r->vae, &r->net.cfg, clip, &own)) return -1;
        l = &own;
    }
    const gv_clip_info *info = &clip->info;
    float *z = malloc((size_t)gv_clip_latents_z_count(l) * sizeof *z);
    uint8_t *frames = malloc((size_t)GV_CLIP_FRAMES * info->width * info->height * 3);
    int rc = z && frames ? 0 : gv_fail("restore: out of memory");
    if (rc == 0) rc = gv_restore_latent(&r->net, l, &o->sampler, gv_restore_clip_seed(o->sampler.seed, name), z);
    if (rc == 0) rc = gv_restore_compose(&r->vae, clip, l, z, o->compose, o->sampler.release, frames);
    if (rc == 0 && o->out_dir) {
        char stem[512];
        clip_stem(name, stem, sizeof stem);
        rc = write_outputs(o->out_dir, stem, clip, frames, o->save_clips);
    }
    if (rc == 0 && o->each) rc = o->each(o->each_ctx, clip, frames, note, note_size);
    free(z), free(frames);
    if (!given) gv_clip_latents_free(&own);
    return rc;
}

/* Whether a clip of run id belongs to the run o asks for (its split, scene and interval). */
static int run_selected(const gv_run_id *id, const gv_restore_options *o)
{
    return (!o->split || !strcmp(id->split, o->split)) && (!o->scene || !strcmp(id->scene, o->scene)) &&
           (!o->interval || id->interval == o->interval);
}

/* The manifest entry of a clip file (NULL when the manifest does not list it). */
static const gv_manifest_clip *manifest_clip(const gv_manifest *man, const char *file)
{
    for (int i = 0; i < man->n_clips; i++)
        if (!strcmp(man->clips[i].file, file)) return &man->clips[i];
    return NULL;
}

static void progress_note(gv_progress *bar, long done, const char *note)
{
    if (note[0]) gv_progress_update(bar, done, "%s", note);
    else gv_progress_update(bar, done, NULL);
}

int gv_restore_files(gv_restorer *r, const char *const *paths, int n_paths, const gv_restore_options *o)
{
    if (!o->keep_renders && gv_sampler_check(&o->sampler)) return -1;
    gv_progress bar;
    gv_progress_start(&bar, "restore", n_paths);
    int rc = 0;
    char note[64] = ""; /* o->each's last note */
    for (int i = 0; rc == 0 && i < n_paths; i++) {
        gv_clip clip;
        if (gv_clip_read(paths[i], &clip)) {
            rc = -1;
            break;
        }
        const gv_run_id *id = &clip.info.id;
        if ((o->scene && strcmp(id->scene, o->scene)) || (o->interval && id->interval != o->interval)) {
            rc = gv_fail("%s: a clip of %s at n = %d, not of %s at n = %d", paths[i], id->scene, id->interval,
                         o->scene ? o->scene : id->scene, o->interval ? o->interval : id->interval);
            gv_clip_free(&clip);
            break;
        }
        char name[512];
        clip_stem(paths[i], name, sizeof name);
        rc = restore_one(r, &clip, name, NULL, o, note, sizeof note);
        gv_clip_free(&clip);
        if (rc) gv_fail_context("%s", paths[i]);
        progress_note(&bar, i + 1, note);
    }
    gv_progress_finish(&bar);
    return rc;
}

int gv_restore_dataset(gv_restorer *r, const char *dataset_dir, const gv_restore_options *given)
{
    gv_restore_options keep = *given;
    const gv_restore_options *o = &keep;
    if (keep.keep_renders) keep.use_cache = 0; /* no latents needed */
    if (!o->keep_renders && gv_sampler_check(&o->sampler)) return -1;
    gv_latent_set set;
    memset(&set, 0, sizeof set);
    gv_manifest man;
    int rc = gv_manifest_read_dataset(dataset_dir, &man);
    if (rc == 0 && o->use_cache) rc = gv_latent_set_load(dataset_dir, o->split, r->vae_path, &r->vae, &r->net.cfg, &set);
    int count = o->use_cache ? set.count : man.n_clips;
    /* selected[i]: clip i (of the latent set or of the manifest) is restored */
    char *selected = rc == 0 ? calloc((size_t)count + 1, 1) : NULL;
    if (rc == 0 && !selected) rc = gv_fail("restore: out of memory");
    int total = 0;
    for (int i = 0; rc == 0 && i < count; i++) {
        const gv_manifest_clip *entry = o->use_cache ? manifest_clip(&man, set.names[i]) : &man.clips[i];
        selected[i] = entry && run_selected(&entry->id, o);
        total += selected[i];
    }
    if (rc == 0 && total == 0) {
        char what[256];
        snprintf(what, sizeof what, "%s%s%s%s", o->split ? o->split : "", o->split ? " " : "",
                 o->scene ? o->scene : "", o->scene ? " " : "");
        if (o->interval) rc = gv_fail("%s: the manifest lists no %sclips at n = %d", dataset_dir, what, o->interval);
        else rc = gv_fail("%s: the manifest lists no %sclips", dataset_dir, what);
    }
    gv_progress bar;
    int started = rc == 0; /* no 0/0 bar before an error */
    if (started) gv_progress_start(&bar, "restore", total);
    int done = 0;
    char note[64] = ""; /* o->each's last note */
    for (int i = 0; rc == 0 && i < count; i++) {
        if (!selected[i]) continue;
        const char *name = o->use_cache ? set.names[i] : man.clips[i].file;
        char path[4096];
        gv_clip clip;
        if (gv_path_join(path, sizeof path, dataset_dir, name) || gv_clip_read(path, &clip)) {
            rc = -1;
            break;
        }
        char stem[512];
        clip_stem(name, stem, sizeof stem);
        rc = restore_one(r, &clip, stem, o->use_cache ? &set.clips[i] : NULL, o, note, sizeof note);
        gv_clip_free(&clip);
        if (rc) gv_fail_context("%s", path);
        progress_note(&bar, ++done, note);
    }
    if (started) gv_progress_finish(&bar);
    free(selected);
    gv_latent_set_free(&set);
    gv_manifest_free(&man);
    return rc;
}
