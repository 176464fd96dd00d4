/* Which scenes a restorer saw in training (checkpoint metadata "scenes", docs/TRAINING.md
 * "Checkpoint files"): `pretrain` and `train` record the scenes of the clips they load (from
 * the dataset's manifest) joined with their base's, so that restoring, evaluating or
 * reconstructing one of those scenes can say that its numbers do not measure generalisation.
 * Scenes are named as the dataset names them: by their folder's name. */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "gaussvid/train/checkpoint.h"
#include "gaussvid/core/core.h"
#include "gaussvid/data/dataset.h"
#include "gaussvid/io/json.h"
#include "gaussvid/train/scene_adapt.h"
#include "train/train_internal.h"

int gv_scene_list_has(const char *list, const char *name)
{
    size_t len = strlen(name);
    for (const char *p = list; *p;) {
        const char *comma = strchr(p, ',');
        size_t item = comma ? (size_t)(comma - p) : strlen(p);
        if (item == len && !strncmp(p, name, len)) return 1;
        p += item + (comma != NULL);
    }
    return 0;
}

static int compare_names(const void *a, const void *b) { return strcmp(*(char *const *)a, *(char *const *)b); }

/* Adds name to the sorted comma-separated list (nothing when it is there): the list is split
 * at its commas in a copy, the name joins the items, they are sorted and joined again. */
static int list_add(char *list, size_t size, const char *name)
{
    if (!*name || gv_scene_list_has(list, name)) return 0;
    if (strchr(name, ',')) return gv_fail("scene '%s': a comma in a scene's name cannot be recorded", name);
    size_t len = strlen(list), add = strlen(name);
    if (len + add + 2 > size)
        return gv_fail("scene '%s': more training scenes than a checkpoint's record holds (%zu bytes)", name, size);
    char copy[GV_CHECKPOINT_SCENES];
    char *items[GV_CHECKPOINT_SCENES / 2 + 1];
    int n = 0;
    snprintf(copy, sizeof copy, "%s", list);
    for (char *p = copy; *p;) {
        items[n++] = p;
        char *comma = strchr(p, ',');
        if (!comma) break;
        *comma = '\0', p = comma + 1;
    }
    items[n++] = (char *)name;
    qsort(items, (size_t)n, sizeof items[0], compare_names);
    char joined[GV_CHECKPOINT_SCENES] = "";
    for (int i = 0, at = 0; i < n; i++) at += snprintf(joined + at, sizeof joined - (size_t)at, "%s%s", i ? "," : "", items[i]);
    snprintf(list, size, "%s", joined);
    return 0;
}

int gv_train_add_scenes(gv_train_state *meta, const char *list)
{
    char name[GV_SCENE_NAME_MAX];
    for (const char *p = list; *p;) {
        const char *comma = strchr(p, ',');
        size_t item = comma ? (size_t)(comma - p) : strlen(p);
        snprintf(name, sizeof name, "%.*s", (int)(item < sizeof name ? item : sizeof name - 1), p);
        if (list_add(meta->scenes, sizeof meta->scenes, name)) return -1;
        p += item + (comma != NULL);
    }
    return 0;
}

int gv_train_record_scenes(gv_train_state *meta, const char *clips_dir, const char *split)
{
    gv_manifest m;
    if (gv_manifest_read_dataset(clips_dir, &m)) return -1;
    int rc = 0;
    for (int i = 0; rc == 0 && i < m.n_clips; i++)
        if (!split || !strcmp(m.clips[i].id.split, split))
            rc = list_add(meta->scenes, sizeof meta->scenes, m.clips[i].id.scene);
    gv_manifest_free(&m);
    return rc;
}

/* A checkpoint written before the record existed may have it beside it, as FILE.scenes.json
 * {"data": its metadata "data", "scenes": [names]} (models/README.md): the weights file stays
 * byte for byte as released (scene checkpoints check their base by the file's checksum). The
 * "data" line ties the record to the checkpoint's training set. 1 read, 0 none, -1 bad. */
static int read_beside(const char *ckpt, const gv_train_state *s, char *out, size_t size)
{
    char path[4200], data[GV_CHECKPOINT_TEXT];
    size_t len = strlen(ckpt), ext = strlen(".safetensors");
    if (len > ext && !strcmp(ckpt + len - ext, ".safetensors")) len -= ext;
    snprintf(path, sizeof path, "%.*s.scenes.json", (int)len, ckpt);
    if (!gv_file_exists(path)) return 0;
    char *text = NULL;
    size_t n = 0;
    if (gv_read_file(path, &text, &n)) return -1;
    cJSON *root = cJSON_ParseWithLength(text, n);
    free(text);
    const cJSON *scenes = root ? cJSON_GetObjectItemCaseSensitive(root, "scenes") : NULL;
    int rc = 0;
    if (!root || gv_json_string(root, "data", data, sizeof data) != 0 || !cJSON_IsArray(scenes))
        rc = gv_fail("%s: expected {\"data\": \"...\", \"scenes\": [names]}", path);
    else if (strcmp(data, s->data))
        rc = gv_fail("%s: made for the training set \"%s\", the checkpoint's is \"%s\"", path, data, s->data);
    gv_train_state record;
    record.scenes[0] = '\0';
    const cJSON *name;
    cJSON_ArrayForEach(name, scenes)
    {
        if (rc) break;
        if (!cJSON_IsString(name)) rc = gv_fail("%s: scenes: %s, expected names", path, gv_json_type(name));
        else rc = list_add(record.scenes, sizeof record.scenes, name->valuestring);
    }
    cJSON_Delete(root);
    if (rc) return -1;
    snprintf(out, size, "%s", record.scenes);
    return 1;
}

void gv_restorer_read_scenes(gv_restorer *r, const char *ckpt, const gv_train_state *s)
{
    r->training_scenes[0] = r->scenes_error[0] = '\0';
    r->scenes_known = s->scenes[0] ? 1 : read_beside(ckpt, s, r->training_scenes, sizeof r->training_scenes);
    if (s->scenes[0]) snprintf(r->training_scenes, sizeof r->training_scenes, "%s", s->scenes);
    if (r->scenes_known < 0) snprintf(r->scenes_error, sizeof r->scenes_error, "%s", gv_last_error());
}

int gv_warn_if_trained_on(const gv_restorer *r, const char *ckpt, const char *scene)
{
    if (r->scenes_known < 0) return gv_fail("%s", r->scenes_error);
    if (r->scenes_known && gv_scene_list_has(r->training_scenes, scene))
        gv_warn("scene '%s' was in the restorer's training set (%s: %s): its numbers do not measure generalisation",
                scene, ckpt, r->training_scenes);
    return 0;
}
