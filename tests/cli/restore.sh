#!/bin/bash
# gaussvid restore / eval: exit codes (0 ok, 1 failure, 2 usage), the identity check (the input
# latent through the whole pipeline gives exactly the baseline numbers), the table and JSON,
# reproducible results, the written frames and clips, one-line failures. Runs on a tiny
# pipeline made here: two synthesised scenes, a dataset (sparse 3DGS stopped after 20
# iterations), the tiny VAE, pretraining and fine-tuning of a few steps each, on one thread.
# Usage: bash restore.sh /path/to/gaussvid   ($GV_TMP scratch)
source "$(dirname "$0")/lib/harness.sh"
cli_setup restore "$1"
# json_number FILE SIDE KEY: the value of "KEY" in the first "SIDE" object of a JSON file.
json_number() { grep -A4 "\"$2\"" "$1" | grep -m1 "\"$3\"" | tr -d ' \t,' | cut -d: -f2; }

A="$T/room-a"
B="$T/room-b"
D="$T/data"
expect 0 "synth a" -- "$G" scene synth --seed 3 --frames 14 --size 32x32 --samples 1 --out "$A" --quiet
expect 0 "synth b" -- "$G" scene synth --seed 4 --frames 14 --size 32x32 --samples 1 --out "$B" --quiet
expect 0 "dataset" -- "$G" dataset build --scenes "$A" "$B" --eval-scenes room-b --intervals 6,8 --iters 20 \
    --clips-per-run 2 --seed 5 --out "$D" --quiet --threads 1
expect 0 "vae" -- "$G" vae train --config tiny --scenes "$A" --out "$T/vae.safetensors" --steps 2 --crop 32x32 \
    --stats-clips 4 --quiet --threads 1
expect 0 "pretrain" -- "$G" pretrain --clips "$D" --config tiny --vae "$T/vae.safetensors" --steps 2 --batch 1 \
    --out "$T/base.safetensors" --quiet --threads 1
expect 0 "train" -- "$G" train --clips "$D" --base "$T/base.safetensors" --steps 2 --batch 1 \
    --out "$T/ckpt.safetensors" --quiet --threads 1
C="$T/ckpt.safetensors"

# Help and usage errors: exit 0 and 2, one line.
expect 0 "restore help" -- "$G" restore --help
has "usage: gaussvid restore"
has "--sampler NAME"
expect 0 "eval help" -- "$G" eval --help
has "--identity"
expect 2 "restore without --ckpt" -- "$G" restore --clips "$D" --out "$T/r"
expect 2 "restore without --out" -- "$G" restore --ckpt "$C" --clips "$D"
expect 2 "both --clips and --clip" -- "$G" restore --ckpt "$C" --clips "$D" --clip x --out "$T/r"
one_line "exactly one of --clips DIR and --clip FILE"
expect 2 "neither" -- "$G" restore --ckpt "$C" --out "$T/r"
expect 2 "unknown sampler" -- "$G" eval --ckpt "$C" --clips "$D" --sampler heun
one_line "sampler 'heun'"
expect 2 "t0 out of range" -- "$G" eval --ckpt "$C" --clips "$D" --t0 1.5
one_line "t0 1.5 is not in (0, 1)"
expect 2 "onestep with 2 steps" -- "$G" eval --ckpt "$C" --clips "$D" --steps 2
one_line "it takes one"
expect 2 "euler with samples" -- "$G" eval --ckpt "$C" --clips "$D" --sampler euler --samples 2
expect 2 "blend above 1" -- "$G" eval --ckpt "$C" --clips "$D" --blend 2
one_line "blend 2 is not in (0, 1]"
expect 2 "bad composition" -- "$G" eval --ckpt "$C" --clips "$D" --compose blend
one_line "composition 'blend'"
expect 2 "bad split" -- "$G" eval --ckpt "$C" --clips "$D" --split test
one_line "--split test"
expect 2 "negative seed" -- "$G" eval --ckpt "$C" --clips "$D" --seed -1
expect 2 "identity with a sampler" -- "$G" eval --ckpt "$C" --clips "$D" --identity --sampler euler
expect 2 "split with one clip" -- "$G" restore --ckpt "$C" --clip x --split eval --out "$T/r"

# Bad inputs: exit 1, one line naming the file.
expect 1 "missing checkpoint" -- "$G" eval --ckpt "$T/none.safetensors" --clips "$D" --quiet
one_line "none.safetensors"
expect 1 "not a checkpoint" -- "$G" eval --ckpt "$T/vae.safetensors" --clips "$D" --quiet
one_line "vae.safetensors"
expect 1 "not a dataset" -- "$G" eval --ckpt "$C" --clips "$A" --quiet
one_line "no manifest.json"
expect 1 "missing clip" -- "$G" restore --ckpt "$C" --clip "$T/nothing.safetensors" --out "$T/r" --quiet
one_line "nothing.safetensors"
# Without --quiet: a bad input is refused before the checkpoint is loaded (no checkpoint line on
# stdout, no progress bar), so the one line is all the user sees.
expect 1 "not a dataset, not quiet" -- "$G" eval --ckpt "$C" --clips "$A"
one_line "no manifest.json"
check "nothing on stdout" test ! -s "$T/out"
expect 1 "not a clip, not quiet" -- "$G" restore --ckpt "$C" --clip "$T/vae.safetensors" --out "$T/r"
one_line "vae.safetensors"
check "nothing on stdout" test ! -s "$T/out"

# The identity check: restored = baseline, exactly, in the table and the JSON.
expect 0 "identity" -- "$G" eval --ckpt "$C" --clips "$D" --identity --json "$T/identity.json" --quiet --threads 1
has "identity check passed"
has "| **mean** | 3 |"
has "| 6 | 2 |"
has "| 8 | 1 |"
b=$(json_number "$T/identity.json" baseline psnr)
r=$(json_number "$T/identity.json" restored psnr)
check "identity JSON psnr $b = $r" test -n "$b" -a "$b" = "$r"
check "identity JSON ssim" test "$(json_number "$T/identity.json" baseline ssim)" = \
    "$(json_number "$T/identity.json" restored ssim)"
check "latent cache written" ls "$D"/latents_*_both.safetensors

# The network: a table and JSON with the means and per n, the same numbers twice.
expect 0 "eval" -- "$G" eval --ckpt "$C" --clips "$D" --json "$T/eval.json" --quiet --threads 1
has "restored PSNR"
# The checkpoint records its training scenes (room-a, the train split; docs/TRAINING.md): the
# eval split (room-b) is unseen and warns nothing, room-a's clips warn once, on stderr.
check "an unseen scene: no warning" test "$(grep -c "training set" "$T/err")" -eq 0
check "the checkpoint records room-a" grep -qE '"scenes":[[:space:]]*"room-a"' <("$G" st inspect --json "$C")
expect 0 "eval on every split" -- "$G" eval --ckpt "$C" --clips "$D" --split all --quiet --threads 1
check "room-a was trained on: one line" test "$(grep -c "training set" "$T/err")" -eq 1
check "the warning's words" grep -qF "warning: scene 'room-a' was in the restorer's training set ($C: room-a): its numbers do not measure generalisation" "$T/err"
# A checkpoint from before the record (its "scenes" key taken out of the header, the tensors as
# they are) says nothing; FILE.scenes.json beside it gives the record when its "data" is the
# checkpoint's, and fails in one line when it is another training set's.
python3 - "$C" "$T/old.safetensors" <<'PY'
import json, struct, sys
b = open(sys.argv[1], "rb").read()
n = struct.unpack("<Q", b[:8])[0]
header = json.loads(b[8:8 + n])
del header["__metadata__"]["scenes"]
text = json.dumps(header).encode()
text += b" " * (-(8 + len(text)) % 8)
open(sys.argv[2], "wb").write(struct.pack("<Q", len(text)) + text + b[8 + n:])
PY
expect 0 "a checkpoint without the record" -- "$G" eval --ckpt "$T/old.safetensors" --clips "$D" --split train --quiet --threads 1
check "no record: no warning" test "$(grep -c "training set" "$T/err")" -eq 0
data=$("$G" st inspect "$T/old.safetensors" | sed -n 's/^  data: //p')
printf '{"data": "%s", "scenes": ["room-a", "room-c"]}\n' "$data" >"$T/old.scenes.json"
expect 0 "the record beside it" -- "$G" eval --ckpt "$T/old.safetensors" --clips "$D" --split train --quiet --threads 1
check "the record beside it warns" grep -qF "warning: scene 'room-a' was in the restorer's training set ($T/old.safetensors: room-a,room-c)" "$T/err"
printf '{"data": "9 clips (split train), names fnv1a64 0000000000000000", "scenes": ["room-a"]}\n' >"$T/old.scenes.json"
expect 1 "a record of another training set" -- "$G" eval --ckpt "$T/old.safetensors" --clips "$D" --split train --quiet --threads 1
one_line "old.scenes.json: made for the training set"
check "eval json" grep -q '"per_n"' "$T/eval.json"
check "eval json clips" test "$(json_number "$T/eval.json" restored clips)" = 3
check "eval json sampler" grep -q '"sampler":.*"onestep t0=0.05 steps=1 shift=1 samples=8' "$T/eval.json"
check "baseline as identity" test "$(json_number "$T/eval.json" baseline psnr)" = "$b"
expect 0 "eval again" -- "$G" eval --ckpt "$C" --clips "$D" --json "$T/eval2.json" --quiet --threads 1
check "reproducible" cmp -s "$T/eval.json" "$T/eval2.json"
expect 0 "eval without the cache" -- "$G" eval --ckpt "$C" --clips "$D" --json "$T/eval3.json" --no-cache --quiet --threads 1
check "cache gives the same" cmp -s "$T/eval.json" "$T/eval3.json"
expect 0 "eval released" -- "$G" eval --ckpt "$C" --clips "$D" --sampler released --compose decoded --quiet --threads 1
has "euler t0=0.5556 steps=10 shift=5"

# restore: PNGs and clips; a clip alone gives the same result as within the folder.
expect 0 "restore folder" -- "$G" restore --ckpt "$C" --clips "$D" --split eval --out "$T/r" --save-clips --quiet --threads 1
has "3 clips restored"
for f in 0 1 2 3 4; do exists "$T/r/room-b_n06_000/f$f.png"; done
exists "$T/r/room-b_n08_000.safetensors"
expect 0 "restore one clip" -- "$G" restore --ckpt "$C" --clip "$D/clips/room-b_n08_000.safetensors" --out "$T/one" \
    --save-clips --quiet --threads 1
has "1 clips restored"
check "a clip of an unseen scene: no warning" test "$(grep -c "training set" "$T/err")" -eq 0
expect 0 "restore a clip of a training scene" -- "$G" restore --ckpt "$C" --clip "$D/clips/room-a_n06_000.safetensors" \
    --out "$T/seen" --quiet --threads 1
check "a clip of a training scene warns" grep -q "warning: scene 'room-a' was in the restorer's training set" "$T/err"
check "same restored clip" cmp -s "$T/r/room-b_n08_000.safetensors" "$T/one/room-b_n08_000.safetensors"
check "same frame" cmp -s "$T/r/room-b_n08_000/f2.png" "$T/one/room-b_n08_000/f2.png"
expect 0 "dataset show on a restored clip" -- "$G" dataset show "$T/one/room-b_n08_000.safetensors" --out "$T/sheet.png"
if ls "$T"/r/*.tmp* "$T"/one/*.tmp* >/dev/null 2>&1; then bad "temporaries left"; else ok; fi

cli_finish
