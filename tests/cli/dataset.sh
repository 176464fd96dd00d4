#!/bin/bash
# gaussvid dataset build / stats / show: exit codes (0 ok, 1 failure, 2 usage), resuming, the
# files a build writes, the stats table and JSON, the contact sheet, one-line failures.
# Builds on two tiny synthesised scenes with sparse 3DGS stopped after a few iterations, on
# one thread (the same thread count gives the same clips; tiny images gain nothing from more).
# Usage: bash dataset.sh /path/to/gaussvid   ($GV_TMP scratch)
source "$(dirname "$0")/lib/harness.sh"
cli_setup dataset "$1"
# png_size FILE: "W H" from the IHDR chunk.
png_size() { od -An -tu1 -j16 -N8 "$1" | awk '{print $3 * 256 + $4, $7 * 256 + $8}'; }

A="$T/room-a"
B="$T/room-b"
expect 0 "synth a" -- "$G" scene synth --seed 3 --frames 14 --size 32x24 --samples 1 --out "$A" --quiet
expect 0 "synth b" -- "$G" scene synth --seed 4 --frames 14 --size 32x24 --samples 1 --out "$B" --quiet
D="$T/data"

# Help and usage errors: exit 0 and 2.
expect 0 "group help" -- "$G" dataset --help
has "build"
expect 2 "unknown subcommand" -- "$G" dataset nope
expect 0 "build help" -- "$G" dataset build --help
has "usage: gaussvid dataset build"
expect 0 "stats help" -- "$G" dataset stats --help
expect 0 "show help" -- "$G" dataset show --help
expect 2 "no --out" -- "$G" dataset build --scenes "$A"
expect 2 "no --scenes" -- "$G" dataset build --out "$D"
expect 2 "--scenes without value" -- "$G" dataset build --out "$D" --scenes
expect 2 "bad intervals" -- "$G" dataset build --scenes "$A" --out "$D" --intervals 6:
one_line "intervals '6:'"
expect 2 "bad sampling" -- "$G" dataset build --scenes "$A" --out "$D" --sampling sorted
one_line "sampling 'sorted'"
expect 2 "negative seed" -- "$G" dataset build --scenes "$A" --out "$D" --seed -1
expect 2 "stats without folder" -- "$G" dataset stats
expect 2 "show without --out" -- "$G" dataset show "$D/x.safetensors"

# Bad inputs: exit 1, one line naming the problem, nothing written.
expect 1 "unknown scene" -- "$G" dataset build --scenes "$A,$T/nowhere" --intervals 6 --out "$D" --quiet
one_line "nowhere"
expect 1 "interval beyond the frames" -- "$G" dataset build --scenes "$A" --intervals 6,14 --out "$D" --quiet
one_line "interval 14 with anchor gap 1 spans 14 frames, but the scene has 14 frames"
expect 1 "unknown eval scene" -- "$G" dataset build --scenes "$A" --intervals 6 --eval-scenes room-z --out "$D" --quiet
one_line "eval scene 'room-z'"
if [ ! -e "$D" ]; then ok; else bad "a failed check created $D"; fi

# A build: two scenes (a list and a repeated flag), n = 6, 20 iterations, 2 clips per run.
expect 0 "build" -- "$G" dataset build --scenes "$A" --scenes "$B" --eval-scenes room-b \
    --intervals 6 --iters 20 --clips-per-run 2 --seed 5 --out "$D" --quiet --threads 1
has "2 runs (2 built, 0 already there), 4 clips written"
for f in manifest.json runs/room-a_n06.json runs/room-b_n06.json \
         clips/room-a_n06_000.safetensors clips/room-a_n06_001.safetensors \
         clips/room-b_n06_000.safetensors clips/room-b_n06_001.safetensors; do
    exists "$D/$f"
done
if ls "$D"/clips/*.tmp.* >/dev/null 2>&1; then bad "temporaries left"; else ok; fi
cp "$D/clips/room-b_n06_001.safetensors" "$T/first.safetensors"

# Again, the scenes given as folders after the flag: everything is already there.
expect 0 "resume" -- "$G" dataset build --scenes "$A" "$B" --eval-scenes room-b --intervals 6 \
    --iters 20 --clips-per-run 2 --seed 5 --out "$D" --quiet
has "2 runs (0 built, 2 already there), 0 clips written"
# Rebuilt from nothing with the same seed: the same clip, byte for byte.
rm -rf "$D.again"
expect 0 "rebuild" -- "$G" dataset build --scenes "$A,$B" --eval-scenes room-b --intervals 6 \
    --iters 20 --clips-per-run 2 --seed 5 --out "$D.again" --quiet --threads 1
if cmp -s "$D.again/clips/room-b_n06_001.safetensors" "$T/first.safetensors"; then ok; else bad "same seed, different clip"; fi
# Two runs side by side (--jobs 2, one thread each): the clips of --threads 1, byte for byte,
# and a manifest listing the same clips.
rm -rf "$D.jobs"
expect 0 "jobs" -- "$G" dataset build --scenes "$A,$B" --eval-scenes room-b --intervals 6 \
    --iters 20 --clips-per-run 2 --seed 5 --out "$D.jobs" --jobs 2
has "2 runs (2 built, 0 already there), 4 clips written"
for f in room-a_n06_000 room-a_n06_001 room-b_n06_000 room-b_n06_001; do
    if cmp -s "$D.jobs/clips/$f.safetensors" "$D.again/clips/$f.safetensors"; then ok
    else bad "--jobs 2 changed clip $f"; fi
done
if diff <(grep -v seconds "$D.jobs/manifest.json") <(grep -v seconds "$D.again/manifest.json") >/dev/null
then ok; else bad "--jobs 2 manifest differs"; fi
expect 2 "jobs 0" -- "$G" dataset build --scenes "$A" --intervals 6 --out "$D.jobs" --jobs 0
one_line "--jobs 0"
# Other options into the same folder: refused.
expect 1 "other options" -- "$G" dataset build --scenes "$A" --intervals 6 --iters 30 --out "$D" --quiet
one_line "--iters 20"

# The clip as any safetensors reader sees it.
expect 0 "st inspect" -- "$G" st inspect "$D/clips/room-a_n06_000.safetensors"
has "inputs"
has "frame_indices"

# stats: table and JSON.
expect 0 "stats" -- "$G" dataset stats "$D"
has "4 clips from 2 runs of 2 scenes"
has "--iters 20 --densify reference --anchor-gap 1 --sampling uniform --clips-per-run 2 --seed 5"
if grep -qE '^ +6 +2 +2 +2 +22 ' "$T/out"; then ok; else bad "stats row for n=6: $(cat "$T/out")"; fi
expect 0 "stats json" -- "$G" dataset stats "$D" --json
has '"per_n"'
has '"densify":	"reference"'
has '"clips_eval":	2'
# --runs: one Markdown row per run, and the same in the JSON (with the training views' scores).
expect 0 "stats runs" -- "$G" dataset stats "$D" --runs
has "| scene | split | n | training views |"
if grep -qE '^\| room-a \| train \| 6 \| 3 \| [0-9.]+ / [0-9.]+ \| [0-9.]+ / [0-9.]+ \| 2 \|' "$T/out"; then ok; else bad "runs row of room-a: $(cat "$T/out")"; fi
has "| room-b | eval | 6 | 3 |"
expect 0 "stats runs json" -- "$G" dataset stats "$D" --runs --json
has '"runs"'
has '"train_views":	3'
if [ "$(grep -c '"train":' "$T/out")" -eq 2 ]; then ok; else bad "runs JSON lacks train scores"; fi
expect 1 "stats of a non-dataset" -- "$G" dataset stats "$A"
one_line "no manifest.json"
echo '{"format": "gaussvid.clips", "format_version": 1}' >"$T/manifest.json"
expect 1 "stats of a malformed manifest" -- "$G" dataset stats "$T"
one_line "manifest.json"

# show: the contact sheet is 5 frames wide and 2 high with 2-pixel gaps.
expect 0 "show" -- "$G" dataset show "$D/clips/room-a_n06_001.safetensors" --out "$T/sheet.png"
has "scene room-a (train), n=6, frames [6, 8, 9, 10, 12], 32x24"
if [ "$(png_size "$T/sheet.png")" = "168 50" ]; then ok; else bad "sheet size $(png_size "$T/sheet.png")"; fi
echo "not a clip" >"$T/bad.safetensors"
expect 1 "show a malformed clip" -- "$G" dataset show "$T/bad.safetensors" --out "$T/bad.png"
one_line "bad.safetensors"
if [ ! -e "$T/bad.png" ]; then ok; else bad "a sheet was written for a bad clip"; fi
expect 1 "show a missing clip" -- "$G" dataset show "$T/none.safetensors" --out "$T/none.png"
one_line "none.safetensors"

cli_finish
