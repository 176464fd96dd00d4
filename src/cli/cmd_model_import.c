/* gaussvid model import --from RELEASE_DIR --config PRESET|FILE --out DIR [--lora FILE]: a
 * published Wan2.1-VACE release folder as a gaussvid base checkpoint (DIR/base.safetensors)
 * and VAE (DIR/vae.safetensors), for restore, eval and train (docs/WAN_WEIGHTS.md), with the
 * published GaussVid checkpoint fused when given (docs/GAUSSVID_RELEASE.md). */
#include <stdio.h>
#include <string.h>

#include "cli/commands.h"
#include "gaussvid/core/core.h"
#include "gaussvid/train/model_import.h"
#include "gaussvid/model/release_lora.h"
#include "gaussvid/pth/weight_files.h"

static int usage_error(const char *what)
{
    fprintf(stderr, "gaussvid model import: %s\n", what);
    return 2;
}

/* --list-keys: the checkpoint routed against the release's DiT and VAE files, nothing written. */
static int list_lora_keys(const gv_release_files *files)
{
    gv_st_file lora = {0}, dit = {0}, vae = {0};
    gv_release_plan plan = {0};
    int rc = gv_st_open(&lora, files->lora);
    if (rc == 0) rc = gv_weights_open(&dit, files->dit);
    if (rc == 0) rc = gv_weights_open(&vae, files->vae);
    if (rc == 0) rc = gv_release_plan_build(&plan, &lora, &dit, &vae);
    if (rc == 0) {
        char summary[512];
        gv_release_plan_list(&plan, stdout);
        gv_release_plan_summary(&plan, summary, sizeof summary);
        printf("%s: %s\n", files->lora, summary);
    }
    gv_release_plan_free(&plan);
    gv_st_close(&vae);
    gv_st_close(&dit);
    gv_st_close(&lora);
    return rc ? gv_report_failure() : 0;
}

int cmd_model_import(int argc, char **argv)
{
    const char *from = NULL, *config = NULL, *out = NULL, *dit = NULL, *vae = NULL, *t5 = NULL, *tokenizer = NULL;
    const char *prompt = GV_GAUSSVID_PROMPT;
    const char *lora = NULL;
    int no_text = 0, list_keys = 0;
    const gv_flag flags[] = {
        {"from", GV_FLAG_STRING, &from, "DIR", "the release folder (diffusion_pytorch_model*.safetensors[.index.json], Wan2.1_VAE.pth)", 1},
        {"config", GV_FLAG_STRING, &config, "PRESET|FILE", "wan2.1-vace-1.3b, wan2.1-vace-14b, or a JSON config of the same network", 1},
        {"out", GV_FLAG_STRING, &out, "DIR", "writes DIR/base.safetensors and DIR/vae.safetensors (not with --list-keys)", 0},
        {"lora", GV_FLAG_STRING, &lora, "FILE", "the GaussVid checkpoint (epoch-4.safetensors) to fuse as the release does", 0},
        {"list-keys", GV_FLAG_BOOL, &list_keys, NULL, "with --lora: print each checkpoint key's fate and write nothing", 0},
        {"dit", GV_FLAG_STRING, &dit, "FILE", "the DiT + VACE weights, if not under their published name in --from", 0},
        {"vae", GV_FLAG_STRING, &vae, "FILE", "the VAE weights, if not under their published name in --from", 0},
        {"prompt", GV_FLAG_STRING, &prompt, "TEXT", "the prompt whose text context is computed (default GaussVid's)", 0},
        {"t5", GV_FLAG_STRING, &t5, "FILE", "the umT5 encoder, if not models_t5_umt5-xxl-enc-bf16.pth in --from", 0},
        {"tokenizer", GV_FLAG_STRING, &tokenizer, "FILE", "its SentencePiece model, if not google/umt5-xxl/spiece.model in --from", 0},
        {"no-text", GV_FLAG_BOOL, &no_text, NULL, "do not compute the prompt's text context", 0},
    };
    const gv_command_spec spec = {
        "model import", NULL, "a published Wan2.1-VACE release folder as a base checkpoint and VAE",
        "Reads the release as published: the DiT + VACE as one safetensors file or as shards\n"
        "with their *.safetensors.index.json (F32 or BF16), the VAE as Wan2.1_VAE.pth (a PyTorch\n"
        "zip checkpoint, read without executing anything) and config.json when present (its\n"
        "numbers must be the config's). Every tensor is checked by name, shape and value. Writes\n"
        "DIR/base.safetensors (the DiT + VACE in the release's dtypes, camera variant none, no\n"
        "LoRA tensors) and DIR/vae.safetensors (F32, with the published latent statistics);\n"
        "with the umT5 encoder and its tokenizer, also DIR/text_context.safetensors, the\n"
        "prompt's text context [512, 4096], computed once.\n"
        "With --lora, the published GaussVid checkpoint is applied as the authors' loader does:\n"
        "pipe.dit.* / pipe.vace.* LoRA pairs (PEFT lora_A/lora_B[.default], kohya\n"
        "lora_down/lora_up) fused into their base weight, W <- bf16(bf16(W) + bf16(B A)), stored\n"
        "BF16; pipe.vae.model.decoder.NAME replaces the VAE tensor decoder.NAME when the shapes\n"
        "agree (else skipped); other keys ignored. One line sums it up; --list-keys prints each\n"
        "key's fate (docs/GAUSSVID_RELEASE.md).\n"
        "Then: gaussvid restore --ckpt DIR/base.safetensors ... (the zero-shot base), or\n"
        "gaussvid train --base DIR/base.safetensors --config wan2.1-vace-1.3b ... (GaussVid\n"
        "fine-tuning: LoRA + camera encoder). See docs/WAN_WEIGHTS.md.",
        flags, (int)(sizeof flags / sizeof flags[0]), 0, 0};
    int parsed = gv_args_parse(&spec, argc, argv, NULL, NULL);
    if (parsed != GV_ARGS_OK) return gv_args_exit_code(parsed);
    gv_model_config c;
    if (gv_model_config_load(&c, config) != 0) return gv_report_failure();
    gv_release_files files;
    if (gv_release_find(from, &files) != 0) {
        /* both files given: the folder's names are not needed */
        if (!dit || !vae) return gv_report_failure();
        files.config[0] = '\0';
    }
    if (dit) snprintf(files.dit, sizeof files.dit, "%s", dit);
    if (vae) snprintf(files.vae, sizeof files.vae, "%s", vae);
    if (t5) snprintf(files.t5, sizeof files.t5, "%s", t5);
    if (tokenizer) snprintf(files.tokenizer, sizeof files.tokenizer, "%s", tokenizer);
    if (lora) snprintf(files.lora, sizeof files.lora, "%s", lora);
    if (list_keys) return lora ? list_lora_keys(&files) : usage_error("--list-keys needs --lora");
    if (!out) return usage_error("--out is required (or --list-keys)");
    double t0 = gv_now();
    gv_import_summary s;
    if (gv_model_import(&files, &c, no_text ? NULL : prompt, out, &s) != 0) return gv_report_failure();
    static const char *const dtypes[] = {"F32", "BF16", "F16", "F64"};
    char mix[96] = "";
    for (int k = 0; k < 4; k++)
        if (s.dit_dtypes[k]) {
            size_t len = strlen(mix);
            snprintf(mix + len, sizeof mix - len, "%s%d %s", len ? ", " : "", s.dit_dtypes[k], dtypes[k]);
        }
    printf("%s: DiT + VACE %d tensors, %lld values (%s), %.1f MB -> %s/base.safetensors\n", files.dit, s.dit_tensors,
           (long long)s.dit_values, mix, (double)s.dit_bytes / 1e6, out);
    printf("%s: VAE %d tensors, %lld values -> %s/vae.safetensors (%s)\n", files.vae, s.vae_tensors,
           (long long)s.vae_values, out, s.vae_checksum);
    if (files.config[0]) printf("%s: agrees with %s\n", files.config, c.name);
    if (s.lora_summary[0]) printf("%s: %s\n", files.lora, s.lora_summary);
    if (s.text_tokens)
        printf("%s: \"%s\" is %d tokens -> %s/text_context.safetensors\n", files.t5, prompt, s.text_tokens, out);
    else
        printf("no text context (%s): the network gets zeros\n", no_text ? "--no-text" : "no text encoder and tokenizer");
    gv_info("model import: %.1f s", gv_now() - t0);
    return 0;
}
