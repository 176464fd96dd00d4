#!/usr/bin/env bash
# The main job behind `make run`, on the embedded default scene (a procedural room, seed 1,
# never used to train the released restorer): synthesise it, train sparse-view 3D Gaussian
# Splatting on every n-th frame, render the held-out frames, cut them into clips (clean
# anchor, three renders, clean anchor) and restore them with the released GaussVid
# checkpoint, printing baseline against restored PSNR / SSIM.
# Usage: scripts/demo.sh path/to/gaussvid OUTDIR
# Environment: GV_DEMO_SEED (scene, default 1), GV_DEMO_INTERVAL (n, default 16),
#              GV_DEMO_ITERS (3DGS iterations, default 3000, as the released model's data),
#              GV_DEMO_CLIPS (clips, default 8), GV_DEMO_CKPT (default models/gaussvid-small.safetensors).
set -euo pipefail
gaussvid=${1:-build/gaussvid}
out=${2:-demo}
seed=${GV_DEMO_SEED:-1}
interval=${GV_DEMO_INTERVAL:-16}
iters=${GV_DEMO_ITERS:-3000}
clips=${GV_DEMO_CLIPS:-8}
ckpt=${GV_DEMO_CKPT:-models/gaussvid-small.safetensors}
start=$(date +%s)

[ -f "$ckpt" ] || { echo "demo: $ckpt: no such checkpoint (see models/README.md)" >&2; exit 1; }
mkdir -p "$out"
echo "== 1. synthesise the default scene (seed $seed, 160 frames, 256x144) -> $out/scene"
[ -d "$out/scene" ] || "$gaussvid" scene synth --seed "$seed" --out "$out/scene"

echo
echo "== 2. its sparse split: every ${interval}th frame is a training view"
"$gaussvid" scene info "$out/scene" --interval "$interval"

echo
echo "== 3. sparse 3DGS ($iters iterations), held-out renders and $clips clips -> $out/data"
"$gaussvid" dataset build --scenes "$out/scene" --eval-scenes scene --intervals "$interval" \
    --iters "$iters" --clips-per-run "$clips" --sampling random --seed 0 --out "$out/data"

echo
echo "== 4. restore the held-out renders with $ckpt -> $out/restored"
"$gaussvid" restore --ckpt "$ckpt" --clips "$out/data" --out "$out/restored"

echo
echo "done in $(( $(date +%s) - start )) s: the scene is in $out/scene, the clips in $out/data," \
     "the restored clips (f0..f4.png; f1-f3 restored) in $out/restored"
