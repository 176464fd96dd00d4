/* gaussvid model: the restoration network's configs and weights. `model inspect` prints a
 * config's parameter counts per module, the trainable count of GaussVid fine-tuning and the
 * forward cost of one clip, and checks safetensors files against the tensors the config
 * implies (docs/MODEL.md). */
#include <cjson/cJSON.h>
#include <inttypes.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "cli/commands.h"
#include "gaussvid/train/condition.h"
#include "gaussvid/core/core.h"
#include "gaussvid/pth/weight_files.h"
#include "gaussvid/model/model_config.h"
#include "gaussvid/model/weight_names.h"

enum { SHOWN_PER_KIND = 10 };

static const char *human(char *out, size_t size, double v)
{
    if (v >= 1e9) snprintf(out, size, "%.2f B", v / 1e9);
    else if (v >= 1e6) snprintf(out, size, "%.2f M", v / 1e6);
    else if (v >= 1e3) snprintf(out, size, "%.1f K", v / 1e3);
    else snprintf(out, size, "%.0f", v);
    return out;
}

static void print_config(const gv_model_config *c, const char *spec)
{
    const gv_dit_config *d = &c->dit;
    const gv_vae_config *v = &c->vae;
    int k[3];
    gv_model_camera_kernel(c, k);
    printf("model %s (%s)\n", c->name, spec);
    printf("  dit: dim %d, ffn_dim %d, %d heads of %d, %d layers, patch %dx%dx%d, latent channels %d, ",
           d->dim, d->ffn_dim, d->num_heads, d->dim / d->num_heads, d->num_layers, d->patch_size[0],
           d->patch_size[1], d->patch_size[2], d->in_dim);
    if (d->cross_attn) printf("text %d x %d\n", d->text_len, d->text_dim);
    else printf("no text\n");
    printf("  vace: %d blocks at layers", d->n_vace_layers);
    for (int j = 0; j < d->n_vace_layers; j++) printf("%s %d", j ? "," : "", d->vace_layers[j]);
    printf(", vace_in_dim %d\n", d->vace_in_dim);
    printf("  vae: dim %d, dim_mult [", v->dim);
    for (int i = 0; i < v->n_levels; i++) printf("%s%d", i ? ", " : "", v->dim_mult[i]);
    printf("], %d res blocks, z_dim %d, spatial x%d, temporal x%d, latent stats %s\n", v->num_res_blocks,
           v->z_dim, v->spatial_factor, v->temporal_factor, v->has_latent_stats ? "given" : "none");
    printf("  camera: %s", gv_camera_variant_name(c->variant.camera));
    if (c->variant.camera != GV_CAMERA_NONE)
        printf(", %d channels per stream, gate %d, proj %d, kernel %dx%dx%d, gamma %g", c->camera.channels,
               c->camera.gate_hidden, c->camera.proj_hidden, k[0], k[1], k[2], c->camera.gamma_init);
    printf("\n  lora: ");
    if (c->lora.rank == 0) printf("none\n");
    else {
        printf("rank %d, alpha %g, targets", c->lora.rank, c->lora.alpha);
        for (int i = 0; i < c->lora.n_targets; i++) printf("%s %s", i ? "," : "", c->lora.targets[i]);
        printf(" on%s%s\n", c->lora.blocks ? " blocks" : "", c->lora.vace_blocks ? " vace_blocks" : "");
    }
    printf("  variant: anchors %s, per-frame %s, skip %s%s\n", gv_anchors_name(c->variant.anchors), c->variant.per_frame ? "yes" : "no",
           c->variant.skip ? "yes" : "no", c->variant.coverage ? ", coverage mask" : "");
}

static void print_counts(const gv_weight_counts *n)
{
    char h[32];
    printf("\n  %-18s %8s %15s\n", "MODULE", "TENSORS", "PARAMETERS");
    for (int m = 0; m < GV_N_MODULES; m++)
        printf("  %-18s %8d %15" PRId64 "  %s\n", gv_module_name((gv_module)m), n->tensors[m], n->params[m],
               human(h, sizeof h, (double)n->params[m]));
    printf("  %-18s %8d %15" PRId64 "  %s\n", "total", n->n_tensors, n->total, human(h, sizeof h, (double)n->total));
    printf("trainable in fine-tuning (LoRA + camera): %" PRId64 " (%.3f%%)\n", n->trainable,
           n->total ? 100.0 * (double)n->trainable / (double)n->total : 0.0);
    printf("frozen (DiT, VACE, VAE): %" PRId64 "\n", n->total - n->trainable);
}

static void print_cost(const gv_model_cost *k, const int clip[3])
{
    printf("\nclip %dx%dx%d: latent %dx%dx%d, %d video + %d camera tokens", clip[0], clip[1], clip[2],
           k->latent_frames, k->latent_height, k->latent_width, k->video_tokens, k->camera_tokens);
    if (k->evaluations > 1) printf(" per frame, %d evaluations", k->evaluations);
    printf("\n  forward %.3f GFLOP: blocks linear %.3f, attention %.3f, cross-attention %.3f, vace %.3f, "
           "camera %.3f, lora %.3f, embeddings+head %.3f\n",
           k->flops_total / 1e9, k->flops_blocks_linear / 1e9, k->flops_blocks_attention / 1e9,
           k->flops_cross_attention / 1e9, k->flops_vace / 1e9, k->flops_camera / 1e9, k->flops_lora / 1e9,
           k->flops_embed_head / 1e9);
}

static void print_issues(const char *kind, const gv_weight_issue *items, int n)
{
    printf("%s: %d\n", kind, n);
    for (int i = 0; i < n && i < SHOWN_PER_KIND; i++) {
        printf("  %s", items[i].name);
        if (items[i].detail[0]) printf("%s%s", items[i].file ? ": " : " ", items[i].detail);
        if (items[i].file) printf(" (in %s)", items[i].file);
        printf("\n");
    }
    if (n > SHOWN_PER_KIND) printf("  ... and %d more\n", n - SHOWN_PER_KIND);
}

/* Tensors of the model (listed name and shape, a float dtype) holding a NaN or an infinity:
 * the loaders refuse them (docs/ARCHITECTURE.md 4), so they decide whether the files load too. */
typedef struct {
    int n;
    gv_weight_issue items[SHOWN_PER_KIND];
} value_report;

static int check_values(const gv_weight_list *l, const gv_st_file *files, int n_files, value_report *vr)
{
    memset(vr, 0, sizeof *vr);
    for (int f = 0; f < n_files; f++)
        for (int i = 0; i < files[f].n_tensors; i++) {
            const gv_st_tensor *t = &files[f].tensors[i];
            const gv_weight_spec *w = gv_weight_list_find(l, t->name);
            if (!w || w->rank != t->rank || memcmp(w->shape, t->shape, sizeof(int64_t) * (size_t)t->rank)) continue;
            float *x = malloc((size_t)t->n_elements * sizeof *x);
            if (!x) return gv_fail("out of memory for %s", t->name);
            int64_t bad = -1;
            if (gv_st_tensor_to_f32(&files[f], t, x) == 0) /* other dtypes are reported as mis-shaped */
                for (int64_t k = 0; k < t->n_elements && bad < 0; k++)
                    if (!isfinite(x[k])) bad = k;
            if (bad >= 0 && vr->n < SHOWN_PER_KIND) {
                gv_weight_issue *e = &vr->items[vr->n];
                e->name = t->name, e->file = files[f].path;
                snprintf(e->detail, sizeof e->detail, "element %lld is %g", (long long)bad, (double)x[bad]);
            }
            vr->n += bad >= 0;
            free(x);
        }
    gv_clear_error();
    return 0;
}

static void print_report(const gv_weight_report *r, const value_report *vr, const gv_st_file *files, int n_files)
{
    printf("\nweights: %d file%s, %d tensors (", n_files, n_files == 1 ? "" : "s", r->n_found);
    for (int f = 0; f < n_files; f++) printf("%s%s: %d", f ? ", " : "", files[f].path, files[f].n_tensors);
    printf(")\nexpected from the checked parts: %d tensors\n", r->n_expected);
    print_issues("missing", r->missing, r->n_missing);
    print_issues("unexpected", r->unexpected, r->n_unexpected);
    print_issues("mis-shaped", r->mismatched, r->n_mismatched);
    print_issues("duplicated", r->duplicate, r->n_duplicate);
    print_issues("non-finite", vr->items, vr->n);
    printf("the weights load: %s\n", gv_weight_report_ok(r) && vr->n == 0 ? "yes" : "no");
}

static void print_list(const gv_weight_list *l)
{
    char shape[96];
    printf("\n");
    for (int i = 0; i < l->n; i++) {
        const gv_weight_spec *w = &l->items[i];
        gv_st_shape_str(shape, sizeof shape, w->shape, w->rank);
        for (char *s = shape, *t = shape;; s++) /* "[2, 3]" -> "[2,3]": one field for scripts */
            if (*s != ' ' && !(*t++ = *s)) break;
        printf("%s %s %s %s\n", w->name, shape, gv_module_name(w->module), w->trainable ? "trainable" : "frozen");
    }
}

/* ---- JSON ----------------------------------------------------------------------------- */

static cJSON *shape_json(const int64_t *shape, int rank)
{
    cJSON *a = cJSON_CreateArray();
    for (int k = 0; k < rank; k++) cJSON_AddItemToArray(a, cJSON_CreateNumber((double)shape[k]));
    return a;
}

static cJSON *issues_json(const gv_weight_issue *items, int n)
{
    cJSON *a = cJSON_CreateArray();
    for (int i = 0; i < n; i++) {
        cJSON *o = cJSON_CreateObject();
        cJSON_AddStringToObject(o, "name", items[i].name);
        if (items[i].file) cJSON_AddStringToObject(o, "file", items[i].file);
        if (items[i].detail[0]) cJSON_AddStringToObject(o, "detail", items[i].detail);
        cJSON_AddItemToArray(a, o);
    }
    return a;
}

static void add_report_json(cJSON *root, const gv_weight_report *r, const value_report *vr, const gv_st_file *files,
                            int n_files)
{
    cJSON *w = cJSON_AddObjectToObject(root, "weights");
    cJSON *names = cJSON_AddArrayToObject(w, "files");
    for (int f = 0; f < n_files; f++) cJSON_AddItemToArray(names, cJSON_CreateString(files[f].path));
    cJSON_AddNumberToObject(w, "found", r->n_found);
    cJSON_AddNumberToObject(w, "expected", r->n_expected);
    cJSON_AddItemToObject(w, "missing", issues_json(r->missing, r->n_missing));
    cJSON_AddItemToObject(w, "unexpected", issues_json(r->unexpected, r->n_unexpected));
    cJSON_AddItemToObject(w, "mis_shaped", issues_json(r->mismatched, r->n_mismatched));
    cJSON_AddItemToObject(w, "duplicated", issues_json(r->duplicate, r->n_duplicate));
    cJSON_AddItemToObject(w, "non_finite", issues_json(vr->items, vr->n < SHOWN_PER_KIND ? vr->n : SHOWN_PER_KIND));
    cJSON_AddNumberToObject(w, "n_non_finite", vr->n);
    cJSON_AddBoolToObject(w, "loads", gv_weight_report_ok(r) && vr->n == 0);
}

static int print_json(const gv_model_config *c, const gv_weight_list *l, const gv_weight_counts *n,
                      const gv_model_cost *cost, const gv_weight_report *r, const value_report *vr,
                      const gv_st_file *files, int n_files, int list)
{
    char *config_text = gv_model_config_to_json(c);
    cJSON *root = cJSON_CreateObject();
    cJSON_AddItemToObject(root, "config", config_text ? cJSON_Parse(config_text) : cJSON_CreateNull());
    free(config_text);
    cJSON *modules = cJSON_AddObjectToObject(root, "modules");
    for (int m = 0; m < GV_N_MODULES; m++) {
        cJSON *o = cJSON_AddObjectToObject(modules, gv_module_name((gv_module)m));
        cJSON_AddNumberToObject(o, "tensors", n->tensors[m]);
        cJSON_AddNumberToObject(o, "parameters", (double)n->params[m]);
    }
    cJSON_AddNumberToObject(root, "tensors", n->n_tensors);
    cJSON_AddNumberToObject(root, "parameters", (double)n->total);
    cJSON_AddNumberToObject(root, "trainable", (double)n->trainable);
    cJSON_AddNumberToObject(root, "frozen", (double)(n->total - n->trainable));
    if (cost) {
        cJSON *k = cJSON_AddObjectToObject(root, "clip_cost");
        cJSON_AddNumberToObject(k, "video_tokens", cost->video_tokens);
        cJSON_AddNumberToObject(k, "camera_tokens", cost->camera_tokens);
        cJSON_AddNumberToObject(k, "evaluations", cost->evaluations);
        cJSON_AddNumberToObject(k, "forward_flops", cost->flops_total);
    }
    if (r) add_report_json(root, r, vr, files, n_files);
    if (list) {
        cJSON *a = cJSON_AddArrayToObject(root, "tensor_list");
        for (int i = 0; i < l->n; i++) {
            cJSON *o = cJSON_CreateObject();
            cJSON_AddStringToObject(o, "name", l->items[i].name);
            cJSON_AddItemToObject(o, "shape", shape_json(l->items[i].shape, l->items[i].rank));
            cJSON_AddStringToObject(o, "module", gv_module_name(l->items[i].module));
            cJSON_AddBoolToObject(o, "trainable", l->items[i].trainable);
            cJSON_AddItemToArray(a, o);
        }
    }
    char *text = cJSON_Print(root);
    cJSON_Delete(root);
    if (!text) return gv_fail("out of memory for the JSON output");
    printf("%s\n", text);
    free(text);
    return 0;
}

/* ---- the command ---------------------------------------------------------------------- */

typedef struct {
    const char *config, *variant, *parts;
    int json, list, clip[3], clip_given;
} inspect_options;

static int open_weights(const gv_flag_list *names, gv_st_file *files)
{
    for (int f = 0; f < names->n; f++) {
        if (gv_weights_open(&files[f], names->items[f]) != 0) {
            for (int g = 0; g < f; g++) gv_st_close(&files[g]);
            return -1;
        }
    }
    return 0;
}

static int inspect(const inspect_options *o, const gv_flag_list *names, unsigned parts)
{
    gv_model_config c;
    if (gv_model_config_load(&c, o->config) != 0) return gv_report_failure();
    if (o->variant && gv_model_config_set_variant(&c, o->variant, "--variant") != 0) {
        fprintf(stderr, "gaussvid model inspect: %s\n", gv_last_error());
        return 2;
    }
    /* any size: the cost of the clip padded to the network's block, as the restorer runs it */
    int clip[3] = {o->clip[0], o->clip[1], o->clip[2]};
    if (gv_condition_padded_size(&c, o->clip[2], o->clip[1], &clip[2], &clip[1]) != 0) {
        fprintf(stderr, "gaussvid model inspect: %s\n", gv_last_error());
        return 2;
    }
    gv_model_cost cost;
    int have_cost = gv_model_cost_estimate(&c, clip[0], clip[1], clip[2], &cost) == 0;
    if (!have_cost && o->clip_given) {
        fprintf(stderr, "gaussvid model inspect: %s\n", gv_last_error());
        return 2;
    }
    gv_weight_list l;
    if (gv_weight_list_build(&l, &c) != 0) return gv_report_failure();
    gv_weight_counts counts;
    gv_weight_list_count(&l, &counts);
    gv_st_file *files = calloc((size_t)names->n + 1, sizeof *files);
    gv_weight_report report = {0};
    value_report values = {0};
    int rc = files ? 0 : gv_fail("out of memory");
    if (!rc && names->n) rc = open_weights(names, files);
    if (!rc && names->n) {
        rc = gv_weights_check(&l, parts, files, names->n, &report);
        if (!rc) rc = check_values(&l, files, names->n, &values);
        if (rc) for (int f = 0; f < names->n; f++) gv_st_close(&files[f]);
    }
    if (!rc) {
        if (o->json) {
            rc = print_json(&c, &l, &counts, have_cost ? &cost : NULL, names->n ? &report : NULL, &values, files,
                            names->n, o->list);
        } else {
            print_config(&c, o->config);
            print_counts(&counts);
            if (have_cost) print_cost(&cost, clip);
            if (names->n) print_report(&report, &values, files, names->n);
            if (o->list) print_list(&l);
        }
        for (int f = 0; f < names->n; f++) gv_st_close(&files[f]);
    }
    int loads = !names->n || (gv_weight_report_ok(&report) && values.n == 0);
    gv_weight_report_free(&report);
    gv_weight_list_free(&l);
    free(files);
    if (rc) return gv_report_failure();
    return loads ? 0 : 1;
}

static int cmd_model_inspect(int argc, char **argv)
{
    inspect_options o = {NULL, NULL, "all", 0, 0, {5, 144, 256}, 0};
    gv_flag_list names = {.n = 0};
    int frames = 0, height = 0, width = 0;
    const gv_flag flags[] = {
        {"config", GV_FLAG_STRING, &o.config, "PRESET|FILE", "a preset (tiny, small, wan2.1-vace-1.3b, wan2.1-vace-14b) or a JSON config", 1},
        {"weights", GV_FLAG_LIST, &names, "FILE[,FILE]", "safetensors files to check; repeat the flag or separate with commas", 0},
        {"variant", GV_FLAG_STRING, &o.variant, "V", GV_VARIANT_HELP, 0},
        {"parts", GV_FLAG_STRING, &o.parts, "P", "parts the files must provide: dit,vace,vae,camera,lora, base, adapters, all (default)", 0},
        {"frames", GV_FLAG_INT, &frames, "N", "clip frames for the cost estimate (default 5)", 0},
        {"height", GV_FLAG_INT, &height, "N", "clip height in pixels (default 144; any: the cost is of the clip padded to the block, as restoration runs it)", 0},
        {"width", GV_FLAG_INT, &width, "N", "clip width in pixels (default 256)", 0},
        {"list", GV_FLAG_BOOL, &o.list, NULL, "also list every tensor: name, shape, module, trainable|frozen", 0},
        {"json", GV_FLAG_BOOL, &o.json, NULL, "print everything as JSON", 0},
    };
    const gv_command_spec spec = {
        "model inspect", NULL, "parameter counts of a model config, and a check of weight files against it",
        "Prints the config, the parameters per module (patch, time and text embeddings, blocks,\n"
        "head, VACE, VAE encoder and decoder, camera encoder, LoRA), the trainable count of\n"
        "GaussVid fine-tuning (LoRA + camera; base frozen) and the forward FLOPs of one clip.\n"
        "With --weights, lists tensors of the checked parts missing from every file, tensors\n"
        "that are no tensor of the model, mis-shaped tensors, names found in two files and\n"
        "tensors holding a NaN or an infinity; exit code 0 when the files load, 1 when not.\n"
        "Published Wan2.1 files: --parts base (DiT+VACE\n"
        "and VAE are separate files: give both). See docs/MODEL.md.",
        flags, (int)(sizeof flags / sizeof flags[0]), 0, 0};
    unsigned parts = GV_PART_ALL;
    int parsed = gv_args_parse(&spec, argc, argv, NULL, NULL), rc = parsed == GV_ARGS_OK ? 0 : gv_args_exit_code(parsed);
    if (parsed == GV_ARGS_OK && gv_parts_parse(o.parts, &parts, "--parts") != 0) {
        fprintf(stderr, "gaussvid model inspect: %s\n", gv_last_error());
        rc = 2;
    }
    if (parsed == GV_ARGS_OK && rc == 0) {
        o.clip_given = frames || height || width;
        if (frames) o.clip[0] = frames;
        if (height) o.clip[1] = height;
        if (width) o.clip[2] = width;
        rc = inspect(&o, &names, parts);
    }
    return rc;
}

static const gv_subcommand model_commands[] = {
    {"inspect", cmd_model_inspect, "parameter counts per module; check weight files against a config"},
    {"run", cmd_model_run, "one forward pass of a network part on named input tensors"},
    {"import", cmd_model_import, "a published Wan2.1-VACE release folder as a base checkpoint and VAE"},
    {"merge", cmd_model_merge, "the published GaussVid checkpoint fused into base weights"},
};

int cmd_model(int argc, char **argv)
{
    return gv_run_subcommand("model", model_commands, (int)(sizeof model_commands / sizeof model_commands[0]), argc, argv);
}
