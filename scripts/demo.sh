#!/usr/bin/env bash
# The main job behind `make run`: the pipeline as far as it exists, on the embedded default
# scene (a procedural room, seed 1). Usage: scripts/demo.sh path/to/gaussvid OUTDIR
set -euo pipefail
gaussvid=${1:-build/gaussvid}
out=${2:-demo}
seed=${GV_DEMO_SEED:-1}

mkdir -p "$out"
echo "== 1. synthesise the default scene (seed $seed, 160 frames, 256x144) -> $out/scene"
"$gaussvid" scene synth --seed "$seed" --out "$out/scene"

echo
echo "== 2. describe it and its sparse split at interval 6"
"$gaussvid" scene info "$out/scene" --interval 6

echo
echo "== 3. how different are neighbouring frames? (PSNR/SSIM of frame 0 vs frames 1 and 6)"
for j in 1 6; do
  printf 'frame 0 vs frame %d: ' "$j"
  "$gaussvid" metrics "$out/scene/images/frame_00000.png" "$(printf '%s/scene/images/frame_%05d.png' "$out" "$j")"
done
echo
echo "done: the scene is in $out/scene (open images/ or points3D.ply)"
