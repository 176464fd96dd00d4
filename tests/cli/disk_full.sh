#!/bin/bash
# A full disk (issue 25): every writer fails with one line naming the file and leaves the
# previous file as it was, with no temporary left beside it. Each command first runs with room
# and then again with its files limited to a few kB (`ulimit -f`, SIGXFSZ ignored: write()
# fails with EFBIG at the limit as a full disk fails with ENOSPC). As root, where a mount
# namespace can be made, three writers also run on a really full tmpfs (ENOSPC).
# Runs on a pipeline of a synthesised scene, its 3DGS, a dataset and the micro model (a config
# smaller than the tiny preset), on one thread.
# Usage: bash disk_full.sh /path/to/gaussvid   ($GV_TMP scratch)
source "$(dirname "$0")/lib/harness.sh"
LIB=$(cd "$(dirname "$0")/lib" && pwd)
cli_setup disk_full "$1"
G=$(realpath "$G")
cd "$T" || exit 1
export OMP_NUM_THREADS=1

cp "$LIB/micro.json" micro.json # the micro network of the tests

# Every output once with room.
Q=(--quiet --threads 1)
SPLAT=(splat train --scene S --interval 4 --iters 10 --out a.ply "${Q[@]}")
DATA=(dataset build --scenes S --intervals 6 --iters 5 --clips-per-run 1 --seed 5 --out D "${Q[@]}")
VAE=(vae train --config micro.json --scenes S --steps 2 --checkpoint-every 1 --crop 32x32 --stats-clips 1 --out vae.safetensors "${Q[@]}")
PRE=(pretrain --clips D --config micro.json --vae vae.safetensors --steps 2 --checkpoint-every 1 --batch 1 --seed 1 --out base.safetensors "${Q[@]}")
FT=(train --clips D --base base.safetensors --steps 2 --checkpoint-every 1 --batch 1 --out ft.safetensors "${Q[@]}")
RESTORE=(restore --ckpt ft.safetensors --clips D --out R --save-clips "${Q[@]}")
expect 0 "synth" -- "$G" scene synth --seed 3 --frames 14 --size 32x32 --samples 1 --out S --quiet
BIG=(scene synth --seed 3 --frames 2 --size 256x256 --samples 1 --out S2 --quiet) # PNGs past stdio's buffer
expect 0 "synth, larger frames" -- "$G" "${BIG[@]}"
expect 0 "splat train" -- "$G" "${SPLAT[@]}"
expect 0 "splat export" -- "$G" splat export a.ply --out a.splat
expect 0 "splat eval" -- "$G" splat eval --model a.ply --scene S --interval 4 --json e.json "${Q[@]}"
expect 0 "splat render" -- "$G" splat render --model a.ply --scene S --frames 1 --out P "${Q[@]}"
expect 0 "dataset build" -- "$G" "${DATA[@]}"
expect 0 "vae train" -- "$G" "${VAE[@]}"
expect 0 "pretrain" -- "$G" "${PRE[@]}"
expect 0 "train" -- "$G" "${FT[@]}"
expect 0 "restore" -- "$G" "${RESTORE[@]}"
mkdir -p before && cp -r S S2 a.ply a.splat e.json P D vae.safetensors* base.safetensors* ft.safetensors* R before/

# full DESC KB REASON -- CMD...: runs CMD with files limited to KB kB; it must exit 1 with one
# line mentioning REASON, leave every file of the first run as it was and no temporary.
full() {
    local what=$1 kb=$2 reason=$3
    shift 4
    (ulimit -f "$kb"; trap '' XFSZ; exec "$@") >"$T/out" 2>"$T/err"
    local rc=$?
    # restore warns first that S trained its checkpoint (docs/TRAINING.md): not the failure's line
    sed -i "/^warning: scene 'S' was in the restorer's training set/d" "$T/err"
    if [ $rc -eq 1 ]; then ok; else bad "$what with $kb kB: exit $rc, expected 1: $(head -c 300 "$T/err")"; fi
    one_line "$reason"
    local f changed=""
    for f in before/*; do diff -r "$f" "$(basename "$f")" >/dev/null || changed+=" $(basename "$f")"; done
    if [ -z "$changed" ]; then ok; else bad "$what changed$changed"; fi
    if [ -z "$(find . -name '*.tmp.*' -o -name '*.partial-*')" ]; then ok
    else bad "$what left temporaries: $(find . -name '*.tmp.*' -o -name '*.partial-*')"; fi
}
TOO_LARGE="File too large"
full "splat train" 4 "a.ply: write error: $TOO_LARGE" -- "$G" "${SPLAT[@]}"
full "splat export" 1 "a.splat: write error: $TOO_LARGE" -- "$G" splat export a.ply --out a.splat
full "splat eval" 1 "e.json: write error: $TOO_LARGE" -- "$G" splat eval --model a.ply --scene S --interval 4 --json e.json "${Q[@]}"
full "splat render" 1 "P/frame_00001.png" -- "$G" splat render --model a.ply --scene S --frames 1 --out P "${Q[@]}"
full "scene synth" 1 "$TOO_LARGE" -- "$G" scene synth --seed 3 --frames 14 --size 32x32 --samples 1 --out S --quiet
full "scene synth, libpng's own write fails" 8 "png: write error: $TOO_LARGE" -- "$G" "${BIG[@]}"
full "dataset build, a new interval" 8 "$TOO_LARGE" -- "$G" "${DATA[@]/#6/6,7}"
full "vae train" 64 "vae.safetensors" -- "$G" "${VAE[@]}"
full "pretrain" 64 "base.safetensors" -- "$G" "${PRE[@]}"
full "train" 64 "ft.safetensors" -- "$G" "${FT[@]}"
full "restore" 1 "$TOO_LARGE" -- "$G" "${RESTORE[@]}"

# A real full disk: a tmpfs of 4 MB filled up, in a private mount namespace (root only).
if [ "$(id -u)" -eq 0 ] && unshare -m true 2>/dev/null; then
    mkdir -p small
    cat >inner.sh <<'SH'
# inner.sh FILE -- CMD...: FILE's previous copy on a full tmpfs at small/, then CMD; prints
# the exit code, then whether FILE is unchanged, then the temporaries left.
file=$1; shift 2
mount -t tmpfs -o size=4m tmpfs small || exit 9
cp "before/$file" "small/$file" || exit 9
dd if=/dev/zero of=small/filler bs=4k 2>/dev/null   # until the disk is full
"$@" >out 2>err
echo "rc=$?"
cmp -s "before/$file" "small/$file" && echo same || echo changed
ls small | grep -c '\.tmp\.'
SH
    on_tmpfs() {  # on_tmpfs FILE -- CMD...
        local file=$1
        unshare -m bash inner.sh "$@" >result
        if [ "$(tr '\n' ' ' <result)" = "rc=1 same 0 " ]; then ok; else bad "full tmpfs, $file: $(tr '\n' ' ' <result) $(cat err)"; fi
        one_line "No space left on device"
        check "full tmpfs, $file named" grep -qF "small/$file" err
    }
    on_tmpfs a.splat -- "$G" splat export a.ply --out small/a.splat
    on_tmpfs a.ply -- "$G" "${SPLAT[@]/a.ply/small/a.ply}"
    on_tmpfs base.safetensors -- "$G" "${PRE[@]/base.safetensors/small/base.safetensors}" --checkpoint-every 100
fi

cli_finish
