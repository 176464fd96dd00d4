#!/bin/bash
# gaussvid bench splat: help, usage errors, a missing scene, and a 20-iteration smoke run on
# a tiny synthesised scene in table and JSON form (the full run and its numbers are in
# docs/BENCHMARKS.md). Usage: bash bench_splat.sh /path/to/gaussvid
source "$(dirname "$0")/lib/harness.sh"
cli_setup bench-splat "$1"
gaussvid="$G"
tmp="$T"

"$gaussvid" bench splat --help > "$tmp/help.txt"
check "--help exits 0" test $? -eq 0
check "--help lists --scene" grep -q -- "--scene DIR" "$tmp/help.txt"
"$gaussvid" bench splat --iters 0 --scene "$tmp" 2> /dev/null
check "--iters 0 exits 2" test $? -eq 2
"$gaussvid" bench splat --scene "$tmp/nowhere" --iters 5 > /dev/null 2> "$tmp/err.txt"
check "missing scene exits 1" test $? -eq 1
check "missing scene named" grep -q "nowhere" "$tmp/err.txt"

"$gaussvid" scene synth --frames 13 --size 48x32 --samples 1 --out "$tmp/scene" --quiet
"$gaussvid" bench splat --scene "$tmp/scene" --iters 20 --threads 1 --quiet > "$tmp/table.txt"
check "table run exits 0" test $? -eq 0
check "table has the stages" grep -q "raster bwd" "$tmp/table.txt"
rows=$(grep -cE '^ +[0-9]+ +[0-9]+ +[0-9]+ +[0-9]+ ' "$tmp/table.txt")
check "table has checkpoint rows" test "$rows" -ge 5
check "table has the phases" grep -q "median ms per iteration: render" "$tmp/table.txt"
check "table has the quality" grep -q "held-out PSNR" "$tmp/table.txt"
check "table compares the default with the reference" \
    test "$(grep -cE '^\| scene \| (lean \+ dropgaussian,decay \+ 1/4 schedule \(default\)|reference) \| [0-9.]+ \| [0-9.]+ \| [0-9.]+ \| [0-9.]+ \|' "$tmp/table.txt")" -eq 2
check "the reference's ratios are 1" grep -qE '^\| scene \| reference \| [0-9.]+ \| [0-9.]+ \| 1.00 \| 1.00 \|' "$tmp/table.txt"
check "the default's ratio line" grep -qE '^scene: lean \+ dropgaussian,decay \+ 1/4 schedule \(default\) / reference: wall [0-9.]+, CPU [0-9.]+; held-out PSNR' "$tmp/table.txt"
check "the time target is not judged at 20 iterations" \
    grep -q "^scene: time target not judged: this run is 20 iterations, interval 6, 48x32, 1 threads" "$tmp/table.txt"
"$gaussvid" bench splat --scene "$tmp/scene" --iters 20 --threads 1 --quiet --resolution-schedule 1 > "$tmp/res.txt"
check "--resolution-schedule adds a run" test "$(grep -cE '^\| scene \| [a-z][^|]* \| [0-9.]+ \| ' "$tmp/res.txt")" -eq 3
check "the full-size run is named" grep -qE '^\| scene \| lean \+ dropgaussian,decay \| ' "$tmp/res.txt"
check "the default's line is still one" test "$(grep -c ' (default) / reference' "$tmp/res.txt")" -eq 1
"$gaussvid" bench splat --scene "$tmp/scene" --iters 20 --threads 1 --quiet --regularize none > "$tmp/none.txt"
check "--regularize none: plain lean, not the default" grep -qE '^\| scene \| lean \+ 1/4 schedule \| [0-9.]+ \| ' "$tmp/none.txt"
check "--regularize none: no default's line" test -z "$(grep ' (default) / reference' "$tmp/none.txt")"
"$gaussvid" bench splat --scene "$tmp/scene" --iters 20 --regularize decay,turbo 2> "$tmp/err.txt"
check "unknown regulariser exits 2" test $? -eq 2
check "unknown regulariser named" grep -q "decay,turbo: expected none or a comma-separated list" "$tmp/err.txt"
for k in 3 4; do # 4 is the default run's
    "$gaussvid" bench splat --scene "$tmp/scene" --iters 20 --resolution-schedule $k 2> /dev/null
    check "--resolution-schedule $k exits 2" test $? -eq 2
done
"$gaussvid" bench splat --scene "$tmp/scene" --iters 20 --threads 1 --quiet --densify mcmc > "$tmp/mcmc.txt"
check "--densify mcmc runs one" test "$(grep -c 'density control mcmc' "$tmp/mcmc.txt")" -eq 1
"$gaussvid" bench splat --scene "$tmp/scene" --iters 20 --densify lean,dense 2> "$tmp/err.txt"
check "unknown mode exits 2" test $? -eq 2
check "unknown mode named" grep -q "'dense' is not one of lean, reference or mcmc" "$tmp/err.txt"
"$gaussvid" bench splat --scene "$tmp/scene" --iters 20 --threads 1 --quiet --json > "$tmp/b.json"
check "json run exits 0" test $? -eq 0
check "json names the regularisers" grep -q '"regularize":.*"dropgaussian,decay"' "$tmp/b.json"
for key in seconds cpu_seconds median_ms checkpoints held_out_psnr final_gaussians; do
    check "json has $key" grep -q "\"$key\":" "$tmp/b.json"
done
check "json has the table's checkpoints" test "$(grep -c '"iteration":' "$tmp/b.json")" -eq "$rows"

cli_finish
