/* PNG and JPEG images through the signature dispatch every scene image goes through
 * (gv_image_read), then the RGB conversion the scene loader applies. */
#include "fuzz.h"
#include "gaussvid/io/image.h"

static int fuzz_one(const uint8_t *data, size_t size)
{
    const char *path = fuzz_file("frame.png", data, size);
    gv_image img;
    gv_clear_error();
    int rc = gv_image_read_rgb(path, &img);
    fuzz_check_failure(rc, "frame.png");
    if (rc == 0) {
        if (img.channels != 3 || img.width <= 0 || img.height <= 0) abort();
        volatile uint8_t last = img.pixels[(size_t)img.width * img.height * 3 - 1]; /* every byte is there */
        (void)last;
        gv_image_free(&img);
    }
    return 0;
}
