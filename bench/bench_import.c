/* `gaussvid bench import`: the cost of `gaussvid model import` on a release of the real shapes
 * (docs/WAN_WEIGHTS.md). Writes a stand-in release folder into --dir: the DiT + VACE tensors
 * of the preset (no camera encoder, no LoRA) with small pseudo-random values, in BF16 or
 * F32, as one file or as shards with an index, and the VAE as Wan2.1_VAE.safetensors (F32);
 * then runs `gaussvid model import` on it as a child process, so that its wall time, CPU time
 * and peak resident set (wait4's rusage) are the import's alone. */
#include <cjson/cJSON.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/resource.h>
#include <sys/wait.h>
#include <unistd.h>

#include "gaussvid/core/core.h"
#include "gaussvid/io/safetensors.h"
#include "gaussvid/model/vae.h"
#include "gaussvid/model/weight_names.h"

/* Runs `gaussvid model import` (this same program) and returns its exit status and rusage. */
static int run_import(const char *release, const char *preset, const char *out, struct rusage *ru, double *wall)
{
    double t0 = gv_now();
    pid_t pid = fork();
    if (pid < 0) return gv_fail("bench import: cannot fork");
    if (pid == 0) {
        execl("/proc/self/exe", "gaussvid", "model", "import", "--from", release, "--config", preset, "--out", out,
              "--quiet", (char *)NULL);
        _exit(127);
    }
    int status = 0;
    if (wait4(pid, &status, 0, ru) != pid) return gv_fail("bench import: lost the import process");
    *wall = gv_now() - t0;
    if (!WIFEXITED(status) || WEXITSTATUS(status) != 0) return gv_fail("bench import: the import failed (status %d)", status);
    return 0;
}

/* The DiT + VACE tensors into n_shards files (one: diffusion_pytorch_model.safetensors; more:
 * the huggingface names and index). All tensors share one buffer of values. */
static int write_dit(const char *dir, const gv_weight_list *l, gv_st_dtype dtype, int n_shards, int64_t *bytes)
{
    int64_t largest = 0, total = 0;
    for (int i = 0; i < l->n; i++) {
        const gv_weight_spec *w = &l->items[i];
        if (!(gv_module_part(w->module) & (GV_PART_DIT | GV_PART_VACE))) continue;
        int64_t n = 1;
        for (int k = 0; k < w->rank; k++) n *= w->shape[k];
        if (n > largest) largest = n;
        total += n;
    }
    float *values = malloc((size_t)largest * sizeof *values);
    if (!values) return gv_fail("bench import: out of memory");
    for (int64_t k = 0; k < largest; k++) values[k] = 0.02f * (float)gv_uniform_at(7, (uint64_t)k) - 0.01f;
    cJSON *index = cJSON_CreateObject(), *map = cJSON_AddObjectToObject(index, "weight_map");
    int64_t per_shard = total / n_shards + 1, used = 0;
    int rc = 0, shard = 0, i = 0;
    *bytes = 0;
    while (rc == 0 && shard < n_shards) {
        char name[96], path[4200];
        if (n_shards == 1) snprintf(name, sizeof name, "diffusion_pytorch_model.safetensors");
        else snprintf(name, sizeof name, "diffusion_pytorch_model-%05d-of-%05d.safetensors", shard + 1, n_shards);
        gv_st_builder b;
        gv_st_builder_init(&b);
        for (; rc == 0 && i < l->n && (used < per_shard * (shard + 1) || shard == n_shards - 1); i++) {
            const gv_weight_spec *w = &l->items[i];
            if (!(gv_module_part(w->module) & (GV_PART_DIT | GV_PART_VACE))) continue;
            int64_t n = 1;
            for (int k = 0; k < w->rank; k++) n *= w->shape[k];
            rc = gv_st_add_f32(&b, w->name, dtype, w->shape, w->rank, values);
            cJSON_AddStringToObject(map, w->name, name);
            used += n, *bytes += n * (gv_st_dtype_bits(dtype) / 8);
        }
        if (rc == 0) rc = gv_st_add_metadata(&b, "format", "pt");
        if (rc == 0) rc = gv_path_join(path, sizeof path, dir, name);
        if (rc == 0) rc = gv_st_write(&b, path);
        gv_st_builder_free(&b);
        shard++;
    }
    if (rc == 0 && n_shards > 1) {
        char path[4200], *text = cJSON_Print(index);
        rc = !text || gv_path_join(path, sizeof path, dir, "diffusion_pytorch_model.safetensors.index.json") ||
             gv_write_text_atomic(path, text);
        free(text);
    }
    cJSON_Delete(index);
    free(values);
    return rc ? -1 : 0;
}

int gv_bench_import_command(int argc, char **argv)
{
    const char *preset = "wan2.1-vace-1.3b", *dir = NULL, *dtype_name = "BF16";
    int shards = 1, keep = 0;
    const gv_flag flags[] = {
        {"dir", GV_FLAG_STRING, &dir, "DIR", "scratch folder for the stand-in release and the import (several GB)", 1},
        {"preset", GV_FLAG_STRING, &preset, "P", "the network (default wan2.1-vace-1.3b)", 0},
        {"dtype", GV_FLAG_STRING, &dtype_name, "T", "BF16 (default) or F32", 0},
        {"shards", GV_FLAG_INT, &shards, "N", "DiT files: 1 (default) or N shards with an index", 0},
        {"keep", GV_FLAG_BOOL, &keep, NULL, "keep the files (default: removed after timing)", 0},
    };
    const gv_command_spec spec = {"bench import", NULL, "model import on a stand-in release of the real shapes",
                                  NULL, flags, (int)(sizeof flags / sizeof flags[0]), 0, 0};
    int parsed = gv_args_parse(&spec, argc, argv, NULL, NULL);
    if (parsed != GV_ARGS_OK) return gv_args_exit_code(parsed);
    int dtype = gv_st_dtype_from_name(dtype_name);
    if ((dtype != GV_ST_BF16 && dtype != GV_ST_F32) || shards < 1 || shards > 99) {
        fprintf(stderr, "gaussvid bench import: --dtype BF16 or F32, --shards 1 to 99\n");
        return 2;
    }
    gv_model_config c;
    if (gv_model_config_load(&c, preset) || gv_model_config_set_variant(&c, "camera=none,lora=0", "bench")) return gv_report_failure();
    char release[4200], out[4200], vae_path[4200];
    if (gv_path_join(release, sizeof release, dir, "release") || gv_path_join(out, sizeof out, dir, "imported") ||
        gv_mkdirs(release) || gv_path_join(vae_path, sizeof vae_path, release, "Wan2.1_VAE.safetensors"))
        return gv_report_failure();
    gv_weight_list l;
    if (gv_weight_list_build(&l, &c)) return gv_report_failure();
    double t0 = gv_now();
    int64_t bytes = 0;
    int rc = write_dit(release, &l, (gv_st_dtype)dtype, shards, &bytes);
    gv_weight_list_free(&l);
    gv_vae vae;
    if (rc == 0) rc = gv_vae_init(&vae, &c, 0, 3);
    if (rc == 0) {
        rc = gv_vae_save(&vae, &c, vae_path, NULL, NULL, 0);
        gv_vae_free(&vae);
    }
    double written = gv_now() - t0, wall = 0;
    struct rusage ru;
    if (rc == 0) rc = run_import(release, preset, out, &ru, &wall);
    if (rc) return gv_report_failure();
    double cpu = (double)ru.ru_utime.tv_sec + ru.ru_utime.tv_usec / 1e6 + (double)ru.ru_stime.tv_sec + ru.ru_stime.tv_usec / 1e6;
    printf("bench import: %s, DiT + VACE %.2f GB %s in %d file%s, VAE F32 safetensors (written in %.1f s)\n", preset,
           (double)bytes / 1e9, dtype_name, shards, shards > 1 ? "s + index" : "", written);
    printf("model import: %.1f s wall, %.1f s CPU (%.2f GB/s of DiT); peak resident set %.2f GB, mapped file pages "
           "included\n", wall, cpu, (double)bytes / 1e9 / wall, (double)ru.ru_maxrss * 1024.0 / 1e9);
    if (!keep) {
        char command[9000];
        snprintf(command, sizeof command, "rm -rf '%s' '%s'", release, out);
        if (system(command) != 0) gv_warn("bench import: could not remove %s", dir);
    }
    return 0;
}
