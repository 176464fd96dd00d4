/* gaussvid model merge --base BASE --lora FILE --out OUT [--vae VAE --vae-out VAE_OUT]
 * [--precision bf16|f32] [--list-keys]: the published GaussVid checkpoint fused into a base
 * file, written tensor by tensor (docs/GAUSSVID_RELEASE.md). */
#include <stdio.h>
#include <string.h>

#include "cli/commands.h"
#include "gaussvid/core/core.h"
#include "gaussvid/model/release_lora.h"
#include "gaussvid/pth/weight_files.h"

static int merge(const char *base_path, const char *lora_path, const char *out, const char *vae_path,
                 const char *vae_out, gv_fuse_precision precision, int list_keys)
{
    gv_st_file lora = {0}, base = {0}, vae = {0};
    gv_release_plan plan = {0};
    int rc = gv_st_open(&lora, lora_path);
    if (rc == 0) rc = gv_weights_open(&base, base_path);
    if (rc == 0 && vae_path) rc = gv_weights_open(&vae, vae_path);
    if (rc == 0) rc = gv_release_plan_build(&plan, &lora, &base, vae_path ? &vae : NULL);
    if (rc == 0 && list_keys) gv_release_plan_list(&plan, stdout);
    if (rc == 0 && !list_keys) {
        double t0 = gv_now();
        rc = gv_release_merge(&plan, &lora, &base, out, vae_path ? &vae : NULL, vae_out, precision);
        if (rc == 0) gv_info("model merge: %.1f s", gv_now() - t0);
    }
    if (rc == 0) {
        char summary[512];
        gv_release_plan_summary(&plan, summary, sizeof summary);
        printf("%s: %s\n", lora_path, summary);
        if (!list_keys) {
            printf("%s -> %s (%s)\n", base_path, out, precision == GV_FUSE_BF16 ? "bf16" : "f32");
            if (vae_out) printf("%s -> %s (%s)\n", vae_path, vae_out, precision == GV_FUSE_BF16 ? "bf16" : "f32");
        }
    }
    gv_release_plan_free(&plan);
    gv_st_close(&vae);
    gv_st_close(&base);
    gv_st_close(&lora);
    return rc;
}

int cmd_model_merge(int argc, char **argv)
{
    const char *base = NULL, *lora = NULL, *out = NULL, *vae = NULL, *vae_out = NULL, *precision_name = "bf16";
    int list_keys = 0;
    const gv_flag flags[] = {
        {"base", GV_FLAG_STRING, &base, "FILE", "the DiT + VACE weights (safetensors, or a shard index .json)", 1},
        {"lora", GV_FLAG_STRING, &lora, "FILE", "the GaussVid checkpoint (epoch-4.safetensors)", 1},
        {"out", GV_FLAG_STRING, &out, "FILE", "the merged DiT + VACE weights (not needed with --list-keys)", 0},
        {"vae", GV_FLAG_STRING, &vae, "FILE", "the VAE (Wan2.1_VAE.pth or .safetensors), for the decoder entries", 0},
        {"vae-out", GV_FLAG_STRING, &vae_out, "FILE", "the VAE with the decoder entries replaced (needs --vae)", 0},
        {"precision", GV_FLAG_STRING, &precision_name, "bf16|f32",
         "bf16: the release's rounding, every float tensor BF16 (default); f32: W + B A, no bf16", 0},
        {"list-keys", GV_FLAG_BOOL, &list_keys, NULL, "print each checkpoint key's fate and write nothing", 0},
    };
    const gv_command_spec spec = {
        "model merge", NULL, "the GaussVid checkpoint fused into base weights, for inspection",
        "Routes the checkpoint's keys as the authors' loader does: pipe.dit.* and pipe.vace.* LoRA\n"
        "pairs (PEFT lora_A/lora_B[.default] or kohya lora_down/lora_up) are fused into the base\n"
        "tensor of their module, W <- bf16(bf16(W) + bf16(B A)) with alpha 1 (bf16) or W + B A\n"
        "(f32); pipe.vae.model.decoder.NAME replaces the VAE tensor decoder.NAME when the shapes\n"
        "agree (else it is skipped and listed); every other key is ignored. The outputs are\n"
        "written tensor by tensor, so the 14B base is never in memory at once. A LoRA module or\n"
        "shape the base does not have fails naming the key. See docs/GAUSSVID_RELEASE.md.",
        flags, (int)(sizeof flags / sizeof flags[0]), 0, 0};
    int parsed = gv_args_parse(&spec, argc, argv, NULL, NULL);
    if (parsed != GV_ARGS_OK) return gv_args_exit_code(parsed);
    gv_fuse_precision precision;
    if (gv_fuse_precision_from_name(precision_name, &precision)) return gv_report_failure();
    if (!out && !list_keys) {
        fprintf(stderr, "gaussvid model merge: --out is required (or --list-keys)\n");
        return 2;
    }
    if (!vae != !vae_out && !(list_keys && vae)) {
        fprintf(stderr, "gaussvid model merge: --vae and --vae-out go together\n");
        return 2;
    }
    return merge(base, lora, out, vae, vae_out, precision, list_keys) ? gv_report_failure() : 0;
}
