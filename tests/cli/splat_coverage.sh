#!/bin/bash
# gaussvid splat render --depth --opacity and gaussvid splat coverage on a tiny synthesised
# scene: the .npy maps (layout, shape, value ranges), the coverage table and JSON (frames
# between two training frames, the render's PSNR equal to splat eval's), and bad inputs
# failing with one line. Usage: bash splat_coverage.sh /path/to/gaussvid
set -u
source "$(dirname "$0")/lib/harness.sh"
cli_setup splat_coverage "$1"

"$G" scene synth --frames 16 --size 48x32 --samples 1 --out "$T/scene" --quiet
"$G" splat train --scene "$T/scene" --interval 4 --iters 150 --seed 3 --threads 2 \
    --out "$T/m.ply" --quiet > /dev/null
check "trained a model" test -s "$T/m.ply"

# ---- render maps ----
expect 0 "render with maps" -- "$G" splat render --model "$T/m.ply" --scene "$T/scene" \
    --frames 0,5 --depth --opacity --out "$T/r" --quiet
for f in frame_00000 frame_00005; do
    exists "$T/r/$f.png"
    exists "$T/r/$f.depth.npy"
    exists "$T/r/$f.opacity.npy"
done
# numpy.save's layout: 128-byte header, then 32 x 48 float32 values
check "depth file size" test "$(stat -c %s "$T/r/frame_00005.depth.npy")" -eq $((128 + 32 * 48 * 4))
check "npy magic and shape" grep -qa "NUMPY.*'descr': '<f4', 'fortran_order': False, 'shape': (32, 48), }" \
    "$T/r/frame_00005.depth.npy"
values() { tail -c +129 "$1" | od -An -v -f | tr -s ' ' '\n' | grep -v '^$'; }
check "opacity within [0, 1]" test "$(values "$T/r/frame_00005.opacity.npy" | awk '$1 < 0 || $1 > 1' | wc -l)" -eq 0
check "opacity mostly high" test "$(values "$T/r/frame_00005.opacity.npy" | awk '$1 > 0.5' | wc -l)" -gt 1000
check "depth non-negative, positive where opaque" test "$(paste <(values "$T/r/frame_00005.depth.npy") \
    <(values "$T/r/frame_00005.opacity.npy") | awk '$1 < 0 || ($2 > 0.01 && $1 <= 0)' | wc -l)" -eq 0
expect 0 "render without maps" -- "$G" splat render --model "$T/m.ply" --scene "$T/scene" \
    --frames 1 --out "$T/plain" --quiet
check "no maps unless asked" test "$(ls "$T/plain")" = "frame_00001.png"
expect 0 "maps along a path" -- "$G" splat render --model "$T/m.ply" --scene "$T/scene" \
    --frames 0,4 --path 3 --opacity --out "$T/path" --quiet
exists "$T/path/path_00002.opacity.npy"

# ---- coverage ----
expect 0 "coverage runs" -- "$G" splat coverage --model "$T/m.ply" --scene "$T/scene" \
    --interval 4 --json "$T/c.json" --quiet
# frames 1-3, 5-7, 9-11 lie between training frames; 13-15 have no second anchor
has "mean over 9 held-out frames: covered"
has "oracle"
check "9 table rows" test "$(grep -c '^[0-9]' "$T/out")" -eq 9
check "anchors of frame 5" grep -q "^5 .* 4,8 " "$T/out"
check "oracle never below the render" test "$(awk '/^[0-9]/ && $8 < $5 - 0.005' "$T/out" | wc -l)" -eq 0
check "coverage within 0-100 %" test "$(awk '/^[0-9]/ && ($4 + 0 < 0 || $4 + 0 > 100)' "$T/out" | wc -l)" -eq 0
check "json per_frame" test "$(grep -c '"psnr_oracle":' "$T/c.json")" -eq 10
check "json mean" grep -q '"uncovered_error_share":' "$T/c.json"
check "json blend" test "$(grep -c '"psnr_blend":' "$T/c.json")" -eq 10
has "mean of render and warps"
check "json anchors" grep -q '"anchors":' "$T/c.json"
# the render's PSNR is splat eval's (8-bit render against the 8-bit image)
"$G" splat eval --model "$T/m.ply" --scene "$T/scene" --interval 4 > "$T/eval.txt"
eval_psnr=$(awk '$1 == 6 {print $4}' "$T/eval.txt")
cov_psnr=$(awk '$1 == 6 {print $5}' "$T/out")
check "render PSNR as splat eval ($eval_psnr, $cov_psnr)" \
    awk -v a="$eval_psnr" -v b="$cov_psnr" 'BEGIN { exit !(a - b < 0.006 && b - a < 0.006) }'
# a looser tolerance covers at least as much
"$G" splat coverage --model "$T/m.ply" --scene "$T/scene" --interval 4 --tolerance 0.5 \
    --quiet > "$T/loose.txt"
tight=$(grep -o 'covered [0-9.]*%' "$T/out" | head -1 | tr -dc '0-9.')
loose=$(grep -o 'covered [0-9.]*%' "$T/loose.txt" | head -1 | tr -dc '0-9.')
check "looser tolerance covers more ($tight, $loose)" awk -v a="$tight" -v b="$loose" 'BEGIN { exit !(b >= a) }'

# ---- bad inputs: one line, exit 1; no JSON ----
expect 1 "interval too large" -- "$G" splat coverage --model "$T/m.ply" --scene "$T/scene" \
    --interval 16 --json "$T/x.json"
one_line "need at least 17 frames"
check "no JSON on failure" test ! -e "$T/x.json"
expect 1 "interval 1" -- "$G" splat coverage --model "$T/m.ply" --scene "$T/scene" --interval 1
one_line "interval 1"
expect 1 "missing model" -- "$G" splat coverage --model "$T/none.ply" --scene "$T/scene" --interval 4
one_line "none.ply"
head -c 3000 "$T/m.ply" > "$T/cut.ply"
expect 1 "truncated model" -- "$G" splat coverage --model "$T/cut.ply" --scene "$T/scene" --interval 4
one_line "cut.ply"
expect 2 "tolerance 0" -- "$G" splat coverage --model "$T/m.ply" --scene "$T/scene" --interval 4 \
    --tolerance 0
expect 2 "missing --interval" -- "$G" splat coverage --model "$T/m.ply" --scene "$T/scene"
expect 0 "help" -- "$G" splat coverage --help
has "usage: gaussvid splat coverage"

cli_finish
