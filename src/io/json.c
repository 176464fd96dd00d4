/* Typed reads of JSON members (json.h). */
#include "gaussvid/io/json.h"

#include <math.h>
#include <string.h>

const char *gv_json_type(const cJSON *j)
{
    if (cJSON_IsString(j)) return "a string";
    if (cJSON_IsNumber(j)) return "a number";
    if (cJSON_IsBool(j)) return "a boolean";
    if (cJSON_IsNull(j)) return "null";
    if (cJSON_IsArray(j)) return "an array";
    if (cJSON_IsObject(j)) return "an object";
    return "an invalid value";
}

int gv_json_number(const cJSON *o, const char *key, double min, double max, int integer, double *out)
{
    const cJSON *v = cJSON_GetObjectItemCaseSensitive(o, key);
    if (!v) return 1;
    if (!cJSON_IsNumber(v) || !(v->valuedouble >= min && v->valuedouble <= max) ||
        (integer && v->valuedouble != floor(v->valuedouble)))
        return -1;
    *out = v->valuedouble;
    return 0;
}

int gv_json_string(const cJSON *o, const char *key, char *out, size_t size)
{
    const cJSON *v = cJSON_GetObjectItemCaseSensitive(o, key);
    if (!v) return 1;
    if (!cJSON_IsString(v) || strlen(v->valuestring) >= size) return -1;
    memcpy(out, v->valuestring, strlen(v->valuestring) + 1);
    return 0;
}
