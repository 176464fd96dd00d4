#!/bin/bash
# The coverage mask (variant coverage; docs/RESTORATION.md "The coverage mask") end to end on
# a tiny pipeline made here: `dataset build` with sparse 3DGS writes each clip's coverage
# plane; without the variant, eval and restore give the same numbers and frames, byte for
# byte, on the clips with the plane and on the same clips without it (as every clip before
# the plane: stripped here); with the variant the checkpoint records it and its latents are
# cached apart. One thread.
# Usage: bash coverage_mask.sh /path/to/gaussvid   ($GV_TMP scratch)
source "$(dirname "$0")/lib/harness.sh"
cli_setup coverage_mask "$1"
json_number() { grep -A4 "\"$2\"" "$1" | grep -m1 "\"$3\"" | tr -d ' \t,' | cut -d: -f2; }

A="$T/room"
D="$T/data"
D0="$T/data-old"
expect 0 "synth" -- "$G" scene synth --seed 3 --frames 14 --size 32x32 --samples 1 --out "$A" --quiet
expect 0 "dataset" -- "$G" dataset build --scenes "$A" --intervals 6 --iters 20 \
    --clips-per-run 2 --seed 5 --out "$D" --quiet --threads 1
check "the clips carry the plane; stripped copy" test "$(python3 "$(dirname "$0")/lib/strip_coverage.py" "$D" "$D0")" = 2
expect 0 "vae" -- "$G" vae train --config tiny --scenes "$A" --out "$T/vae.safetensors" --steps 2 --crop 32x32 \
    --stats-clips 4 --quiet --threads 1
expect 0 "pretrain" -- "$G" pretrain --clips "$D" --config tiny --vae "$T/vae.safetensors" --steps 2 \
    --batch 1 --out "$T/base.safetensors" --quiet --threads 1
expect 0 "train" -- "$G" train --clips "$D" --base "$T/base.safetensors" --steps 2 --batch 1 \
    --out "$T/plain.safetensors" --quiet --threads 1
expect 0 "train coverage" -- "$G" train --clips "$D" --base "$T/base.safetensors" --steps 2 --batch 1 \
    --variant coverage --out "$T/coverage.safetensors" --quiet --threads 1
# the config is JSON text inside the safetensors metadata: its quotes and tabs are escaped
check "the checkpoint records the variant" grep -aqF '\"coverage\":\ttrue' "$T/coverage.safetensors"
check "the plain one does not" bash -c "! grep -aqF '\\\"coverage\\\":' '$T/plain.safetensors'"

# Without the variant the plane changes nothing.
for d in "$D" "$D0"; do
    expect 0 "eval plain $d" -- "$G" eval --ckpt "$T/plain.safetensors" --clips "$d" --split train \
        --json "$d.plain.json" --quiet --threads 1
    expect 0 "restore plain $d" -- "$G" restore --ckpt "$T/plain.safetensors" --clips "$d" --split train \
        --out "$d.restored" --quiet --threads 1
    expect 0 "eval coverage $d" -- "$G" eval --ckpt "$T/coverage.safetensors" --clips "$d" --split train \
        --json "$d.coverage.json" --quiet --threads 1
done
for k in psnr ssim; do
    p=$(json_number "$D.plain.json" restored $k)
    check "plain restored $k $p the same without the plane" test -n "$p" -a "$p" = "$(json_number "$D0.plain.json" restored $k)"
done
for f in "$D.restored"/*/f[123].png; do
    check "frame $f the same without the plane" cmp -s "$f" "$D0.restored/${f#"$D.restored/"}"
done
# With the variant the latents are cached apart (the per-pixel context itself is checked
# exactly in tests/test_condition_coverage.c: two training steps leave the tiny network's VACE
# hints too small to move an 8-bit frame).
check "a cache of its own" test -e "$(ls "$D"/latents_*_both_coverage.safetensors)"
check "baselines agree" test "$(json_number "$D.coverage.json" baseline psnr)" = "$(json_number "$D0.plain.json" baseline psnr)"
expect 2 "coverage without both anchors" -- "$G" train --clips "$D" --base "$T/base.safetensors" \
    --steps 1 --variant anchors=first,coverage --out "$T/x.safetensors" --quiet --threads 1
one_line "variant.coverage"

cli_finish
