#!/bin/bash
# gaussvid splat export: exit codes (0 success, 1 failure, 2 usage), the .splat size
# (32 bytes per Gaussian), bytes of a known record, and bad models failing with one line
# that names the file. Usage: bash ply.sh /path/to/gaussvid
source "$(dirname "$0")/lib/harness.sh"
cli_setup ply "$1"

# A degree-0 model of three Gaussians written byte by byte: 17 float32 LE per Gaussian in
# the reference order x y z nx ny nz f_dc_0..2 opacity scale_0..2 rot_0..3.
zero='\x00\x00\x00\x00'
one='\x00\x00\x80\x3f'    # 1.0
two='\x00\x00\x00\x40'    # 2.0
header() {  # header N [PROPERTY_TO_LEAVE_OUT]
    printf 'ply\nformat binary_little_endian 1.0\nelement vertex %d\n' "$1"
    for p in x y z nx ny nz f_dc_0 f_dc_1 f_dc_2 opacity scale_0 scale_1 scale_2 \
             rot_0 rot_1 rot_2 rot_3; do
        [ "$p" = "$2" ] || printf 'property float %s\n' "$p"
    done
    printf 'end_header\n'
}
gaussian() {  # gaussian X: at (X, 0, 0), colour and opacity 0, scale 1, rotation (1,0,0,0)
    printf "$1$zero$zero"                  # x y z
    printf "$zero$zero$zero"               # nx ny nz
    printf "$zero$zero$zero"               # f_dc
    printf "$zero"                         # opacity
    printf "$zero$zero$zero"               # scale
    printf "$one$zero$zero$zero"           # rot
}
model="$T/model.ply"
{ header 3; gaussian "$zero"; gaussian "$one"; gaussian "$two"; } > "$model"

# Success: 3 x 32 bytes, the count and the degree printed.
"$G" splat export "$model" --out "$T/model.splat" > "$T/out.txt" 2> "$T/err.txt"
check "export exits 0" test $? -eq 0
check "splat is 96 bytes" test "$(stat -c %s "$T/model.splat" 2>/dev/null)" = 96
check "prints the count" grep -q "3 Gaussians" "$T/out.txt"
check "prints the degree" grep -q "SH degree 0" "$T/out.txt"
# Equal weights keep the file order: the first record is the Gaussian at x = 0. Its colour
# (0.5 x 255 = 127.5 -> 127), alpha (sigmoid(0) x 255 -> 127) and rotation (255 128 128 128).
record=$(od -An -tu1 -j24 -N8 "$T/model.splat" | tr -s ' ' | sed 's/^ //')
check "first record bytes 24..31" test "$record" = "127 127 127 127 255 128 128 128"
check "first record scale is 1.0" test "$(od -An -tx1 -j12 -N4 "$T/model.splat" | tr -d ' ')" = 0000803f
x3=$(od -An -tx1 -j64 -N4 "$T/model.splat" | tr -d ' ')
check "third record at x = 2" test "$x3" = 00000040

# Help and usage errors.
"$G" splat export --help > "$T/help.txt"
check "--help exits 0" test $? -eq 0
check "--help shows usage" grep -q "usage: gaussvid splat export" "$T/help.txt"
"$G" splat export "$model" 2> /dev/null
check "missing --out exits 2" test $? -eq 2
"$G" splat export --out "$T/x.splat" 2> /dev/null
check "missing model exits 2" test $? -eq 2
"$G" splat export "$model" --out "$T/x.splat" --bogus 2> /dev/null
check "unknown flag exits 2" test $? -eq 2

# Failures: exit 1, one line naming the file and the problem, no output left behind.
bad_case() {  # bad_case NAME NEEDLE: exports $T/NAME.ply and expects a failure
    local in="$T/$1.ply" out="$T/$1.splat"
    "$G" splat export "$in" --out "$out" > /dev/null 2> "$T/$1.err"
    local rc=$?
    check "$1 exits 1" test $rc -eq 1
    check "$1 names the file" grep -q "$in" "$T/$1.err"
    check "$1 says '$2'" grep -q "$2" "$T/$1.err"
    check "$1 message is one line" test "$(wc -l < "$T/$1.err")" -eq 1
    check "$1 leaves no output" test ! -e "$out"
}
bad_case absent "cannot open"
head -c -5 "$model" > "$T/truncated.ply"
bad_case truncated "truncated"
{ header 2 rot_2; gaussian "$zero"; gaussian "$one"; } > "$T/norot2.ply"
bad_case norot2 "no property 'rot_2'"
{ header 1 | grep -v end_header; gaussian "$zero"; } > "$T/noend.ply"
bad_case noend "end_header"
{ header 1; printf "$zero$zero$zero$zero$zero$zero$zero$zero$zero"; printf '\x00\x00\xc0\x7f'; \
  printf "$zero$zero$zero$one$zero$zero$zero"; } > "$T/nan.ply"
bad_case nan "property 'opacity' is not finite"
"$G" splat export "$model" --out "$T/no/such/dir/x.splat" 2> "$T/dir.err"
check "unwritable output exits 1" test $? -eq 1
check "unwritable output is named" grep -q "no/such/dir/x.splat" "$T/dir.err"

cli_finish
