#!/usr/bin/env bash
# Compares the restoration samplers and compositions of docs/RESTORATION.md on held-out clips
# with one checkpoint: runs `gaussvid eval` for every candidate and prints one Markdown table
# (mean baseline and restored PSNR / SSIM, the worst per-n PSNR change, seconds per clip).
#
# Usage: scripts/compare_samplers.sh CKPT CLIPS_DIR [OUT_DIR] [SPLIT]
#   CKPT       a fine-tuned checkpoint (gaussvid train)
#   CLIPS_DIR  a dataset folder whose SPLIT clips (default eval) come from scenes never trained on
#   OUT_DIR    where <candidate>.json and compare.md go (default compare-samplers)
# Environment: GAUSSVID (default build/gaussvid), THREADS (default 2), CANDIDATES (a subset of
# the names below, space-separated).
set -euo pipefail
ckpt=${1:?usage: scripts/compare_samplers.sh CKPT CLIPS_DIR [OUT_DIR] [SPLIT]}
clips=${2:?usage: scripts/compare_samplers.sh CKPT CLIPS_DIR [OUT_DIR] [SPLIT]}
out=${3:-compare-samplers}
split=${4:-eval}
gaussvid=${GAUSSVID:-build/gaussvid}
threads=${THREADS:-2}
mkdir -p "$out"

# name | gaussvid eval flags
candidates=(
  "identity|--identity"
  "onestep-t0.1|--sampler onestep --t0 0.1"
  "onestep-t0.2|--sampler onestep --t0 0.2"
  "onestep-t0.3|--sampler onestep --t0 0.3"
  "onestep-t0.45|--sampler onestep --t0 0.45"
  "onestep-t0.3-x4|--sampler onestep --t0 0.3 --samples 4"
  "onestep-t0.05-x8|--sampler onestep --t0 0.05 --samples 8"
  "onestep-t0.1-x8|--sampler onestep --t0 0.1 --samples 8"
  "onestep-t0.2-x8|--sampler onestep --t0 0.2 --samples 8"
  "onestep-t0.3-x8|--sampler onestep --t0 0.3 --samples 8"
  "onestep-t0.1-x8-b0.5|--sampler onestep --t0 0.1 --samples 8 --blend 0.5"
  "onestep-t0.3-b0.5|--sampler onestep --t0 0.3 --blend 0.5"
  "onestep-t0.3-x4-b0.3|--sampler onestep --t0 0.3 --samples 4 --blend 0.3"
  "onestep-t0.3-x4-b0.5|--sampler onestep --t0 0.3 --samples 4 --blend 0.5"
  "iterate-t0.3-3|--sampler iterate --t0 0.3 --steps 3"
  "iterate-t0.45-3|--sampler iterate --t0 0.45 --steps 3"
  "euler-t0.2-10|--sampler euler --t0 0.2 --steps 10"
  "euler-t0.3-10|--sampler euler --t0 0.3 --steps 10"
  "released|--sampler released"
  "onestep-t0.3-decoded|--sampler onestep --t0 0.3 --compose decoded"
  "identity-decoded|--sampler identity --compose decoded"
)

# value KEY FILE SIDE: the number "KEY" of the first "SIDE" object of an eval JSON.
value() { grep -A4 "\"$3\"" "$2" | grep -m1 "\"$1\"" | tr -d ' \t,' | cut -d: -f2; }
# worst_change FILE: the lowest restored - baseline PSNR over the per_n rows.
worst_change() {
  awk '/"per_n"/ {p = 1} p && /"baseline"/ {s = "b"} p && /"restored"/ {s = "r"}
       p && /"psnr"/ {gsub(/[,\t ]/, ""); split($0, a, ":"); if (s == "b") b = a[2]; else {d = a[2] - b; if (!n++ || d < w) w = d}}
       END {printf "%+.2f", w}' "$1"
}

table="$out/compare.md"
{
  echo "checkpoint \`$ckpt\`, clips \`$clips\` (split $split)"
  echo
  echo "| candidate | clips | baseline PSNR | baseline SSIM | restored PSNR | restored SSIM | mean change | worst n change | s / clip |"
  echo "|---|---|---|---|---|---|---|---|---|"
} >"$table"
for entry in "${candidates[@]}"; do
  name=${entry%%|*}
  flags=${entry#*|}
  if [ -n "${CANDIDATES:-}" ] && [[ " $CANDIDATES " != *" $name "* ]]; then continue; fi
  json="$out/$name.json"
  start=$(date +%s.%N)
  # shellcheck disable=SC2086
  "$gaussvid" eval --ckpt "$ckpt" --clips "$clips" --split "$split" $flags --json "$json" --threads "$threads" --quiet \
    >"$out/$name.txt"
  end=$(date +%s.%N)
  n=$(value clips "$json" restored)
  bp=$(value psnr "$json" baseline) bs=$(value ssim "$json" baseline)
  rp=$(value psnr "$json" restored) rs=$(value ssim "$json" restored)
  printf '| %s | %d | %.2f | %.4f | %.2f | %.4f | %+.2f | %s | %.1f |\n' "$name" "$n" "$bp" "$bs" "$rp" "$rs" \
    "$(awk "BEGIN {print $rp - $bp}")" "$(worst_change "$json")" "$(awk "BEGIN {print ($end - $start) / $n}")" >>"$table"
  echo "$name done" >&2
done
cat "$table"
