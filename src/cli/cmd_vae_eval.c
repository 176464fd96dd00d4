/* gaussvid vae eval --weights vae.safetensors --scenes DIR...: reconstruction PSNR and SSIM
 * of VAE weights on whole frames of scenes (docs/VAE.md). */
#include <stdio.h>
#include <string.h>

#include "cli/cmd_vae.h"
#include "cli/commands.h"
#include "gaussvid/core/core.h"
#include "gaussvid/eval/eval.h"

static void print_json_string(const char *s)
{
    putchar('"');
    for (; *s; s++) {
        if (*s == '"' || *s == '\\') printf("\\%c", *s);
        else if ((unsigned char)*s < 0x20) printf("\\u%04x", *s);
        else putchar(*s);
    }
    putchar('"');
}

static void print_result(const char *name, const gv_vae_eval_result *r, int json, int last)
{
    if (json) {
        printf("    {\"scene\": ");
        print_json_string(name);
        printf(", \"clips\": %d, \"frames\": %d, \"psnr\": %.4f, \"ssim\": %.5f, \"psnr_first\": %.4f, "
               "\"psnr_grouped\": %.4f, \"seconds\": %.2f}%s\n",
               r->n_clips, r->n_frames, r->psnr, r->ssim, r->psnr_first, r->psnr_grouped, r->seconds, last ? "" : ",");
    } else {
        printf("  %-40s %3d clips %4d frames  PSNR %6.2f dB  SSIM %.4f  (first frames %.2f dB, grouped %.2f dB)\n", name,
               r->n_clips, r->n_frames, r->psnr, r->ssim, r->psnr_first, r->psnr_grouped);
    }
}

/* The frame-weighted mean of per-scene results. */
static void accumulate(gv_vae_eval_result *all, const gv_vae_eval_result *r)
{
    int grouped = r->n_frames - r->n_clips, all_grouped = all->n_frames - all->n_clips;
    all->psnr = (all->psnr * all->n_frames + r->psnr * r->n_frames) / (all->n_frames + r->n_frames);
    all->ssim = (all->ssim * all->n_frames + r->ssim * r->n_frames) / (all->n_frames + r->n_frames);
    all->psnr_first = (all->psnr_first * all->n_clips + r->psnr_first * r->n_clips) / (all->n_clips + r->n_clips);
    if (grouped + all_grouped > 0)
        all->psnr_grouped = (all->psnr_grouped * all_grouped + r->psnr_grouped * grouped) / (all_grouped + grouped);
    all->n_frames += r->n_frames;
    all->n_clips += r->n_clips;
    all->seconds += r->seconds;
}

int cmd_vae_eval(int argc, char **argv)
{
    gv_flag_list scenes = {.n = 0};
    const char *weights = NULL, *config = NULL;
    int frames = 5, stride = 1, max_clips = 0, downscale = 1, json = 0, rc = 0;
    const gv_flag flags[] = {
        {"scenes", GV_FLAG_LIST, &scenes, "DIR...", "scene folders (COLMAP sparse/0 or transforms.json)", 1},
        {"weights", GV_FLAG_STRING, &weights, "FILE", "VAE weights (.safetensors)", 1},
        {"config", GV_FLAG_STRING, &config, "PRESET|FILE", "model config (default: the one in the weights' metadata)", 0},
        {"frames", GV_FLAG_INT, &frames, "N", "frames per clip, 1 + k x temporal factor (default 5)", 0},
        {"stride", GV_FLAG_INT, &stride, "S", "spacing of a clip's frames (default 1: consecutive)", 0},
        {"max-clips", GV_FLAG_INT, &max_clips, "N", "clips per scene, spread evenly (default 0: all, non-overlapping)", 0},
        {"downscale", GV_FLAG_INT, &downscale, "K", "image downscale 1, 2, 4 or 8 (default 1)", 0},
        {"json", GV_FLAG_BOOL, &json, NULL, "print the results as JSON", 0},
    };
    const gv_command_spec spec = {
        "vae eval", NULL, "reconstruction PSNR and SSIM of VAE weights on scene frames",
        "Each clip of --frames frames of every scene is encoded as Wan does (the first frame\n"
        "alone, then groups of the temporal factor, through the causal caches), decoded, clamped\n"
        "to [-1, 1] and compared with its frames: PSNR and SSIM as the 3DGS evaluation computes\n"
        "them, averaged over frames; also the PSNR of the frames encoded alone (first of each\n"
        "clip) and of the others.\n"
        "Evaluate on frames the VAE was not trained on (another scene).",
        flags, sizeof flags / sizeof flags[0], 0, 0};
    int parsed = gv_args_parse(&spec, argc, argv, NULL, NULL);
    if (parsed != GV_ARGS_OK) return gv_args_exit_code(parsed);
    if (frames < 1 || stride < 1 || max_clips < 0) {
        fprintf(stderr, "gaussvid vae eval: --frames and --stride must be positive\n");
        return 2;
    }
    gv_model_config c;
    if (config ? gv_model_config_load(&c, config) : gv_vae_file_config(weights, &c)) return gv_report_failure();
    gv_vae v;
    if (gv_vae_init(&v, &c, 0, 0)) return gv_report_failure();
    if (gv_vae_load(&v, weights, 0)) {
        gv_vae_free(&v);
        return gv_report_failure();
    }
    gv_vae_eval_result all;
    memset(&all, 0, sizeof all);
    if (json) {
        printf("{\n  \"weights\": ");
        print_json_string(weights);
        printf(",\n  \"config\": ");
        print_json_string(c.name);
        printf(",\n  \"clip_frames\": %d,\n  \"stride\": %d,\n  \"scenes\": [\n", frames, stride);
    } else {
        printf("%s (%s VAE, %dx spatial, %dx temporal): %d-frame clips, spacing %d\n", weights, c.name,
               c.vae.spatial_factor, c.vae.temporal_factor, frames, stride);
    }
    for (int i = 0; i < scenes.n && rc == 0; i++) {
        gv_vae_frames f;
        gv_vae_eval_result r;
        if (gv_vae_frames_load(&f, &scenes.items[i], 1, downscale)) {
            rc = -1;
            break;
        }
        rc = gv_vae_evaluate(&v, &f, frames, stride, max_clips, &r);
        gv_vae_frames_free(&f);
        if (rc) break;
        print_result(scenes.items[i], &r, json, i == scenes.n - 1);
        accumulate(&all, &r);
    }
    gv_vae_free(&v);
    if (rc) {
        if (json) printf("  ]\n}\n");
        return gv_report_failure();
    }
    if (json) {
        printf("  ],\n  \"clips\": %d,\n  \"frames\": %d,\n  \"psnr\": %.4f,\n  \"ssim\": %.5f,\n  \"psnr_first\": %.4f,\n"
               "  \"psnr_grouped\": %.4f,\n  \"seconds\": %.2f\n}\n",
               all.n_clips, all.n_frames, all.psnr, all.ssim, all.psnr_first, all.psnr_grouped, all.seconds);
    } else {
        printf("  %-40s %3d clips %4d frames  PSNR %6.2f dB  SSIM %.4f  (first frames %.2f dB, grouped %.2f dB)\n", "all",
               all.n_clips, all.n_frames, all.psnr, all.ssim, all.psnr_first, all.psnr_grouped);
    }
    return 0;
}
