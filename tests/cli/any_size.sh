#!/bin/bash
# Any image size (issue 41; docs/RESTORATION.md "Any image size"): on a scene of 37x23 frames
# (neither a multiple of the restorer's 16-pixel block) every command that restores runs and
# writes frames of 37x23: dataset build, pretrain, restore, eval, adapt with an open gate and
# restore with its scene checkpoint, reconstruct (with --adapt, and at --interval 1 as the
# README's example); reconstruct on 1-pixel edges (1x17, 17x1, 1x1); an empty picture is
# refused with one line. Fixtures as reconstruct.sh: the tiny preset with a VAE of temporal
# factor 1, trained two steps on the odd clips.
# Usage: bash any_size.sh /path/to/gaussvid   ($GV_TMP scratch)
source "$(dirname "$0")/lib/harness.sh"
cli_setup any_size "$1"
LIB="$(cd "$(dirname "$0")/lib" && pwd)"
cd "$T" || exit 1

# png_size FILE: "WxH" from the PNG's IHDR.
png_size() { python3 -c "import struct,sys; d=open(sys.argv[1],'rb').read(24); print('%dx%d' % struct.unpack('>II', d[16:24]))" "$1"; }
# all_sized SIZE FILE...: every PNG is SIZE (and there is at least one)
all_sized() {
    local want=$1 f
    shift
    [ $# -gt 0 ] || return 1
    for f in "$@"; do [ "$(png_size "$f")" = "$want" ] || { echo "$f is $(png_size "$f"), not $want" >&2; return 1; }; done
}

tiny1_config tiny1.json
expect 0 "synth 37x23" -- "$G" scene synth --seed 3 --frames 25 --size 37x23 --samples 1 --out S --quiet
expect 0 "dataset of odd clips" -- "$G" dataset build --scenes S --intervals 6 --iters 20 --clips-per-run 2 --seed 5 \
    --out D --quiet --threads 1
expect 0 "vae" -- "$G" vae train --config tiny1.json --scenes S --steps 2 --crop 16x16 --stats-clips 2 \
    --out vae.safetensors --quiet
expect 0 "pretrain on odd clips" -- "$G" pretrain --clips D --config tiny1.json --vae vae.safetensors --steps 2 \
    --batch 2 --out base.safetensors --quiet

# restore and eval: the restored frames at the clips' size
expect 0 "restore" -- "$G" restore --ckpt base.safetensors --clips D --out RS --save-clips --threads 2 --quiet
check "restored frames 37x23" all_sized 37x23 RS/*/f*.png
check "two clips restored" test "$(ls -d RS/*/ | wc -l)" -eq 2
check "the network changed the renders" test -n "$(for c in D/clips/*.safetensors; do
    cmp -s "$c" "RS/$(basename "$c")" || echo changed; done)"
expect 0 "eval" -- "$G" eval --ckpt base.safetensors --clips D --split all --threads 2 --quiet
has "| 6 | 2 |"

# adapt (internal pairs of 37x23, fine-tuning on padded latents) with the gate forced open,
# then restore with the scene checkpoint: the adapted network runs on the odd clips
AD=(--scene S --interval 6 --base base.safetensors --config tiny1.json --iters 20 --steps 2 --val-every 2 --threads 1)
expect 0 "adapt" -- "$G" adapt "${AD[@]}" --out open.safetensors --gate-margin -1000 --gate-min-frames 1
has "gate open"
expect 0 "restore, gate open" -- "$G" restore --ckpt open.safetensors --clips D --out RA --quiet
has "the renders are restored"
check "adapted frames 37x23" all_sized 37x23 RA/*/f*.png

# reconstruct with --adapt (its gate decides), and at --interval 1 (every view trains)
RC=(--scene S --ckpt base.safetensors --iters 60 --refine-iters 20 --threads 2)
expect 0 "reconstruct --adapt" -- "$G" reconstruct "${RC[@]}" --interval 6 --adapt --adapt-config tiny1.json \
    --adapt-steps 2 --out R --stop-after evaluate
has "n=6 restore:"
check "restored frames 37x23" all_sized 37x23 R/n6/frames/restored/*.png
check "refined frames 37x23" all_sized 37x23 R/n6/frames/refined/*.png
# (the network restores these, ungated: the default path would keep the renders at n = 1)
expect 0 "reconstruct --interval 1" -- "$G" reconstruct "${RC[@]}" --interval 1 --restore-with checkpoint --out R1 \
    --stop-after restore
check "smooth path restored at 37x23" all_sized 37x23 R1/n1/frames/restored/*.png

# 1-pixel edges: the same cameras, pictures of 1x17, 17x1 and 1x1
for size in "1 17" "17 1" "1 1"; do
    set -- $size
    python3 "$LIB/resize_scene.py" S "E$1x$2" "$1" "$2"
    expect 0 "reconstruct $1x$2" -- "$G" reconstruct "${RC[@]}" --scene "E$1x$2" --interval 6 --out "RE$1x$2" \
        --restore-with checkpoint --stop-after restore
    check "restored frames $1x$2" all_sized "$1x$2" "RE$1x$2"/n6/frames/restored/*.png
done

# an empty picture is refused with one line
python3 "$LIB/resize_scene.py" S E0 1 1
python3 - E0/transforms.json <<'PY'
import json, sys
t = json.load(open(sys.argv[1])); t["w"] = 0; json.dump(t, open(sys.argv[1], "w"))
PY
expect 1 "width 0" -- "$G" reconstruct "${RC[@]}" --scene E0 --interval 6 --out RE0
one_line "E0"
check "nothing written" test ! -e RE0

cli_finish
