/* gaussvid metrics A B [--json] [--lpips WEIGHTS]: PSNR and SSIM of two images as the
 * official 3DGS evaluation computes them (docs/METRICS.md), and LPIPS when its AlexNet
 * weights are given (docs/LPIPS.md). `gaussvid metrics consistency DIR` is
 * cmd_metrics_consistency.c. */
#include <string.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>

#include <cjson/cJSON.h>

#include "cli/commands.h"
#include "gaussvid/core/core.h"
#include "gaussvid/io/image.h"
#include "gaussvid/eval/lpips.h"
#include "gaussvid/io/metrics.h"

/* lpips: NULL when not computed. */
static int print_json(double psnr, double ssim, const double *lpips, int width, int height)
{
    cJSON *root = cJSON_CreateObject();
    int identical = isinf(psnr);
    if (identical) cJSON_AddNullToObject(root, "psnr"); /* JSON has no infinity */
    else cJSON_AddNumberToObject(root, "psnr", psnr);
    cJSON_AddNumberToObject(root, "ssim", ssim);
    if (lpips) cJSON_AddNumberToObject(root, "lpips", *lpips);
    cJSON_AddNumberToObject(root, "width", width);
    cJSON_AddNumberToObject(root, "height", height);
    cJSON_AddBoolToObject(root, "identical", identical);
    char *text = cJSON_PrintUnformatted(root);
    cJSON_Delete(root);
    if (!text) return gv_fail("metrics: out of memory writing JSON");
    printf("%s\n", text);
    cJSON_free(text);
    return 0;
}

int cmd_metrics(int argc, char **argv)
{
    if (argc >= 2 && !strcmp(argv[1], "consistency")) return cmd_metrics_consistency(argc - 1, argv + 1);
    int json = 0;
    const char *lpips_path = NULL;
    const gv_flag flags[] = {
        {"json", GV_FLAG_BOOL, &json, NULL, "print one JSON object on stdout", 0},
        {"lpips", GV_FLAG_STRING, &lpips_path, "WEIGHTS",
         "also LPIPS (AlexNet) with these safetensors weights", 0},
    };
    const gv_command_spec spec = {
        "metrics", "A B", "PSNR (dB) and SSIM of two images of the same size",
        "Both images are read as 8-bit PNG or JPEG and converted to RGB (grey is replicated,\n"
        "alpha is dropped, as 3DGS's metrics.py keeps the first three channels); values are\n"
        "v / 255. PSNR = -10 log10(MSE) over all values; SSIM uses the 11x11 Gaussian window\n"
        "(sigma 1.5) with zero padding, C1 = 0.01^2, C2 = 0.03^2, averaged over all pixels and\n"
        "channels. Identical images have infinite PSNR, written as null in JSON together with\n"
        "\"identical\": true. JSON keys: psnr, ssim, width, height, identical.\n"
        "--lpips adds LPIPS (0 for identical images; lower is closer), as lpips.LPIPS(net='alex')\n"
        "on the RGB images read as v / 127.5 - 1; both must be at least 31x31. JSON key: lpips.\n"
        "'gaussvid metrics consistency DIR' measures the 3D consistency of a reconstruct folder's\n"
        "frames (see its --help).",
        flags, 2, 2, 2};
    char *positional[2];
    int n_positional = 0;
    int parsed = gv_args_parse(&spec, argc, argv, positional, &n_positional);
    if (parsed != GV_ARGS_OK) return gv_args_exit_code(parsed);

    gv_image a = {0}, b = {0};
    if (gv_image_read_rgb(positional[0], &a) != 0) return gv_report_failure();
    if (gv_image_read_rgb(positional[1], &b) != 0) {
        gv_image_free(&a);
        return gv_report_failure();
    }
    double psnr = 0.0, ssim = 0.0;
    int rc;
    if (a.width != b.width || a.height != b.height)
        rc = gv_fail("%s is %dx%d but %s is %dx%d: images must have the same size",
                     positional[0], a.width, a.height, positional[1], b.width, b.height);
    else
        rc = gv_image_psnr_ssim(&a, &b, &psnr, &ssim);
    double lpips = 0.0;
    if (rc == 0 && lpips_path) {
        gv_lpips net;
        rc = gv_lpips_load(&net, lpips_path);
        if (rc == 0 && gv_lpips_distance(&net, &a, &b, &lpips) != 0)
            rc = gv_fail_context("%s", positional[0]);
        gv_lpips_free(&net);
    }
    int width = a.width, height = a.height;
    gv_image_free(&a);
    gv_image_free(&b);
    if (rc != 0) return gv_report_failure();
    if (json) {
        if (print_json(psnr, ssim, lpips_path ? &lpips : NULL, width, height) != 0)
            return gv_report_failure();
    } else {
        if (isinf(psnr)) printf("PSNR: inf (identical images)\nSSIM: %.6f\n", ssim);
        else printf("PSNR: %.4f dB\nSSIM: %.6f\n", psnr, ssim);
        if (lpips_path) printf("LPIPS: %.6f\n", lpips);
    }
    return 0;
}
