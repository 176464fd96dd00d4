/* Typed reads of a JSON object's members (cJSON), shared by every reader of the project's JSON
 * files (model configs, manifests, run records, transforms.json). Each returns 0 with the
 * value, 1 when the object has no such member (the value untouched), or -1 when the member
 * has another type or is out of range; the reader words the message, naming its file. */
#ifndef GAUSSVID_JSON_H
#define GAUSSVID_JSON_H

#include <stddef.h>

#include <cjson/cJSON.h>

/* The type of a JSON value in words ("a string", "a number", ...), for messages. */
const char *gv_json_type(const cJSON *j);
/* A number in [min, max] (NaN never is), an integer when `integer` is set. */
int gv_json_number(const cJSON *o, const char *key, double min, double max, int integer, double *out);
/* A string shorter than size bytes, copied into out. */
int gv_json_string(const cJSON *o, const char *key, char *out, size_t size);

#endif
