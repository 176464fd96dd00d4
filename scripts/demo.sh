#!/usr/bin/env bash
# The main job behind `make run`, on the embedded default scene (a procedural room, seed 1):
# synthesise it, train sparse-view 3D Gaussian Splatting on every 6th frame, render the
# held-out frames and evaluate them (PSNR / SSIM against the ground truth).
# Usage: scripts/demo.sh path/to/gaussvid OUTDIR
# Environment: GV_DEMO_SEED (scene, default 1), GV_DEMO_ITERS (training, default 2000).
set -euo pipefail
gaussvid=${1:-build/gaussvid}
out=${2:-demo}
seed=${GV_DEMO_SEED:-1}
iters=${GV_DEMO_ITERS:-2000}
interval=6
start=$(date +%s)

mkdir -p "$out"
echo "== 1. synthesise the default scene (seed $seed, 160 frames, 256x144) -> $out/scene"
"$gaussvid" scene synth --seed "$seed" --out "$out/scene"

echo
echo "== 2. its sparse split: every ${interval}th frame is a training view"
"$gaussvid" scene info "$out/scene" --interval "$interval"

echo
echo "== 3. train sparse 3DGS on the training views ($iters iterations) -> $out/model.ply"
"$gaussvid" splat train --scene "$out/scene" --interval "$interval" --iters "$iters" \
    --out "$out/model.ply"

echo
echo "== 4. render the held-out views -> $out/held-out"
"$gaussvid" splat render --model "$out/model.ply" --scene "$out/scene" --frames held-out \
    --interval "$interval" --out "$out/held-out" --quiet

echo
echo "== 5. evaluate: PSNR / SSIM of held-out and training views -> $out/eval.json"
"$gaussvid" splat eval --model "$out/model.ply" --scene "$out/scene" --interval "$interval" \
    --json "$out/eval.json" --quiet | tail -n 2

echo
echo "done in $(( $(date +%s) - start )) s: the scene is in $out/scene, the model in" \
     "$out/model.ply (opens in 3DGS viewers), renders of the held-out frames in $out/held-out"
