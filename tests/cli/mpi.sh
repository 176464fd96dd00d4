#!/bin/bash
# mpirun -np 2 gaussvid (docs/DISTRIBUTED.md): the sharded dataset build gives the clips and run
# records of one process byte for byte and its manifest but for the measured seconds;
# data-parallel pretrain, train and adapt with one clip per rank give the weights of one
# process bit for bit, with two clips per rank within rounding (bounded); a run resumed under
# K = 2 after K = 1 and the reverse ends with the uninterrupted run's weights; rank 0 alone
# writes the log; a command that does not share its work, or a batch smaller than the ranks,
# fails with one line; a killed rank ends the job within 30 s with one line, and --resume
# continues. Skipped (77) when gaussvid was built without MPI or mpirun is missing.
# Usage: bash mpi.sh /path/to/gaussvid   ($GV_TMP scratch)
source "$(dirname "$0")/lib/harness.sh"
cli_setup mpi "$1"

if "$G" --version | grep -q "MPI: not compiled in" || ! command -v mpirun >/dev/null; then
    echo "gaussvid built without MPI, or no mpirun: skipped"
    exit 77
fi
# CI runs as root; two ranks on one machine over loopback TCP; no Open MPI banners (-q).
export OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1
M=(mpirun -q -np 2 --oversubscribe --mca btl self,vader --mca btl_vader_single_copy_mechanism none --mca oob_tcp_if_include lo)

data_bytes() {
    local n
    n=$(od -An -tu8 -N8 "$1" | tr -d ' ')
    tail -c +$((9 + n)) "$1"
}
same_data() { cmp -s <(data_bytes "$1") <(data_bytes "$2"); }
# max_diff A B: the largest |a - b| over the tensors' floats (same tensors, same order).
max_diff() {
    paste <(data_bytes "$1" | od -An -v -tf4 -w4) <(data_bytes "$2" | od -An -v -tf4 -w4) |
        awk '{ d = $1 - $2; if (d < 0) d = -d; if (d > m) m = d } END { printf "%.3g\n", m + 0 }'
}
below() { awk -v a="$1" -v b="$2" 'BEGIN { exit !(a <= b) }'; }
no_seconds() { grep -v '"seconds"' "$1"; }

cd "$T" || exit 1
expect 0 "version" -- "$G" --version
has "MPI: Open MPI"
expect 0 "synth a" -- "$G" scene synth --seed 3 --frames 18 --size 32x32 --samples 1 --out A --quiet
expect 0 "synth b" -- "$G" scene synth --seed 4 --frames 18 --size 32x32 --samples 1 --out B --quiet

# The dataset: one process, then two ranks (each its share of the four runs).
BUILD=(dataset build --scenes A B --eval-scenes B --intervals 6,8 --iters 20 --clips-per-run 2 --seed 5 --threads 1)
expect 0 "dataset, one process" -- "$G" "${BUILD[@]}" --out D --quiet
expect 0 "dataset, two ranks" -- "${M[@]}" "$G" "${BUILD[@]}" --out D2
has "D2: 4 runs (4 built, 0 already there), 8 clips written"
check "rank 0 alone reports" test "$(grep -c 'runs (' "$T/out")" -eq 1
check "same clip files" diff <(cd D/clips && ls) <(cd D2/clips && ls)
for f in D/clips/*.safetensors; do
    check "clip ${f##*/} byte for byte" cmp -s "$f" "D2/clips/${f##*/}"
done
for f in D/runs/*.json; do
    check "run record ${f##*/} but its seconds" diff <(grep -v seconds "$f") <(grep -v seconds "D2/runs/${f##*/}")
done
check "manifest but its seconds" diff <(no_seconds D/manifest.json) <(no_seconds D2/manifest.json)
expect 0 "sharded build resumed" -- "${M[@]}" "$G" "${BUILD[@]}" --out D2
has "D2: 4 runs (0 built, 4 already there)"

expect 0 "vae" -- "$G" vae train --config tiny --scenes A --steps 2 --crop 32x32 --stats-clips 2 --out vae.safetensors --quiet
# Pretraining, one clip per rank: every tensor trains.
PRE=(pretrain --clips D --vae vae.safetensors --config tiny --steps 3 --batch 2 --threads 1 --quiet)
expect 0 "pretrain, one process" -- "$G" "${PRE[@]}" --out base.safetensors
expect 0 "pretrain, two ranks" -- "${M[@]}" "$G" "${PRE[@]}" --out base2.safetensors
check "pretrain: the same weights bit for bit" same_data base.safetensors base2.safetensors

# Fine-tuning, one clip per rank: bit for bit (each clip's gradient is computed from zero on
# either side and g0 + g1 is the one sum of two floats, in whichever order).
TR=(train --clips D --base base.safetensors --steps 4 --checkpoint-every 2 --threads 1 --quiet)
expect 0 "train, one process" -- "$G" "${TR[@]}" --batch 2 --out t1.safetensors --log t1.tsv
expect 0 "train, two ranks" -- "${M[@]}" "$G" "${TR[@]}" --batch 2 --out t2.safetensors --log t2.tsv
check "train: the same weights bit for bit" same_data t1.safetensors t2.safetensors
check "train: the same moments bit for bit" same_data t1.safetensors.ckpt t2.safetensors.ckpt
check "one log, a row per step" test "$(wc -l <t2.tsv)" -eq 5
check "the same losses logged" diff <(cut -f1,3-8 t1.tsv) <(cut -f1,3-8 t2.tsv)
# Two clips per rank: the four clips' gradients are summed (g0 + g1) + (g2 + g3) instead of
# ((g0 + g1) + g2) + g3, so the weights differ by rounding only: far below a step's size
# (lr 1e-4 moves a weight by about 1e-4 per step; measured 6e-9 after 4 steps).
expect 0 "batch 4, one process" -- "$G" "${TR[@]}" --batch 4 --out b1.safetensors
expect 0 "batch 4, two ranks" -- "${M[@]}" "$G" "${TR[@]}" --batch 4 --out b2.safetensors
d=$(max_diff b1.safetensors b2.safetensors)
check "batch 4: weights within 1e-6 (got $d)" below "$d" 1e-6
d=$(max_diff b1.safetensors t1.safetensors)
check "the comparison sees a real difference (batch 2 against 4: $d)" below 1e-5 "$d"

# Resumed under the other number of ranks: the uninterrupted run's weights.
expect 0 "K=1 to step 2" -- "$G" "${TR[@]}" --batch 2 --out r12.safetensors --stop-after 2
expect 0 "K=2 resumes" -- "${M[@]}" "$G" "${TR[@]}" --batch 2 --out r12.safetensors --resume
check "K=1 then K=2: the weights of one run" same_data t1.safetensors r12.safetensors
expect 0 "K=2 to step 2" -- "${M[@]}" "$G" "${TR[@]}" --batch 2 --out r21.safetensors --stop-after 2
expect 0 "K=1 resumes" -- "$G" "${TR[@]}" --batch 2 --out r21.safetensors --resume
check "K=2 then K=1: the weights of one run" same_data t1.safetensors r21.safetensors

# adapt: rank 0 builds the internal pairs, both fine-tune, rank 0 measures the gate.
tiny1_config tiny1.json
expect 0 "vae, one frame a latent" -- "$G" vae train --config tiny1.json --scenes A --steps 2 --crop 32x32 \
    --stats-clips 2 --out vae1.safetensors --quiet
expect 0 "base for adapt" -- "$G" pretrain --clips D --config tiny1.json --vae vae1.safetensors --steps 2 --batch 2 \
    --out base1.safetensors --quiet --threads 1
AD=(adapt --scene A --interval 4 --base base1.safetensors --config tiny1.json --iters 20 --steps 4 --val-every 2 --threads 1)
expect 0 "adapt, one process" -- "$G" "${AD[@]}" --out a1.safetensors --quiet
expect 0 "adapt, two ranks" -- "${M[@]}" "$G" "${AD[@]}" --out a2.safetensors
has "a2.safetensors: A n=4"
check "adapt: the same scene checkpoint's tensors" same_data a1.safetensors a2.safetensors

# One line when the command cannot run under mpirun.
expect 2 "a command that does not share its work" -- "${M[@]}" "$G" scene info A
one_line "only pretrain, train, adapt and dataset build"
expect 1 "a batch smaller than the ranks" -- "${M[@]}" "$G" "${TR[@]}" --batch 1 --out x.safetensors
one_line "each rank needs a clip"
expect 1 "bad input on every rank" -- "${M[@]}" "$G" "${TR[@]}" --batch 2 --clips nowhere --out x.safetensors
one_line "nowhere"

# A rank killed mid-run: the job ends within 30 s with one line; --resume continues.
"${M[@]}" "$G" train --clips D --base base.safetensors --steps 100000 --batch 2 --checkpoint-every 3 --threads 1 \
    --quiet --out k.safetensors 2>kill.err >/dev/null &
job=$!
victim=""
for _ in $(seq 300); do  # rank 1, once a checkpoint exists
    for p in $(ps -o pid= --ppid $job); do
        tr '\0' '\n' <"/proc/$p/environ" 2>/dev/null | grep -qx OMPI_COMM_WORLD_RANK=1 && victim=$p
    done
    [ -n "$victim" ] && [ -e k.safetensors.ckpt ] && break
    sleep 0.1
done
check "found rank 1 and a checkpoint" test -n "$victim" -a -e k.safetensors.ckpt
start=$(date +%s)
kill -9 "$victim"
for _ in $(seq 300); do kill -0 $job 2>/dev/null || break; sleep 0.1; done
took=$(($(date +%s) - start))
if kill -0 $job 2>/dev/null; then bad "the job still runs 30 s after rank 1 was killed"; kill $job; fi
wait $job
check "the job failed" test $? -ne 0
check "ended within 30 s (took $took s)" test "$took" -le 30
check "one line: $(cat kill.err)" test "$(wc -l <kill.err)" -eq 1
check "the line says what to do" grep -q "resume" kill.err
expect 0 "resumed after the kill" -- "$G" train --clips D --base base.safetensors --steps 100000 --batch 2 \
    --checkpoint-every 3 --threads 1 --out k.safetensors --resume --stop-after 1
grep -q "resuming at step" "$T/err" && ok || bad "did not resume: $(cat "$T/err")"

cli_finish
