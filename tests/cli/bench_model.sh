#!/bin/bash
# gaussvid bench model: help, usage errors, the --quick smoke run of the tiny preset on a small
# clip in table and JSON form, a preset too large for this machine skipped with the reason,
# and bad presets or clips refused (the full run and its numbers are in docs/BENCHMARKS.md).
# Usage: bash bench_model.sh /path/to/gaussvid
set -u
source "$(dirname "$0")/lib/harness.sh"
cli_setup bench-model "$1"

"$G" bench --help | grep -q "model"
check_rc "bench --help lists model" $?
"$G" bench model --help | grep -q -- "--presets"
check_rc "bench model --help lists --presets" $?
expect 2 "unknown flag" -- "$G" bench model --nope
expect 2 "positional argument" -- "$G" bench model extra
expect 2 "zero frames" -- "$G" bench model --frames 0

small=(--presets tiny --frames 5 --height 32 --width 64 --quick --threads 1)
expect 0 "quick table" -- "$G" bench model "${small[@]}"
has "model tiny, clip 5x32x64: 16 video + 16 camera tokens"
has "fine-tuning step (decomposed, shipped)"
has "per-frame restorer (camera none)"
has "inference (no gradients): camera stream recomputed"
has "VAE (0.20 M parameters), chunked as Wan: encode"
rows=$(grep -c "^  [ a-z(-].* [0-9.]*  *[0-9.]*  *[0-9.]*  *[0-9.]*  *[0-9.]*  *[0-9.]*$" "$T/out")
check_rc "eight timed rows ($rows)" $((rows == 8 ? 0 : 1))

expect 0 "quick JSON" -- "$G" bench model "${small[@]}" --json
check "JSON is one object" bash -c "head -1 '$T/out' | grep -q '^{$' && tail -1 '$T/out' | grep -q '^}$'"
n=$(grep -c '"step_s":' "$T/out")
check_rc "JSON has a step time per row ($n)" $((n == 8 ? 0 : 1))
has '"speedup":'
has '"encode_s":'
has '"preset":	"tiny"'

# a config file works as a preset; presets above --step-limit get the forward pass only
expect 0 "forward only above the step limit" -- "$G" bench model --presets "$(dirname "$0")/../../configs/tiny.json" \
    --frames 5 --height 32 --width 64 --quick --threads 1 --step-limit 1000 --no-vae
has "model tiny, clip 5x32x64"
has "forward (decomposed, frozen weights)"
check "no fine-tuning rows in forward-only mode" bash -c "! grep -q 'variant monolithic' '$T/out'"

# Wan2.1-VACE-14B needs about 80 GB for its weights: skipped here with the reason
avail_kb=$(awk '/^MemAvailable:/ { print $2 }' /proc/meminfo)
if [ -n "$avail_kb" ] && [ "$avail_kb" -lt 60000000 ]; then
    expect 0 "14b skipped" -- "$G" bench model --presets wan2.1-vace-14b --quick
    has "GB of float32 weights (+15% for activations) exceed 80% of the"
fi

expect 1 "unknown preset" -- "$G" bench model --presets nonesuch --quick
one_line "nonesuch"
expect 1 "a clip off the grid" -- "$G" bench model --presets tiny --frames 4 --height 32 --width 64 --quick
one_line "tiny"

cli_finish
