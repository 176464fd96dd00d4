#!/bin/bash
# gaussvid bench raster: help, usage errors, a missing model or scene (one line naming it),
# and a 3-pass smoke run on a model trained for 20 iterations on a tiny synthesised scene,
# in table and JSON form (the measured numbers are in docs/BENCHMARKS.md).
# Usage: bash bench_raster.sh /path/to/gaussvid
source "$(dirname "$0")/lib/harness.sh"
cli_setup bench-raster "$1"

"$G" bench raster --help > "$T/help.txt"
check "--help exits 0" test $? -eq 0
check "--help lists --model" grep -q -- "--model MODEL.ply" "$T/help.txt"
"$G" scene synth --frames 13 --size 48x32 --samples 1 --out "$T/scene" --quiet
"$G" splat train --scene "$T/scene" --interval 6 --iters 20 --threads 1 --quiet --out "$T/m.ply" > /dev/null
check "model trained" test -s "$T/m.ply"

expect 2 "--passes 0 exits 2" -- "$G" bench raster --model "$T/m.ply" --scene "$T/scene" --passes 0
expect 2 "no --model exits 2" -- "$G" bench raster --scene "$T/scene"
expect 1 "missing model exits 1" -- "$G" bench raster --model "$T/nowhere.ply" --scene "$T/scene"
one_line "nowhere.ply"
expect 1 "missing scene exits 1" -- "$G" bench raster --model "$T/m.ply" --scene "$T/noscene"
one_line "noscene"

expect 0 "table run exits 0" -- "$G" bench raster --model "$T/m.ply" --scene "$T/scene" \
    --passes 3 --threads 1 --quiet
for stage in projection binning+sort SH "raster fwd" "raster bwd" "projection bwd" "SH bwd" \
    loss Adam "whole pass"; do
    check "table has $stage" grep -q "^| $stage | [0-9]" "$T/out"
done
has "3 passes, 1 threads"

expect 0 "json run exits 0" -- "$G" bench raster --model "$T/m.ply" --scene "$T/scene" \
    --passes 3 --threads 2 --quiet --json
for key in gaussians passes threads mean_visible stages cpu_ms wall_ms cpu_ms_per_pass; do
    check "json has $key" grep -q "\"$key\":" "$T/out"
done
check "json has eleven stages" test "$(grep -c '"cpu_ms":' "$T/out")" -eq 11

cli_finish
