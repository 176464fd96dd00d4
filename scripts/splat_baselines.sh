#!/usr/bin/env bash
# The sparse-3DGS baseline table of docs/RESULTS.md: held-out and training-view PSNR / SSIM,
# Gaussian count, wall seconds and peak RSS of `splat train` at 8000 iterations, n = 6, 12
# and 26, on the shared courtyard and livingroom and three procedural rooms, one thread per
# run and two runs side by side. Resumable: a cell whose JSON exists is not run again.
#
#   scripts/splat_baselines.sh OUT [splat train flags...]    e.g. --densify reference
#
# Without flags the cells train at `splat train`'s defaults (--densify lean since issue 38;
# the earlier tables were the reference's: pass --densify reference to repeat them).
#
# Needs build/gaussvid (or $GV); the rooms are made in $SCENES (default data/synth, ignored by
# git) if missing.
# CELLS="courtyard:6 synth-2:26" runs only those cells (n = 16 too, which the table leaves out);
# SEED sets every run's seed (default 0); ITERS the iterations (default 8000).
# Prints one Markdown row per cell to OUT/table.md; CPU seconds (user + system) are the time to
# compare when the machine is shared, wall seconds only on an idle one.
set -euo pipefail
out=${1:?usage: splat_baselines.sh OUT [splat train flags...]}
shift
root=$(cd "$(dirname "$0")/.." && pwd)
gv=${GV:-$root/build/gaussvid}
shared_scenes=${GV_SHARED_DATA:-$root/data}/scenes
scenes_dir=${SCENES:-$root/data/synth}
mkdir -p "$out" "$scenes_dir"
for k in 1 2 3; do
  [ -d "$scenes_dir/synth-$k" ] || "$gv" scene synth --seed "$k" --out "$scenes_dir/synth-$k" --quiet
done

cell() { # scene-name scene-dir n
  local name=$1 dir=$2 n=$3 base="$out/$1_n$3"
  [ -f "$base.json" ] && return 0
  /usr/bin/time -f "%e %M %U %S" -o "$base.time" "$gv" splat train --scene "$dir" --interval "$n" \
    --iters "${ITERS:-8000}" --threads 1 --seed "${SEED:-0}" --quiet --out "$base.ply" "${flags[@]}" > "$base.log" 2>&1
  "$gv" splat eval --model "$base.ply" --scene "$dir" --interval "$n" --json "$base.json.tmp" \
    --quiet > /dev/null
  mv "$base.json.tmp" "$base.json"
}

flags=("$@")
jobs=()
for scene in courtyard livingroom synth-1 synth-2 synth-3; do
  dir=$shared_scenes/$scene
  [ -d "$dir" ] || dir=$scenes_dir/$scene
  for n in 6 12 16 26; do # n = 16 only when CELLS names it: the table is n = 6, 12, 26
    if { [ -z "${CELLS:-}" ] && [ "$n" != 16 ]; } || [[ " ${CELLS:-} " == *" $scene:$n "* ]]; then
      jobs+=("$scene $dir $n")
    fi
  done
done
running=0
for job in "${jobs[@]}"; do
  cell $job &
  running=$((running + 1))
  if [ "$running" -ge 2 ]; then wait -n; running=$((running - 1)); fi
done
wait

{
  echo "| scene | n | held-out PSNR / SSIM | training views PSNR / SSIM | Gaussians | wall s | CPU s | peak RSS MiB |"
  echo "|---|---:|---|---|---:|---:|---:|---:|"
  for job in "${jobs[@]}"; do
    set -- $job
    base="$out/$1_n$3"
    gaussians=$(sed -n 's/.*: \([0-9]*\) Gaussians, SH.*/\1/p' "$base.log" | tail -1)
    read -r secs kib user sys < "$base.time"
    python3 - "$base.json" "$1" "$3" "$gaussians" "$secs" "$kib" "$user" "$sys" <<'EOF'
import json, sys
d = json.load(open(sys.argv[1]))
h, t = d["held_out"], d["train"]
print(f"| {sys.argv[2]} | {sys.argv[3]} | {h['psnr']:.2f} / {h['ssim']:.4f} | "
      f"{t['psnr']:.2f} / {t['ssim']:.4f} | {int(sys.argv[4]):,} | {float(sys.argv[5]):.0f} | "
      f"{float(sys.argv[7]) + float(sys.argv[8]):.0f} | {int(sys.argv[6]) / 1024:.0f} |")
EOF
  done
} > "$out/table.md"
cat "$out/table.md"
