#!/bin/bash
# scripts/ablations.sh in QUICK mode on a QUICK train_small.sh folder (a few steps per variant):
# every variant trains and is evaluated, the tables hold one row per variant with the same
# baseline (the same held-out clips), a second run trains nothing, and a folder without the
# recipe's outputs gives one clear line. It measures nothing; the real tables are in
# docs/RESULTS.md.
# Usage: bash ablations.sh /path/to/gaussvid   ($GV_TMP scratch)
source "$(dirname "$0")/lib/harness.sh"
cli_setup ablations "$1"
SCRIPTS="$(dirname "$0")/../../scripts"
export GAUSSVID="$G" QUICK=1 OMP_NUM_THREADS=1

bash "$SCRIPTS/train_small.sh" "$T/w" >"$T/out" 2>"$T/err"
check_rc "quick recipe runs: $(tail -3 "$T/err")" $?
bash "$SCRIPTS/ablations.sh" "$T/w" >"$T/out" 2>"$T/err"
check_rc "quick ablations run: $(tail -3 "$T/err")" $?
M="$T/w/ablations/ablations.md"
exists "$M"
for v in ours camera-none camera-early camera-monolithic shuffle curriculum progressive anchors-none \
         anchors-first vanilla-lora per-frame; do
    exists "$T/w/ablations/$v.safetensors"
done
exists "$T/w/ablations/zero-shot.json"
check "four tables" test "$(grep -c '^### ' "$M")" -eq 4
check "fifteen rows with numbers" test "$(grep -cE '^\| [^|]+ \| [0-9.]+ / [0-9.]+ \| [0-9.]+ / [0-9.]+ \| [-+][0-9.]+ \| [-+][0-9.]+ \|$' "$M")" -eq 15
check "one baseline in every row" test "$(grep -E '^\| [^|]+ \| [0-9.]+ /' "$M" | cut -d'|' -f3 | sort -u | wc -l)" -eq 1
check "eleven variants trained" test "$(wc -l <"$T/w/ablations/times.tsv")" -eq 11

bash "$SCRIPTS/ablations.sh" "$T/w" >"$T/out" 2>"$T/err"
check_rc "second run" $?
check "second run skips every variant" test "$(grep -c 'evaluated, skipped' "$T/out")" -eq 12
check "nothing trained again" test "$(wc -l <"$T/w/ablations/times.tsv")" -eq 11

# recipe_folder DIR: a recipe folder with the quick recipe's data and base and no ablations.
recipe_folder() {
    mkdir -p "$1/ablations"
    ln -s "$T/w/data" "$1/data"
    ln -s "$T/w/base.safetensors" "$1/base.safetensors"
}
NUMBERS='^\| [^|]+ \| [0-9.]+ / [0-9.]+ \|' # a table row with numbers

# The tables hold every variant evaluated so far, whatever ONLY asks to run: one table's run
# on the complete folder keeps all four, and a folder with only the camera variants gives the
# other tables' rows as "not run".
ONLY=camera bash "$SCRIPTS/ablations.sh" "$T/w" >"$T/out" 2>"$T/err"
check_rc "ONLY=camera on the complete folder" $?
check "ONLY=camera keeps the four tables" test "$(grep -cE "$NUMBERS" "$M")" -eq 15
recipe_folder "$T/w3"
for v in ours camera-none camera-early camera-monolithic; do cp "$T/w/ablations/$v".{safetensors,md,json} "$T/w3/ablations/"; done
ONLY=camera bash "$SCRIPTS/ablations.sh" "$T/w3" >"$T/out" 2>"$T/err"
check_rc "ONLY=camera with the camera variants only" $?
check "nothing trained there" test ! -e "$T/w3/ablations/times.tsv"
check "four tables there" test "$(grep -c '^### ' "$T/w3/ablations/ablations.md")" -eq 4
check "seven rows with numbers there" test "$(grep -cE "$NUMBERS" "$T/w3/ablations/ablations.md")" -eq 7
check "eight rows not run there" test "$(grep -c '| not run |' "$T/w3/ablations/ablations.md")" -eq 8
ONLY="camera nosuch" bash "$SCRIPTS/ablations.sh" "$T/w3" >"$T/out" 2>"$T/err"
check_rc "an unknown table exits 1" $(($? == 1 ? 0 : 1))
one_line "'nosuch' is not a table"

# TRAIN_FLAGS and EVAL_FLAGS reach every command: a recipe folder without ablations, first
# with a bad train flag (nothing is trained), then with ours trained and a bad eval flag.
recipe_folder "$T/w2"
TRAIN_FLAGS="--crop 0x3" bash "$SCRIPTS/ablations.sh" "$T/w2" >"$T/out" 2>"$T/err"
check_rc "a bad train flag fails" $(($? != 0 ? 0 : 1))
check "the train flag is passed" grep -q -- "--crop 0x3: expected rows x columns" "$T/err"
cp "$T/w/ablations/ours.safetensors" "$T/w2/ablations/"
EVAL_FLAGS="--sampler nosuch" bash "$SCRIPTS/ablations.sh" "$T/w2" >"$T/out" 2>"$T/err"
check_rc "a bad eval flag fails" $(($? != 0 ? 0 : 1))
check "the eval flag is passed" grep -q "sampler 'nosuch'" "$T/err"
check "no evaluation left behind" test ! -e "$T/w2/ablations/ours.json"

mkdir -p "$T/empty"
bash "$SCRIPTS/ablations.sh" "$T/empty" >"$T/out" 2>"$T/err"
check_rc "folder without a recipe exits 1" $(($? == 1 ? 0 : 1))
one_line "run scripts/train_small.sh"

cli_finish
