#!/bin/bash
# scripts/train_small.sh in its QUICK mode (tiny scenes, a few steps of every stage): the stages
# chain, their outputs exist, eval.json has the documented keys, and a second run skips every
# stage. It measures nothing; the real run's numbers are in docs/RESULTS.md.
# Usage: bash recipe.sh /path/to/gaussvid   ($GV_TMP scratch)
source "$(dirname "$0")/lib/harness.sh"
cli_setup recipe "$1"
SCRIPT="$(dirname "$0")/../../scripts/train_small.sh"

GAUSSVID="$G" QUICK=1 OMP_NUM_THREADS=1 bash "$SCRIPT" "$T/w" >"$T/out" 2>"$T/err"
check_rc "quick recipe runs: $(tail -3 "$T/err")" $?
for f in scenes/room-11/transforms.json data/manifest.json data/stats.txt vae.safetensors \
         base.safetensors gaussvid.safetensors eval.json eval.md times.tsv; do
    exists "$T/w/$f"
done
check "eval.json has baseline and restored means" grep -q '"restored"' "$T/w/eval.json"
has "| **mean** |"

GAUSSVID="$G" QUICK=1 OMP_NUM_THREADS=1 bash "$SCRIPT" "$T/w" >"$T/out" 2>"$T/err"
check_rc "second run" $?
check "second run skips every stage" test "$(grep -c "exists, skipped" "$T/out")" -eq 9
check "no stage ran again" test "$(wc -l <"$T/w/times.tsv")" -eq 9

GAUSSVID="$G" QUICK=1 UNTIL=vae OMP_NUM_THREADS=1 bash "$SCRIPT" "$T/w" >"$T/out" 2>"$T/err"
check_rc "UNTIL=vae" $?
check "UNTIL=vae stops after the vae stage" grep -q "^== stopped after vae" "$T/out"
check "UNTIL=vae lists no later stage" test "$(grep -c '^== ' "$T/out")" -eq 7

GAUSSVID="$G" QUICK=1 DENSIFY=lean UNTIL=dataset OMP_NUM_THREADS=1 bash "$SCRIPT" "$T/w4" >"$T/out" 2>"$T/err"
check_rc "DENSIFY=lean" $?
check "DENSIFY=lean builds the artifacts with the lean control" grep -q '"densify":[[:space:]]*"lean"' "$T/w4/data/manifest.json"
check "the default recipe's are the reference control's" grep -q '"densify":[[:space:]]*"reference"' "$T/w/data/manifest.json"

GAUSSVID="$G" TRAIN_SEEDS="11 21" bash "$SCRIPT" "$T/w3" >"$T/out" 2>"$T/err"
check_rc "a held-out room among TRAIN_SEEDS exits 1" $(($? == 1 ? 0 : 1))
one_line "room 21 is held out"
check "nothing made for it" test ! -e "$T/w3"

GAUSSVID="$T/nowhere" bash "$SCRIPT" "$T/w2" >"$T/out" 2>"$T/err"
check_rc "missing program exits 1" $(($? == 1 ? 0 : 1))
one_line "not built"

cli_finish
