/* Model config files (JSON, docs/MODEL.md) through gv_model_config_load, as every model
 * command reads --config. */
#include "fuzz.h"
#include "gaussvid/model/model_config.h"

static int fuzz_one(const uint8_t *data, size_t size)
{
    const char *path = fuzz_file("config.json", data, size);
    gv_model_config c;
    gv_clear_error();
    int rc = gv_model_config_load(&c, path);
    fuzz_check_failure(rc, "config.json");
    if (rc == 0) {
        char *text = gv_model_config_to_json(&c);
        if (!text) abort();
        gv_model_config again; /* what we write must read back */
        if (gv_model_config_parse(&again, text, "round trip") != 0) {
            fprintf(stderr, "fuzz: a loaded config does not read back: %s\n", gv_last_error());
            abort();
        }
        free(text);
    }
    return 0;
}
