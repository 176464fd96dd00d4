/* safetensors dtypes: names, sizes, and the half-precision conversions (IEEE binary16 and
 * bfloat16) used to read and write F16/BF16 tensors. */
#include "gaussvid/io/safetensors.h"

#include <string.h>

static const struct {
    const char *name;
    int bits;
} dtype_table[GV_ST_N_DTYPES] = {
    [GV_ST_BOOL] = {"BOOL", 8},         [GV_ST_F4] = {"F4", 4},
    [GV_ST_F6_E2M3] = {"F6_E2M3", 6},   [GV_ST_F6_E3M2] = {"F6_E3M2", 6},
    [GV_ST_U8] = {"U8", 8},             [GV_ST_I8] = {"I8", 8},
    [GV_ST_F8_E5M2] = {"F8_E5M2", 8},   [GV_ST_F8_E4M3] = {"F8_E4M3", 8},
    [GV_ST_F8_E8M0] = {"F8_E8M0", 8},   [GV_ST_F8_E4M3FNUZ] = {"F8_E4M3FNUZ", 8},
    [GV_ST_F8_E5M2FNUZ] = {"F8_E5M2FNUZ", 8},
    [GV_ST_I16] = {"I16", 16},          [GV_ST_U16] = {"U16", 16},
    [GV_ST_F16] = {"F16", 16},          [GV_ST_BF16] = {"BF16", 16},
    [GV_ST_I32] = {"I32", 32},          [GV_ST_U32] = {"U32", 32},
    [GV_ST_F32] = {"F32", 32},          [GV_ST_C64] = {"C64", 64},
    [GV_ST_F64] = {"F64", 64},          [GV_ST_I64] = {"I64", 64},
    [GV_ST_U64] = {"U64", 64},
};

const char *gv_st_dtype_name(gv_st_dtype dtype)
{
    return (unsigned)dtype < GV_ST_N_DTYPES ? dtype_table[dtype].name : "?";
}

int gv_st_dtype_from_name(const char *name)
{
    for (int d = 0; d < GV_ST_N_DTYPES; d++)
        if (!strcmp(name, dtype_table[d].name)) return d;
    return -1;
}

int gv_st_dtype_bits(gv_st_dtype dtype)
{
    return (unsigned)dtype < GV_ST_N_DTYPES ? dtype_table[dtype].bits : 0;
}

static uint32_t float_bits(float x)
{
    uint32_t u;
    memcpy(&u, &x, 4);
    return u;
}

static float bits_float(uint32_t u)
{
    float x;
    memcpy(&x, &u, 4);
    return x;
}

/* binary16: 1 sign, 5 exponent (bias 15), 10 mantissa bits; exponent 0 holds the
 * subnormals m * 2^-24, exponent 31 infinity and NaN. */
float gv_f16_to_f32(uint16_t h)
{
    uint32_t sign = (uint32_t)(h & 0x8000) << 16;
    uint32_t exponent = (h >> 10) & 0x1f, mantissa = h & 0x3ff;
    if (exponent == 0) {  /* zero or subnormal: exact in float32 */
        float v = (float)mantissa * 0x1p-24f;
        return sign ? -v : v;
    }
    if (exponent == 31) return bits_float(sign | 0x7f800000u | (mantissa << 13));
    return bits_float(sign | ((exponent + 112) << 23) | (mantissa << 13));
}

/* Rounds `value >> shift` to nearest, ties to even. */
static uint32_t shift_round_even(uint32_t value, int shift)
{
    uint32_t kept = value >> shift, rest = value & ((1u << shift) - 1), half = 1u << (shift - 1);
    if (rest > half || (rest == half && (kept & 1))) kept++;
    return kept;
}

uint16_t gv_f32_to_f16(float x)
{
    uint32_t u = float_bits(x);
    uint16_t sign = (uint16_t)((u >> 16) & 0x8000);
    uint32_t a = u & 0x7fffffffu;
    if (a > 0x7f800000u) return sign | 0x7e00 | (uint16_t)((a >> 13) & 0x3ff);  /* quiet NaN */
    /* 65520 = 0x477ff000 is half-way between 65504 (max half) and 65536: ties to even go up */
    if (a >= 0x477ff000u) return sign | 0x7c00;
    if (a >= 0x38800000u) {  /* >= 2^-14: a normal half; a carry into the exponent is right */
        uint32_t rebiased = a - ((uint32_t)(127 - 15) << 23);
        return sign | (uint16_t)shift_round_even(rebiased, 13);
    }
    if (a <= 0x33000000u) return sign;  /* <= 2^-25: rounds to zero (2^-25 is a tie to 0) */
    /* subnormal half: m * 2^(e - 150) in units of 2^-24 is m >> (126 - e), e in [102, 112] */
    uint32_t e = a >> 23, m = (a & 0x7fffff) | 0x800000;
    return sign | (uint16_t)shift_round_even(m, (int)(126 - e));
}

float gv_bf16_to_f32(uint16_t b)
{
    return bits_float((uint32_t)b << 16);
}

uint16_t gv_f32_to_bf16(float x)
{
    uint32_t u = float_bits(x);
    if ((u & 0x7fffffffu) > 0x7f800000u) return (uint16_t)((u >> 16) | 0x0040);  /* quiet NaN */
    u += 0x7fffu + ((u >> 16) & 1);  /* round to nearest even; overflow gives infinity */
    return (uint16_t)(u >> 16);
}
