#!/usr/bin/env bash
# The paper's ablation tables (section 4.4) at small scale, on the work folder of
# scripts/train_small.sh: every variant is fine-tuned from the same base, on the same clips,
# for the same number of steps, then evaluated on the same held-out clips. A variant whose
# evaluation exists is skipped, and training resumes mid-way, so the script can be stopped and
# run again.
#
# Usage: scripts/ablations.sh [WORK_DIR]            (default: runs/small)
#   WORK_DIR must hold what train_small.sh makes: data/ (both splits), base.safetensors.
# Environment:
#   GAUSSVID   the program (default build/gaussvid)
#   STEPS      fine-tuning steps of every variant (default 1500; QUICK=1: 3)
#   BATCH      clips per step (default 2; QUICK=1: 1)
#   METHOD     the method's own variant flags, given to every run (default "skip", as
#              train_small.sh fine-tunes; "" for the config's variant)
#   ONLY       run only these tables: camera strategy anchors adaptation (default all); the
#              tables written hold every variant evaluated so far, the others "not run"
#   TRAIN_FLAGS  more `gaussvid train` flags for every variant (e.g. "--crop 5x8 --t-max 0.1")
#   EVAL_FLAGS   more `gaussvid eval` flags for every evaluation (e.g. "--samples 1")
#
# Outputs in WORK_DIR/ablations: <variant>.safetensors, <variant>.md and .json (gaussvid eval),
# times.tsv (training seconds per variant) and ablations.md, the tables. Rows:
#   camera      none / early fusion / monolithic dual stream / ours (decomposed)
#   strategy    shuffle / + curriculum / + progressive loss / both (ours)
#   anchors     none / first / both (ours)
#   adaptation  zero-shot base / vanilla LoRA (no camera, shuffle) / per-frame restorer / ours
set -euo pipefail

G=${GAUSSVID:-build/gaussvid}
W=${1:-runs/small}
if [ "${QUICK:-0}" = 1 ]; then STEPS=${STEPS:-3} BATCH=${BATCH:-1}; fi
STEPS=${STEPS:-1500}
BATCH=${BATCH:-2}
METHOD=${METHOD-skip}
N_MAX=${N_MAX:-28} # the curriculum's n_max, as train_small.sh fine-tunes
TABLES="camera strategy anchors adaptation"
ONLY=${ONLY:-$TABLES}
for t in $ONLY; do
  [[ " $TABLES " == *" $t "* ]] || { echo "ablations.sh: ONLY: '$t' is not a table ($TABLES)" >&2; exit 1; }
done
read -r -a TRAIN_EXTRA <<< "${TRAIN_FLAGS:-}"
read -r -a EVAL_EXTRA <<< "${EVAL_FLAGS:-}"
A="$W/ablations"

[ -x "$G" ] || { echo "ablations.sh: $G: not built (run make)" >&2; exit 1; }
for f in "$W/data/manifest.json" "$W/base.safetensors"; do
  [ -e "$f" ] || { echo "ablations.sh: $f: missing (run scripts/train_small.sh $W first)" >&2; exit 1; }
done
mkdir -p "$A"

# variant NAME VARIANT_SPEC TRAIN_FLAGS...: fine-tunes NAME from the base and evaluates it.
variant() {
  local name=$1 spec=$2
  shift 2
  local full=$METHOD
  [ -n "$spec" ] && full=${full:+$full,}$spec
  if [ -e "$A/$name.json" ]; then
    echo "== $name: evaluated, skipped"
    return
  fi
  echo "== $name (variant: ${full:-as configured}; flags: ${*:-none})"
  if [ ! -e "$A/$name.safetensors" ]; then
    local start=$SECONDS
    "$G" train --clips "$W/data" --base "$W/base.safetensors" ${full:+--variant "$full"} --n-max "$N_MAX" "${TRAIN_EXTRA[@]}" "$@" \
      --steps "$STEPS" --batch "$BATCH" --resume --log "$A/$name.tsv" --out "$A/$name.safetensors"
    printf '%s\t%d\n' "$name" $((SECONDS - start)) >> "$A/times.tsv"
  fi
  evaluate "$name" "$A/$name.safetensors"
}

# evaluate NAME CHECKPOINT: gaussvid eval on the held-out split into NAME.md and NAME.json.
evaluate() {
  "$G" eval --ckpt "$2" --clips "$W/data" --split eval "${EVAL_EXTRA[@]}" --json "$A/$1.json.tmp" > "$A/$1.md"
  mv "$A/$1.json.tmp" "$A/$1.json"
}

# row LABEL NAME: one table row from NAME.md's mean line and its worst per-n change; "not run"
# while NAME has no evaluation (NAME.json is written last, when NAME.md is complete).
row() {
  if [ ! -e "$A/$2.json" ]; then
    echo "| $1 | not run | | | |"
    return
  fi
  awk -v label="$1" -F'|' '
    $2 ~ /\*\*mean\*\*/ { b = $4; bs = $5; r = $6; rs = $7; d = $8; next }
    $2 ~ /^ *[0-9]+ *$/ { c = $8 + 0; if (worst == "" || c < worst) worst = c }
    END { gsub(/ /, "", r); gsub(/ /, "", rs); gsub(/ /, "", d); gsub(/ /, "", b); gsub(/ /, "", bs)
          printf "| %s | %s / %s | %s / %s | %s | %+.2f |\n", label, b, bs, r, rs, d, worst }' "$A/$2.md"
}

# table TITLE LABEL NAME [LABEL NAME]...: the table, with every variant evaluated so far, so
# that runs of different ONLY sets add up to the same ablations.md.
table() {
  echo
  echo "### $1"
  echo
  echo "| variant | baseline PSNR / SSIM | restored PSNR / SSIM | PSNR change | worst n |"
  echo "|---|---|---|---|---|"
  shift
  while [ $# -gt 0 ]; do
    row "$1" "$2"
    shift 2
  done
}

wants() { [[ " $ONLY " == *" $1 "* ]]; }

variant ours ""
wants camera && {
  variant camera-none camera=none
  variant camera-early camera=early
  variant camera-monolithic camera=monolithic
}
wants strategy && {
  variant shuffle "" --no-curriculum --no-progressive-loss
  variant curriculum "" --no-progressive-loss
  variant progressive "" --no-curriculum
}
wants anchors && {
  variant anchors-none anchors=none
  variant anchors-first anchors=first
}
wants adaptation && {
  if [ -e "$A/zero-shot.json" ]; then echo "== zero-shot: evaluated, skipped"
  else echo "== zero-shot (the base, no fine-tuning)"; evaluate zero-shot "$W/base.safetensors"; fi
  variant vanilla-lora camera=none --no-curriculum --no-progressive-loss
  variant per-frame per-frame
}

{
  echo "# Ablations ($STEPS fine-tuning steps each, batch $BATCH, method variant: ${METHOD:-as configured};"
  echo "train flags: ${TRAIN_FLAGS:-none}; eval flags: ${EVAL_FLAGS:-none})"
  echo
  echo "Held-out clips of $W/data (split eval); PSNR change = restored - baseline (dB), mean"
  echo "over frames; worst n = the lowest per-interval change. From scripts/ablations.sh."
  table "Camera injection" "none" camera-none "early fusion" camera-early \
        "monolithic dual stream" camera-monolithic "decomposed (ours)" ours
  table "Training strategy" "shuffle" shuffle "+ curriculum" curriculum "+ progressive loss" progressive \
        "both (ours)" ours
  table "Anchors" "none" anchors-none "first" anchors-first "both (ours)" ours
  table "Adaptation" "zero-shot base" zero-shot "vanilla LoRA" vanilla-lora "per-frame restorer" per-frame "ours" ours
} > "$A/ablations.md.tmp"
mv "$A/ablations.md.tmp" "$A/ablations.md"
cat "$A/ablations.md"
