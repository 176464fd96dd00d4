#!/bin/bash
# gaussvid metrics: exit codes, text and JSON output, channel conversion and bad files.
# Usage: bash metrics.sh /path/to/gaussvid   ($GV_TMP: scratch folder)
# The PNGs are written here byte by byte (stored deflate blocks, CRC-32 and Adler-32
# computed in bash), so the test does not depend on any image tool or on libpng's writer.
set -u
source "$(dirname "$0")/lib/harness.sh"
cli_setup metrics "$1"

crc32() { # CRC-32 (PNG, ISO 3309) of the decimal bytes given as arguments
    local crc=$((0xFFFFFFFF)) b k
    for b in "$@"; do
        crc=$((crc ^ b))
        for k in 0 1 2 3 4 5 6 7; do
            if ((crc & 1)); then crc=$(((crc >> 1) ^ 0xEDB88320)); else crc=$((crc >> 1)); fi
        done
    done
    echo $((crc ^ 0xFFFFFFFF))
}

be32() { echo $((($1 >> 24) & 255)) $((($1 >> 16) & 255)) $((($1 >> 8) & 255)) $(($1 & 255)); }

emit() { # writes decimal bytes as binary to stdout
    local b out=""
    for b in "$@"; do out+=$(printf '\\x%02x' "$b"); done
    printf "$out"
}

chunk() { # chunk TYPE data-bytes...: length, type, data, CRC over type and data
    local type=$1; shift
    local tbytes=$(printf '%s' "$type" | od -An -tu1)
    emit $(be32 $#) $tbytes "$@" $(be32 $(crc32 $tbytes "$@"))
}

# write_png FILE WIDTH HEIGHT COLOR_TYPE CHANNELS pixel-bytes... (8-bit, row-major)
write_png() {
    local file=$1 w=$2 h=$3 ct=$4 c=$5; shift 5
    local -a px=("$@") raw=()
    local y i
    for ((y = 0; y < h; y++)); do
        raw+=(0) # filter type None
        for ((i = 0; i < w * c; i++)); do raw+=("${px[y * w * c + i]}"); done
    done
    local n=${#raw[@]} a=1 b=0 v
    for v in "${raw[@]}"; do a=$(((a + v) % 65521)); b=$(((b + a) % 65521)); done
    # zlib header, one final stored block (LEN, NLEN little-endian), data, Adler-32
    local -a z=(120 1 1 $((n & 255)) $((n >> 8)) $((~n & 255)) $(((~n >> 8) & 255))
                "${raw[@]}" $(be32 $(((b << 16) | a))))
    {
        emit 137 80 78 71 13 10 26 10
        chunk IHDR $(be32 "$w") $(be32 "$h") 8 "$ct" 0 0 0
        chunk IDAT "${z[@]}"
        chunk IEND
    } >"$file"
}

# An 8x8 grey ramp, the same ramp as RGB and as RGBA (alpha varying), a copy with one pixel
# changed by 255, a 7x8 image, a truncated PNG and a text file.
grey=() rgb=() rgba=() grey_one=()
for ((i = 0; i < 64; i++)); do
    v=$((i * 4))
    grey+=("$v") rgb+=("$v" "$v" "$v") rgba+=("$v" "$v" "$v" $((255 - i)))
done
grey_one=("${grey[@]}")
grey_one[0]=255 # was 0
write_png "$T/grey.png" 8 8 0 1 "${grey[@]}"
write_png "$T/rgb.png" 8 8 2 3 "${rgb[@]}"
write_png "$T/rgba.png" 8 8 6 4 "${rgba[@]}"
write_png "$T/grey_one.png" 8 8 0 1 "${grey_one[@]}"
write_png "$T/small.png" 7 8 0 1 "${grey[@]:0:56}"
head -c 60 "$T/rgb.png" >"$T/cut.png"
echo "not an image" >"$T/notes.png"

# Identical images (through three channel layouts): exit 0, null PSNR, SSIM 1.
out=$("$G" metrics "$T/grey.png" "$T/rgb.png" --json)
check_rc "identical grey/RGB exit 0" $?
[ "$(printf '%s\n' "$out" | wc -l)" -eq 1 ]
check_rc "JSON is one line on stdout" $?
for key in '"psnr":null' '"ssim":1' '"width":8' '"height":8' '"identical":true'; do
    case "$out" in *"$key"*) r=0 ;; *) r=1 ;; esac
    check_rc "JSON has $key ($out)" $r
done
out=$("$G" metrics "$T/rgba.png" "$T/grey.png")
check_rc "RGBA vs grey exit 0" $?
case "$out" in *"PSNR: inf"*"SSIM: 1.000000"*) r=0 ;; *) r=1 ;; esac
check_rc "RGBA alpha dropped: identical ($out)" $r

# One value of 64 off by 255/255 in every channel: MSE = 1/64, PSNR = 10 log10 64.
out=$("$G" metrics "$T/grey.png" "$T/grey_one.png")
check_rc "one pixel differs exit 0" $?
case "$out" in *"PSNR: 18.0618 dB"*) r=0 ;; *) r=1 ;; esac
check_rc "PSNR = 10 log10 64 ($out)" $r
out=$("$G" metrics "$T/grey.png" "$T/grey_one.png" --json)
psnr=$(printf '%s' "$out" | sed -n 's/.*"psnr":\([0-9.eE+-]*\).*/\1/p')
ssim=$(printf '%s' "$out" | sed -n 's/.*"ssim":\([0-9.eE+-]*\).*/\1/p')
awk -v p="$psnr" 'BEGIN { exit !(p > 18.06179 && p < 18.06180) }'
check_rc "JSON psnr 18.0618 ($out)" $?
awk -v s="$ssim" 'BEGIN { exit !(s > 0 && s < 1) }'
check_rc "JSON ssim in (0, 1) ($out)" $?
case "$out" in *'"identical":false'*) r=0 ;; *) r=1 ;; esac
check_rc "JSON identical false" $r

# Failures: exit 1 and one line naming the file.
expect_failure() { # expect_failure needle args...
    local needle=$1; shift
    "$G" metrics "$@" >"$T/out" 2>"$T/err"
    local rc=$?
    [ $rc -eq 1 ]
    check_rc "exit 1 for $* (got $rc)" $?
    [ "$(wc -l <"$T/err")" -eq 1 ] && grep -q -- "$needle" "$T/err"
    check_rc "one line mentioning '$needle' for $*: $(cat "$T/err")" $?
    [ ! -s "$T/out" ]
    check_rc "nothing on stdout for $*" $?
}
expect_failure "cut.png" "$T/grey.png" "$T/cut.png"
expect_failure "notes.png" "$T/notes.png" "$T/grey.png" --json
expect_failure "missing.png" "$T/grey.png" "$T/missing.png"
expect_failure "same size" "$T/grey.png" "$T/small.png"

# Usage errors: exit 2. Help: exit 0.
expect_usage() {
    "$G" metrics "$@" >/dev/null 2>&1
    local rc=$?
    [ $rc -eq 2 ]
    check_rc "usage error exit 2 for '$*' (got $rc)" $?
}
expect_usage
expect_usage "$T/grey.png"
expect_usage "$T/grey.png" "$T/rgb.png" "$T/rgb.png"
expect_usage "$T/grey.png" "$T/rgb.png" --bogus
"$G" metrics --help | grep -q "identical"
check_rc "--help exit 0 and documents the JSON" $?

# --lpips: LPIPS (AlexNet) weights written here as BF16 under the lpips package's names
# (docs/LPIPS.md): convolutions and biases from a repeating pattern of 13 values of both
# signs, heads all 1.0 (non-negative, as the published heads).
write_lpips() { # write_lpips FILE [NAME_LEFT_OUT]
    local file=$1 skip=${2:-} header="{" off=0 conv_bytes=0 lin_bytes=0 entry name shape n
    local -a tensors=(net.slice1.0.weight:64,3,11,11 net.slice1.0.bias:64
        net.slice2.3.weight:192,64,5,5 net.slice2.3.bias:192 net.slice3.6.weight:384,192,3,3
        net.slice3.6.bias:384 net.slice4.8.weight:256,384,3,3 net.slice4.8.bias:256
        net.slice5.10.weight:256,256,3,3 net.slice5.10.bias:256 lin0.model.1.weight:1,64,1,1
        lin1.model.1.weight:1,192,1,1 lin2.model.1.weight:1,384,1,1
        lin3.model.1.weight:1,256,1,1 lin4.model.1.weight:1,256,1,1)
    for entry in "${tensors[@]}"; do
        name=${entry%%:*} shape=${entry#*:}
        [ "$name" = "$skip" ] && continue
        n=$((2 * ${shape//,/*}))
        header+="\"$name\":{\"dtype\":\"BF16\",\"shape\":[$shape],\"data_offsets\":[$off,$((off + n))]},"
        off=$((off + n))
        case $name in lin*) lin_bytes=$((lin_bytes + n)) ;; *) conv_bytes=$((conv_bytes + n)) ;; esac
    done
    header="${header%,}}"
    while ((${#header} % 8)); do header+=" "; done
    { le64 ${#header}; printf '%s' "$header"; head -c $conv_bytes "$T/pattern"
      head -c $lin_bytes "$T/ones"; } >"$file"
}
# BF16 0.0498 -0.0299 0.02 0.04 -0.0498 0.01 -0.02 0.0299 -0.01 0.0449 -0.04 0.015 0.025
printf '\x4c\x3d\xf5\xbc\xa4\x3c\x24\x3d\x4c\xbd\x24\x3c\xa4\xbc\xf5\x3c\x24\xbc\x38\x3d\x24\xbd\x75\x3c\xcd\x3c' >"$T/pattern"
printf '\x80\x3f' >"$T/ones" # BF16 1.0
for i in $(seq 18); do cat "$T/pattern" "$T/pattern" >"$T/p2" && mv "$T/p2" "$T/pattern"; done
for i in $(seq 11); do cat "$T/ones" "$T/ones" >"$T/o2" && mv "$T/o2" "$T/ones"; done
write_lpips "$T/alex.safetensors"
write_lpips "$T/no_lin4.safetensors" lin4.model.1.weight

# 32x32 grey images (AlexNet needs at least 31x31): a ramp, the ramp as RGB, and the ramp
# with a bright 8x8 square.
big=() big_rgb=() big_sq=()
for ((y = 0; y < 32; y++)); do
    for ((x = 0; x < 32; x++)); do
        v=$(((x * 5 + y * 3) % 256)) s=$v
        ((x >= 12 && x < 20 && y >= 12 && y < 20)) && s=250
        big+=("$v") big_rgb+=("$v" "$v" "$v") big_sq+=("$s")
    done
done
write_png "$T/big.png" 32 32 0 1 "${big[@]}"
write_png "$T/big_rgb.png" 32 32 2 3 "${big_rgb[@]}"
write_png "$T/big_sq.png" 32 32 0 1 "${big_sq[@]}"

expect 0 "LPIPS of identical images" -- "$G" metrics "$T/big.png" "$T/big_rgb.png" --lpips "$T/alex.safetensors"
has "LPIPS: 0.000000"
expect 0 "LPIPS of different images" -- "$G" metrics "$T/big.png" "$T/big_sq.png" --lpips "$T/alex.safetensors"
has "SSIM: "
ab=$(sed -n 's/^LPIPS: //p' "$T/out")
awk -v d="$ab" 'BEGIN { exit !(d > 0) }'
check_rc "LPIPS > 0 for different images ($ab)" $?
"$G" metrics "$T/big_sq.png" "$T/big.png" --lpips "$T/alex.safetensors" >"$T/out" 2>/dev/null
ba=$(sed -n 's/^LPIPS: //p' "$T/out")
[ -n "$ab" ] && [ "$ab" = "$ba" ]
check_rc "LPIPS is symmetric ($ab, $ba)" $?
expect 0 "LPIPS in JSON" -- "$G" metrics "$T/big.png" "$T/big_sq.png" --lpips "$T/alex.safetensors" --json
j=$(sed -n 's/.*"lpips":\([0-9.eE+-]*\).*/\1/p' "$T/out")
[ "$(wc -l <"$T/out")" -eq 1 ] && awk -v j="$j" -v t="$ab" 'BEGIN { exit !(j != "" && j - t < 5e-7 && t - j < 5e-7) }'
check_rc "JSON is one line with lpips $j = $ab: $(cat "$T/out")" $?
expect 0 "no LPIPS without --lpips" -- "$G" metrics "$T/big.png" "$T/big_sq.png" --json
! grep -q lpips "$T/out"
check_rc "JSON without --lpips has no lpips key" $?

expect 1 "weights without lin4" -- "$G" metrics "$T/big.png" "$T/big_sq.png" --lpips "$T/no_lin4.safetensors"
one_line "no_lin4.safetensors: not LPIPS (AlexNet) weights: missing lin4.model.1.weight"
expect 1 "absent weights" -- "$G" metrics "$T/big.png" "$T/big_sq.png" --lpips "$T/absent.safetensors"
one_line "absent.safetensors"
expect 1 "images as weights" -- "$G" metrics "$T/big.png" "$T/big_sq.png" --lpips "$T/big.png"
one_line "big.png"
expect 1 "8x8 images are too small for LPIPS" -- "$G" metrics "$T/grey.png" "$T/rgb.png" --lpips "$T/alex.safetensors"
one_line "grey.png: LPIPS: a 8x8 image is too small: AlexNet needs at least 31x31"
[ ! -s "$T/out" ]
check_rc "nothing on stdout when LPIPS fails" $?
expect 2 "--lpips without a value" -- "$G" metrics "$T/big.png" "$T/big_sq.png" --lpips
"$G" metrics --help | grep -q -- "--lpips WEIGHTS"
check_rc "--help documents --lpips" $?

cli_finish
