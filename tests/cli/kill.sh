#!/bin/bash
# Long jobs killed with SIGKILL at seeded random moments, then run again with the same command
# (issue 25): `splat train`, `dataset build --jobs 2`, `vae train`, `pretrain`, `train`, and
# `adapt`, killed in each of its stages (the internal 3DGS subsets, the latents, the
# fine-tuning, the gate) at a seeded share of the stage's duration in an uninterrupted run. After
# each kill every file the job left is whole (each safetensors file opens, each PLY reads, the
# dataset's manifest and run records read); after the second run no temporary is left, the
# log has each step once, and the result equals an uninterrupted run's: byte for byte for the
# PLY, the clips and the weights (tensor data: the metadata holds wall times), the manifest
# and run records with their times left out. splat train has no checkpoint: it starts again.
# At most one checkpoint interval of work is lost (the log's last step against the checkpoint's).
# KILL_SEED (default 25) seeds the moments; KILL_MOMENTS (default 3) is how many per job, and
# ADAPT_MOMENTS (default 2) how many per stage of adapt.
# Usage: bash kill.sh /path/to/gaussvid   ($GV_TMP scratch)
source "$(dirname "$0")/lib/harness.sh"
LIB=$(cd "$(dirname "$0")/lib" && pwd)
cli_setup kill "$1"
G=$(realpath "$G")
cd "$T" || exit 1
export OMP_NUM_THREADS=1
RANDOM=${KILL_SEED:-25}
MOMENTS=${KILL_MOMENTS:-3}

mkdir in
cp "$LIB/micro.json" in/micro.json # the micro network of the tests
expect 0 "synth a" -- "$G" scene synth --seed 3 --frames 14 --size 32x32 --samples 1 --out in/A --quiet
expect 0 "synth b" -- "$G" scene synth --seed 4 --frames 14 --size 32x32 --samples 1 --out in/B --quiet
# adapt: the tiny preset with a VAE of temporal factor 1 (as tests/cli/adapt.sh), and a scene
# of 26 frames: at n = 4, 7 training views, 5 internal clips (3 trained on, 2 held back).
tiny1_config in/tiny1.json
expect 0 "synth s" -- "$G" scene synth --seed 5 --frames 26 --size 32x32 --samples 1 --out in/S --quiet

# Every job runs in its own folder under $T (NAME_ref, NAME_1, ...), so ../in and the other
# jobs' reference outputs are at the same relative paths from each.
Q=(--quiet --threads 1)
SPLAT=(splat train --scene ../in/A --interval 4 --iters 300 --out a.ply "${Q[@]}")
DATA=(dataset build --scenes ../in/A ../in/B --eval-scenes B --intervals 6,8 --iters 40 --clips-per-run 2 --seed 5
      --jobs 2 --out D "${Q[@]}")
VAE=(vae train --config ../in/micro.json --scenes ../in/A --steps 12 --checkpoint-every 2 --crop 32x32 --stats-clips 1
     --resume --log vae.tsv --out vae.safetensors "${Q[@]}")
PRE=(pretrain --clips ../data_ref/D --config ../in/micro.json --vae ../vae_ref/vae.safetensors --steps 40
     --checkpoint-every 4 --batch 1 --seed 1 --resume --log pre.tsv --out base.safetensors "${Q[@]}")
FT=(train --clips ../data_ref/D --base ../pretrain_ref/base.safetensors --steps 40 --checkpoint-every 4 --batch 1
    --resume --log ft.tsv --out ft.safetensors "${Q[@]}")

# data_bytes FILE: the tensor data of a safetensors file (after its header).
data_bytes() { local n; n=$(od -An -tu8 -N8 "$1" | tr -d ' '); tail -c +$((9 + n)) "$1"; }
# timeless FILE: a JSON file without its wall times.
timeless() { sed -E 's/"(seconds|train_seconds|render_seconds)":[[:space:]]*[0-9.e+-]+/"\1": -/g' "$1"; }
# timeless_meta FILE: a safetensors file's metadata without the wall times ("seconds...").
timeless_meta() {
    "$G" st inspect --json "$1" | sed -E 's/"(seconds[a-z_]*)":[[:space:]]*"[^"]*"/"\1": -/g; s/"(file|file_bytes|header_bytes)":[^,]*,//g'
}
# steps LOG: the step column of a log, header left out.
steps() { tail -n +2 "$1" | cut -f1; }

# whole DIR: every file the job left in DIR (temporaries aside) reads.
whole() {
    local f broken=""
    while IFS= read -r f; do
        case "$f" in
        *.tmp.*) ;;
        *.safetensors | *.ckpt) "$G" st inspect "$f" >/dev/null 2>&1 || broken+=" $f" ;;
        *.ply) "$G" splat export "$f" --out /dev/null >/dev/null 2>&1 || broken+=" $f" ;;
        */manifest.json) "$G" dataset stats "$(dirname "$f")" >/dev/null 2>&1 || broken+=" $f" ;;
        esac
    done < <(find "$1" -type f)
    echo "$broken"
}

# same_result JOB DIR: DIR's outputs equal JOB_ref's.
same_result() {
    local ref="$T/$1_ref" dir=$2 f differ=""
    case $1 in
    splat) cmp -s "$ref/a.ply" "$dir/a.ply" || differ+=" a.ply" ;;
    data)
        for f in $(cd "$ref/D" && find . -type f | sort); do
            case "$f" in
            *.json) cmp -s <(timeless "$ref/D/$f") <(timeless "$dir/D/$f") || differ+=" $f" ;;
            *) cmp -s "$ref/D/$f" "$dir/D/$f" || differ+=" $f" ;;
            esac
        done
        [ "$(cd "$ref/D" && find . -type f | sort)" = "$(cd "$dir/D" && find . -type f | sort)" ] || differ+=" (file list)" ;;
    adapt)
        # the scene checkpoint: its tensors, and its metadata but for the stages' wall times
        cmp -s <(data_bytes "$ref/s.safetensors") <(data_bytes "$dir/s.safetensors") || differ+=" s.safetensors"
        cmp -s <(timeless_meta "$ref/s.safetensors") <(timeless_meta "$dir/s.safetensors") || differ+=" s.safetensors(metadata)"
        # the work folder: internal clips, latent cache, fine-tuning and best-step weights, logs
        local w=s.safetensors.work
        for f in $(cd "$ref" && find $w -type f -name '*.safetensors*' | sort); do
            cmp -s <(data_bytes "$ref/$f") <(data_bytes "$dir/$f") || differ+=" $f"
            cmp -s <(timeless_meta "$ref/$f") <(timeless_meta "$dir/$f") || differ+=" $f(metadata)"
        done
        for f in $(cd "$ref" && find $w -name '*.json' | sort); do
            cmp -s <(timeless "$ref/$f") <(timeless "$dir/$f") || differ+=" $f"
        done
        for f in $w/train.tsv $w/val.tsv; do
            [ -z "$(tail -c 1 "$dir/$f")" ] || differ+=" $f(last line cut)"
            cmp -s <(steps "$ref/$f") <(steps "$dir/$f") || differ+=" $f(steps)"
        done
        [ "$(cd "$ref" && find $w -type f | sort)" = "$(cd "$dir" && find $w -type f | sort)" ] || differ+=" (file list)" ;;
    *)
        for f in $(cd "$ref" && ls *.safetensors *.ckpt 2>/dev/null); do
            cmp -s <(data_bytes "$ref/$f") <(data_bytes "$dir/$f") || differ+=" $f"
            cmp -s <(timeless_meta "$ref/$f") <(timeless_meta "$dir/$f") || differ+=" $f(metadata)"
        done
        for f in $(cd "$ref" && ls *.tsv 2>/dev/null); do
            [ -z "$(tail -c 1 "$dir/$f")" ] || differ+=" $f(last line cut)"
            cmp -s <(steps "$ref/$f") <(steps "$dir/$f") || differ+=" $f(steps)"
        done ;;
    esac
    echo "$differ"
}

# lost NAME DIR: steps the job's log shows done beyond its checkpoint's step (the work a kill
# loses), then the checkpoint interval; nothing for splat and data.
lost() {
    local ckpt log every
    case $1 in
    vae) ckpt=vae.safetensors.ckpt log=vae.tsv every=2 ;;
    pretrain) ckpt=base.safetensors.ckpt log=pre.tsv every=4 ;;
    train) ckpt=ft.safetensors.ckpt log=ft.tsv every=4 ;;
    adapt) ckpt=s.safetensors.work/train.safetensors.ckpt log=s.safetensors.work/train.tsv every=2 ;;
    *) return ;;
    esac
    local at=0 done=0
    [ -f "$2/$ckpt" ] && at=$("$G" st inspect --json "$2/$ckpt" | tr ',' '\n' | grep '"step"' | grep -o '[0-9]*' | head -1)
    [ -f "$2/$log" ] && done=$(grep -a '^[0-9]' "$2/$log" | grep -a "$(printf '\t')" | tail -1 | cut -f1)
    echo "$((${done:-0} - ${at:-0})) $every"
}

# job NAME CMD...: the reference run, then MOMENTS runs killed at a seeded moment of the
# reference's duration and run again to the end.
job() {
    local name=$1
    shift
    mkdir -p "$T/${name}_ref"
    local start end ref_ms
    start=$(date +%s%N)
    (cd "$T/${name}_ref" && "$G" "$@" >out 2>err)
    check_rc "$name: uninterrupted run" $?
    end=$(date +%s%N)
    ref_ms=$(((end - start) / 1000000))
    for i in $(seq 1 "$MOMENTS"); do
        local dir="$T/${name}_$i" percent=$((5 + RANDOM % 91))
        local ms=$((ref_ms * percent / 100))
        mkdir -p "$dir"
        (cd "$dir" && exec "$G" "$@" >out 2>err) &
        local pid=$!
        sleep "$((ms / 1000)).$(printf %03d $((ms % 1000)))"
        local when="killed at ${ms} ms (${percent}% of ${ref_ms} ms)"
        kill -9 "$pid" 2>/dev/null || when="finished before ${ms} ms"
        wait "$pid" 2>/dev/null
        after_kill "$name" "$dir" "$when" "$@"
    done
}

# after_kill NAME DIR WHEN: DIR's files whole and the work lost bounded at the kill, then the
# command run again to the end: no temporary left, the result the uninterrupted run's.
after_kill() {
    local name=$1 dir=$2 when=$3 i=${2##*_}
    shift 3
    local left broken loss
    left=$(find "$dir" -type f ! -name out ! -name err | sed "s|$dir/||" | sort | tr '\n' ' ')
    broken=$(whole "$dir")
    if [ -z "$broken" ]; then ok; else bad "$name $i: $when: broken files:$broken"; fi
    loss=$(lost "$name" "$dir")
    if [ -n "$loss" ]; then
        local steps_lost=${loss% *} every=${loss#* }
        when+=", $steps_lost steps past the checkpoint"
        if [ "$steps_lost" -le "$every" ]; then ok; else bad "$name $i: $when: more than $every steps lost"; fi
    fi
    (cd "$dir" && "$G" "$@" >out 2>err)
    check_rc "$name $i: run again after the kill" $?
    local temps differ
    temps=$(find "$dir" -name '*.tmp.*' -o -name '*.partial-*')
    if [ -z "$temps" ]; then ok; else bad "$name $i: temporaries left: $temps"; fi
    differ=$(same_result "$name" "$dir")
    if [ -z "$differ" ]; then ok; else bad "$name $i: $when: differs from the uninterrupted run:$differ"; fi
    echo "kill: $name $i: $when; left: ${left:-nothing}; result: ${differ:-identical}"
}

job splat "${SPLAT[@]}"
job data "${DATA[@]}"
job vae "${VAE[@]}"
job pretrain "${PRE[@]}"
job train "${FT[@]}"
# adapt, killed in each stage: its stage lines on stderr (docs/ADAPT.md "Command") mark when
# a stage starts; the kill comes a seeded share (0-80 %) of that stage's seconds in the
# uninterrupted run later. The stage actually reached is the last stage line before the kill
# (a loaded machine can move it on). Its base: the tiny1 network pretrained for two steps on
# the dataset above, with a VAE trained for two.
mkdir -p "$T/adapt_in"
(cd "$T/adapt_in" && "$G" vae train --config ../in/tiny1.json --scenes ../in/A --steps 2 --crop 32x32 --stats-clips 2 \
    --out vae.safetensors "${Q[@]}" && "$G" pretrain --clips ../data_ref/D --config ../in/tiny1.json --vae vae.safetensors \
    --steps 2 --batch 2 --out base.safetensors "${Q[@]}") >"$T/out" 2>"$T/err"
check_rc "adapt: its base" $?
ADAPT=(adapt --scene ../in/S --interval 4 --base ../adapt_in/base.safetensors --config ../in/tiny1.json --iters 40
       --steps 8 --val-every 2 --threads 1 --out s.safetensors)
STAGES=(pairs latents fine-tuning gate)
MARKERS=("internal pairs:" "adapt: latents:" "internal clips for training" "adapt: gate:")
# stage_reached ERR: the last stage whose line ERR shows.
stage_reached() {
    local k reached=start
    for k in 0 1 2 3; do grep -qF "${MARKERS[$k]}" "$1" && reached=${STAGES[$k]}; done
    [ "$reached" = pairs ] && reached+=" (subset $(grep -c "internal pairs:" "$1"))"
    echo "$reached"
}
# A dead writer's temporaries (PID 4194305 is above Linux's largest) beside the scene
# checkpoint and the best step's adapters, as a kill while writing them leaves: removed.
mkdir -p "$T/adapt_ref/s.safetensors.work"
touch "$T/adapt_ref/s.safetensors.tmp.4194305.1" "$T/adapt_ref/s.safetensors.work/best.safetensors.tmp.4194305.1"
(cd "$T/adapt_ref" && "$G" "${ADAPT[@]}" >out 2>err)
check_rc "adapt: uninterrupted run" $?
check "adapt: a dead writer's temporaries removed" test -z "$(find "$T/adapt_ref" -name '*.tmp.*')"
# "seconds: pairs 4.9, latents 1.9, fine-tuning 0.8, gate 0.6"
read -ra stage_seconds < <(sed -nE 's/^seconds: pairs ([0-9.]+), latents ([0-9.]+), fine-tuning ([0-9.]+), gate ([0-9.]+).*/\1 \2 \3 \4/p' \
    "$T/adapt_ref/out")
check "adapt: the stages' seconds reported" test "${#stage_seconds[@]}" -eq 4
n=0
for k in 0 1 2 3; do
    for m in $(seq 1 "${ADAPT_MOMENTS:-2}"); do
        n=$((n + 1))
        dir="$T/adapt_$n" percent=$((RANDOM % 81))
        delay=$(awk -v s="${stage_seconds[$k]:-0}" -v p="$percent" 'BEGIN { printf "%.3f", s * p / 100 }')
        mkdir -p "$dir"
        (cd "$dir" && exec "$G" "${ADAPT[@]}" >out 2>err) &
        pid=$!
        while kill -0 "$pid" 2>/dev/null && ! grep -qF "${MARKERS[$k]}" "$dir/err"; do sleep 0.01; done
        sleep "$delay"
        when="aimed at ${STAGES[$k]} + ${percent}% of ${stage_seconds[$k]:-?} s"
        if kill -9 "$pid" 2>/dev/null; then when+=", killed in $(stage_reached "$dir/err")"; else when+=", finished first"; fi
        wait "$pid" 2>/dev/null
        after_kill adapt "$dir" "$when" "${ADAPT[@]}"
    done
done

# pretrain and train write their latent cache into the shared dataset folder: nothing left there
temps=$(find "$T" -name '*.tmp.*' -o -name '*.partial-*')
if [ -z "$temps" ]; then ok; else bad "temporaries left: $temps"; fi

cli_finish
