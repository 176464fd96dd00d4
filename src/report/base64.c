/* Base64 (RFC 4648 section 4, with padding): how images and the model travel inside the
 * report and the viewer as data the page reads without a server. */
#include "gaussvid/report/report.h"
#include "gaussvid/core/core.h"

#include <stdlib.h>

static const char ALPHABET[] = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";

char *gv_base64_encode(const uint8_t *data, size_t n)
{
    size_t length = (n + 2) / 3 * 4;
    char *out = malloc(length + 1);
    if (!out) {
        gv_fail("out of memory encoding %zu bytes as base64", n);
        return NULL;
    }
    size_t o = 0;
    for (size_t i = 0; i < n; i += 3) {
        uint32_t v = (uint32_t)data[i] << 16;
        if (i + 1 < n) v |= (uint32_t)data[i + 1] << 8;
        if (i + 2 < n) v |= data[i + 2];
        out[o++] = ALPHABET[(v >> 18) & 63];
        out[o++] = ALPHABET[(v >> 12) & 63];
        out[o++] = i + 1 < n ? ALPHABET[(v >> 6) & 63] : '=';
        out[o++] = i + 2 < n ? ALPHABET[v & 63] : '=';
    }
    out[o] = '\0';
    return out;
}

static int sextet(char c)
{
    if (c >= 'A' && c <= 'Z') return c - 'A';
    if (c >= 'a' && c <= 'z') return c - 'a' + 26;
    if (c >= '0' && c <= '9') return c - '0' + 52;
    if (c == '+') return 62;
    if (c == '/') return 63;
    return -1;
}

int gv_base64_decode(const char *text, size_t length, uint8_t **out, size_t *n)
{
    *out = NULL;
    *n = 0;
    if (length % 4 != 0) return gv_fail("base64: length %zu is not a multiple of 4", length);
    size_t pad = length && text[length - 1] == '=' ? (length > 1 && text[length - 2] == '=' ? 2 : 1) : 0;
    size_t size = length / 4 * 3 - pad;
    uint8_t *bytes = malloc(size ? size : 1);
    if (!bytes) return gv_fail("out of memory decoding %zu base64 characters", length);
    size_t o = 0;
    for (size_t i = 0; i < length; i += 4) {
        int last = i + 4 == length;
        uint32_t v = 0;
        for (int k = 0; k < 4; k++) {
            int s = sextet(text[i + k]);
            if (s < 0 && !(last && text[i + k] == '=' && k >= 4 - (int)pad)) {
                free(bytes);
                return gv_fail("base64: invalid character at offset %zu", i + k);
            }
            v = v << 6 | (uint32_t)(s < 0 ? 0 : s);
        }
        for (int k = 0; k < 3 && o < size; k++) bytes[o++] = (uint8_t)(v >> (16 - 8 * k));
    }
    *out = bytes;
    *n = size;
    return 0;
}
