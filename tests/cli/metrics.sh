#!/bin/bash
# gaussvid metrics: exit codes, text and JSON output, channel conversion and bad files.
# Usage: bash metrics.sh /path/to/gaussvid   ($GV_TMP: scratch folder)
# The PNGs are written here byte by byte (stored deflate blocks, CRC-32 and Adler-32
# computed in bash), so the test does not depend on any image tool or on libpng's writer.
set -u
GV="$1"
DIR="${GV_TMP:-/tmp/gaussvid-cli-metrics}"
rm -rf "$DIR" && mkdir -p "$DIR" || exit 1
passed=0
failed=0

check() { # check "description" condition-exit-status
    if [ "$2" -eq 0 ]; then passed=$((passed + 1)); else failed=$((failed + 1)); echo "FAILED: $1"; fi
}

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
write_png "$DIR/grey.png" 8 8 0 1 "${grey[@]}"
write_png "$DIR/rgb.png" 8 8 2 3 "${rgb[@]}"
write_png "$DIR/rgba.png" 8 8 6 4 "${rgba[@]}"
write_png "$DIR/grey_one.png" 8 8 0 1 "${grey_one[@]}"
write_png "$DIR/small.png" 7 8 0 1 "${grey[@]:0:56}"
head -c 60 "$DIR/rgb.png" >"$DIR/cut.png"
echo "not an image" >"$DIR/notes.png"

# Identical images (through three channel layouts): exit 0, null PSNR, SSIM 1.
out=$("$GV" metrics "$DIR/grey.png" "$DIR/rgb.png" --json)
check "identical grey/RGB exit 0" $?
[ "$(printf '%s\n' "$out" | wc -l)" -eq 1 ]
check "JSON is one line on stdout" $?
for key in '"psnr":null' '"ssim":1' '"width":8' '"height":8' '"identical":true'; do
    case "$out" in *"$key"*) r=0 ;; *) r=1 ;; esac
    check "JSON has $key ($out)" $r
done
out=$("$GV" metrics "$DIR/rgba.png" "$DIR/grey.png")
check "RGBA vs grey exit 0" $?
case "$out" in *"PSNR: inf"*"SSIM: 1.000000"*) r=0 ;; *) r=1 ;; esac
check "RGBA alpha dropped: identical ($out)" $r

# One value of 64 off by 255/255 in every channel: MSE = 1/64, PSNR = 10 log10 64.
out=$("$GV" metrics "$DIR/grey.png" "$DIR/grey_one.png")
check "one pixel differs exit 0" $?
case "$out" in *"PSNR: 18.0618 dB"*) r=0 ;; *) r=1 ;; esac
check "PSNR = 10 log10 64 ($out)" $r
out=$("$GV" metrics "$DIR/grey.png" "$DIR/grey_one.png" --json)
psnr=$(printf '%s' "$out" | sed -n 's/.*"psnr":\([0-9.eE+-]*\).*/\1/p')
ssim=$(printf '%s' "$out" | sed -n 's/.*"ssim":\([0-9.eE+-]*\).*/\1/p')
awk -v p="$psnr" 'BEGIN { exit !(p > 18.06179 && p < 18.06180) }'
check "JSON psnr 18.0618 ($out)" $?
awk -v s="$ssim" 'BEGIN { exit !(s > 0 && s < 1) }'
check "JSON ssim in (0, 1) ($out)" $?
case "$out" in *'"identical":false'*) r=0 ;; *) r=1 ;; esac
check "JSON identical false" $r

# Failures: exit 1 and one line naming the file.
expect_failure() { # expect_failure needle args...
    local needle=$1; shift
    "$GV" metrics "$@" >"$DIR/out" 2>"$DIR/err"
    local rc=$?
    [ $rc -eq 1 ]
    check "exit 1 for $* (got $rc)" $?
    [ "$(wc -l <"$DIR/err")" -eq 1 ] && grep -q -- "$needle" "$DIR/err"
    check "one line mentioning '$needle' for $*: $(cat "$DIR/err")" $?
    [ ! -s "$DIR/out" ]
    check "nothing on stdout for $*" $?
}
expect_failure "cut.png" "$DIR/grey.png" "$DIR/cut.png"
expect_failure "notes.png" "$DIR/notes.png" "$DIR/grey.png" --json
expect_failure "missing.png" "$DIR/grey.png" "$DIR/missing.png"
expect_failure "same size" "$DIR/grey.png" "$DIR/small.png"

# Usage errors: exit 2. Help: exit 0.
expect_usage() {
    "$GV" metrics "$@" >/dev/null 2>&1
    local rc=$?
    [ $rc -eq 2 ]
    check "usage error exit 2 for '$*' (got $rc)" $?
}
expect_usage
expect_usage "$DIR/grey.png"
expect_usage "$DIR/grey.png" "$DIR/rgb.png" "$DIR/rgb.png"
expect_usage "$DIR/grey.png" "$DIR/rgb.png" --bogus
"$GV" metrics --help | grep -q "identical"
check "--help exit 0 and documents the JSON" $?

echo "$passed passed, $failed failed"
[ "$failed" -eq 0 ]
