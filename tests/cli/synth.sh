#!/bin/bash
# gaussvid scene synth: exit codes (0 ok, 1 failure, 2 usage), the output folder's layout,
# the same files again for the same seed, 'scene info' on the result, and refusal to
# overwrite a folder that is not a synthesised scene.
# Usage: bash synth.sh /path/to/gaussvid   ($GV_TMP scratch)
source "$(dirname "$0")/lib/harness.sh"
cli_setup synth "$1"

TINY=(--frames 4 --size 48x32 --quiet)

# Usage errors: exit 2, one line, nothing written.
expect 0 "help" -- "$G" scene synth --help
has "usage: gaussvid scene synth"
has "--seed S"
expect 2 "no --out" -- "$G" scene synth --seed 1
one_line "--out is required"
expect 2 "size without x" -- "$G" scene synth --out "$T/x" --size 64
one_line "--size needs WxH"
expect 2 "size with junk" -- "$G" scene synth --out "$T/x" --size 64x36px
one_line "--size needs WxH"
expect 2 "size too small" -- "$G" scene synth --out "$T/x" --size 8x8
one_line "--size 8x8 is out of range"
expect 2 "size too large" -- "$G" scene synth --out "$T/x" --size 5000x3000
one_line "out of range"
expect 2 "aspect ratio" -- "$G" scene synth --out "$T/x" --size 1000x100
one_line "aspect ratio"
expect 2 "one frame" -- "$G" scene synth --out "$T/x" --frames 1
one_line "--frames 1 is out of range"
expect 2 "frames not a number" -- "$G" scene synth --out "$T/x" --frames many
expect 2 "samples 0" -- "$G" scene synth --out "$T/x" --samples 0
one_line "--samples 0 is out of range"
expect 2 "negative seed" -- "$G" scene synth --out "$T/x" --seed -3
one_line "--seed must be 0 or more"
expect 2 "unknown flag" -- "$G" scene synth --out "$T/x" --colour blue
expect 2 "stray argument" -- "$G" scene synth --out "$T/x" extra
if [ ! -e "$T/x" ]; then ok; else bad "a usage error wrote $T/x"; fi

# A tiny scene: exit 0 and the shared layout.
S="$T/scene"
expect 0 "tiny scene" -- "$G" scene synth --seed 5 --out "$S" "${TINY[@]}"
for f in images/frame_00000.png images/frame_00003.png transforms.json points3D.ply synth.txt \
         sparse/0/cameras.txt sparse/0/images.txt sparse/0/points3D.txt; do
    exists "$S/$f"
done
if [ "$(ls "$S/images" | wc -l)" -eq 4 ]; then ok; else bad "expected 4 images: $(ls "$S/images")"; fi
if [ "$(ls -a "$T" | grep -c -e partial -e '[.]old')" -eq 0 ]; then ok; else bad "temporary folders left: $(ls -a "$T")"; fi
if grep -q "PINHOLE 48 32 37.3333" "$S/sparse/0/cameras.txt"; then ok; else bad "cameras.txt: $(tail -1 "$S/sparse/0/cameras.txt")"; fi
if grep -q "seed 5, 4 frames of 48x32" "$S/synth.txt"; then ok; else bad "synth.txt: $(head -3 "$S/synth.txt")"; fi
if [ "$(head -c 8 "$S/images/frame_00002.png" | od -An -tx1 | tr -d ' \n')" = "89504e470d0a1a0a" ]; then ok
else bad "frame_00002.png is not a PNG"; fi

# The scene reader accepts it.
expect 0 "scene info" -- "$G" scene info "$S" --interval 2
has "frames      4"
has "image size  48x32"

# The same seed again (replacing the folder): the same bytes; another seed: other images.
cp -r "$S" "$T/first"
expect 0 "same seed again" -- "$G" scene synth --seed 5 --out "$S" "${TINY[@]}"
if diff -r "$S" "$T/first" >/dev/null; then ok; else bad "same seed gave different files"; fi
expect 0 "other seed" -- "$G" scene synth --seed 6 --out "$T/other" "${TINY[@]}"
if ! cmp -s "$S/images/frame_00000.png" "$T/other/images/frame_00000.png"; then ok; else bad "seeds 5 and 6 gave the same frame"; fi

# Folders that are not synthesised scenes are refused (exit 1, one line) and left alone.
mkdir -p "$T/mine" && echo keep >"$T/mine/notes.txt"
expect 1 "foreign folder" -- "$G" scene synth --out "$T/mine" "${TINY[@]}"
one_line "not a synthesised scene"
if [ "$(ls "$T/mine")" = "notes.txt" ]; then ok; else bad "foreign folder changed: $(ls "$T/mine")"; fi
echo data >"$T/afile"
expect 1 "output is a file" -- "$G" scene synth --out "$T/afile" "${TINY[@]}"
one_line "is not a folder"
mkdir -p "$T/empty"
expect 0 "empty folder is fine" -- "$G" scene synth --out "$T/empty" "${TINY[@]}"
exists "$T/empty/transforms.json"

cli_finish
