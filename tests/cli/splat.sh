#!/bin/bash
# gaussvid splat train / render / eval on a tiny synthesised scene: exit codes (0 success,
# 1 failure, 2 usage), the files written, the JSON layout, the same model for the same seed,
# and bad inputs (truncated or malformed model, too few frames for the interval) failing
# with one line that names the file or the problem. Usage: bash splat.sh /path/to/gaussvid
source "$(dirname "$0")/lib/harness.sh"
cli_setup splat "$1"
gaussvid="$G"
tmp="$T"

scene="$tmp/scene"
"$gaussvid" scene synth --frames 12 --size 48x32 --samples 1 --out "$scene" --quiet
check "synth a scene" test -f "$scene/transforms.json"

# Train: 60 iterations on frames 0, 4, 8; the same seed gives the same bytes.
train() {  # train OUT [more flags]
    local out="$1"
    shift
    "$gaussvid" splat train --scene "$scene" --interval 4 --iters 60 --seed 5 --threads 2 \
        --out "$out" --quiet "$@"
}
train "$tmp/a.ply" > "$tmp/train.txt" 2> "$tmp/train_err.txt"
check "train exits 0" test $? -eq 0
check "train writes the model" test -s "$tmp/a.ply"
check "train prints the count" grep -q "Gaussians, SH degree 3, 60 iterations" "$tmp/train.txt"
# 3 training views of 48x32 = 4608 pixels: the count over that, to three decimals.
count=$(sed -n 's/.*: \([0-9]*\) Gaussians, SH degree.*/\1/p' "$tmp/train.txt")
check "train prints Gaussians per training pixel" grep -q "$(awk -v n="$count" 'BEGIN { printf "%.3f Gaussians per training pixel", n / 4608 }')" "$tmp/train.txt"
train "$tmp/b.ply" > /dev/null 2>&1
check "same seed, same model" cmp -s "$tmp/a.ply" "$tmp/b.ply"
train "$tmp/c.ply" --seed 6 --random-bg > /dev/null 2>&1
check "another seed, another model" test -s "$tmp/c.ply" -a -n "$(cmp "$tmp/a.ply" "$tmp/c.ply")"
"$gaussvid" splat train --scene "$scene" --iters 30 --sh-degree 1 --out "$tmp/d.ply" --quiet > "$tmp/d.txt"
check "--sh-degree 1" grep -q "SH degree 1" "$tmp/d.txt"

# Density control: lean is the default; past the first densification (iteration 600) lean's
# higher threshold gives another model, the reference's at threshold 0.0004; an unknown mode
# is a usage error.
train "$tmp/lean_default.ply" --iters 700 > /dev/null 2>&1
train "$tmp/lean.ply" --iters 700 --densify lean > /dev/null 2>&1
train "$tmp/lean_as_ref.ply" --iters 700 --densify reference --grad-threshold 0.0004 > /dev/null 2>&1
train "$tmp/ref.ply" --iters 700 --densify reference > /dev/null 2>&1
check "lean is the default" cmp -s "$tmp/lean_default.ply" "$tmp/lean.ply"
check "lean = reference at threshold 0.0004" cmp -s "$tmp/lean.ply" "$tmp/lean_as_ref.ply"
check "lean is another model" test -s "$tmp/ref.ply" -a -n "$(cmp "$tmp/lean.ply" "$tmp/ref.ply")"
train "$tmp/x.ply" --densify dense > /dev/null 2> "$tmp/err.txt"
check "unknown --densify exits 2" test $? -eq 2
check "unknown --densify explained" grep -q "expected lean, reference or mcmc" "$tmp/err.txt"
check "unknown --densify: no model" test ! -e "$tmp/x.ply"

# Regularisers: DropGaussian to 0.1 with the opacity decay to half the run is the default. In
# 1200 iterations the decay acts from 501 to 600: the default is --regularize
# dropgaussian,decay --decay-until 0.5 --drop-rate 0.1 (and the default schedule), another
# model than DropGaussian alone, plain 3DGS (--regularize none), the decay to the end or
# DropGaussian to 0.2. With mcmc the default is plain (the decay needs the lean or reference
# control). DropGaussian trains another model, the same for the same seed; unknown, empty or
# repeated names are usage errors.
train "$tmp/dec_default.ply" --iters 1200 > /dev/null 2>&1
train "$tmp/dec_half.ply" --iters 1200 --regularize decay,dropgaussian --decay-until 0.5 --drop-rate 0.1 \
    --resolution-schedule 4 > /dev/null 2>&1
train "$tmp/drop_02.ply" --iters 1200 --drop-rate 0.2 > /dev/null 2>&1
train "$tmp/dec_end.ply" --iters 1200 --regularize dropgaussian,decay --decay-until 1 > /dev/null 2>&1
train "$tmp/drop_only.ply" --iters 1200 --regularize dropgaussian > /dev/null 2>&1
train "$tmp/none1200.ply" --iters 1200 --regularize none > /dev/null 2>&1
check "dropgaussian with the decay to half the run is the default" cmp -s "$tmp/dec_default.ply" "$tmp/dec_half.ply"
for other in none1200 drop_only dec_end drop_02; do
    check "the default is not $other" test -s "$tmp/$other.ply" -a -n "$(cmp "$tmp/dec_default.ply" "$tmp/$other.ply")"
done
train "$tmp/none.ply" --regularize none > /dev/null 2>&1
train "$tmp/mcmc_default.ply" --densify mcmc > /dev/null 2>&1
train "$tmp/mcmc_none.ply" --densify mcmc --regularize none > /dev/null 2>&1
check "with mcmc the default is plain 3DGS" cmp -s "$tmp/mcmc_default.ply" "$tmp/mcmc_none.ply"
train "$tmp/x.ply" --densify mcmc --regularize decay > /dev/null 2> "$tmp/err.txt"
check "decay with mcmc refused" test $? -eq 1 -a -n "$(grep -i "decay" "$tmp/err.txt")" -a ! -e "$tmp/x.ply"
# usage_errors RUN MESSAGE BAD...: for each BAD (flags), `RUN x.ply BAD` exits 2 with the one
# line "gaussvid splat train: MESSAGE".
usage_errors() {
    local run="$1" message="$2" bad
    shift 2
    for bad in "$@"; do
        "$run" "$tmp/x.ply" $bad > /dev/null 2> "$tmp/err.txt"
        check "$bad exits 2" test $? -eq 2
        check "$bad explained in one line" test "$(cat "$tmp/err.txt")" = "gaussvid splat train: $message"
    done
}
usage_errors train "--decay-factor must be in (0, 1) and --decay-until in (0, 1]" \
    "--decay-until 0" "--decay-until 1.5" "--decay-factor 1" "--decay-factor 0"
# Binocular3DGS's consistency loss with the decay (the release's method): with
# --binocular-from 0.5 of 120 iterations it runs after iteration 60 and the summary says so;
# another model than the decay alone, another with another baseline, the same bytes for the
# same seed (one thread); not in the default; bad values, and its flags without it, are usage
# errors.
bino() { # OUT [more flags]
    local out="$1"
    shift
    "$gaussvid" splat train --scene "$scene" --interval 4 --iters 120 --seed 5 --threads 1 --out "$out" \
        --regularize decay,binocular --binocular-from 0.5 "$@"
}
bino "$tmp/bino1.ply" > "$tmp/bino.txt" 2>&1
check "decay,binocular trains" test -s "$tmp/bino1.ply"
check "binocular reports its shifted views" \
    grep -q "Binocular3DGS consistency: after iteration 60, 60 shifted views, baseline up to" "$tmp/bino.txt"
check "binocular is named among the regularisers" grep -q "sparse-view regularisers: decay,binocular" "$tmp/bino.txt"
bino "$tmp/bino2.ply" > /dev/null 2>&1
check "binocular, one thread: same seed, same model" cmp -s "$tmp/bino1.ply" "$tmp/bino2.ply"
"$gaussvid" splat train --scene "$scene" --interval 4 --iters 120 --seed 5 --threads 1 --out "$tmp/dec120.ply" \
    --regularize decay > /dev/null 2>&1
check "binocular is another model than the decay alone" test -n "$(cmp "$tmp/bino1.ply" "$tmp/dec120.ply")"
# It is opt-in: the default (DropGaussian with the decay) renders no shifted view.
"$gaussvid" splat train --scene "$scene" --interval 4 --iters 120 --seed 5 --threads 1 --out "$tmp/def120.ply" \
    > "$tmp/def120.txt" 2>&1
check "the default is dropgaussian,decay" grep -q "sparse-view regularisers: dropgaussian,decay" "$tmp/def120.txt"
check "the default has no binocular term" test -s "$tmp/def120.ply" -a -z "$(grep Binocular3DGS "$tmp/def120.txt")"
bino "$tmp/bino3.ply" --binocular-baseline 0.05 > /dev/null 2>&1
check "another baseline, another model" test -s "$tmp/bino3.ply" -a -n "$(cmp "$tmp/bino1.ply" "$tmp/bino3.ply")"
usage_errors bino "--binocular-from must be in [0, 1) and --binocular-baseline in (0, 1)" \
    "--binocular-from 1" "--binocular-from -0.1" "--binocular-baseline 0" "--binocular-baseline 1"
train "$tmp/x.ply" --binocular-from 0.5 > /dev/null 2> "$tmp/err.txt"
check "--binocular-from without binocular exits 2" test $? -eq 2
check "--binocular-from without binocular explained in one line" test "$(cat "$tmp/err.txt")" = \
    "gaussvid splat train: --binocular-from and --binocular-baseline need binocular in --regularize"
check "bad binocular flags: no model" test ! -e "$tmp/x.ply"
train "$tmp/drop1.ply" --regularize dropgaussian > /dev/null 2>&1
train "$tmp/drop2.ply" --regularize dropgaussian > /dev/null 2>&1
check "dropgaussian: same seed, same model" cmp -s "$tmp/drop1.ply" "$tmp/drop2.ply"
check "dropgaussian is another model" test -s "$tmp/drop1.ply" -a -n "$(cmp "$tmp/none.ply" "$tmp/drop1.ply")"
# --drop-rate sets the share at the last iteration: 0 leaves nothing out and scales by 1,
# which is plain 3DGS to the byte; another share is another model.
train "$tmp/drop_0.ply" --regularize dropgaussian --drop-rate 0 > /dev/null 2>&1
check "dropgaussian --drop-rate 0 is plain 3DGS" cmp -s "$tmp/drop_0.ply" "$tmp/none.ply"
train "$tmp/drop_05.ply" --regularize dropgaussian --drop-rate 0.5 > /dev/null 2>&1
check "--drop-rate 0.5 is another model" test -s "$tmp/drop_05.ply" -a -n "$(cmp "$tmp/drop1.ply" "$tmp/drop_05.ply")"
usage_errors train "--drop-rate must be in [0, 1)" "--drop-rate 1" "--drop-rate -0.1"
for bad in dropout dropgaussian,dropgaussian "" dropgaussian, none,dropgaussian; do
    train "$tmp/x.ply" --regularize "$bad" > /dev/null 2> "$tmp/err.txt"
    check "--regularize '$bad' exits 2" test $? -eq 2
    check "--regularize '$bad' explained" grep -q "expected none or a comma-separated list" "$tmp/err.txt"
done
check "bad --regularize: no model" test ! -e "$tmp/x.ply"
train "$tmp/x.ply" --regularize fsgs --densify mcmc > /dev/null 2> "$tmp/err.txt"
check "fsgs with mcmc refused" grep -q "fsgs unpools at the densification steps" "$tmp/err.txt"
"$gaussvid" splat train --scene "$scene" --interval 4 --iters 700 --seed 5 --threads 2 --out "$tmp/fsgs.ply" \
    --regularize fsgs,dropgaussian --fsgs-distance 0.05 > "$tmp/fsgs.txt" 2>&1
check "fsgs,dropgaussian trains" test -s "$tmp/fsgs.ply"
check "fsgs reports its unpooling" grep -q "FSGS unpooling (proximity above 0.05 x extent): [1-9][0-9]* Gaussians added" "$tmp/fsgs.txt"
"$gaussvid" splat train --scene "$scene" --interval 4 --iters 700 --seed 5 --threads 2 --out "$tmp/corgs.ply" \
    --regularize corgs --corgs-distance 0.02 > "$tmp/corgs.txt" 2>&1
check "corgs trains" test -s "$tmp/corgs.ply"
check "corgs reports its co-pruning" grep -q "CoR-GS co-pruning (within 0.02 x extent): [0-9]* and [0-9]* Gaussians pruned" "$tmp/corgs.txt"
check "corgs is another model" test -n "$(cmp "$tmp/lean.ply" "$tmp/corgs.ply")"
# SE-GS with --segs-interval 40: the model is rendered at the pseudo views at 520, 560, 600
# and 640 (before 700 - 40); the ring of 3 renders is full from 600: 2 perturbations. With
# --segs-interval 1000 nothing is rendered: the two fields and the pseudo-view term alone.
segs() { # OUT INTERVAL
    "$gaussvid" splat train --scene "$scene" --interval 4 --iters 700 --seed 5 --threads 1 --out "$1" \
        --regularize segs --segs-interval "$2"
}
segs "$tmp/segs1.ply" 40 > "$tmp/segs.txt" 2>&1
check "segs trains" test -s "$tmp/segs1.ply"
check "segs reports its perturbations" grep -q "SE-GS: 2 perturbations of the second field (every 40 iterations), [1-9][0-9]* Gaussians perturbed" "$tmp/segs.txt"
check "segs does not co-prune" test -z "$(grep "CoR-GS co-pruning" "$tmp/segs.txt")"
segs "$tmp/segs2.ply" 40 > /dev/null 2>&1
check "segs, one thread: same seed, same model" cmp -s "$tmp/segs1.ply" "$tmp/segs2.ply"
segs "$tmp/segs_none.ply" 1000 > "$tmp/segs_none.txt" 2>&1
check "segs without a perturbation reports none" grep -q "SE-GS: 0 perturbations" "$tmp/segs_none.txt"
check "the perturbations change the model" test -n "$(cmp "$tmp/segs1.ply" "$tmp/segs_none.ply")"
train "$tmp/x.ply" --regularize segs --segs-interval 0 > /dev/null 2> "$tmp/err.txt"
check "--segs-interval 0 exits 2" test $? -eq 2
check "--segs-interval 0 explained in one line" test "$(cat "$tmp/err.txt")" = "gaussvid splat train: --segs-interval must be at least 1"

# Resolution scheduling, the default from 1/4: 48x32 at 1/4 then 1/2 for the first 30 of 60
# iterations; the summary names the steps; the same seed gives the same bytes, another model
# than at full size (--resolution-schedule 1); bad factors and --resolution-full-at with
# --resolution-schedule 1 are usage errors.
"$gaussvid" splat train --scene "$scene" --interval 4 --iters 60 --seed 5 --threads 2 --out "$tmp/res1.ply" \
    --resolution-schedule 4 > "$tmp/res.txt" 2>&1
check "--resolution-schedule trains" test -s "$tmp/res1.ply"
check "--resolution-schedule names its steps" \
    grep -q "resolution schedule: 1/4 from iteration 1, 1/2 from 16, full from 31" "$tmp/res.txt"
train "$tmp/res2.ply" --resolution-schedule 4 > /dev/null 2>&1
check "--resolution-schedule: same seed, same model" cmp -s "$tmp/res1.ply" "$tmp/res2.ply"
check "the schedule from 1/4 is the default" cmp -s "$tmp/a.ply" "$tmp/res1.ply"
"$gaussvid" splat train --scene "$scene" --interval 4 --iters 60 --seed 5 --threads 2 --out "$tmp/res_full.ply" \
    --resolution-schedule 1 > "$tmp/res_full.txt" 2>&1
check "--resolution-schedule 1 is another model" test -s "$tmp/res_full.ply" -a -n "$(cmp "$tmp/a.ply" "$tmp/res_full.ply")"
check "--resolution-schedule 1 names no steps" test -z "$(grep "resolution schedule" "$tmp/res_full.txt")" \
    -a -n "$(grep "sparse-view regularisers" "$tmp/res_full.txt")"
"$gaussvid" splat train --scene "$scene" --interval 4 --iters 60 --threads 2 --out "$tmp/res3.ply" \
    --resolution-schedule 2 --resolution-full-at 1 > "$tmp/res3.txt" 2>&1
check "--resolution-full-at 1: 1/2 to the end" grep -q "resolution schedule: 1/2 from iteration 1 (" "$tmp/res3.txt"
for bad in "--resolution-schedule 3" "--resolution-schedule 16" \
           "--resolution-schedule 1 --resolution-full-at 0.5" "--resolution-full-at 1.5"; do
    train "$tmp/y.ply" $bad > /dev/null 2> "$tmp/err.txt"
    check "'$bad' exits 2" test $? -eq 2
done
check "bad resolution schedule: no model" test ! -e "$tmp/y.ply"

# Eval: 12 frames, 3 of them training views; JSON means and per-frame list.
"$gaussvid" splat eval --model "$tmp/a.ply" --scene "$scene" --interval 4 --json "$tmp/e.json" > "$tmp/eval.txt"
check "eval exits 0" test $? -eq 0
check "eval table has 12 rows" test "$(grep -c '^[0-9]' "$tmp/eval.txt")" -eq 12
check "eval held-out mean" grep -q "held-out mean (9 frames): PSNR" "$tmp/eval.txt"
check "eval train mean" grep -q "train mean (3 frames): PSNR" "$tmp/eval.txt"
check "json held_out" grep -q '"held_out":' "$tmp/e.json"
check "json train" grep -q '"train":' "$tmp/e.json"
check "json per_frame" grep -q '"per_frame":' "$tmp/e.json"
check "json 12 frames" test "$(grep -c '"split":' "$tmp/e.json")" -eq 12
check "json psnr" test "$(grep -c '"psnr":' "$tmp/e.json")" -eq 14

# Render: held-out frames named like the images; a list; a path.
"$gaussvid" splat render --model "$tmp/a.ply" --scene "$scene" --interval 4 --out "$tmp/held" --quiet > /dev/null
check "render held-out exits 0" test $? -eq 0
check "9 held-out PNGs" test "$(ls "$tmp/held" | wc -l)" -eq 9
check "held-out names" test -f "$tmp/held/frame_00001.png" -a ! -e "$tmp/held/frame_00004.png"
"$gaussvid" splat render --model "$tmp/a.ply" --scene "$scene" --frames 0,11 --out "$tmp/list" --quiet > /dev/null
check "render a list" test "$(ls "$tmp/list" | tr '\n' ' ')" = "frame_00000.png frame_00011.png "
"$gaussvid" splat render --model "$tmp/a.ply" --scene "$scene" --frames 0,4,8 --path 5 --out "$tmp/path" --quiet > /dev/null
check "render a path" test "$(ls "$tmp/path" | wc -l)" -eq 5 -a -f "$tmp/path/path_00004.png"
# The ends of a path are the key frames themselves.
"$gaussvid" metrics "$tmp/path/path_00000.png" "$tmp/list/frame_00000.png" --json > "$tmp/m.json"
check "path starts at the first key" grep -q '"identical":true' "$tmp/m.json"

# Bad inputs: one line naming the file or the problem, exit 1.
size=$(stat -c %s "$tmp/a.ply")
head -c $((size - 100)) "$tmp/a.ply" > "$tmp/truncated.ply"
"$gaussvid" splat eval --model "$tmp/truncated.ply" --scene "$scene" --interval 4 > /dev/null 2> "$tmp/err.txt"
check "truncated model exits 1" test $? -eq 1
check "truncated model named" grep -q "truncated.ply" "$tmp/err.txt"
check "one error line" test "$(wc -l < "$tmp/err.txt")" -eq 1
printf 'ply\nformat binary_little_endian 1.0\nelement vertex 2\nproperty float x\nend_header\n' > "$tmp/bad.ply"
"$gaussvid" splat render --model "$tmp/bad.ply" --scene "$scene" --out "$tmp/bad" > /dev/null 2> "$tmp/err.txt"
check "malformed model exits 1" test $? -eq 1
check "malformed model named" grep -q "bad.ply" "$tmp/err.txt"
"$gaussvid" splat train --scene "$scene" --interval 12 --iters 10 --out "$tmp/x.ply" --quiet > /dev/null 2> "$tmp/err.txt"
check "too few frames exits 1" test $? -eq 1
check "too few frames explained" grep -q "interval 12 leaves 1 training frame" "$tmp/err.txt"
check "no model written" test ! -e "$tmp/x.ply"
"$gaussvid" splat eval --model "$tmp/a.ply" --scene "$scene" --interval 20 > /dev/null 2> "$tmp/err.txt"
check "eval too few frames exits 1" test $? -eq 1
"$gaussvid" splat train --scene "$tmp/nowhere" --out "$tmp/x.ply" > /dev/null 2> "$tmp/err.txt"
check "missing scene exits 1" test $? -eq 1
check "missing scene named" grep -q "nowhere" "$tmp/err.txt"
"$gaussvid" splat render --model "$tmp/a.ply" --scene "$scene" --frames 0,99 --out "$tmp/bad" > /dev/null 2> "$tmp/err.txt"
check "frame out of range exits 1" test $? -eq 1
check "frame out of range explained" grep -q "0..11" "$tmp/err.txt"

# Usage errors exit 2; --help exits 0.
"$gaussvid" splat train --scene "$scene" --out "$tmp/x.ply" --white-bg --random-bg 2> /dev/null
check "two backgrounds exit 2" test $? -eq 2
"$gaussvid" splat train --out "$tmp/x.ply" 2> /dev/null
check "missing --scene exits 2" test $? -eq 2
"$gaussvid" splat eval --model "$tmp/a.ply" --scene "$scene" 2> /dev/null
check "missing --interval exits 2" test $? -eq 2
for c in train render eval; do
    "$gaussvid" splat $c --help > "$tmp/help.txt"
    check "splat $c --help" grep -q "usage: gaussvid splat $c" "$tmp/help.txt"
done

cli_finish
